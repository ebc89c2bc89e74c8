"""The core commands: derive, simulate, check, examples."""

from __future__ import annotations

import argparse
import json
import os
import sys

from ..errors import ModelError
from ..io._files import is_stdout
from ._control import add_feedback_options, feedback_inputs
from ._common import (MODEL_HELP, add_simulation_options, check_writable, events_csv, events_summary, run_simulation,
                      write_output)


def register(sub, fmt) -> None:
    d = sub.add_parser("derive", help="print Lagrange's equations and their matrix form",
                       formatter_class=fmt, description="Derive Lagrange's equations of a model and print them "
                       "(text by default, or LaTeX, or JSON).",
                       epilog="Examples:\n  lagrangian derive cart-pendulum\n  lagrangian derive my_model.toml --json\n"
                              "  lagrangian derive rotating-pendulum --latex\n"
                              "  lagrangian derive whipple-bicycle --expanded   # every entry in full (megabytes)")
    d.add_argument("model", help=MODEL_HELP)
    g = d.add_mutually_exclusive_group()
    g.add_argument("--json", action="store_true",
                   help="print one JSON object (coordinates, mass_matrix, forcing, equations, ...)")
    g.add_argument("--latex", action="store_true", help="print LaTeX (each equation and the matrix form)")
    d.add_argument("--expanded", action="store_true",
                   help="text: print every entry of M and f in full even when it could expand to more than 5,000 "
                        "terms (by default such equations, a chain of bodies in space, are written with named "
                        "quantities); JSON and LaTeX always give every entry in full")
    d.add_argument("--quasi-velocities", action="store_true",
                   help="text: also print the equations in quasi-velocities (Boltzmann-Hamel / Kane): the speeds "
                        "of a frame turned by three angles of its own (a spherical joint) are its angular velocity "
                        "relative to its parent in its axes, with the kinematic equations q_dot = W(q) u")
    d.set_defaults(handler=_cmd_derive)

    s = sub.add_parser("simulate", help="simulate a model and write its trajectory as CSV",
                       formatter_class=fmt, description="Simulate a model with an adaptive integrator and write "
                       "CSV: header t,<q...>,<q_dot...>[,inputs][,energy], one row for each t = 0, dt, 2dt, ... <= T. "
                       "Options not given come from the model file's [simulation] table.",
                       epilog="Example:\n  lagrangian simulate cart-pendulum --t-end 5 --initial q1=0,q2=0.5,q2_dot=0 "
                              "--param M1=2 --input \"F=1.5*sin(3*t)\" --dt 0.05 --output out.csv")
    s.add_argument("model", help=MODEL_HELP)
    add_simulation_options(s)
    s.add_argument("--output", "-o", default="-", metavar="FILE",
                   help="CSV file to write ('-' for stdout, the default)")
    s.add_argument("--events-output", metavar="FILE",
                   help="CSV file for the --event crossings: event,t,<states>, in time order")
    add_feedback_options(s)
    s.set_defaults(handler=_cmd_simulate)

    c = sub.add_parser("check", help="check a model and diagnose its mass matrix and its constraints",
                       formatter_class=fmt, description="Check a model: report det M in factored form, where it "
                       "vanishes, the velocity combination with no inertia there, the likely cause and a fix. For a "
                       "model with constraints, also the rank of their Jacobian G at the initial configuration, the "
                       "configurations where G loses rank (the constraints dependent: which ones, and which motions "
                       "become free) and the dead points of the coordinates that drive the mechanism ([simulation] "
                       "independent, a coordinate an input alone acts on, or --driver).",
                       epilog="Examples:\n  lagrangian check cart-pendulum-massless"
                              "\n  lagrangian check my_model.toml --json"
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
        print(eqs.text(expanded=args.expanded))
        if args.quasi_velocities:
            print()
            print(eqs.quasi_velocity_text())
    return 0


def _cmd_simulate(args: argparse.Namespace) -> int:
    from ..errors import SimulationError, SingularMassMatrixError

    if args.events_output is not None and not args.event:
        raise ModelError("--events-output needs at least one --event NAME=EXPR, "
                         "for example --event \"upright=cos(q2)\"")
    for option, path in (("--output", args.output), ("--events-output", args.events_output)):
        if path is not None:
            check_writable(path, option=option)
    feedback_inputs(args)  # --lqr, --controller: the law as --input
    to_stdout = is_stdout(args.output)
    notes = sys.stderr if to_stdout else sys.stdout
    try:
        _, _, traj = run_simulation(args, equations_to=notes)
    except (SimulationError, SingularMassMatrixError) as exc:
        if exc.partial is None:
            raise
        exc.args = (f"{exc}\n{_keep_partial(args.output, exc.partial)}",)
        raise
    write_output(args.output, traj.to_csv(), "--output")
    if not to_stdout:
        drift = traj.energy_drift
        extra = f"; {traj.energy_name} drift {drift:.2e}" if drift is not None and traj.conservative else ""
        print(f"wrote {len(traj.t)} rows (t = 0 .. {traj.t[-1]:g}) to {args.output}{extra}")
    if args.events_output is not None:
        write_output(args.events_output, events_csv(traj), "--events-output")
    for line in events_summary(traj) if args.event else ():
        print(line, file=notes)
    return 0


def partial_path(output: str) -> str:
    """Where the rows of a failed run go when --output is a file: beside it, out.csv -> out.partial.csv,
    so that the file named keeps its earlier, complete contents."""
    stem, suffix = os.path.splitext(output)
    return f"{stem}.partial{suffix or '.csv'}"


def _keep_partial(output: str, partial) -> str:
    """Write the rows of a failed run (a Trajectory marked partial) where they belong, and say where:
    a stream (stdout, a FIFO, /dev/null) receives them directly; a file keeps its contents, and the rows
    go to its partial sibling (partial_path), replacing only an earlier partial output there."""
    from ..io._files import is_stream, write_atomically

    rows = f"The {len(partial.t)} rows computed up to t = {partial.t[-1]:g}"
    if is_stream(output):
        write_output(output, partial.to_csv(), "--output")
        where = "stdout" if is_stdout(output) else output
        return f"{rows} were written to {where}, marked as partial in the CSV's first line ('# partial: ...')."
    path = partial_path(output)
    if os.path.lexists(path) and not _is_partial_output(path):
        return (f"{rows} were not written: {path}, where they would go, exists and is not a partial output of "
                "lagrangian (its first line is not '# partial: ...'); move it away to keep them next time.")
    kept = "keeps its earlier contents" if os.path.lexists(output) else "was not created"
    try:
        write_atomically(path, partial.to_csv())
    except OSError as exc:
        return f"{rows} were not written: {path}: {exc.strerror or exc}."
    return (f"{rows} were written to {path}, marked as partial in the CSV's first line ('# partial: ...'); "
            f"{output} {kept} (it receives complete runs only).")


def _is_partial_output(path: str) -> bool:
    """Whether `path` is a regular file (not a link) whose first line is the '# partial:' mark."""
    if os.path.islink(path) or not os.path.isfile(path):
        return False
    with open(path, "rb") as fh:
        return fh.read(11) == b"# partial: "


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
