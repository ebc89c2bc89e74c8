"""Helpers shared by the CLI's commands: NAME=VALUE options, numbers, safe output files, and the
simulation options that `simulate` and `animate` share."""

from __future__ import annotations

import argparse
import sys
from typing import Mapping, Sequence

from ..errors import ModelError
from ..io._files import check_output, write_atomically, write_output  # noqa: F401  (the writers of every command)
from ..model._expr import constant_value as number  # the value of a numeric option (shared with the playground)

MODEL_HELP = "a model file (.toml) or a built-in example name (see `lagrangian examples`)"


def split_top_level(text: str) -> list[str]:
    """Split at the commas that are not inside parentheses: "q1=0,q2=atan2(1,2)" -> 2 parts."""
    parts, depth, start = [], 0, 0
    for i, ch in enumerate(text):
        depth += (ch == "(") - (ch == ")")
        if ch == "," and depth == 0:
            parts.append(text[start:i])
            start = i + 1
    parts.append(text[start:])
    return parts


_EXAMPLES = {"initial": "q2=0.5", "input": "F=1.5*sin(3*t)", "velocity": "phi_dot=4", "momentum": "p_phi=1",
             "at": "q2=pi/2", "sample-time": "F=0.01"}


def assignments(items: Sequence[str], what: str, *, split_commas: bool = True) -> dict[str, str]:
    out: dict[str, str] = {}
    for item in items:
        parts = split_top_level(item) if split_commas else [item]
        for part in parts:
            part = part.strip()
            if not part:
                continue
            if "=" not in part:
                raise ModelError(f"--{what} '{part}': expected NAME=VALUE, for example --{what} "
                                 + _EXAMPLES.get(what, "k=2"))
            name, value = part.split("=", 1)
            out[name.strip()] = value.strip()
    return out


def parameter_values(model, params: Mapping[str, float], leave_out: Sequence[str] = ()) -> dict[str, float]:
    """The names an option's expression (--initial, --input, --at, ...) may use: the parameters of
    `model` (a Model or its Equations) with their values, those of --param (`params`) in their place;
    without those in `leave_out` (a swept parameter, whose value varies)."""
    names = [p.name for p in model.parameters]
    values = {p.name: float(v) for p, v in model.parameters.items() if v is not None}
    values.update({k: v for k, v in params.items() if k in names})
    out = {k: v for k, v in values.items() if k not in leave_out}
    for k, e in getattr(getattr(model, "model", model), "derived_parameters", {}).items():
        if {s.name for s in e.free_symbols} <= set(out):  # a derived parameter at these values
            out[k] = float(e.xreplace({s: out[s.name] for s in e.free_symbols}))
    return out


def check_writable(path: str, example: str = "out.csv", option: str = "--output") -> None:
    """Fail before a long computation, not after it, when the output cannot be written (see
    lagrangian.io._files.check_output: a stream such as a FIFO or /dev/null passes)."""
    check_output(path, option, example)


class InvalidNumber(str):
    """The message about a numeric option's value that failed its check: parsed as the option's value
    and raised by check_numbers (in main, as one ModelError with every such problem: exit 2)."""


def option_number(flag: str, *, integer: bool = False, example: str | None = None, **bounds):
    """The argparse `type` of a numeric option: the number, checked by lagrangian._limits.number_problem
    (finite; `bounds`: positive, minimum, maximum), or an InvalidNumber saying what is wrong."""
    from .._limits import number_problem

    example = example or f"{flag} {'200' if integer else '0.5'}"

    def parse(text: str):
        try:
            value = int(text) if integer else float(text)
        except ValueError:
            return InvalidNumber(f"{flag} must be {'a whole number' if integer else 'a number'}, got {text!r}; "
                                 f"for example {example}")
        problem = number_problem(value, flag, integer=integer, example=example, shown=text, **bounds)
        return InvalidNumber(problem) if problem else value

    parse.__name__ = "whole number" if integer else "number"
    return parse


def check_numbers(args: argparse.Namespace) -> None:
    """Raise one ModelError with every numeric option that failed its check (see option_number)."""
    from ..errors import Problem

    bad = [Problem(str(v)) for v in vars(args).values() if isinstance(v, InvalidNumber)]
    if bad:
        raise ModelError(bad)


def add_simulation_options(s: argparse.ArgumentParser) -> None:
    """The options of a simulation, shared by every command that simulates (simulate, animate)."""
    s.add_argument("--t-end", type=option_number("--t-end", positive=True, example="--t-end 10"), metavar="T",
                   help="final time (s)")
    s.add_argument("--initial", action="append", default=[], metavar="NAME=VALUE,...",
                   help="initial coordinates and velocities, e.g. q1=0,q2=0.5,q2_dot=0 (values may use pi and the "
                        "model's parameters, at their --param values); the others keep the model file's "
                        "[simulation] initial values (0 where it gives none)")
    s.add_argument("--param", action="append", default=[], metavar="NAME=VALUE",
                   help="override a parameter value (repeatable, or comma-separated)")
    s.add_argument("--input", action="append", default=[], metavar="NAME=EXPR",
                   help="an input as an expression of t, the coordinates, velocities and parameters, e.g. "
                        "\"F=1.5*sin(3*t)\" or the feedback law \"F=-20*(q2-pi/2)-5*q2_dot\", which may switch: "
                        "where(condition, a, b), min, max, clip (repeatable), or a measured signal, a column of "
                        "a CSV file: \"F=@data.csv:acc\" (linear between rows; add :cubic for the not-a-knot "
                        "spline, :hold to hold the end values outside the table's times); inputs not given keep "
                        "the model file's [simulation] inputs (0 where it gives none)")
    s.add_argument("--sample-time", metavar="TS or NAME=TS",
                   help="sample the inputs every TS seconds and hold them in between (a digital controller); "
                        "NAME=TS,... samples only the named inputs")
    s.add_argument("--dt", type=option_number("--dt", positive=True, example="--dt 0.01"),
                   help="output interval (default: the model's, or 0.01)")
    s.add_argument("--rtol", type=option_number("--rtol", positive=True, maximum=1, example="--rtol 1e-9"),
                   help="relative tolerance (default 1e-9)")
    s.add_argument("--atol", type=option_number("--atol", positive=True, example="--atol 1e-9"),
                   help="absolute tolerance (default 1e-9)")
    s.add_argument("--method", default="DOP853",
                   help="integrator: DOP853 (default, compiled), variational (compiled, fixed step, for long "
                        "conservative runs), or SciPy's RK45, RK23, Radau, BDF, LSODA")
    s.add_argument("--backend", default="auto", choices=("auto", "numba", "c", "scipy"),
                   help="where the integrator runs: auto (default: numba when it can), numba, c (needs a C "
                        "compiler), scipy (SciPy's solve_ivp)")
    s.add_argument("--step", type=option_number("--step", positive=True, example="--step 0.001"),
                   help="fixed step of --method variational (default: at most 1e-3, dividing dt)")
    s.add_argument("--event", action="append", default=[], metavar="NAME=EXPR",
                   help="record where an expression of t, coordinates, velocities, inputs and parameters crosses "
                        "zero, e.g. \"upright=cos(q2)\" (repeatable; compiled DOP853 only)")
    s.add_argument("--stop-on", action="append", default=[], metavar="NAME",
                   help="stop at the first crossing of this --event (repeatable)")
    s.add_argument("--constraints", default="project", choices=("project", "eliminate"),
                   help="a constrained model: project (default: all coordinates, projected onto the constraints "
                        "after every step) or eliminate (an ODE in the [simulation] independent coordinates, the "
                        "others by Newton on g = 0)")
    s.add_argument("--show-equations", action="store_true", help="print the equations before simulating")


def run_simulation(args, *, equations_to=None):
    """Load, derive and simulate as the simulation options say; returns (model, equations, trajectory).

    `equations_to` is the stream for --show-equations (stderr when stdout carries the data)."""
    from .. import derive, load, simulate

    model = load(args.model)
    params = {k: number(v, f"--param {k}") for k, v in assignments(args.param, "param").items()}
    names = parameter_values(model, params)
    initial = {k: number(v, f"--initial {k}", names) for k, v in assignments(args.initial, "initial").items()}
    inputs = signal_inputs(assignments(args.input, "input", split_commas=False))
    events = assignments(getattr(args, "event", []), "event", split_commas=False)
    stop_on = [name.strip() for item in getattr(args, "stop_on", []) for name in item.split(",") if name.strip()]
    eqs = derive(model)
    if args.show_equations:
        print(eqs.text(), file=equations_to or sys.stdout)
    traj = simulate(eqs, args.t_end, initial or None, inputs=inputs or None, params=params,  # merged by name
                    dt=args.dt, rtol=args.rtol, atol=args.atol, method=args.method,
                    backend=getattr(args, "backend", "auto"), step=getattr(args, "step", None),
                    events=events or None, stop_on=tuple(stop_on),
                    sample_time=sample_time_option(getattr(args, "sample_time", None)),
                    constraints=getattr(args, "constraints", "project"))
    return model, eqs, traj


def signal_inputs(inputs: Mapping[str, str]) -> dict:
    """--input NAME=@FILE.csv[:COLUMN][:cubic][:hold]: the column (default: the column named NAME) of a
    CSV file as a measured signal (lagrangian.Signal), linear (or cubic) between its rows; the others
    as they are."""
    from ..io._signalspec import split_signal_spec
    from ..numeric import Signal

    out: dict = {}
    for name, text in inputs.items():
        if not text.startswith("@"):
            out[name] = text
            continue
        path, column, options = split_signal_spec(name, text)
        if not path:
            raise ModelError(f"--input {name}={text}: expected a CSV file after '@', for example "
                             f"--input {name}=@data.csv:{name} (or @data.csv:{name}:cubic, @data.csv:{name}:hold)")
        out[name] = Signal.from_csv(path, column, **options)
    return out


def sample_time_option(text: str | None):
    """--sample-time: a period (every input) or NAME=PERIOD,... (the named inputs), or None."""
    if text is None:
        return None
    if "=" not in text:
        return number(text, "--sample-time")
    return {k: number(v, f"--sample-time {k}") for k, v in assignments([text], "sample-time").items()}


def events_csv(traj) -> str:
    """The event crossings of a trajectory as CSV: event,t,<states>, in time order."""
    rows = [(float(t), name, x) for name, ev in traj.events.items() for t, x in zip(ev["t"], ev["x"])]
    rows.sort(key=lambda r: r[0])
    lines = [",".join(["event", "t", *traj.state_names])]
    lines += [",".join([name, repr(t), *(repr(float(v)) for v in x)]) for t, name, x in rows]
    return "\n".join(lines) + "\n"


def events_summary(traj) -> list[str]:
    """One line for each event: how many crossings and the first; and why the run stopped."""
    out = []
    for name, ev in traj.events.items():
        k = len(ev["t"])
        first = f", the first at t = {ev['t'][0]:.6g}" if k else ""
        out.append(f"event {name}: {k} crossing{'' if k == 1 else 's'}{first}")
    if "stopped_by" in traj.stats:
        out.append(f"stopped by event {traj.stats['stopped_by']} at t = {traj.stats['stop_time']:.6g} "
                   f"(the last output row is t = {traj.t[-1]:g})")
    return out
