"""The fit command: parameter identification from measurements (lagrangian.fit)."""

from __future__ import annotations

import argparse
import json
import os

from ..errors import ModelError
from ._common import MODEL_HELP, assignments, check_writable, number, option_number, parameter_values


def register(sub, fmt) -> None:
    f = sub.add_parser("fit", help="fit a model's parameters to measurements (CSV)", formatter_class=fmt,
                       description="Fit parameters of a model to measured data by multiple shooting with exact "
                       "sensitivities (Gauss-Newton / Levenberg-Marquardt). Each CSV is one experiment: a time "
                       "column t and columns named as coordinates (theta), velocities (theta_dot), inputs (F: the "
                       "measured signal, interpolated linearly), named outputs or points' positions (bob.x). "
                       "Parameters the data cannot determine are named with the combination that is determined, "
                       "and held, not fitted.",
                       epilog="Examples:\n  lagrangian fit pendulum.toml swing.csv --params l,c --guess l=0.8,c=0.3\n"
                              "  lagrangian fit msd.toml run1.csv run2.csv --params m,c,k --noise x=1e-4 --json")
    f.add_argument("model", help=MODEL_HELP)
    f.add_argument("data", nargs="+", metavar="DATA.csv", help="measurements, one CSV file per experiment")
    f.add_argument("--params", required=True, metavar="NAME,...", help="the parameters to fit, e.g. m,l,c")
    f.add_argument("--guess", action="append", default=[], metavar="NAME=VALUE",
                   help="first guesses of fitted parameters, values of others (default: the model's values)")
    f.add_argument("--bounds", action="append", default=[], metavar="NAME=LOW:HIGH",
                   help="bounds of a fitted parameter, e.g. c=0:10 (an empty side is open: m=0:)")
    f.add_argument("--columns", default=None, metavar="NAME,...",
                   help="the columns of the data to fit (default: all but a simulation's energy and multipliers), "
                        "e.g. theta to leave out a simulation's theta_dot; an input's column drives the model anyway")
    f.add_argument("--initial", action="append", default=[], metavar="NAME=VALUE",
                   help="known initial states, held for every experiment (the others are estimated)")
    f.add_argument("--noise", action="append", default=[], metavar="[NAME=]SIGMA",
                   help="the standard deviation of the measurements: one number for all columns, or per column "
                        "(theta=0.01); default: estimated from the residuals")
    f.add_argument("--input", action="append", default=[], metavar="NAME=VALUE",
                   help="a constant value of an input that is not a column of the data")
    f.add_argument("--intervals", type=option_number("--intervals", integer=True, example="--intervals 20",
                                                     minimum=1, maximum=400),
                   default=None, help="shooting intervals per experiment (1: single shooting; default: one per "
                                      "10 samples, at most 40)")
    f.add_argument("--confidence", type=option_number("--confidence", example="--confidence 0.95", minimum=0,
                                                      maximum=1), default=0.95,
                   help="the level of the confidence intervals (default 0.95)")
    f.add_argument("--max-iterations", type=option_number("--max-iterations", integer=True,
                                                          example="--max-iterations 200", minimum=1,
                                                          maximum=100000),
                   default=200, help="the most Gauss-Newton iterations (default 200)")
    f.add_argument("--plot", metavar="FILE.png", default=None,
                   help="save the fitted columns against the data as a figure")
    f.add_argument("--json", action="store_true",
                   help="print JSON: parameters {estimate, standard_error, interval}, correlation, "
                        "not_identifiable, combinations, rank, noise, initial_states, residual_rms, iterations")
    f.set_defaults(handler=_cmd_fit)


def _bounds(items) -> dict:
    out = {}
    for name, text in assignments(items, "bounds").items():
        if ":" not in text:
            raise ModelError(f"--bounds {name}={text}: expected NAME=LOW:HIGH, for example --bounds {name}=0:10 (an "
                             "empty side is open)")
        lo, hi = text.split(":", 1)
        out[name] = (number(lo, f"--bounds {name}") if lo.strip() else None,
                     number(hi, f"--bounds {name}") if hi.strip() else None)
    return out


def _noise(items):
    plain = [i for item in items for i in item.split(",") if i.strip() and "=" not in i]
    named = [i for item in items for i in item.split(",") if "=" in i]
    if plain and named:
        raise ModelError("--noise: give one number for every column (--noise 0.01) or one per column "
                         "(--noise theta=0.01,x=0.002), not both")
    if len(plain) > 1:
        raise ModelError(f"--noise: {len(plain)} numbers without names; give one (for all columns) or NAME=SIGMA")
    if plain:
        return number(plain[0], "--noise")
    if named:
        return {k: number(v, f"--noise {k}") for k, v in assignments(named, "noise").items()}
    return None


def _cmd_fit(args: argparse.Namespace) -> int:
    from .. import derive, load
    from ..identification import fit

    if args.plot:
        check_writable(args.plot, "fit.png", "--plot")
    eqs = derive(load(args.model))
    names = parameter_values(eqs, {})
    guess = {k: number(v, f"--guess {k}", names) for k, v in assignments(args.guess, "guess").items()}
    initial = {k: number(v, f"--initial {k}", names) for k, v in assignments(args.initial, "initial").items()}
    inputs = {k: number(v, f"--input {k}", names) for k, v in assignments(args.input, "input").items()}
    result = fit(eqs, list(args.data), args.params, guess=guess, bounds=_bounds(args.bounds), initial=initial or None,
                 noise=_noise(args.noise), inputs=inputs or None, intervals=args.intervals, columns=args.columns,
                 confidence=args.confidence, max_iterations=args.max_iterations)
    if args.plot:
        import matplotlib

        matplotlib.use("Agg")
        fig = result.plot()
        from ..io._files import replacing

        with replacing(args.plot) as tmp:  # atomically, with the user's umask
            fig.savefig(tmp, dpi=120, bbox_inches="tight", format=os.path.splitext(args.plot)[1][1:].lower())
    if args.json:
        print(json.dumps(result.to_dict(), indent=2))
    else:
        print(result.text())
        if args.plot:
            print(f"wrote the figure to {args.plot}")
    return 0 if result.success else 1
