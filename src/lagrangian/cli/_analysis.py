"""The analysis commands: equilibria, linearize, modes, sweep."""

from __future__ import annotations

import argparse
import json
import os
from typing import Mapping

from ..errors import ModelError
from ._common import MODEL_HELP, assignments, check_writable, number, option_number, parameter_values


def register(sub, fmt) -> None:
    e = sub.add_parser("equilibria", help="find the equilibria and their stability", formatter_class=fmt,
                       description="Find the states at rest (exactly when SymPy can, with the conditions "
                       "for them to exist; by a multi-start numerical search otherwise) and classify their "
                       "stability from the eigenvalues of the linearization.",
                       epilog="Examples:\n  lagrangian equilibria rotating-pendulum --param Omega=6\n"
                              "  lagrangian equilibria cart-pendulum --input F=0 --json")
    e.add_argument("model", help=MODEL_HELP)
    _values(e)
    e.add_argument("--json", action="store_true",
                   help="print a JSON list of {coordinates, stable, eigenvalues, stability, exact, conditions, family}")
    e.set_defaults(handler=_cmd_equilibria)

    st = sub.add_parser("steady", help="find the steady motions (cyclic coordinates turning at constant rates)",
                        formatter_class=fmt,
                        description="Find the steady motions (relative equilibria): the coordinates the equations "
                        "contain constant, each cyclic coordinate turning at a constant rate, given by --velocity or "
                        "through its momentum by --momentum (Routh). Exactly when SymPy can, by a multi-start "
                        "numerical search otherwise; stability from the eigenvalues of the linearization about each "
                        "(all 2n states) and Routh's criterion. With constraints: the rates of ignorable "
                        "coordinates (those the motion does not depend on: a wheel's position, heading and spin) "
                        "are given, the others follow from the constraints, the shape is found numerically, with "
                        "the multipliers.",
                        epilog="Examples:\n  lagrangian steady spherical-pendulum --velocity phi_dot=4\n"
                               "  lagrangian steady kepler --momentum p_phi=1 --json\n"
                               "  lagrangian steady heavy-top --velocity phi_dot=2,psi_dot=50\n"
                               "  lagrangian steady rolling-disk --velocity psi_dot=2,theta_dot=20")
    st.add_argument("model", help=MODEL_HELP)
    st.add_argument("--velocity", action="append", default=[], metavar="NAME_dot=VALUE",
                    help="the rate of a cyclic coordinate, e.g. phi_dot=4 (repeatable, or comma-separated); "
                         "cyclic coordinates given neither a rate nor a momentum stay at rest")
    st.add_argument("--momentum", action="append", default=[], metavar="p_NAME=VALUE",
                    help="the momentum dL/dq_dot of a cyclic coordinate, e.g. p_phi=1: its rate is found (Routh)")
    _values(st)
    st.add_argument("--json", action="store_true",
                    help="print a JSON list of {coordinates, velocities, stable, eigenvalues, stability, momenta, "
                         "exact, ..., multipliers, dependent}")
    st.set_defaults(handler=_cmd_steady)

    lin = sub.add_parser("linearize", help="linearize about an operating point", formatter_class=fmt,
                         description="Linearize about an operating point: M dq'' + (C + G) dq' + K dq = B0 du "
                         "and the state space x' = A x + B u, x = [q, q_dot]. Without --at, about the "
                         "stable equilibrium nearest q = 0.",
                         epilog="Examples:\n  lagrangian linearize cart-pendulum --at q1=0,q2=pi/2\n"
                                "  lagrangian linearize cart-pendulum --at q2=pi/2 --input F=0 --json")
    lin.add_argument("model", help=MODEL_HELP)
    _at(lin)
    _values(lin)
    lin.add_argument("--json", action="store_true",
                     help="print one JSON object: state_names, input_names, A, B, M, C, K, G, input_matrix, ...")
    lin.set_defaults(handler=_cmd_linearize)

    m = sub.add_parser("modes", help="natural frequencies, mode shapes and damping ratios", formatter_class=fmt,
                       description="Natural frequencies (Hz and rad/s), mass-normalized mode shapes, modal "
                       "masses and stiffnesses, damping ratios, about an operating point (default: the stable "
                       "equilibrium nearest q = 0).",
                       epilog="Examples:\n  lagrangian modes mck\n  lagrangian modes sliding-mass-pendulum "
                              "--at q1=0.24525,q2=0 --json")
    m.add_argument("model", help=MODEL_HELP)
    _at(m)
    _values(m)
    m.add_argument("--json", action="store_true",
                   help="print one JSON object: frequencies_hz (ascending), damping_ratios, shapes, ...")
    m.set_defaults(handler=_cmd_modes)

    s = sub.add_parser("sweep", help="follow the equilibria as a parameter varies (bifurcation diagram)",
                       formatter_class=fmt,
                       description="Follow the equilibria and their stability as one parameter varies; report "
                       "the branches and the critical values of the parameter (exact when possible); "
                       "optionally draw the bifurcation diagram.",
                       epilog="Examples:\n  lagrangian sweep rotating-pendulum --param Omega --from 0 --to 8 "
                              "--steps 200 --plot omega.png\n"
                              "  lagrangian sweep rotating-pendulum --param Omega --param l=1 --from 0 --to 8 --json")
    s.add_argument("model", help=MODEL_HELP)
    s.add_argument("--param", action="append", default=[], metavar="NAME[=VALUE]",
                   help="the parameter to sweep (a name), and other parameter values (NAME=VALUE, repeatable)")
    s.add_argument("--from", dest="start", type=option_number("--from", example="--from 0"), required=True, metavar="A",
                   help="first value")
    s.add_argument("--to", dest="stop", type=option_number("--to", example="--to 8"), required=True, metavar="B",
                   help="last value")
    s.add_argument("--steps", type=option_number("--steps", integer=True, minimum=1, maximum=100_000,
                                                 example="--steps 200"),
                   default=200, help="number of intervals between A and B (default 200)")
    s.add_argument("--input", action="append", default=[], metavar="NAME=VALUE",
                   help="a constant input value, a number or an expression of the model's parameters such as "
                        "\"tau1=g*l1*(m1/2+m2)\" (repeatable, or comma-separated); inputs not given are 0")
    s.add_argument("--plot", metavar="FILE", help="draw the bifurcation diagram into FILE (.png, .pdf, .svg)")
    s.add_argument("--coordinate", metavar="NAME", help="the coordinate on the diagram's vertical axis")
    s.add_argument("--json", action="store_true",
                   help="print one JSON object: branches (each a list of {param, coordinates, stable}), "
                        "critical_values, ...")
    s.set_defaults(handler=_cmd_sweep)


def _values(p: argparse.ArgumentParser) -> None:
    p.add_argument("--param", action="append", default=[], metavar="NAME=VALUE",
                   help="override a parameter value (repeatable, or comma-separated)")
    p.add_argument("--input", action="append", default=[], metavar="NAME=VALUE",
                   help="a constant input value, a number or an expression of the model's parameters such as "
                        "\"tau1=g*l1*(m1/2+m2)\" (repeatable, or comma-separated); inputs not given are 0")


def _at(p: argparse.ArgumentParser) -> None:
    p.add_argument("--at", action="append", default=[], metavar="NAME=VALUE,...",
                   help="the operating point: coordinates and velocities, e.g. q1=0,q2=pi/2 (values may use the "
                        "model's parameters); merged by name with the model's [operating_point]: names not given "
                        "keep its values, the others are 0; "
                        "default: the model's [operating_point], else the stable equilibrium nearest q = 0")
    p.add_argument("--t", type=option_number("--t", example="--t 0"), default=0.0,
                   help="the time, for models that contain t (default 0)")


def _numbers(items, what: str, names: Mapping[str, float] | None = None) -> dict[str, float]:
    """NAME=VALUE options as numbers; with `names` (parameter_values), the values may be expressions of the
    model's parameters."""
    return {k: number(v, f"--{what} {k}", names) for k, v in assignments(items, what).items()}


def _load(args):
    from .. import derive, load

    return derive(load(args.model))


def _cmd_equilibria(args: argparse.Namespace) -> int:
    from ..analysis import equilibria

    eqs = _load(args)
    params = _numbers(args.param, "param")
    found = equilibria(eqs, params=params, inputs=_numbers(args.input, "input", parameter_values(eqs, params)))
    if args.json:
        print(json.dumps([e.to_dict() for e in found], indent=2))
        return 0
    print(found.text(eqs.model.name))
    return 0


def _cmd_steady(args: argparse.Namespace) -> int:
    from ..analysis import steady_motions

    eqs = _load(args)
    params = _numbers(args.param, "param")
    names = parameter_values(eqs, params)
    found = steady_motions(eqs, _numbers(args.velocity, "velocity", names),
                           momenta=_numbers(args.momentum, "momentum", names), params=params,
                           inputs=_numbers(args.input, "input", names))
    if args.json:
        print(json.dumps([e.to_dict() for e in found], indent=2))
    else:
        print(found.text(eqs.model.name))
    return 0


def _operating_point(args, eqs):
    """(linear model, description): about --at, or the stable equilibrium nearest q = 0."""
    from ..analysis import equilibria, linearize

    params = _numbers(args.param, "param")
    names = parameter_values(eqs, params)  # --input and --at may use the model's parameters
    inputs = _numbers(args.input, "input", names)
    if args.at or eqs.model.operating_point:
        at = _numbers(args.at, "at", names) if args.at else None  # None: the model's [operating_point]
        if at is not None and eqs.model.operating_point:
            # --at merges with [operating_point] by name, as --initial does with [simulation] initial:
            # the names --at does not give keep the model file's values (the others are 0)
            at = {**_model_operating_point(eqs, names), **at}
        return linearize(eqs, at, params=params, inputs=inputs, t=args.t), None
    found = [e for e in equilibria(eqs, params=params, inputs=inputs, t=args.t) if e.linear_model is not None]
    stable = [e for e in found if e.stable]
    if not stable:
        raise ModelError(f"{eqs.model.name} has no stable equilibrium to linearize about"
                         + (f" (its equilibria: {'; '.join(e.text() for e in found)})" if found else "")
                         + "; give the operating point with --at, e.g. --at "
                         + ",".join(f"{c.name}=0" for c in eqs.coordinates))
    e = min(stable, key=lambda e: sum(abs(v) for v in e.coordinates.values()))  # the one nearest q = 0
    return e.linear_model, "about the stable equilibrium " + ", ".join(f"{k} = {v:.6g}"
                                                                       for k, v in e.coordinates.items())


def _model_operating_point(eqs, names: Mapping[str, float]) -> dict[str, float]:
    """The model's [operating_point] at the parameter values `names` (the model's, --param's in their place)."""
    import sympy

    values = {sympy.Symbol(k): v for k, v in names.items()}
    return {k: float(sympy.sympify(e).xreplace(values)) for k, e in eqs.model.operating_point.items()}


def _cmd_linearize(args: argparse.Namespace) -> int:
    eqs = _load(args)
    lin, note = _operating_point(args, eqs)
    if args.json:
        print(json.dumps(lin.to_dict(), indent=2))
    else:
        print(lin.text())
    return 0


def _cmd_modes(args: argparse.Namespace) -> int:
    from ..analysis import modes

    eqs = _load(args)
    lin, note = _operating_point(args, eqs)
    result = modes(lin)
    if args.json:
        print(json.dumps({"operating_point": dict(lin.operating_point), **result.to_dict()}, indent=2))
    else:
        at = note or "at " + ", ".join(f"{k} = {v:.6g}" for k, v in lin.operating_point.items())
        print(f"Modes of {eqs.model.name} {at}:")
        print(result.text())
    return 0


def _cmd_sweep(args: argparse.Namespace) -> int:
    import numpy as np

    from ..analysis import continuation

    swept = [p.strip() for item in args.param for p in item.split(",") if p.strip() and "=" not in p]
    fixed = [item for item in args.param if "=" in item]
    if len(swept) != 1:
        raise ModelError("--param: name exactly one parameter to sweep (without a value), e.g. --param Omega; "
                         f"got {', '.join(swept) or 'none'}")
    if args.plot:
        ext = os.path.splitext(args.plot)[1].lower()
        if ext not in (".png", ".pdf", ".svg"):
            raise ModelError(f"--plot {args.plot}: expected a file ending in .png, .pdf or .svg")
        check_writable(args.plot, "diagram.png", option="--plot")
    eqs = _load(args)
    names = [c.name for c in eqs.coordinates]
    if args.coordinate is not None and args.coordinate not in names:
        from .._util import did_you_mean

        raise ModelError(f"--coordinate {args.coordinate}: not a coordinate of {eqs.model.name}"
                         f"{did_you_mean(args.coordinate, names)}; the coordinates are {', '.join(names)}")
    params = _numbers(fixed, "param")
    result = continuation(eqs, swept[0], np.linspace(args.start, args.stop, args.steps + 1), params=params,
                          inputs=_numbers(args.input, "input", parameter_values(eqs, params, leave_out=swept)))
    if args.plot:
        import matplotlib

        matplotlib.use("Agg")
        fig = result.plot(args.coordinate)
        from ..io._files import replacing

        with replacing(args.plot) as tmp:  # atomically, with the user's umask
            fig.savefig(tmp, dpi=120, bbox_inches="tight", format=os.path.splitext(args.plot)[1][1:].lower())
    if args.json:
        print(json.dumps(result.to_dict(), indent=2))
    else:
        print(result.text())
        if args.plot:
            print(f"wrote the bifurcation diagram to {args.plot}")
    return 0
