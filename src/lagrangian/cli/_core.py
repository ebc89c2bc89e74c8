"""The core commands: derive, simulate, check, examples."""

from __future__ import annotations

import argparse
import json
import sys

from ..errors import ModelError
from ._common import (MODEL_HELP, add_simulation_options, check_writable, events_csv, events_summary, run_simulation,
                      write_atomically)


def register(sub, fmt) -> None:
    d = sub.add_parser("derive", help="print Lagrange's equations and their matrix form",
                       formatter_class=fmt, description="Derive Lagrange's equations of a model and print them "
                       "(text by default, or LaTeX, or JSON).",
                       epilog="Examples:\n  lagrangian derive cart-pendulum\n  lagrangian derive my_model.toml --json\n"
                              "  lagrangian derive rotating-pendulum --latex")
    d.add_argument("model", help=MODEL_HELP)
    g = d.add_mutually_exclusive_group()
    g.add_argument("--json", action="store_true", help="print one JSON object (coordinates, mass_matrix, forcing, equations, ...)")
    g.add_argument("--latex", action="store_true", help="print LaTeX (each equation and the matrix form)")
    d.set_defaults(handler=_cmd_derive)

    s = sub.add_parser("simulate", help="simulate a model and write its trajectory as CSV",
                       formatter_class=fmt, description="Simulate a model with an adaptive integrator and write "
                       "CSV: header t,<q...>,<q_dot...>[,inputs][,energy], one row for each t = 0, dt, 2dt, ... <= T. "
                       "Options not given come from the model file's [simulation] table.",
                       epilog="Example:\n  lagrangian simulate cart-pendulum --t-end 5 --initial q1=0,q2=0.5,q2_dot=0 "
                              "--param M1=2 --input \"F=1.5*sin(3*t)\" --dt 0.05 --output out.csv")
    s.add_argument("model", help=MODEL_HELP)
    add_simulation_options(s)
    s.add_argument("--output", "-o", default="-", metavar="FILE", help="CSV file to write ('-' for stdout, the default)")
    s.add_argument("--events-output", metavar="FILE",
                   help="CSV file for the --event crossings: event,t,<states>, in time order")
    s.set_defaults(handler=_cmd_simulate)

    c = sub.add_parser("check", help="check a model and diagnose its mass matrix and its constraints",
                       formatter_class=fmt, description="Check a model: report det M in factored form, where it "
                       "vanishes, the velocity combination with no inertia there, the likely cause and a fix. For a "
                       "model with constraints, also the rank of their Jacobian G at the initial configuration, the "
                       "configurations where G loses rank (the constraints dependent: which ones, and which motions "
                       "become free) and the dead points of the coordinates that drive the mechanism ([simulation] "
                       "independent, a coordinate an input alone acts on, or --driver).",
                       epilog="Examples:\n  lagrangian check cart-pendulum-massless\n  lagrangian check my_model.toml --json"
                              "\n  lagrangian check slider-crank --driver s")
    c.add_argument("model", help=MODEL_HELP)
    c.add_argument("--json", action="store_true", help="print one JSON object (singular, det_mass_matrix, ..., "
                   "constraint_singularities)")
    c.add_argument("--driver", action="append", metavar="NAMES",
                   help="coordinates that drive a constrained model (comma-separated: one set driving together; "
                        "repeatable): their dead points are searched instead of the default drivers'")
    c.set_defaults(handler=_cmd_check)

    e = sub.add_parser("examples", help="list the built-in examples", formatter_class=fmt,
                       description="List the built-in examples with a one-line description.",
                       epilog="Examples:\n  lagrangian examples\n  lagrangian examples --json\n"
                              "  lagrangian examples --show cart-pendulum   # print its model file")
    e.add_argument("--json", action="store_true", help="print {name: description} as JSON")
    e.add_argument("--show", metavar="NAME", help="print the model file of one example")
    e.set_defaults(handler=_cmd_examples)


def _cmd_derive(args: argparse.Namespace) -> int:
    from .. import derive, load

    eqs = derive(load(args.model))
    if args.json:
        print(eqs.to_json())
    elif args.latex:
        print(eqs.latex())
    else:
        print(eqs.text())
    return 0


def _cmd_simulate(args: argparse.Namespace) -> int:
    if args.events_output is not None and not args.event:
        raise ModelError("--events-output needs at least one --event NAME=EXPR, for example --event \"upright=cos(q2)\"")
    for path in (args.output, args.events_output):
        if path not in ("-", None):
            check_writable(path)
    _, _, traj = run_simulation(args, equations_to=sys.stderr if args.output == "-" else sys.stdout)
    notes = sys.stderr if args.output == "-" else sys.stdout
    if args.output == "-":
        sys.stdout.write(traj.to_csv())
    else:
        write_atomically(args.output, traj.to_csv())
        drift = traj.energy_drift
        extra = f"; {traj.energy_name} drift {drift:.2e}" if drift is not None and traj.conservative else ""
        print(f"wrote {len(traj.t)} rows (t = 0 .. {traj.t[-1]:g}) to {args.output}{extra}")
    if args.events_output is not None:
        write_atomically(args.events_output, events_csv(traj))
    for line in events_summary(traj) if args.event else ():
        print(line, file=notes)
    return 0


def _cmd_check(args: argparse.Namespace) -> int:
    from .. import constraint_singularities, derive, load, singularities

    eqs = derive(load(args.model))
    drivers = None if args.driver is None else [[k.strip() for k in item.split(",") if k.strip()]
                                                for item in args.driver]
    if drivers is not None and not eqs.is_constrained:
        raise ModelError(f"--driver: model '{eqs.model.name}' has no constraints, so no coordinate drives it through "
                         "dead points; --driver is for mechanisms (models with [[constraints]])")
    constraints = constraint_singularities(eqs, drivers) if eqs.is_constrained else None
    report = singularities(eqs)
    if args.json:
        out = {"model": eqs.model.name, "coordinates": [c.name for c in eqs.coordinates], **report.to_dict(),
               "constraint_singularities": None if constraints is None else constraints.to_dict()}
        print(json.dumps(out, indent=2))
    else:
        print(f"{eqs.model.name}: {eqs.n} coordinates ({', '.join(c.name for c in eqs.coordinates)}); model is valid.")
        print(report.text())
        if constraints is not None:
            print(constraints.text())
    return 0


def _cmd_examples(args: argparse.Namespace) -> int:
    from ..examples import example_descriptions, example_source

    if args.show:
        text = example_source(args.show)
        if text is None:
            from ..io import load

            load(args.show)  # raises the 'no such example' error with a suggestion
        print(text, end="")
        return 0
    desc = example_descriptions()
    if args.json:
        print(json.dumps(desc, indent=2))
    else:
        width = max(map(len, desc))
        for name, text in desc.items():
            print(f"{name:<{width}}  {text}")
    return 0
