"""The command-line interface: a thin layer over the library.

Exit status: 0 on success, 2 for bad input (a bad model file, option or name), 1 when a
computation fails (a singular mass matrix reached by a simulation, an integrator failure).
Errors go to stderr, without a traceback.
"""

from __future__ import annotations

import argparse
import json
import os
import sys
import tempfile
from typing import Sequence

from ..errors import ExpressionError, LagrangianError, ModelError, SimulationError, SingularMassMatrixError

__all__ = ["main"]

_MODEL_HELP = "a model file (.toml) or a built-in example name (see `lagrangian examples`)"


class _Parser(argparse.ArgumentParser):
    def error(self, message):  # exit 2 with a one-line hint, no usage dump
        self.exit(2, f"lagrangian: error: {message}\nRun `{self.prog} --help` for the options and an example.\n")


def _parser() -> argparse.ArgumentParser:
    p = _Parser(prog="lagrangian", description="Lagrangian dynamics of mechanical systems: derive Lagrange's "
                "equations, diagnose the mass matrix and simulate, from a TOML model file or a built-in example.",
                epilog="Example: lagrangian derive cart-pendulum")
    p.add_argument("--version", action="version", version=f"lagrangian {_version()}")
    sub = p.add_subparsers(dest="command", metavar="COMMAND", parser_class=_Parser)
    fmt = argparse.RawDescriptionHelpFormatter

    d = sub.add_parser("derive", help="print Lagrange's equations and their matrix form",
                       formatter_class=fmt, description="Derive Lagrange's equations of a model and print them "
                       "(text by default, or LaTeX, or JSON).",
                       epilog="Examples:\n  lagrangian derive cart-pendulum\n  lagrangian derive my_model.toml --json\n"
                              "  lagrangian derive rotating-pendulum --latex")
    d.add_argument("model", help=_MODEL_HELP)
    g = d.add_mutually_exclusive_group()
    g.add_argument("--json", action="store_true", help="print one JSON object (coordinates, mass_matrix, forcing, equations, ...)")
    g.add_argument("--latex", action="store_true", help="print LaTeX (each equation and the matrix form)")

    s = sub.add_parser("simulate", help="simulate a model and write its trajectory as CSV",
                       formatter_class=fmt, description="Simulate a model with an adaptive integrator and write "
                       "CSV: header t,<q...>,<q_dot...>[,inputs][,energy], one row for each t = 0, dt, 2dt, ... <= T. "
                       "Options not given come from the model file's [simulation] table.",
                       epilog="Example:\n  lagrangian simulate cart-pendulum --t-end 5 --initial q1=0,q2=0.5,q2_dot=0 "
                              "--param M1=2 --input \"F=1.5*sin(3*t)\" --dt 0.05 --output out.csv")
    s.add_argument("model", help=_MODEL_HELP)
    s.add_argument("--t-end", type=float, metavar="T", help="final time (s)")
    s.add_argument("--initial", action="append", default=[], metavar="NAME=VALUE,...",
                   help="initial coordinates and velocities, e.g. q1=0,q2=0.5,q2_dot=0 (values may use pi); others are 0")
    s.add_argument("--param", action="append", default=[], metavar="NAME=VALUE",
                   help="override a parameter value (repeatable, or comma-separated)")
    s.add_argument("--input", action="append", default=[], metavar="NAME=EXPR",
                   help="an input as an expression of t, e.g. \"F=1.5*sin(3*t)\" (repeatable); inputs not given are 0")
    s.add_argument("--dt", type=float, help="output interval (default: the model's, or 0.01)")
    s.add_argument("--rtol", type=float, help="relative tolerance (default 1e-9)")
    s.add_argument("--atol", type=float, help="absolute tolerance (default 1e-9)")
    s.add_argument("--method", default="DOP853", help="integrator: DOP853 (default), RK45, RK23, Radau, BDF, LSODA")
    s.add_argument("--output", "-o", default="-", metavar="FILE", help="CSV file to write ('-' for stdout, the default)")
    s.add_argument("--show-equations", action="store_true", help="print the equations before simulating")

    c = sub.add_parser("check", help="check a model and diagnose its mass matrix",
                       formatter_class=fmt, description="Check a model: report det M in factored form, where it "
                       "vanishes, the velocity combination with no inertia there, the likely cause and a fix.",
                       epilog="Examples:\n  lagrangian check cart-pendulum-massless\n  lagrangian check my_model.toml --json")
    c.add_argument("model", help=_MODEL_HELP)
    c.add_argument("--json", action="store_true", help="print one JSON object (singular, det_mass_matrix, ...)")

    e = sub.add_parser("examples", help="list the built-in examples", formatter_class=fmt,
                       description="List the built-in examples with a one-line description.",
                       epilog="Examples:\n  lagrangian examples\n  lagrangian examples --json\n"
                              "  lagrangian examples --show cart-pendulum   # print its model file")
    e.add_argument("--json", action="store_true", help="print {name: description} as JSON")
    e.add_argument("--show", metavar="NAME", help="print the model file of one example")
    return p


def _version() -> str:
    from .. import __version__

    return __version__


def _split_top_level(text: str) -> list[str]:
    """Split at the commas that are not inside parentheses: "q1=0,q2=atan2(1,2)" -> 2 parts."""
    parts, depth, start = [], 0, 0
    for i, ch in enumerate(text):
        depth += (ch == "(") - (ch == ")")
        if ch == "," and depth == 0:
            parts.append(text[start:i])
            start = i + 1
    parts.append(text[start:])
    return parts


def _assignments(items: Sequence[str], what: str, *, split_commas: bool = True) -> dict[str, str]:
    out: dict[str, str] = {}
    for item in items:
        parts = _split_top_level(item) if split_commas else [item]
        for part in parts:
            part = part.strip()
            if not part:
                continue
            if "=" not in part:
                raise ModelError(f"--{what} '{part}': expected NAME=VALUE, for example --{what} "
                                 + ("q2=0.5" if what == "initial" else "F=1.5*sin(3*t)" if what == "input" else "k=2"))
            name, value = part.split("=", 1)
            out[name.strip()] = value.strip()
    return out


def _number(text: str, where: str) -> float:
    """A number, or a constant expression such as pi/2 (parsed safely)."""
    from ..io._expr import parse_expression

    try:
        return float(text)
    except ValueError:
        pass
    try:
        value = parse_expression(text, {})
    except ExpressionError as exc:
        raise ModelError(f"{where}: '{text}' is not a number ({exc.reason}); write e.g. 0.5 or pi/2") from None
    return float(value)


def _cmd_derive(args) -> int:
    from .. import derive, load

    eqs = derive(load(args.model))
    if args.json:
        print(eqs.to_json())
    elif args.latex:
        print(eqs.latex())
    else:
        print(eqs.text())
    return 0


def _cmd_simulate(args) -> int:
    from .. import derive, load, simulate

    if args.output != "-":
        _check_writable(args.output)
    model = load(args.model)
    initial = {k: _number(v, f"--initial {k}") for k, v in _assignments(args.initial, "initial").items()}
    params = {k: _number(v, f"--param {k}") for k, v in _assignments(args.param, "param").items()}
    inputs = _assignments(args.input, "input", split_commas=False)
    eqs = derive(model)
    if args.show_equations:
        print(eqs.text(), file=sys.stderr if args.output == "-" else sys.stdout)
    defaults = model.simulation
    traj = simulate(eqs, args.t_end, initial or None,
                    inputs={**defaults.get("inputs", {}), **inputs} or None, params=params,
                    dt=args.dt, rtol=args.rtol, atol=args.atol, method=args.method)
    if args.output == "-":
        sys.stdout.write(traj.to_csv())
    else:
        _write_atomically(args.output, traj.to_csv())
        drift = traj.energy_drift
        extra = f"; {traj.energy_name} drift {drift:.2e}" if drift is not None and traj.conservative else ""
        print(f"wrote {len(traj.t)} rows (t = 0 .. {traj.t[-1]:g}) to {args.output}{extra}")
    return 0


def _check_writable(path: str) -> None:
    """Fail before a long computation, not after it, when the output cannot be written."""
    folder = os.path.dirname(os.path.abspath(path))
    if os.path.isdir(path):
        raise ModelError(f"--output {path}: it is a directory; give a file name such as {os.path.join(path, 'out.csv')}")
    if not os.path.isdir(folder):
        raise ModelError(f"--output {path}: the folder {folder} does not exist; create it or choose another path")
    if not os.access(folder, os.W_OK):
        raise ModelError(f"--output {path}: the folder {folder} is not writable; choose another path")


def _write_atomically(path: str, text: str) -> None:
    """Write to a temporary file beside `path`, then rename: an existing file is replaced only by a
    complete new one."""
    folder = os.path.dirname(os.path.abspath(path))
    fd, tmp = tempfile.mkstemp(prefix=".lagrangian-", suffix=".csv.tmp", dir=folder)
    try:
        with os.fdopen(fd, "w", newline="") as fh:
            fh.write(text)
        os.replace(tmp, path)
    except BaseException:
        if os.path.exists(tmp):
            os.unlink(tmp)
        raise


def _cmd_check(args) -> int:
    from .. import derive, load, singularities

    eqs = derive(load(args.model))
    report = singularities(eqs)
    if args.json:
        out = {"model": eqs.model.name, "coordinates": [c.name for c in eqs.coordinates], **report.to_dict()}
        print(json.dumps(out, indent=2))
    else:
        print(f"{eqs.model.name}: {eqs.n} coordinates ({', '.join(c.name for c in eqs.coordinates)}); model is valid.")
        print(report.text())
    return 0


def _cmd_examples(args) -> int:
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


def main(argv: Sequence[str] | None = None) -> int:
    """Run the CLI; returns the exit status."""
    parser = _parser()
    args = parser.parse_args(argv)
    if args.command is None:
        parser.print_help(sys.stderr)
        return 2
    handler = {"derive": _cmd_derive, "simulate": _cmd_simulate, "check": _cmd_check,
               "examples": _cmd_examples}[args.command]
    try:
        return handler(args)
    except (SingularMassMatrixError, SimulationError) as exc:
        print(f"lagrangian {args.command}: error: {exc}", file=sys.stderr)
        return 1
    except (ModelError, ExpressionError) as exc:
        print(f"lagrangian {args.command}: error: {exc}", file=sys.stderr)
        return 2
    except LagrangianError as exc:
        print(f"lagrangian {args.command}: error: {exc}", file=sys.stderr)
        return 1
    except BrokenPipeError:  # the reader of our output went away (| head): not an error of ours
        try:
            devnull = os.open(os.devnull, os.O_WRONLY)
            os.dup2(devnull, sys.stdout.fileno())
        except OSError:
            pass
        return 0
    except OSError as exc:
        print(f"lagrangian {args.command}: error: {exc.strerror or exc}: {exc.filename or ''}", file=sys.stderr)
        return 2
    except KeyboardInterrupt:
        print("lagrangian: interrupted", file=sys.stderr)
        return 130
