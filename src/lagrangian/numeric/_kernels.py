"""The constants and the calling convention of the model-independent compiled kernels.

The kernels themselves (the input programs' interpreter, the scaled LDL^T solve of M q_ddot = f,
DOP853 with dense output, events and the singular-mass-matrix event, the batch drivers and the
midpoint variational integrator) are the numba module _kernels_numba.py, plain Python that ruff
and a reader read; :func:`kernel_source` returns its text, which ``_fast.kernels()`` loads from the
cache folder (see there). This module holds what the rest of the library needs without numba:
the status codes, the thresholds, the opcodes of the input programs, and the layout of the small
tuples the integrators take their problem in (plain tuples, unpacked by name in the kernels:
numba types a tuple as fast as its fields, a NamedTuple costs its dispatcher about 6 us a call),

    Model     (rhs, n, project, nwork, energy,    addresses of the model's functions (project: a
               energy_rows)                       constrained model's projection, 0: none, which
                                                  returns its result code as a double; nwork:
                                                  its rhs's work size, 0: n * n + 2 n; energy: 0
                                                  for no output stage; energy_rows: the energy at
                                                  many output rows at once, 0: none) and the
                                                  number n of coordinates
    Program   (ops, args, starts, nstack)         the inputs' (or events') postfix programs
    Control   (t0, rtol, atol, max_step, first_step)
    Events    (ops, args, starts, terminal, t, k, x, count)   event programs and their crossings
    Sampling  (hold, samples, which, history)     sampled inputs
    Outputs   (X, info, stats, U, E)              states, stop, counters, and the output stage's
                                                  inputs and Jacobi integral at the output times

so that dop853(model, x0, t_out, p, program, control, events, sampling, outputs) takes 9 arguments
(it took 35 as one flat list).
"""

from __future__ import annotations

from ..errors import Status

__all__ = ["EVENT_RATIO", "OPCODES", "PROJECTION_MET", "PROJECTION_NOT_FINITE", "PROJECTION_SINGULAR", "SINGULAR_RATIO",
           "STATUS", "STATUS_PROJECTION_NOT_FINITE", "STATUS_PROJECTION_SINGULAR", "SWITCH_OPCODES", "kernel_source"]

#: inertia measure of M at or below which the mass matrix counts as singular (stops at once).
SINGULAR_RATIO = 1e-12
#: the singular-mass-matrix event: the inertia measure crossing this value downwards.
EVENT_RATIO = 1e-9

#: Status codes returned by the compiled integrators: their messages, from the one enumeration
#: (lagrangian.errors.Status, whose members also carry the fix).
STATUS = {int(s): s.message for s in Status}
#: The result codes of a constrained model's projection (the generated lg_projection: on the constraints,
#: a singular system, values not finite; export_c's <ID>_MET, <ID>_SINGULAR, <ID>_NOT_FINITE), and the
#: statuses the compiled DOP853 stops with when the projection returns one of the last two
#: (Status.PROJECTION_SINGULAR, Status.PROJECTION_NOT_FINITE: written here as numbers, the kernels'
#: cache key reads this file's text; tests/numeric/test_projection_failure.py checks them).
PROJECTION_MET, PROJECTION_SINGULAR, PROJECTION_NOT_FINITE = 0, 3, 4
STATUS_PROJECTION_SINGULAR, STATUS_PROJECTION_NOT_FINITE = 7, 8
#: Consecutive steps, each ended by a switch and shorter than CHATTER_STEP of the time span, that
#: stop the integration as chattering (status 5).
CHATTER_STEPS = 100
CHATTER_STEP = 1e-6

#: Opcodes of the input programs (postfix; see _inputs.py).
OPCODES = {
    "const": 0, "t": 1, "param": 2, "add": 3, "mul": 4, "pow": 5, "atan2": 6, "max": 7, "min": 8,
    "sin": 10, "cos": 11, "tan": 12, "exp": 13, "log": 14, "sqrt": 15, "abs": 16, "sign": 17,
    "asin": 18, "acos": 19, "atan": 20, "sinh": 21, "cosh": 22, "tanh": 23, "heaviside": 24,
    "floor": 25, "ceiling": 26, "x": 27, "u": 28,
    # switches (argument: the switch's index) and logic: see _inputs.py
    "gt": 29, "ge": 30, "and": 31, "or": 32, "where": 33, "not": 34, "sign_switch": 35,
    "heaviside_switch": 36,
    # a measured signal (argument: the offset of its table in args; see _inputs.Signal)
    "table": 37,
}
#: Opcodes whose argument is the index of a switch.
SWITCH_OPCODES = (29, 30, 35, 36)


def kernel_source() -> str:
    """The text of the kernels' module, _kernels_numba.py (see the module docstring)."""
    from pathlib import Path

    return (Path(__file__).with_name("_kernels_numba.py")).read_text(encoding="utf-8")
