"""The model-independent compiled kernels: input programs, the scaled Cholesky solve of
M q_ddot = f, DOP853 with dense output and the singular-mass-matrix event, the batch driver, and
the midpoint variational integrator.

:func:`kernel_source` returns them as Python source for numba. They are written once to the cache
directory (see _fast.kernels) and compiled once per machine (``@njit(cache=True)``): a model's
functions (numba ``cfunc``, or the C backend's functions) are passed to them by their addresses,
as integers (typing a function object would cost numba microseconds per call), and have fixed
signatures,

    rhs(t, x*, u*, p*, dx*, work*) -> double  dx = [q_dot, q_ddot]; returns the inertia measure
                                              of M (-1.0 when f is not finite)
    energy(t, x*, u*, p*) -> double           the Jacobi integral
    mass_forcing(t, x*, u*, p*, M*, f*)      M row-major (n x n), f (n)
    lagrange_parts(t, x*, u*, p*, pm*, F*)   pm = dL/dq_dot, F = dL/dq - dD/dq_dot + Q
    rhs_lanes(t*, x*, u*, p*, dx*, work*, L) rhs of L states (lane-major arrays) at once

so that a new model compiles only its own functions (a fraction of a second) and no integrator.

The Runge-Kutta stages are written out with their coefficients as literals and the zero ones
left out. The coefficients of DOP853 (Hairer, Norsett and Wanner's 8(5,3) pair with its order-7
dense output) are read from SciPy's table at generation time, so that this integrator and SciPy's
``solve_ivp(method="DOP853")`` take the same steps; the step-size control follows SciPy's too.
"""

from __future__ import annotations

from ..errors import Status

__all__ = ["kernel_source", "STATUS", "OPCODES", "SWITCH_OPCODES", "SINGULAR_RATIO", "EVENT_RATIO"]

#: inertia measure of M at or below which the mass matrix counts as singular (stops at once).
SINGULAR_RATIO = 1e-12
#: the singular-mass-matrix event: the inertia measure crossing this value downwards.
EVENT_RATIO = 1e-9

#: Status codes returned by the compiled integrators: their messages, from the one enumeration
#: (lagrangian.errors.Status, whose members also carry the fix).
STATUS = {int(s): s.message for s in Status}
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
}
#: Opcodes whose argument is the index of a switch.
SWITCH_OPCODES = (29, 30, 35, 36)


def _coefficients():
    from scipy.integrate._ivp import dop853_coefficients as c

    return c.A, c.C, c.E3, c.E5, c.D


def _lincomb(terms, var: str, index: str = "i") -> str:
    """'a * K[j, i] + ...' for the non-zero coefficients."""
    parts = [f"{float(a)!r} * {var}[{j}, {index}]" for j, a in terms if a != 0.0]
    return " + ".join(parts) if parts else "0.0"


def stage_table() -> tuple:
    """(aptr, aidx, aval, c): the non-zero coefficients of the stages (rows 1..15 of A, row 12
    being the solution's weights, C[12] = 1) in compressed rows, and the nodes c."""
    import numpy as np

    A, C, _, _, _ = _coefficients()
    ptr, idx, val = [0], [], []
    for s in range(16):
        for j in range(s):
            if A[s, j] != 0.0:
                idx.append(j)
                val.append(float(A[s, j]))
        ptr.append(len(idx))
    return (np.array(ptr, dtype=np.int64), np.array(idx, dtype=np.int64), np.array(val),
            np.array(C, dtype=float))


_STAGE_LOOP = """{i}for st in range({first}, {last}):
{i}    for i in range(nx):
{i}        acc = 0.0
{i}        for jj in range(aptr[st], aptr[st + 1]):
{i}            acc += aval[jj] * K[aidx[jj], i]
{i}        xs[i] = y[i] + h * acc
{i}    ts = t + cc[st] * h
{i}    if nin:
{i}        eval_inputs(ts, xs, p, ops, args, starts, stack, u, modes, live, hold, held)
{i}    r = _rc(rc, ts, pxs, pu, pp, _ptr(K, st * nx), pw)"""


def _unrolled(first: int, last: int, indent: str, lanes: bool = False) -> list[str]:
    """Stages first..last-1 written out: of dop853, or (`lanes`) of dop853_lanes, where each
    lane k has its own time T[k] and step H[k] (HW[w] = H[k] for each component w = i * L + k
    of the lane-major arrays) and any trouble hands the block back."""
    A, C, _, _, _ = _coefficients()
    lines = []
    for s in range(first, last):
        c = float(C[s])
        if lanes:
            body = ["for w in range(W):", f"    xs[w] = y[w] + HW[w] * ({_lincomb(enumerate(A[s, :s]), 'K', 'w')})",
                    "for k in range(L):", f"    TS[k] = T[k] + {c!r} * H[k]",
                    "if nin:", "    _lane_inputs(TS, P, ops, args, starts, stack, u1, U, lm, lh)",
                    f"r = _rl(rc, pts, pxs, pu, pp, _ptr(K, {s} * W), pw, L)"]
            check = ["if r < EVENT_RATIO:", "    return 1"]
        else:
            body = ["for i in range(nx):", f"    xs[i] = y[i] + h * ({_lincomb(enumerate(A[s, :s]), 'K')})",
                    f"ts = t + {c!r} * h",
                    "if nin:", "    eval_inputs(ts, xs, p, ops, args, starts, stack, u, modes, live, hold, held)",
                    f"r = _rc(rc, ts, pxs, pu, pp, _ptr(K, {s} * nx), pw)"]
            check = ["nfev += 1", "if r < 0.0 or r <= SINGULAR_RATIO:",
                     "    if r < 0.0 and not live:  # a branch of a switch evaluated out of its region:",
                     "        live = True           # take this step again with the switches live",
                     "        continue",
                     "    return _fail(r, ts, xs, info, stats, nfev, nstep, nrej, j)"]
        lines += [indent + line for line in body + (check if s < 13 else [])]
    return lines


#: Write the stages out (faster steps, longer one-time compilation of the kernels) or loop over
#: a table of coefficients.
UNROLL_STAGES = True


def _interpolant(D, h: str, i: str, indent: str) -> list[str]:
    """Statements of the coefficients F[:, i] of the order-7 interpolant of a step of size h."""
    lines = ["dy = ynew[@] - y[@]", "F[0, @] = dy", "F[1, @] = H * K[0, @] - dy",
             "F[2, @] = 2.0 * dy - H * (K[12, @] + K[0, @])"]
    lines += [f"F[{r + 3}, @] = H * ({_lincomb(enumerate(D[r]), 'K', '@')})" for r in range(D.shape[0])]
    return [indent + line.replace("@", i).replace("H", h) for line in lines]


def _generated_parts() -> dict[str, str]:
    _, _, E3, E5, D = _coefficients()
    if UNROLL_STAGES:
        steps = _unrolled(1, 13, " " * 12)
    else:
        steps = _STAGE_LOOP.format(i=" " * 12, first=1, last=13).splitlines()
        steps += [
            "                nfev += 1",
            "                if r < 0.0 or r <= SINGULAR_RATIO:",
            "                    return _fail(r, ts, xs, info, stats, nfev, nstep, nrej, j)",
        ]
    steps += [
        "            rnew = r",
        "            for i in range(nx):",
        "                ynew[i] = xs[i]",
        "            e5 = 0.0",
        "            e3 = 0.0",
        "            for i in range(nx):",
        "                scl = atol + max(abs(y[i]), abs(ynew[i])) * rtol",
        f"                d5 = ({_lincomb(enumerate(E5), 'K')}) / scl",
        f"                d3 = ({_lincomb(enumerate(E3), 'K')}) / scl",
        "                e5 += d5 * d5",
        "                e3 += d3 * d3",
    ]
    extra = (_unrolled(13, 16, "    ") if UNROLL_STAGES
             else _STAGE_LOOP.format(i="    ", first=13, last=16).splitlines())
    lanes_steps = _unrolled(1, 13, " " * 8, lanes=True) + [
        "        for w in range(W):",
        "            ynew[w] = xs[w]",
        "            scl = atol + max(abs(y[w]), abs(xs[w])) * rtol",
        f"            D5[w] = ({_lincomb(enumerate(E5), 'K', 'w')}) / scl",
        f"            D3[w] = ({_lincomb(enumerate(E3), 'K', 'w')}) / scl",
        "        for k in range(L):",
        "            e5 = 0.0",
        "            e3 = 0.0",
        "            for i in range(nx):",
        "                e5 += D5[i * L + k] ** 2",
        "                e3 += D3[i * L + k] ** 2",
        "            ERR[k] = 0.0 if (e5 == 0.0 and e3 == 0.0) else HA[k] * e5 / math.sqrt((e5 + 0.01 * e3) * nx)",
    ]
    lanes_extra = (_unrolled(13, 16, "    ", lanes=True)
                   + ["    for i in range(nx):", "        for k in range(L):", "            w = i * L + k"]
                   + _interpolant(D, "H[k]", "w", " " * 12))
    extra += ["    for i in range(nx):"] + _interpolant(D, "h", "i", " " * 8)
    return {"@STEP@": "\n".join(steps), "@EXTRA@": "\n".join(extra), "@LSTEP@": "\n".join(lanes_steps),
            "@LEXTRA@": "\n".join(lanes_extra)}


_TEMPLATE = '''"""Compiled kernels of lagrangian (generated by lagrangian.numeric._kernels; do not edit).

Model functions are passed as numba cfuncs of fixed signatures (see that module)."""

import math

import numpy as np
from numba import njit, prange, types
from llvmlite import ir
from numba.extending import intrinsic


@intrinsic
def _ptr(typingctx, arr, offset):
    """The address of arr.flat[offset] as a double* (no reference counting, unlike arr.ctypes)."""
    sig = types.CPointer(types.float64)(arr, offset)

    def codegen(context, builder, signature, args):
        data = context.make_array(signature.args[0])(context, builder, value=args[0]).data
        return builder.gep(data, [args[1]])

    return sig, codegen


def _call(builder, addr, ret, args):
    """Call the C function at the address `addr` (an integer)."""
    fnty = ir.FunctionType(ret, [a.type for a in args])
    return builder.call(builder.inttoptr(addr, fnty.as_pointer()), list(args))


_D = types.float64
_PD = types.CPointer(types.float64)


@intrinsic
def _rc(typingctx, addr, t, x, u, p, dx, work):
    """rhs(t, x, u, p, dx, work) -> double, the model function at `addr`."""
    def codegen(context, builder, signature, args):
        return _call(builder, args[0], ir.DoubleType(), args[1:])
    return _D(types.intp, _D, _PD, _PD, _PD, _PD, _PD), codegen


@intrinsic
def _en(typingctx, addr, t, x, u, p):
    """energy(t, x, u, p) -> double, the model function at `addr`."""
    def codegen(context, builder, signature, args):
        return _call(builder, args[0], ir.DoubleType(), args[1:])
    return _D(types.intp, _D, _PD, _PD, _PD), codegen


@intrinsic
def _vf(typingctx, addr, t, x, u, p, a, b):
    """mass_forcing or lagrange_parts(t, x, u, p, a, b), the model function at `addr`."""
    def codegen(context, builder, signature, args):
        _call(builder, args[0], ir.VoidType(), args[1:])
        return context.get_dummy_value()
    return types.void(types.intp, _D, _PD, _PD, _PD, _PD, _PD), codegen


@intrinsic
def _rl(typingctx, addr, t, x, u, p, dx, work, lanes):
    """rhs_lanes(t, x, u, p, dx, work, L) -> double (t: the lanes' times), the model function
    at `addr`."""
    def codegen(context, builder, signature, args):
        return _call(builder, args[0], ir.DoubleType(), args[1:])
    return _D(types.intp, _PD, _PD, _PD, _PD, _PD, _PD, types.int64), codegen

SINGULAR_RATIO = @SINGULAR@
EVENT_RATIO = @EVENT@
CHATTER_STEPS = @CHATTER_STEPS@
CHATTER_STEP = @CHATTER_STEP@


@njit(cache=True)
def _sign(a):
    return 1.0 if a > 0.0 else (-1.0 if a < 0.0 else 0.0)


@njit(cache=True)
def _heaviside(a):
    return 1.0 if a > 0.0 else (0.5 if a == 0.0 else 0.0)


@njit(cache=True)
def _run(ops, args, lo, hi, t, x, u, p, stack, modes, live):
    """The value of the postfix program ops[lo:hi] (see lagrangian.numeric._inputs).

    A switch (a comparison, or sign) with index s writes its value to modes[s] when `live`,
    and reads it from there when not: the integrator freezes the switches during a step and
    locates where they change."""
    top = 0
    for c in range(lo, hi):
        op = ops[c]
        if op == 0:
            stack[top] = args[c]
            top += 1
        elif op == 1:
            stack[top] = t
            top += 1
        elif op == 2:
            stack[top] = p[int(args[c])]
            top += 1
        elif op == 27:
            stack[top] = x[int(args[c])]
            top += 1
        elif op == 28:
            stack[top] = u[int(args[c])]
            top += 1
        elif op < 10:
            b = stack[top - 1]
            a = stack[top - 2]
            top -= 1
            if op == 3:
                stack[top - 1] = a + b
            elif op == 4:
                stack[top - 1] = a * b
            elif op == 5:
                stack[top - 1] = a ** b
            elif op == 6:
                stack[top - 1] = math.atan2(a, b)
            elif op == 7:
                stack[top - 1] = max(a, b)
            else:
                stack[top - 1] = min(a, b)
        elif op < 27:
            a = stack[top - 1]
            if op == 10:
                a = math.sin(a)
            elif op == 11:
                a = math.cos(a)
            elif op == 12:
                a = math.tan(a)
            elif op == 13:
                a = math.exp(a)
            elif op == 14:
                a = math.log(a) if a > 0.0 else (-math.inf if a == 0.0 else math.nan)
            elif op == 15:
                a = math.sqrt(a) if a >= 0.0 else math.nan
            elif op == 16:
                a = abs(a)
            elif op == 17:
                a = _sign(a)
            elif op == 18:
                a = math.asin(a) if abs(a) <= 1.0 else math.nan
            elif op == 19:
                a = math.acos(a) if abs(a) <= 1.0 else math.nan
            elif op == 20:
                a = math.atan(a)
            elif op == 21:
                a = math.sinh(a)
            elif op == 22:
                a = math.cosh(a)
            elif op == 23:
                a = math.tanh(a)
            elif op == 24:
                a = _heaviside(a)
            elif op == 25:
                a = math.floor(a)
            else:
                a = math.ceil(a)
            stack[top - 1] = a
        elif op < 33:  # gt, ge (switches), and, or
            b = stack[top - 1]
            a = stack[top - 2]
            top -= 1
            if op == 29 or op == 30:
                k = int(args[c])
                if live:
                    v = 1.0 if ((a > b) if op == 29 else (a >= b)) else 0.0
                    modes[k] = v
                else:
                    v = modes[k]
            elif op == 31:
                v = 1.0 if (a != 0.0 and b != 0.0) else 0.0
            else:
                v = 1.0 if (a != 0.0 or b != 0.0) else 0.0
            stack[top - 1] = v
        elif op == 33:  # where(condition, a, b)
            b = stack[top - 1]
            a = stack[top - 2]
            top -= 2
            stack[top - 1] = a if stack[top - 1] != 0.0 else b
        elif op == 34:
            stack[top - 1] = 1.0 if stack[top - 1] == 0.0 else 0.0
        else:  # sign and heaviside as switches
            k = int(args[c])
            if live:
                a = stack[top - 1]
                modes[k] = _sign(a) if op == 35 else _heaviside(a)
            stack[top - 1] = modes[k]
    return stack[0]


@njit(cache=True)
def eval_inputs(t, x, p, ops, args, starts, stack, u, modes, live, hold, held):
    """u[i] = program i (postfix, see lagrangian.numeric._inputs) at (t, x) with parameters p;
    a sampled input (hold[i] = 1) keeps its held value held[i]."""
    for k in range(starts.shape[0] - 1):
        if hold[k]:
            u[k] = held[k]
        else:
            u[k] = _run(ops, args, starts[k], starts[k + 1], t, x, u, p, stack, modes, live)


@njit(cache=True)
def _sample(t, x, p, ops, args, starts, stack, u, modes, hold, held, which, hist, row):
    """A sample instant: held[i] = input i at (t, x) for the sampled inputs with which[row, i];
    hist[row] = held."""
    for k in range(starts.shape[0] - 1):
        if hold[k] and which[row, k]:
            held[k] = _run(ops, args, starts[k], starts[k + 1], t, x, u, p, stack, modes, True)
        hist[row, k] = held[k]


@njit(cache=True)
def _changed(t, x, p, ops, args, starts, stack, u, modes, mlive, nsw, hold, held):
    """Whether a switch evaluated live at (t, x) (into mlive) differs from its frozen value."""
    for k in range(nsw):
        mlive[k] = modes[k]
    eval_inputs(t, x, p, ops, args, starts, stack, u, mlive, True, hold, held)
    for k in range(nsw):
        if mlive[k] != modes[k]:
            return True
    return False


@njit(cache=True)
def switch_count(ops, args):
    """The number of switches of a program (the largest switch index + 1)."""
    m = 0
    for c in range(ops.shape[0]):
        if ops[c] == 29 or ops[c] == 30 or ops[c] == 35 or ops[c] == 36:
            m = max(m, int(args[c]) + 1)
    return m


@njit(cache=True)
def eval_events(t, x, u, p, ops, args, starts, stack, out, emodes):
    """out[k] = event function k at (t, x, u, p) (its switches live)."""
    for k in range(starts.shape[0] - 1):
        out[k] = _run(ops, args, starts[k], starts[k + 1], t, x, u, p, stack, emodes, True)


@njit(cache=True)
def cholesky_solve(n, M, f, w, out, offset):
    """Solve M q_ddot = f by the LDL^T factorization of M (M: n x n row-major in a flat array,
    overwritten by L below the diagonal and 1/D on it; w receives D); q_ddot goes to
    out[offset:offset + n].

    Returns the inertia measure of M: the smallest pivot of the factorization of M scaled to a
    unit diagonal, min_j D_j / M_jj (1 for a diagonal M, 0 for a singular one, the squared
    smallest diagonal entry of the scaled Cholesky factor), or -1.0 when f is not finite."""
    num = 1.0  # the smallest D_j / M_jj as the fraction num / den
    den = 1.0
    for j in range(n):
        mjj = M[j * n + j]
        d = mjj
        for k in range(j):
            d -= M[j * n + k] * M[j * n + k] * w[k]
        if not (d > 0.0) or not (mjj > 0.0) or not math.isfinite(d):
            return 0.0
        if d * den < num * mjj:
            num = d
            den = mjj
        w[j] = d
        inv = 1.0 / d
        for i in range(j + 1, n):  # L_ij = (M_ij - sum_k L_ik L_jk D_k) / D_j
            s = M[i * n + j]
            for k in range(j):
                s -= M[i * n + k] * M[j * n + k] * w[k]
            M[i * n + j] = s * inv
        M[j * n + j] = inv
    measure = num / den
    if measure <= SINGULAR_RATIO:
        return measure
    for i in range(n):
        if not math.isfinite(f[i]):
            return -1.0
    for i in range(n):  # L z = f
        s = f[i]
        for k in range(i):
            s -= M[i * n + k] * out[offset + k]
        out[offset + i] = s
    for i in range(n):  # D y = z
        out[offset + i] *= M[i * n + i]
    for i in range(n - 1, -1, -1):  # L^T q_ddot = y
        s = out[offset + i]
        for k in range(i + 1, n):
            s -= M[k * n + i] * out[offset + k]
        out[offset + i] = s
    return measure


@njit(cache=True)
def _eval(rc, t, x, p, ops, args, starts, stack, u, dx, work, modes, live, hold, held):
    """dx = [q_dot, q_ddot] at (t, x); returns the inertia measure of M (-1.0: f not finite)."""
    eval_inputs(t, x, p, ops, args, starts, stack, u, modes, live, hold, held)
    return _rc(rc, t, _ptr(x, 0), _ptr(u, 0), _ptr(p, 0), _ptr(dx, 0), _ptr(work, 0))


@njit(cache=True)
def rhs(rc, n, t, x, u, p):
    """(x' = [q_dot, q_ddot], shape (2n,), the inertia measure of M); x' is NaN where M is
    singular or f not finite (measure -1.0)."""
    work = np.empty(n * n + 2 * n)
    dx = np.empty(2 * n)
    r = _rc(rc, t, _ptr(x, 0), _ptr(u, 0), _ptr(p, 0), _ptr(dx, 0), _ptr(work, 0))
    if r < 0.0 or r <= SINGULAR_RATIO:
        dx[n:] = np.nan
    return dx, r


@njit(cache=True)
def mass_forcing(mf, n, t, x, u, p):
    """(M (n, n), f (n,))."""
    M = np.empty(n * n)
    f = np.empty(n)
    _vf(mf, t, _ptr(x, 0), _ptr(u, 0), _ptr(p, 0), _ptr(M, 0), _ptr(f, 0))
    return M.reshape((n, n)), f


@njit(cache=True)
def energies(en, times, X, p, ops, args, starts, nstack, out, U, hold):
    """The Jacobi integral and the inputs at each row of (times, X); the sampled inputs
    (hold[i] = 1) are read from U, where the caller put their held values."""
    stack = np.empty(nstack)
    m = starts.shape[0] - 1
    u = np.empty(max(1, m))
    modes = np.empty(max(1, ops.shape[0]))
    for k in range(times.shape[0]):
        xk = np.ascontiguousarray(X[k])
        for i in range(m):
            if hold[i]:
                u[i] = U[k, i]
            else:
                u[i] = _run(ops, args, starts[i], starts[i + 1], times[k], xk, u, p, stack, modes, True)
                U[k, i] = u[i]
        out[k] = _en(en, times[k], _ptr(xk, 0), _ptr(u, 0), _ptr(p, 0))


@njit(cache=True)
def _fail(r, t, x, info, stats, nfev, nstep, nrej, j):
    info[0] = t
    info[1] = r
    for i in range(x.shape[0]):
        info[2 + i] = x[i]
    stats[0] = nfev
    stats[1] = nstep
    stats[2] = nrej
    stats[3] = j
    return 3 if r < 0.0 else 2


@njit(cache=True)
def _dense_at(t, h, y, F, tq, out, k, L):
    """The order-7 interpolant of the step from (t, y) of size h, at tq: out[i] for the
    components y[i * L + k] (all of y for k = 0, L = 1; lane k in dop853_lanes)."""
    s = (tq - t) / h
    for i in range(out.shape[0]):
        w = i * L + k
        v = 0.0
        for r in range(6, -1, -1):
            v += F[r, w]
            if (6 - r) % 2 == 0:
                v *= s
            else:
                v *= 1.0 - s
        out[i] = y[w] + v


@njit(cache=True)
def _dense(t, h, y, F, tq, out):
    """The order-7 interpolant of the step from (t, y) of size h, at tq."""
    _dense_at(t, h, y, F, tq, out, 0, 1)


@njit(cache=True)
def _dense_coefficients(rc, n, t, h, y, ynew, K, F, xs, p, ops, args, starts, stack, u, work, aptr,
                        aidx, aval, cc, modes, live, hold, held):
    """The three extra stages and the coefficients F of the order-7 interpolant."""
    nx = 2 * n
    nin = starts.shape[0] - 1
    pxs = _ptr(xs, 0)
    pu = _ptr(u, 0)
    pp = _ptr(p, 0)
    pw = _ptr(work, 0)
@EXTRA@


@njit(cache=True)
def _measure(rc, t, x, p, ops, args, starts, stack, u, work, scratch, modes, live, hold, held):
    eval_inputs(t, x, p, ops, args, starts, stack, u, modes, live, hold, held)
    return _rc(rc, t, _ptr(x, 0), _ptr(u, 0), _ptr(p, 0), _ptr(scratch, 0), _ptr(work, 0))


@njit(cache=True)
def _rms(a, b):
    s = 0.0
    for i in range(a.shape[0]):
        s += (a[i] / b[i]) ** 2
    return math.sqrt(s / a.shape[0])


@njit(cache=True, nogil=True)
def dop853(rc, n, x0, t0, t_out, p, ops, args, starts, nstack, rtol, atol, max_step, first_step,
           X_out, info, stats, aptr, aidx, aval, cc, eops, eargs, estarts, eterm, ev_t, ev_k, ev_x, ev_n,
           hold, samples, which, hist, proj, nwork):
    """Integrate x' = f(t, x, u, p) from (t0, x0) with DOP853; X_out[j] = x(t_out[j]).

    A constrained model passes `proj`, the address of its projection project(t, x, u, p, work,
    drift) (0: none), called on the state after every accepted step and on the outputs of the step
    (the step's last derivative is kept: see there), and `nwork`, the size of the
    work array its rhs needs (0: the default n * n + 2 n).

    Returns the status (see lagrangian.numeric._kernels.STATUS); unless 0, info = [t, inertia
    measure (or, status 4, the event's index), x...] where it stopped; stats = [nfev, accepted
    steps, rejected steps, outputs(, located switches)]. Event functions (programs
    eops/eargs/estarts of t, x, u, p) are watched at each step: each zero crossing is located on
    the interpolant and recorded in ev_t, ev_k (which event), ev_x (the state), ev_n[0] counting
    them (at most len(ev_t)); a crossing of an event with eterm[k] = 1 stops the integration
    there (status 4).

    Inputs are programs of (t, x, p). Their switches (comparisons in where, sign) are frozen
    during a step, so that each step integrates a smooth right-hand side; after the step they
    are evaluated live at its end, and when one has changed the change is located on the
    interpolant (bisection) and the step ends there: a discontinuous law costs a step, not a
    crawl. Where a switch changes back at once (a sliding mode), that step is taken again with
    the switches live, under the error control alone. Sampled inputs (hold[i] = 1) are
    evaluated at the times `samples` (those with which[s, i]) and held in between; no step
    crosses a sample time; hist[s] receives the held values at samples[s]."""
    nx = 2 * n
    nout = t_out.shape[0]
    K = np.empty((16, nx))
    F = np.empty((7, nx))
    y = x0.copy()
    ynew = np.empty(nx)
    xs = np.empty(nx)
    sc = np.empty(nx)
    nin = starts.shape[0] - 1
    u = np.empty(max(1, nin))
    held = np.zeros(max(1, nin))
    stack = np.empty(nstack)
    work = np.empty(max(nwork, n * n + 2 * n))
    drift = np.zeros(2)  # (passed as _ptr(drift, 0) at each call: a pointer taken once does not keep the array
    # alive, and numba frees an array after its last use, so the projection wrote into whatever reused it)
    nsw = switch_count(ops, args)
    modes = np.zeros(max(1, nsw))
    mlive = np.zeros(max(1, nsw))
    live = nsw == 0  # switches frozen during a step (when there are any)
    flipped = False  # the switches changed at the start of the step being taken
    nswitch = 0
    chatter = 0  # consecutive short steps ended by a switch
    ns = samples.shape[0]
    si = 0
    pxs = _ptr(xs, 0)
    pu = _ptr(u, 0)
    pp = _ptr(p, 0)
    pw = _ptr(work, 0)
    nfev = 0
    nstep = 0
    nrej = 0
    j = 0
    t = t0
    t_end = t_out[nout - 1]
    while j < nout and t_out[j] <= t0:
        for i in range(nx):
            X_out[j, i] = x0[i]
        j += 1
    if si < ns and samples[si] <= t0:
        _sample(t0, y, p, ops, args, starts, stack, u, modes, hold, held, which, hist, si)
        si += 1
    r = _eval(rc, t, y, p, ops, args, starts, stack, u, K[0], work, modes, True, hold, held)
    nfev += 1
    if r < 0.0 or r <= SINGULAR_RATIO:
        return _fail(r, t, y, info, stats, nfev, nstep, nrej, j)
    g_old = r - EVENT_RATIO
    nev = estarts.shape[0] - 1
    eg_old = np.zeros(max(1, nev))
    eg_new = np.zeros(max(1, nev))
    emodes = np.zeros(max(1, eops.shape[0]))
    if nev:
        eval_events(t, y, u, p, eops, eargs, estarts, stack, eg_old, emodes)
    if t_end <= t0:
        stats[0] = nfev
        stats[3] = j
        return 0
    interval = t_end - t0
    if first_step > 0.0:
        h_abs = min(first_step, interval, max_step)
    else:  # Hairer, Norsett and Wanner, II.4, as SciPy
        for i in range(nx):
            sc[i] = atol + abs(y[i]) * rtol
        d0 = _rms(y, sc)
        d1 = _rms(K[0], sc)
        h0 = 1e-6 if (d0 < 1e-5 or d1 < 1e-5) else 0.01 * d0 / d1
        h0 = min(h0, interval)
        for i in range(nx):
            xs[i] = y[i] + h0 * K[0, i]
        r = _eval(rc, t + h0, xs, p, ops, args, starts, stack, u, K[1], work, modes, live, hold, held)
        nfev += 1
        if r < 0.0 or r <= SINGULAR_RATIO:
            return _fail(r, t + h0, xs, info, stats, nfev, nstep, nrej, j)
        for i in range(nx):
            ynew[i] = K[1, i] - K[0, i]
        d2 = _rms(ynew, sc) / h0
        if d1 <= 1e-15 and d2 <= 1e-15:
            h1 = max(1e-6, h0 * 1e-3)
        else:
            h1 = (0.01 / max(d1, d2)) ** (1.0 / 8.0)
        h_abs = min(100.0 * h0, h1, interval, max_step)
    while True:
        min_step = 10.0 * abs(np.nextafter(t, np.inf) - t)
        if h_abs > max_step:
            h_abs = max_step
        elif h_abs < min_step:
            h_abs = min_step
        rejected = False
        while True:
            if h_abs < min_step:
                info[0] = t
                info[1] = g_old + EVENT_RATIO
                for i in range(nx):
                    info[2 + i] = y[i]
                stats[0] = nfev
                stats[1] = nstep
                stats[2] = nrej
                stats[3] = j
                return -1
            tnew = t + h_abs
            if tnew > t_end:
                tnew = t_end
            if si < ns and tnew > samples[si]:
                tnew = samples[si]
            h = tnew - t
            h_abs = abs(h)
@STEP@
            if e5 == 0.0 and e3 == 0.0:
                err = 0.0
            else:
                err = h_abs * e5 / math.sqrt((e5 + 0.01 * e3) * nx)
            if err < 1.0:
                if err == 0.0:
                    factor = 10.0
                else:
                    factor = min(10.0, 0.9 * err ** (-1.0 / 8.0))
                if rejected:
                    factor = min(1.0, factor)
                h_next = h_abs * factor
                break
            h_abs *= max(0.2, 0.9 * err ** (-1.0 / 8.0))
            rejected = True
            nrej += 1
        dense = False
        renew = False  # the right-hand side at the step's end must be evaluated again
        if not live:  # did a switch change during the step?
            if _changed(tnew, ynew, p, ops, args, starts, stack, u, modes, mlive, nsw, hold, held):
                _dense_coefficients(rc, n, t, h, y, ynew, K, F, xs, p, ops, args, starts, stack, u, work, aptr,
                                    aidx, aval, cc, modes, False, hold, held)
                nfev += 3
                dense = True
                a = t
                b = tnew
                for _ in range(200):  # bisection on the interpolant for the first change
                    if b - a <= 4.0 * 2.220446049250313e-16 * max(1.0, abs(b)):
                        break
                    c = 0.5 * (a + b)
                    _dense(t, h, y, F, c, xs)
                    if _changed(c, xs, p, ops, args, starts, stack, u, modes, mlive, nsw, hold, held):
                        b = c
                    else:
                        a = c
                if b - t <= 1e-10 * max(1.0, abs(t)):  # it changes at the step's start
                    nrej += 1
                    if flipped:  # and changed back already: a sliding mode; this step again,
                        live = True  # with the switches live, under the error control alone
                        continue
                    _dense(t, h, y, F, b, xs)  # switch at t, and take the step again
                    eval_inputs(b, xs, p, ops, args, starts, stack, u, modes, True, hold, held)
                    r = _eval(rc, t, y, p, ops, args, starts, stack, u, K[0], work, modes, False, hold, held)
                    nfev += 1
                    if r < 0.0 or r <= SINGULAR_RATIO:
                        return _fail(r, t, y, info, stats, nfev, nstep, nrej, j)
                    flipped = True
                    nswitch += 1
                    continue
                if b < tnew:
                    _dense(t, h, y, F, b, ynew)
                    tnew = b
                nswitch += 1
                renew = True
                if tnew - t < CHATTER_STEP * interval:
                    chatter += 1
                    if chatter >= CHATTER_STEPS:
                        info[0] = tnew
                        info[1] = tnew - t
                        for i in range(nx):
                            info[2 + i] = ynew[i]
                        stats[0] = nfev
                        stats[1] = nstep
                        stats[2] = nrej
                        stats[3] = j
                        return 5
                else:
                    chatter = 0
            else:
                chatter = 0
        nstep += 1
        if renew:  # the switches as they are at the end of the shortened step
            rnew = _eval(rc, tnew, ynew, p, ops, args, starts, stack, u, K[12], work, modes, True, hold, held)
            nfev += 1
            if rnew < 0.0 or rnew <= SINGULAR_RATIO:
                return _fail(rnew, tnew, ynew, info, stats, nfev, nstep, nrej, j)
        g_new = rnew - EVENT_RATIO
        event = g_old >= 0.0 and g_new <= 0.0 and g_old != g_new
        if not dense and (event or (j < nout and t_out[j] < tnew)):
            _dense_coefficients(rc, n, t, h, y, ynew, K, F, xs, p, ops, args, starts, stack, u, work, aptr,
                                aidx, aval, cc, modes, live, hold, held)
            nfev += 3
            dense = True
        t_stop = np.inf
        k_stop = -1
        if nev:
            if nin:
                eval_inputs(tnew, ynew, p, ops, args, starts, stack, u, modes, live, hold, held)
            eval_events(tnew, ynew, u, p, eops, eargs, estarts, stack, eg_new, emodes)
            for k in range(nev):
                ga = eg_old[k]
                gb = eg_new[k]
                if not ((ga < 0.0 and gb >= 0.0) or (ga > 0.0 and gb <= 0.0)):
                    continue
                if not dense:
                    _dense_coefficients(rc, n, t, h, y, ynew, K, F, xs, p, ops, args, starts, stack, u, work,
                                        aptr, aidx, aval, cc, modes, live, hold, held)
                    nfev += 3
                    dense = True
                a = t
                b = tnew
                for _ in range(200):  # bisection on the interpolant
                    if b - a <= 4.0 * 2.220446049250313e-16 * max(1.0, abs(b)):
                        break
                    c = 0.5 * (a + b)
                    _dense(t, h, y, F, c, xs)
                    if nin:
                        eval_inputs(c, xs, p, ops, args, starts, stack, u, modes, False, hold, held)
                    gc = _run(eops, eargs, estarts[k], estarts[k + 1], c, xs, u, p, stack, emodes, True)
                    if (gc < 0.0) == (ga < 0.0) and gc != 0.0:
                        a = c
                    else:
                        b = c
                m = ev_n[0]
                if m < ev_t.shape[0]:
                    ev_t[m] = b
                    ev_k[m] = k
                    _dense(t, h, y, F, b, ev_x[m])
                    ev_n[0] = m + 1
                if eterm[k] and b < t_stop:
                    t_stop = b
                    k_stop = k
            for k in range(nev):
                eg_old[k] = eg_new[k]
        if event:  # bisection on the interpolant for the crossing of the inertia measure
            a = t
            b = tnew
            for _ in range(200):
                if b - a <= 4.0 * 2.220446049250313e-16 * max(1.0, abs(b)):
                    break
                c = 0.5 * (a + b)
                _dense(t, h, y, F, c, xs)
                gc = _measure(rc, c, xs, p, ops, args, starts, stack, u, work, sc, modes, False, hold,
                              held) - EVENT_RATIO
                nfev += 1
                if gc <= 0.0:
                    b = c
                else:
                    a = c
            while j < nout and t_out[j] <= b:
                _dense(t, h, y, F, t_out[j], X_out[j])
                j += 1
            _dense(t, h, y, F, b, xs)
            info[0] = b
            info[1] = _measure(rc, b, xs, p, ops, args, starts, stack, u, work, sc, modes, False, hold, held)
            for i in range(nx):
                info[2 + i] = xs[i]
            stats[0] = nfev
            stats[1] = nstep
            stats[2] = nrej
            stats[3] = j
            return 1
        if k_stop >= 0:
            while j < nout and t_out[j] <= t_stop:
                _dense(t, h, y, F, t_out[j], X_out[j])
                j += 1
            _dense(t, h, y, F, t_stop, xs)
            info[0] = t_stop
            info[1] = k_stop
            for i in range(nx):
                info[2 + i] = xs[i]
            stats[0] = nfev
            stats[1] = nstep
            stats[2] = nrej
            stats[3] = j
            if stats.shape[0] > 4:
                stats[4] = nswitch
            return 4
        j0 = j
        while j < nout and t_out[j] <= tnew:
            if t_out[j] == tnew:
                for i in range(nx):
                    X_out[j, i] = ynew[i]
            else:
                _dense(t, h, y, F, t_out[j], X_out[j])
            j += 1
        if proj != 0:  # onto the constraints: the outputs, then the state the next step starts from
            for jj in range(j0, j):
                for i in range(nx):
                    xs[i] = X_out[jj, i]
                _vf(proj, t_out[jj], pxs, pu, pp, pw, _ptr(drift, 0))
                for i in range(nx):
                    X_out[jj, i] = xs[i]
            # the next step starts from the projected state with the derivative of the step's end (first
            # same as last): they differ by the projection's correction, of the size of the local error,
            # so the stale derivative adds an error h L |correction|, of higher order than the step's
            _vf(proj, tnew, _ptr(ynew, 0), pu, pp, pw, _ptr(drift, 0))
        stats[3] = j  # outputs done so far: read by a progress bar while this runs without the GIL
        if si < ns and tnew >= samples[si]:  # a sample instant: new held inputs, a new f there
            _sample(tnew, ynew, p, ops, args, starts, stack, u, modes, hold, held, which, hist, si)
            si += 1
            rnew = _eval(rc, tnew, ynew, p, ops, args, starts, stack, u, K[12], work, modes, True, hold, held)
            nfev += 1
            if rnew < 0.0 or rnew <= SINGULAR_RATIO:
                return _fail(rnew, tnew, ynew, info, stats, nfev, nstep, nrej, j)
        elif nsw and live:  # the switches as they are at the step's end
            eval_inputs(tnew, ynew, p, ops, args, starts, stack, u, modes, True, hold, held)
        live = nsw == 0
        flipped = False
        t = tnew
        for i in range(nx):
            y[i] = ynew[i]
            K[0, i] = K[12, i]
        g_old = g_new
        h_abs = h_next
        if t >= t_end:
            break
    stats[0] = nfev
    stats[1] = nstep
    stats[2] = nrej
    stats[3] = j
    if stats.shape[0] > 4:
        stats[4] = nswitch
    return 0


@njit(cache=True, parallel=True)
def dop853_batch(rc, n, X0, t0, t_out, P, ops, args, starts, nstack, rtol, atol, max_step, X_out,
                 INFO, STATS, STATUS, aptr, aidx, aval, cc, proj=0, nwork=0):
    """dop853 for each row of X0 (initial states) and P (parameters), in parallel; `proj`, `nwork`:
    a constrained model's projection and work size, as dop853 takes them."""
    for b in prange(X0.shape[0]):
        ei = np.zeros(1, np.int64)
        ef = np.zeros(1)
        STATUS[b] = dop853(rc, n, X0[b], t0, t_out, P[b], ops, args, starts, nstack, rtol, atol,
                           max_step, 0.0, X_out[b], INFO[b], STATS[b], aptr, aidx, aval, cc, ei, ef, ei, ei,
                           ef, ei, np.zeros((1, 2 * n)), np.zeros(1, np.int64),
                           np.zeros(max(1, starts.shape[0] - 1), np.int64), np.zeros(0), np.zeros((1, 1), np.int64),
                           np.zeros((1, max(1, starts.shape[0] - 1))), proj, nwork)


@njit(cache=True)
def _lane_inputs(T, P, ops, args, starts, stack, u1, U, lm, lh):
    """U[m * L + k] = input m of lane k at T[k] (its parameters P[k]), L = P.shape[0]; the
    inputs are functions of t and p only (lm, lh: scratch for the switches and the holds)."""
    L = P.shape[0]
    nin = starts.shape[0] - 1
    for k in range(L):
        eval_inputs(T[k], P[k], P[k], ops, args, starts, stack, u1, lm, True, lh, u1)
        for m in range(nin):
            U[m * L + k] = u1[m]


@njit(cache=True)
def _lane_dense_coefficients(rc, L, nx, T, H, HW, y, ynew, K, F, xs, TS, P, ops, args, starts, stack, u1, U,
                             pts, pp, pw, lm, lh):
    """_dense_coefficients of dop853_lanes: every lane's, each of its own step."""
    W = nx * L
    nin = starts.shape[0] - 1
    pxs = _ptr(xs, 0)
    pu = _ptr(U, 0)
@LEXTRA@


@njit(cache=True)
def _lane_norm(k, L, nx, a, b, scale, atol, rtol, y):
    """The RMS norm of lane k of a - scale * b, over atol + |y| rtol (b ignored when scale = 0)."""
    d = 0.0
    for i in range(nx):
        w = i * L + k
        v = a[w] - scale * b[w] if scale != 0.0 else a[w]
        d += (v / (atol + abs(y[w]) * rtol)) ** 2
    return math.sqrt(d / nx)


@njit(cache=True, nogil=True)
def dop853_lanes(rc, n, X0, t0, t_out, P, ops, args, starts, nstack, rtol, atol, max_step, X_out, STATS):
    """dop853 for the L = X0.shape[0] runs of a block together; rc is the address of the
    model's rhs_lanes. Each run keeps its own time, step size and error control (the same
    steps as dop853 alone, up to rounding); each stage of all of them is one call of
    rhs_lanes, which evaluates the L states with SIMD instructions. A run that has reached the
    end idles (step 0) until the block's last one has. The arrays are lane-major (y[i * L + k]:
    component i of lane k).

    Returns 0, with X_out[k, j] = x_k(t_out[j]) and STATS[k] = [nfev, accepted steps,
    rejected steps, outputs] as dop853; or 1 when a run needs dop853's own handling (its mass
    matrix near singular, f not finite, an argument of sin or cos beyond the polynomial's
    range, a step too small): the caller then runs the block one run at a time."""
    L = X0.shape[0]
    nx = 2 * n
    W = nx * L
    nout = t_out.shape[0]
    npar = P.shape[1]
    K = np.empty((16, W))
    F = np.empty((7, W))
    y = np.empty(W)
    ynew = np.empty(W)
    xs = np.empty(W)
    PL = np.empty(npar * L)
    T = np.full(L, t0)  # each lane's time, step, |step|, next |step|, error, time after the step
    H = np.zeros(L)
    HA = np.zeros(L)
    HN = np.zeros(L)
    ERR = np.zeros(L)
    TN = np.zeros(L)
    TS = np.zeros(L)
    HW = np.zeros(W)
    D5 = np.zeros(W)
    D3 = np.zeros(W)
    J = np.zeros(L, np.int64)
    active = np.ones(L, np.bool_)
    rejected = np.zeros(L, np.bool_)
    accepted = np.zeros(L, np.bool_)
    for k in range(L):
        for m in range(npar):
            PL[m * L + k] = P[k, m]
        for i in range(nx):
            y[i * L + k] = X0[k, i]
    nin = starts.shape[0] - 1
    u1 = np.empty(max(1, nin))
    U = np.empty(max(1, nin) * L)
    lm = np.zeros(max(1, ops.shape[0]))
    lh = np.zeros(max(1, nin), np.int64)
    stack = np.empty(nstack)
    work = np.empty(2 * L)
    pts = _ptr(TS, 0)
    pxs = _ptr(xs, 0)
    pu = _ptr(U, 0)
    pp = _ptr(PL, 0)
    pw = _ptr(work, 0)
    t_end = t_out[nout - 1]
    j0 = 0
    while j0 < nout and t_out[j0] <= t0:
        for k in range(L):
            for i in range(nx):
                X_out[k, j0, i] = X0[k, i]
        j0 += 1
    for k in range(L):
        J[k] = j0
        STATS[k, 0] = 1
        STATS[k, 1] = 0
        STATS[k, 2] = 0
        TS[k] = t0
    if nin:
        _lane_inputs(TS, P, ops, args, starts, stack, u1, U, lm, lh)
    r = _rl(rc, pts, _ptr(y, 0), pu, pp, _ptr(K, 0), pw, L)
    if r < EVENT_RATIO:
        return 1
    if t_end > t0:
        interval = t_end - t0
        for k in range(L):  # the initial step of Hairer, Norsett and Wanner (II.4), as dop853
            d0 = _lane_norm(k, L, nx, y, y, 0.0, atol, rtol, y)
            d1 = _lane_norm(k, L, nx, K[0], y, 0.0, atol, rtol, y)
            H[k] = min(1e-6 if (d0 < 1e-5 or d1 < 1e-5) else 0.01 * d0 / d1, interval)
            TS[k] = t0 + H[k]
            for i in range(nx):
                w = i * L + k
                xs[w] = y[w] + H[k] * K[0, w]
        if nin:
            _lane_inputs(TS, P, ops, args, starts, stack, u1, U, lm, lh)
        r = _rl(rc, pts, pxs, pu, pp, _ptr(K, W), pw, L)
        if r < EVENT_RATIO:
            return 1
        for k in range(L):
            STATS[k, 0] = 2
            h0 = H[k]
            d1 = _lane_norm(k, L, nx, K[0], y, 0.0, atol, rtol, y)
            d2 = _lane_norm(k, L, nx, K[1], K[0], 1.0, atol, rtol, y) / h0
            if d1 <= 1e-15 and d2 <= 1e-15:
                h1 = max(1e-6, h0 * 1e-3)
            else:
                h1 = (0.01 / max(d1, d2)) ** (1.0 / 8.0)
            HA[k] = min(100.0 * h0, h1, interval, max_step)
        left = L
    else:
        left = 0
    while left > 0:
        for k in range(L):  # each active lane's next try
            if not active[k]:
                H[k] = 0.0
                continue
            min_step = 10.0 * abs(np.nextafter(T[k], np.inf) - T[k])
            if not rejected[k]:
                if HA[k] > max_step:
                    HA[k] = max_step
                elif HA[k] < min_step:
                    HA[k] = min_step
            if HA[k] < min_step:
                return 1
            TN[k] = min(T[k] + HA[k], t_end)
            H[k] = TN[k] - T[k]
            HA[k] = abs(H[k])
        for i in range(nx):
            for k in range(L):
                HW[i * L + k] = H[k]
@LSTEP@
        dense = False
        for k in range(L):
            accepted[k] = False
            if not active[k]:
                continue
            STATS[k, 0] += 12
            err = ERR[k]
            if err < 1.0:
                factor = 10.0 if err == 0.0 else min(10.0, 0.9 * err ** (-1.0 / 8.0))
                if rejected[k]:
                    factor = min(1.0, factor)
                HN[k] = HA[k] * factor
                rejected[k] = False
                accepted[k] = True
                STATS[k, 1] += 1
                if J[k] < nout and t_out[J[k]] < TN[k]:
                    dense = True
            else:
                HA[k] *= max(0.2, 0.9 * err ** (-1.0 / 8.0))
                rejected[k] = True
                STATS[k, 2] += 1
        if dense:
            _lane_dense_coefficients(rc, L, nx, T, H, HW, y, ynew, K, F, xs, TS, P, ops, args, starts, stack, u1,
                                     U, pts, pp, pw, lm, lh)
        for k in range(L):
            if not accepted[k]:
                continue
            if dense and J[k] < nout and t_out[J[k]] < TN[k]:
                STATS[k, 0] += 3
            while J[k] < nout and t_out[J[k]] <= TN[k]:
                if t_out[J[k]] == TN[k]:
                    for i in range(nx):
                        X_out[k, J[k], i] = ynew[i * L + k]
                else:
                    _dense_at(T[k], H[k], y, F, t_out[J[k]], X_out[k, J[k]], k, L)
                J[k] += 1
            for i in range(nx):
                w = i * L + k
                y[w] = ynew[w]
                K[0, w] = K[12, w]
            T[k] = TN[k]
            HA[k] = HN[k]
            if T[k] >= t_end:
                active[k] = False
                left -= 1
    for k in range(L):
        STATS[k, 3] = J[k]
    return 0


@njit(cache=True, parallel=True)
def dop853_batch_lanes(rc, rcl, n, lanes, X0, t0, t_out, P, ops, args, starts, nstack, rtol, atol, max_step,
                       X_out, INFO, STATS, STATUS, aptr, aidx, aval, cc):
    """dop853_batch in blocks of `lanes` runs integrated together by dop853_lanes (rcl: the
    address of rhs_lanes for blocks of `lanes`), in parallel. The runs left over after the
    last full block, and a block that dop853_lanes hands back, are run one by one by dop853
    (rc: the address of rhs), so that each of them stops or fails as alone."""
    B = X0.shape[0]
    for b in prange((B + lanes - 1) // lanes):
        a = b * lanes
        e = min(B, a + lanes)
        if e - a == lanes and dop853_lanes(rcl, n, X0[a:e], t0, t_out, P[a:e], ops, args, starts, nstack, rtol,
                                           atol, max_step, X_out[a:e], STATS[a:e]) == 0:
            for q in range(a, e):
                STATUS[q] = 0
            continue
        for q in range(a, e):
            ei = np.zeros(1, np.int64)
            ef = np.zeros(1)
            STATUS[q] = dop853(rc, n, X0[q], t0, t_out, P[q], ops, args, starts, nstack, rtol, atol,
                               max_step, 0.0, X_out[q], INFO[q], STATS[q], aptr, aidx, aval, cc, ei, ef, ei, ei,
                               ef, ei, np.zeros((1, 2 * n)), np.zeros(1, np.int64),
                               np.zeros(max(1, starts.shape[0] - 1), np.int64), np.zeros(0),
                               np.zeros((1, 1), np.int64), np.zeros((1, max(1, starts.shape[0] - 1))), 0, 0)


@njit(cache=True)
def variational(mf, lp, n, x0, t0, h, nsteps, every, p, ops, args, starts, nstack, X_out, info,
                stats):
    """The midpoint variational integrator: the discrete Lagrangian
    L_d(q0, q1) = h L(t + h/2, (q0 + q1)/2, (q1 - q0)/h), with the non-conservative forces
    -dD/dq_dot + Q at the midpoint (discrete Lagrange-d'Alembert principle). In position-momentum
    form, with v = (q1 - q0)/h and the midpoint qm = q0 + h v / 2, F = dL/dq - dD/dq_dot + Q:

        p0 = dL/dq_dot(qm, v) - h/2 F(qm, v)     (solved for v by Newton's method, with the
        p1 = dL/dq_dot(qm, v) + h/2 F(qm, v)      Jacobian approximated by M(qm))

    X_out[k] = x at t0 + k * every * h, k = 0 .. nsteps // every; velocities from
    M q_dot = p - dL/dq_dot(q, 0) (T quadratic in the velocities)."""
    nx = 2 * n
    xm = np.empty(nx)
    pk = np.empty(n)
    pm = np.empty(n)
    Fq = np.empty(n)
    R = np.empty(n)
    dv = np.empty(n)
    v = np.empty(n)
    q = np.empty(n)
    u = np.empty(max(1, starts.shape[0] - 1))
    stack = np.empty(nstack)
    M = np.empty(n * n)
    f = np.empty(n)
    w = np.empty(n)
    nfev = 0
    r = 1.0
    for i in range(n):
        q[i] = x0[i]
        v[i] = x0[n + i]
    modes = np.zeros(max(1, ops.shape[0]))
    hold = np.zeros(max(1, starts.shape[0] - 1), np.int64)
    xdep = False  # whether the inputs read the state (feedback): then evaluated at each iterate
    for c in range(ops.shape[0]):
        if ops[c] == 27:
            xdep = True
    eval_inputs(t0, x0, p, ops, args, starts, stack, u, modes, True, hold, u)
    _vf(lp, t0, _ptr(x0, 0), _ptr(u, 0), _ptr(p, 0), _ptr(pk, 0), _ptr(Fq, 0))
    for i in range(nx):
        X_out[0, i] = x0[i]
    j = 1
    vprev = np.empty(n)
    for i in range(n):
        vprev[i] = v[i]
    for k in range(nsteps):
        t = t0 + k * h
        tm = t + 0.5 * h
        if not xdep:
            eval_inputs(tm, x0, p, ops, args, starts, stack, u, modes, True, hold, u)
        if k > 0:  # first guess: extrapolate the last two mean velocities
            for i in range(n):
                g = 2.0 * v[i] - vprev[i]
                vprev[i] = v[i]
                v[i] = g
        converged = False
        for it in range(100):
            for i in range(n):
                xm[i] = q[i] + 0.5 * h * v[i]
                xm[n + i] = v[i]
            if xdep:
                eval_inputs(tm, xm, p, ops, args, starts, stack, u, modes, True, hold, u)
            _vf(lp, tm, _ptr(xm, 0), _ptr(u, 0), _ptr(p, 0), _ptr(pm, 0), _ptr(Fq, 0))
            nfev += 1
            for i in range(n):
                R[i] = pm[i] - 0.5 * h * Fq[i] - pk[i]
            _vf(mf, tm, _ptr(xm, 0), _ptr(u, 0), _ptr(p, 0), _ptr(M, 0), _ptr(f, 0))
            r = cholesky_solve(n, M, R, w, dv, 0)
            if r < 0.0 or r <= SINGULAR_RATIO:
                return _fail(r, tm, xm, info, stats, nfev, k, 0, j)
            big = 0.0
            size = 0.0
            for i in range(n):
                v[i] -= dv[i]
                big = max(big, abs(dv[i]))
                size = max(size, abs(v[i]))
            if big <= 4e-16 * (1.0 + size) or (big <= 1e-13 * (1.0 + size) and it > 8):
                converged = True
                break
        if not converged:
            info[0] = t
            info[1] = r
            for i in range(n):
                info[2 + i] = q[i]
                info[2 + n + i] = v[i]
            stats[0] = nfev
            stats[1] = k
            stats[3] = j
            return -3
        for i in range(n):
            xm[i] = q[i] + 0.5 * h * v[i]
            xm[n + i] = v[i]
        if xdep:
            eval_inputs(tm, xm, p, ops, args, starts, stack, u, modes, True, hold, u)
        _vf(lp, tm, _ptr(xm, 0), _ptr(u, 0), _ptr(p, 0), _ptr(pm, 0), _ptr(Fq, 0))
        nfev += 1
        for i in range(n):
            q[i] += h * v[i]
            pk[i] = pm[i] + 0.5 * h * Fq[i]
        if (k + 1) % every == 0:
            t1 = t0 + (k + 1) * h
            for i in range(n):
                xm[i] = q[i]
                xm[n + i] = v[i]  # the inputs at the mean velocity of the last step
            eval_inputs(t1, xm, p, ops, args, starts, stack, u, modes, True, hold, u)
            for i in range(n):
                xm[n + i] = 0.0
            _vf(lp, t1, _ptr(xm, 0), _ptr(u, 0), _ptr(p, 0), _ptr(pm, 0), _ptr(Fq, 0))
            _vf(mf, t1, _ptr(xm, 0), _ptr(u, 0), _ptr(p, 0), _ptr(M, 0), _ptr(f, 0))
            for i in range(n):
                R[i] = pk[i] - pm[i]
            r = cholesky_solve(n, M, R, w, dv, 0)
            if r < 0.0 or r <= SINGULAR_RATIO:
                return _fail(r, t1, xm, info, stats, nfev, k, 0, j)
            for i in range(n):
                X_out[j, i] = q[i]
                X_out[j, n + i] = dv[i]
            j += 1
    stats[0] = nfev
    stats[1] = nsteps
    stats[3] = j
    return 0
'''


def kernel_source() -> str:
    """The kernels as Python source (see the module docstring)."""
    text = _TEMPLATE.replace("@SINGULAR@", repr(SINGULAR_RATIO)).replace("@EVENT@", repr(EVENT_RATIO))
    text = text.replace("@CHATTER_STEPS@", repr(CHATTER_STEPS)).replace("@CHATTER_STEP@", repr(CHATTER_STEP))
    for key, value in _generated_parts().items():
        text = text.replace(key, value)
    return text
