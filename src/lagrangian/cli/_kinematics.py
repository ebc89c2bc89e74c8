"""The commands kinematics (a point's or frame's position, velocity and Jacobian) and inverse-dynamics
(the generalized forces that hold a pose or drive a motion)."""

from __future__ import annotations

import argparse
import json
import math

from ..errors import ModelError
from ._common import MODEL_HELP, assignments, check_writable, number, option_number, parameter_values, write_output


def register(sub, fmt) -> None:
    k = sub.add_parser("kinematics", help="position, velocity and Jacobian of a named point or frame",
                       formatter_class=fmt,
                       description="The position, velocity and Jacobian J = d position/dq of a named point, particle "
                       "or body (its centre of mass; a planar body adds its angle), or of a frame (its origin, its "
                       "rotation R, its angular velocity in world and in its own axes, and the angular Jacobian "
                       "d omega/d q_dot), in world axes: printed symbolically, and as numbers at --at.",
                       epilog="Examples:\n  lagrangian kinematics double-pendulum --point bob2\n"
                              "  lagrangian kinematics double-pendulum --point bob2 --at theta1=0.3,theta2=0.5 --json\n"
                              "  lagrangian kinematics heavy-top --frame body --at theta=1,phi_dot=2,psi_dot=50")
    k.add_argument("model", help=MODEL_HELP)
    which = k.add_mutually_exclusive_group(required=True)
    which.add_argument("--point", metavar="NAME", help="a point, particle or body of the model")
    which.add_argument("--frame", metavar="NAME", help="a frame of the model (or world)")
    _state_options(k, "coordinates and velocities, e.g. q1=0.3,q2=0.5,q1_dot=1 (values may use pi and the model's "
                      "parameters; others 0): the numbers are printed too")
    k.add_argument("--json", action="store_true",
                   help="print one JSON object: model, name, kind, coordinates, position, velocity, jacobian (and "
                        "rotation, angle, angular_velocity, angular_velocity_body, angular_jacobian where they "
                        "exist), as expressions; with --at also state and values (the numbers)")
    k.set_defaults(handler=_cmd_kinematics)

    i = sub.add_parser("inverse-dynamics", help="the generalized forces that hold a pose or drive a motion",
                       formatter_class=fmt,
                       description="Inverse dynamics: tau = M q_ddot - f = M q_ddot + C q_dot + G - Q, the generalized "
                       "forces (by coordinate) that, added to the model's own, hold the pose (--at with coordinates "
                       "only) or drive the motion (--at with velocities and accelerations, or --motion, a CSV file "
                       "with the columns t, each coordinate, <q>_dot and <q>_ddot; the model's inputs from columns of "
                       "their names, or --input). Without --at or --motion, tau is printed symbolically. A "
                       "constrained model's actuators act on --actuated (default: [simulation] independent); the "
                       "multipliers are printed too.",
                       epilog="Examples:\n  lagrangian inverse-dynamics double-pendulum\n"
                              "  lagrangian inverse-dynamics double-pendulum --at theta1=0.5,theta2=0.2\n"
                              "  lagrangian inverse-dynamics cart-pendulum --at q2=1,q2_dot=0.5,q1_ddot=2 --json\n"
                              "  lagrangian inverse-dynamics double-pendulum --motion motion.csv -o torques.csv")
    i.add_argument("model", help=MODEL_HELP)
    _state_options(i, "coordinates, velocities and accelerations, e.g. q1=0.3,q1_dot=1,q1_ddot=-2 (values may use pi "
                      "and the model's parameters; others 0)")
    i.add_argument("--motion", metavar="FILE.csv",
                   help="a motion: a CSV file with a header row, the columns t, each coordinate, <q>_dot and <q>_ddot "
                        "(and optionally the inputs), one row per state")
    i.add_argument("--input", action="append", default=[], metavar="NAME=VALUE",
                   help="a constant input value (a number or an expression of the parameters; repeatable, or "
                        "comma-separated); inputs given neither here nor in --motion are 0")
    i.add_argument("--actuated", metavar="NAMES",
                   help="a constrained model: the coordinates the actuators act on, comma-separated (default: the "
                        "model's [simulation] independent coordinates)")
    i.add_argument("--json", action="store_true",
                   help="print one JSON object: model, coordinates, actuated, t, tau (one row per state), "
                        "multiplier_names, multipliers, total; without --at or --motion: {model, coordinates, tau} "
                        "as expressions")
    i.add_argument("--output", "-o", metavar="FILE",
                   help="write the table t,tau_<q>...,lambda_<c>... as CSV to FILE ('-' for stdout)")
    i.set_defaults(handler=_cmd_inverse_dynamics)


def _state_options(p: argparse.ArgumentParser, what: str) -> None:
    p.add_argument("--at", action="append", default=[], metavar="NAME=VALUE,...", help=what)
    p.add_argument("--param", action="append", default=[], metavar="NAME=VALUE",
                   help="override a parameter value (repeatable, or comma-separated)")
    p.add_argument("--t", type=option_number("--t", example="--t 0"), default=0.0,
                   help="the time, for models that contain t (default 0)")


def _at(args, model, params, allowed: list[str]) -> dict[str, float]:
    """--at NAME=VALUE,... as numbers, each name one of `allowed` (did-you-mean otherwise)."""
    from .._util import did_you_mean

    names = parameter_values(model, params)
    out = {}
    for key, text in assignments(args.at, "at").items():
        if key not in allowed:
            kinds = "coordinate, velocity or acceleration" if any(a.endswith("_ddot") for a in allowed) else \
                "coordinate or velocity"
            raise ModelError(f"--at {key}: '{key}' is not a {kinds} of the model{did_you_mean(key, allowed)}; "
                             f"the names are {', '.join(allowed)}")
        out[key] = number(text, f"--at {key}", names)
    return out


def _params(args) -> dict[str, float]:
    return {k: number(v, f"--param {k}") for k, v in assignments(args.param, "param").items()}


def _cmd_kinematics(args: argparse.Namespace) -> int:
    from .. import load
    from ..analysis import kinematics

    model = load(args.model)
    result = kinematics(model, args.point, frame=args.frame)
    params = _params(args)
    values = None
    if args.at:
        q = [c.name for c in model.q]
        qd = [f"{c}_dot" for c in q]
        at = _at(args, model, params, q + qd)
        values = result.at([at.get(c, 0.0) for c in q], [at.get(c, 0.0) for c in qd], params=params, t=args.t)
    elif params:
        result.at([0.0] * len(model.q), params=params)  # the parameters checked, though not used
    if args.json:
        out = result.to_dict()
        if values is not None:
            out["state"] = {**{c: at.get(c, 0.0) for c in q + qd}, "t": args.t}
            out["values"] = values.to_dict()
        print(json.dumps(out, indent=2))
        return 0
    print(result.text())
    if values is not None:
        state = ", ".join(f"{k} = {v:g}" for k, v in at.items()) or "q = 0"
        print(f"\nAt {state}" + (f", t = {args.t:g}" if args.t else "") + ":")
        print(values.text())
    return 0


def _cmd_inverse_dynamics(args: argparse.Namespace) -> int:
    from .. import derive, load
    from ..analysis import inverse_dynamics
    from ..equations._readable import text

    if args.at and args.motion:
        raise ModelError("--at and --motion: give one state (--at) or a motion (--motion FILE.csv), not both")
    if args.output:
        check_writable(args.output, "torques.csv", option="--output")
    model = load(args.model)
    eqs = derive(model)
    params = _params(args)
    names = parameter_values(eqs, params)
    inputs = {k: number(v, f"--input {k}", names) for k, v in assignments(args.input, "input").items()}
    actuated = None if args.actuated is None else [a.strip() for a in args.actuated.split(",") if a.strip()]
    q = [c.name for c in eqs.coordinates]
    if not args.at and not args.motion:
        if args.output:
            raise ModelError("--output: the table needs numbers: give a state (--at ...) or a motion "
                             "(--motion FILE.csv)")
        tau = eqs.inverse_dynamics
        if args.json:
            print(json.dumps({"model": model.name, "coordinates": q, "tau": [text(e) for e in tau]}, indent=2))
        else:
            print(f"Inverse dynamics of {model.name}: tau = M q_ddot - f, the generalized forces that drive the motion"
                  + (" (with constraints: tau_a + G^T lambda)" if eqs.is_constrained else ""))
            for c, e in zip(q, tau):
                print(f"  tau_{c} = {text(e)}")
        return 0
    if args.at:
        allowed = q + [f"{c}_dot" for c in q] + [f"{c}_ddot" for c in q]
        at = _at(args, eqs, params, allowed)
        state = [[at.get(c + s, 0.0) for c in q] for s in ("", "_dot", "_ddot")]
        if eqs.is_constrained:
            state = _on_the_constraints(eqs, state, at, params, inputs, args.t)
        result = inverse_dynamics(eqs, *state, params=params, inputs=inputs, t=args.t, actuated=actuated)
        if eqs.is_constrained and not args.json:
            print("The state, completed by the constraints (the values given held): "
                  + ", ".join(f"{c + s} = {v:.10g}" for s, row in zip(("", "_dot", "_ddot"), state)
                              for c, v in zip(q, row)))
    else:
        t, columns = read_motion(args.motion, q, [u.name for u in eqs.inputs])
        motion_inputs = {k: v for k, v in columns.items() if k in {u.name for u in eqs.inputs}}
        for k in inputs:
            motion_inputs.pop(k, None)  # --input replaces a column
        result = inverse_dynamics(eqs, _stack(columns, q, ""),
                                  _stack(columns, q, "_dot"), _stack(columns, q, "_ddot"), params=params,
                                  inputs={**inputs, **motion_inputs}, t=t, actuated=actuated)
    if args.output:
        write_output(args.output, result.to_csv(), "--output")
    if args.json:
        print(json.dumps(result.to_dict(), indent=2))
    elif not (args.output and args.output == "-"):
        print(result.text())
        if args.output:
            print(f"wrote {len(result.t)} row{'s' if len(result.t) != 1 else ''} to {args.output}")
    return 0


def _on_the_constraints(eqs, state, at, params, inputs, t):
    """A constrained model's --at state completed as simulate completes an initial state: the values
    given held, the other coordinates by Newton on g = 0 (from the model file's initial values), the
    other velocities and accelerations by the least change that meets G q_dot + b = 0 and G q_ddot = c."""
    import numpy as np

    from ..numeric import SimulationOptions
    from ..numeric._compiled import compile_equations
    from ..numeric._constrained import consistent_state, constrained_model

    nm = compile_equations(eqs)
    names = list(eqs.state_names)
    n = eqs.n
    p = np.array([params.get(k, v) for k, v in zip(nm.parameter_names, nm.parameter_values)], dtype=float)
    u = np.array([inputs.get(k, 0.0) for k in nm.input_names], dtype=float)
    x0 = np.array(state[0] + state[1], dtype=float)
    for k, v in SimulationOptions.from_model(eqs.model).initial.items():
        if k in names[:n] and k not in at and np.ndim(v) == 0:  # guesses for the coordinates only
            x0[names.index(k)] = float(v)
    x = consistent_state(constrained_model(eqs, nm), x0, {k for k in at if k in names}, p)
    G, c, _, _ = nm.constraint_parts(t, x, u, p)
    a = np.array(state[2], dtype=float)
    free = [i for i, name in enumerate(eqs.coordinates) if f"{name}_ddot" not in at]
    if free:
        fixed = [i for i in range(n) if i not in free]
        da, *_ = np.linalg.lstsq(G[:, free], c - G[:, fixed] @ a[fixed], rcond=None)
        a[free] = da
    return [list(x[:n]), list(x[n:]), list(a)]


def _stack(columns, q, suffix):
    import numpy as np

    return np.column_stack([columns[c + suffix] for c in q])


def read_motion(path: str, coordinates: list[str], inputs: list[str]):
    """(t (N,), {column: values (N,)}) of a motion CSV: the columns t, each coordinate, <q>_dot and
    <q>_ddot (every missing one named at once), and the inputs' columns where present; every cell a
    finite number; at most lagrangian's row limit (max_rows)."""
    import csv

    import numpy as np

    from .._limits import MAX_ROWS
    from .._util import did_you_mean

    where = f"--motion {path}"
    try:
        with open(path, newline="", encoding="utf-8-sig") as fh:
            rows = []
            for row in csv.reader(fh):
                if any(c.strip() for c in row):
                    rows.append(row)
                if len(rows) > MAX_ROWS.value + 1:
                    raise ModelError(f"{where}: more than {MAX_ROWS.value:,} rows; {MAX_ROWS.how_to_raise()}")
    except OSError as exc:
        raise ModelError(f"{where}: cannot read the file ({exc.strerror or exc}); check the path") from None
    except UnicodeDecodeError:
        raise ModelError(f"{where}: not a text CSV file (not UTF-8); save it as CSV text") from None
    except csv.Error as exc:
        raise ModelError(f"{where}: not a CSV file ({exc}); expected a header row and rows of numbers") from None
    needed = ["t", *coordinates, *(f"{c}_dot" for c in coordinates), *(f"{c}_ddot" for c in coordinates)]
    if not rows:
        raise ModelError(f"{where}: the file is empty; expected a header row ({','.join(needed)}) and rows of numbers")
    header = [c.strip() for c in rows[0]]
    missing = [c for c in needed if c not in header]
    if missing:
        hints = "".join(did_you_mean(c, header, sentence=True) for c in missing[:3])
        raise ModelError(f"{where}: the column{'s' if len(missing) > 1 else ''} {', '.join(missing)} "
                         f"{'are' if len(missing) > 1 else 'is'} missing; a motion has the columns {','.join(needed)} "
                         f"(its header row has {','.join(header) or 'nothing'}).{hints} Add the accelerations "
                         "<q>_ddot (and velocities <q>_dot) of the motion you want to drive")
    used = needed + [u for u in inputs if u in header]
    index = {c: header.index(c) for c in used}
    data = {c: [] for c in used}
    for r, row in enumerate(rows[1:], start=2):
        for c in used:
            k = index[c]
            cell = row[k].strip() if k < len(row) else ""
            try:
                x = float(cell)
            except ValueError:
                x = math.nan
            if not math.isfinite(x):
                raise ModelError(f"{where}: row {r}, column '{c}': '{cell or 'empty'}' is not a finite number; every "
                                 "cell of the motion's columns must be a number (remove the row or fill it)")
            data[c].append(x)
    if not data["t"]:
        raise ModelError(f"{where}: no data rows after the header; give one row per state")
    out = {c: np.array(v) for c, v in data.items()}
    return out.pop("t"), out
