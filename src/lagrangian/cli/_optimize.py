"""The optimize command: the optimal motion of a model file's [optimal_control] problem."""

from __future__ import annotations

import argparse
import json

from ._common import MODEL_HELP, assignments, check_writable, number, option_number


def register(sub, fmt) -> None:
    o = sub.add_parser("optimize", help="find an optimal motion (direct collocation, IPOPT) and check it by a replay",
                       formatter_class=fmt, description="Solve the model file's [optimal_control] problem by direct "
                       "collocation (Hermite-Simpson on the implicit equations M q_ddot = f, the multipliers as "
                       "unknowns for constrained models) with IPOPT, refine the mesh until the collocation error is "
                       "below the tolerance, then replay the optimal input law with simulate and report the "
                       "deviation. Needs CasADi: pip install 'lagrangian[optimal]'.",
                       epilog="Examples:\n  lagrangian optimize cart-pole.toml\n"
                              "  lagrangian optimize cart-pole.toml --json\n"
                              "  lagrangian optimize cart-pole.toml -o motion.csv --input-law law.csv\n"
                              "  lagrangian simulate cart-pole.toml --input F=@law.csv:F --t-end 2   "
                              "(the law replayed)")
    o.add_argument("model", help=MODEL_HELP)
    o.add_argument("--json", action="store_true",
                   help="print the result as JSON (the numbers, the checks, the columns)")
    o.add_argument("--output", "-o", metavar="FILE", help="write the motion as CSV: t, the states, the inputs")
    o.add_argument("--input-law", metavar="FILE",
                   help="write the free inputs at the collocation points as CSV (t, then each input), for "
                        "simulate --input NAME=@FILE:NAME")
    o.add_argument("--param", action="append", default=[], metavar="NAME=VALUE",
                   help="override a parameter's value (repeatable, or comma-separated)")
    o.add_argument("--intervals", type=option_number("--intervals", integer=True, minimum=2, maximum=5000,
                                                     example="--intervals 50"),
                   help="the first mesh's intervals (default: the table's, or 25)")
    o.add_argument("--tolerance", type=option_number("--tolerance", positive=True, example="--tolerance 1e-6"),
                   help="the collocation error to reach (default: the table's, or 1e-6)")
    o.set_defaults(handler=_cmd_optimize)


def _cmd_optimize(args: argparse.Namespace) -> int:
    from ..equations import derive
    from ..errors import ModelError
    from ..io import load
    from ..optimal_control import optimal_motion

    if args.output:
        check_writable(args.output, "motion.csv")
    if args.input_law:
        check_writable(args.input_law, "law.csv", "--input-law")
    model = load(args.model)
    if not model.optimal_control:
        raise ModelError(f"model '{model.name}' has no [optimal_control] table: add one to the model file, for "
                         "example\n[optimal_control]\nduration = 2.0\nobjective = \"F**2\"\n"
                         "inputs = { F = [-20.0, 20.0] }\ninitial = { q1 = 0.0, q1_dot = 0.0 }\n"
                         "final = { q1 = 1.0, q1_dot = 0.0 }")
    params = {k: number(v, f"--param {k}") for k, v in assignments(args.param, "param").items()}
    eqs = derive(model)
    motion = optimal_motion(eqs, params=params or None, intervals=args.intervals, tolerance=args.tolerance)
    if args.output:
        motion.to_csv(args.output)
    if args.input_law:
        motion.input_law_csv(args.input_law)
    if args.json:
        print(json.dumps(motion.to_dict(), indent=2))
        return 0
    print(f"optimal motion of {model.name}: {motion.status} after {motion.iterations} IPOPT iterations")
    print(f"  cost {motion.cost:.10g}, duration {motion.duration:.10g} s")
    print(f"  mesh: {motion.intervals} intervals, collocation error {motion.collocation_error:.2e} "
          f"({'below' if motion.converged else 'ABOVE'} the tolerance {motion.tolerance:.1e})")
    if eqs.is_constrained:
        print(f"  constraints: largest residual {motion.constraint_error:.2e}")
    if motion.replay_failure:
        print(f"  replay by simulate failed: {motion.replay_failure}")
    else:
        worst = max(motion.replay_deviation, key=motion.replay_deviation.get)
        print(f"  replay by simulate: largest deviation {motion.replay_deviation[worst]:.2e} (in {worst})")
    for path, what in ((args.output, "motion"), (args.input_law, "input law")):
        if path:
            print(f"  wrote the {what} to {path}")
    return 0
