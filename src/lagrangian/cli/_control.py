"""The control and export commands: lqr, place (a state feedback designed on the linearization,
printed as the --input text of `simulate`) and export (FMU, Modelica, C)."""

from __future__ import annotations

import argparse
import json
import os

from ..errors import ModelError
from ._analysis import _at, _load, _numbers, _operating_point, _values
from ._common import MODEL_HELP, assignments, number, split_top_level


def register(sub, fmt) -> None:
    q = sub.add_parser("lqr", help="design an LQR state feedback on the linearization", formatter_class=fmt,
                       description="Linearize about an equilibrium and design the linear-quadratic regulator "
                       "u = u0 - K (x - x0): prints the gain with the state and input names, the closed-loop "
                       "eigenvalues and the law as the --input text that simulates the nonlinear model with it.",
                       epilog="Examples:\n  lagrangian lqr cart-pendulum --at q2=pi/2 --Q q1=1,q2=10,q1_dot=1,q2_dot=1 "
                              "--R F=1\n  lagrangian lqr cart-pendulum --at q2=pi/2 --Q 1,10,1,1 --sample-time 0.02 "
                              "--json")
    q.add_argument("model", help=MODEL_HELP)
    _at(q)
    _values(q)
    q.add_argument("--Q", metavar="WEIGHTS",
                   help="state weights: NAME=W,... (diagonal; states not named weigh 0), W1,W2,... in state order, "
                        "or one number (times the identity); default: the identity")
    q.add_argument("--R", metavar="WEIGHTS",
                   help="input weights: NAME=W,... (every input), W1,... or one number; default: the identity")
    _design_options(q)
    q.set_defaults(handler=_cmd_lqr)

    pl = sub.add_parser("place", help="place the closed-loop poles of a state feedback", formatter_class=fmt,
                        description="Linearize about an equilibrium and compute the state feedback "
                        "u = u0 - K (x - x0) whose closed-loop eigenvalues are the given poles; prints the gain, "
                        "the eigenvalues and the law as the --input text of `simulate`.",
                        epilog="Examples:\n  lagrangian place cart-pendulum --at q2=pi/2 --poles -1,-2,-3,-4\n"
                               "  lagrangian place cart-pendulum --at q2=pi/2 --poles=-2+1j,-2-1j,-3,-4 --json")
    pl.add_argument("model", help=MODEL_HELP)
    _at(pl)
    _values(pl)
    pl.add_argument("--poles", required=True, metavar="P1,P2,...",
                    help="the 2n closed-loop eigenvalues, comma-separated; complex ones as -1+2j, in conjugate pairs "
                         "(write --poles=-1,... when the first is negative)")
    _design_options(pl)
    pl.set_defaults(handler=_cmd_place)

    ex = sub.add_parser("export", help="export the model as an FMU (FMI 2.0), a Modelica model or C source",
                        formatter_class=fmt,
                        description="Write the model for other tools: an FMI 2.0 FMU with Model Exchange and "
                        "Co-Simulation in one archive (the binary for this platform built with the machine's C "
                        "compiler, the sources always included), a self-contained Modelica model, and/or C99 source "
                        "with the right-hand side f(t, x, u, p), M, the forcing and the energy, a CMakeLists.txt "
                        "and an example main.",
                        epilog="Examples:\n  lagrangian export cart-pendulum --fmu cart.fmu\n"
                               "  lagrangian export cart-pendulum --modelica cart.mo --c cart-c --param M2=0.8")
    ex.add_argument("model", help=MODEL_HELP)
    ex.add_argument("--fmu", metavar="FILE.fmu", help="write an FMI 2.0 FMU (Model Exchange and Co-Simulation)")
    ex.add_argument("--modelica", metavar="FILE.mo", help="write a self-contained Modelica model")
    ex.add_argument("--c", metavar="DIR", help="write C99 source, header, CMakeLists.txt and an example main into DIR")
    ex.add_argument("--param", action="append", default=[], metavar="NAME=VALUE",
                    help="a parameter value to export instead of the model's (repeatable, or comma-separated)")
    ex.add_argument("--initial", action="append", default=[], metavar="NAME=VALUE,...",
                    help="the initial (start) state to export instead of the model's [simulation] initial values")
    ex.add_argument("--no-binary", action="store_true",
                    help="an FMU with its sources only (no binary for this platform)")
    ex.set_defaults(handler=_cmd_export)


def _design_options(p: argparse.ArgumentParser) -> None:
    p.add_argument("--sample-time", type=float, metavar="TS",
                   help="design for a controller sampled every TS seconds (zero-order hold): the discrete design "
                        "on the exact discretization; simulate it with --sample-time TS")
    p.add_argument("--wrap", action="append", default=[], metavar="NAME",
                   help="a coordinate that is an angle: the law takes its error modulo 2 pi, "
                        "atan2(sin(q - q0), cos(q - q0)) (repeatable, or comma-separated)")
    p.add_argument("--json", action="store_true",
                   help="print one JSON object: K, gains, closed_loop_eigenvalues, law, input_options, ...")


def _weights(text: str | None, what: str):
    """--Q / --R: None, one number, numbers in order, or NAME=W pairs."""
    if text is None:
        return None
    parts = [p.strip() for p in split_top_level(text) if p.strip()]
    if any("=" in p for p in parts):
        return {k: number(v, f"--{what} {k}") for k, v in assignments([text], what).items()}
    values = [number(p, f"--{what}") for p in parts]
    if not values:
        raise ModelError(f"--{what} is empty: give NAME=W,... or numbers")
    return values[0] if len(values) == 1 else values


def _poles(text: str) -> list[complex]:
    out = []
    for part in split_top_level(text):
        part = part.strip().replace(" ", "")
        if not part:
            continue
        try:
            out.append(complex(part.replace("i", "j")) if "j" in part or "i" in part else number(part, "--poles"))
        except ValueError:
            raise ModelError(f"--poles '{part}': expected a number such as -2 or a complex number such as -1+2j") \
                from None
    return out


def _report(args, feedback) -> int:
    wrap = [w.strip() for item in args.wrap for w in item.split(",") if w.strip()]
    if args.json:
        print(json.dumps(feedback.to_dict(wrap), indent=2))
    else:
        print(feedback.text(wrap))
    return 0


def _linearization(args):
    eqs = _load(args)
    lin, _note = _operating_point(args, eqs)
    return lin


def _cmd_lqr(args: argparse.Namespace) -> int:
    from ..control import lqr

    lin = _linearization(args)
    return _report(args, lqr(lin, _weights(args.Q, "Q"), _weights(args.R, "R"), sample_time=args.sample_time))


def _cmd_place(args: argparse.Namespace) -> int:
    from ..control import place

    lin = _linearization(args)
    return _report(args, place(lin, _poles(args.poles), sample_time=args.sample_time))


def _cmd_export(args: argparse.Namespace) -> int:
    import sys

    from .. import export as ex
    from .. import load

    if not (args.fmu or args.modelica or args.c):
        raise ModelError("nothing to export: give --fmu FILE.fmu, --modelica FILE.mo and/or --c DIR")
    from .. import derive

    eqs = derive(load(args.model))
    params, initial = _numbers(args.param, "param"), _numbers(args.initial, "initial")
    if args.fmu:
        result = ex.export_fmu(eqs, args.fmu, params=params, initial=initial, binary=not args.no_binary)
        kind = f"binary for {result.binary}" if result.binary else "sources only"
        print(f"wrote {args.fmu} (FMI 2.0 FMU, Model Exchange and Co-Simulation, {kind})")
        for warning in result.warnings:
            print(f"lagrangian export: warning: {warning}", file=sys.stderr)
    if args.modelica:
        ex.export_modelica(eqs, args.modelica, params=params, initial=initial)
        print(f"wrote {args.modelica} (Modelica model {ex._modelica.class_name(eqs.model.name)})")
    if args.c:
        result = ex.export_c(eqs, args.c, params=params, initial=initial)
        print(f"wrote {', '.join(os.path.basename(f) for f in result.files)} to {args.c}")
    return 0
