"""The compiled kernels of lagrangian, as numba code: the interpreter of the input programs, the
scaled LDL^T solve of M q_ddot = f, DOP853 with dense output, events and the singular-mass-matrix
event, the batch drivers (one run per thread, or blocks of runs in SIMD lanes) and the midpoint
variational integrator.

This is a real module, read by ruff and by a reader, but the library does not import it by this
name: ``lagrangian.numeric._fast.kernels()`` copies it into the cache folder under a name keyed by
the hash of this file, of _kernels.py (whose constants it reads) and of numba's version, and loads
it from there, so that numba caches its compiled code beside the models' (``@njit(cache=True)``:
compiled once per machine) and a read-only installation works. Nothing in it comes from a model
file: a model's own functions are generated code (numba ``cfunc``, or the C backend's functions),
passed here by their addresses, as integers (typing a function object would cost numba microseconds
per call), with fixed signatures,

    rhs(t, x*, u*, p*, dx*, work*) -> double  dx = [q_dot, q_ddot]; returns the inertia measure
                                              of M (-1.0 when f is not finite)
    energy(t, x*, u*, p*) -> double           the Jacobi integral
    energy_rows(t*, x*, u*, p*, e*, count)    the Jacobi integral at `count` output rows (t[k], x and u
                                              row-major, p) at once, vectorized; NaN in a row whose sin
                                              or cos it leaves to energy (a small model's, numba only;
                                              compiled lazily, 0 until then: see below)
    mass_forcing(t, x*, u*, p*, M*, f*)      M row-major (n x n), f (n)
    lagrange_parts(t, x*, u*, p*, pm*, F*)   pm = dL/dq_dot, F = dL/dq - dD/dq_dot + Q
    rhs_lanes(t*, x*, u*, p*, dx*, work*, L) rhs of L states (lane-major arrays) at once
    project(t, x*, u*, p*, work*, drift*) -> double   a constrained model's projection onto its
                                              constraints; returns PROJECTION_MET, _SINGULAR or _NOT_FINITE

so that a new model compiles only its own functions (a fraction of a second) and no integrator.

The integrators take their problem as a few small tuples (see _kernels.py: Model, Program, Control,
Events, Sampling, Outputs), unpacked by name at the top of each kernel: numba types a plain tuple as
fast as its fields (a NamedTuple costs its dispatcher about 6 us more a call). DOP853 is Hairer,
Norsett and Wanner's 8(5,3) pair with its order-7 dense output; its coefficients are the named
constants below, equal to SciPy's table (tests/numeric/test_kernels.py checks it), so that this integrator
and SciPy's ``solve_ivp(method="DOP853")`` take the same steps; the step-size control follows
SciPy's too. Its stages are written out, the zero coefficients left out, as in Hairer's dop853.f
(a loop over the stages with a branch per stage costs a tenth of the run).
"""

import math

import numpy as np
from llvmlite import ir
from numba import njit, prange, types
from numba.extending import intrinsic

from lagrangian.numeric._kernels import (
    CHATTER_STEP,
    CHATTER_STEPS,
    EVENT_RATIO,
    PROJECTION_MET,
    PROJECTION_SINGULAR,
    SINGULAR_RATIO,
    STATUS_PROJECTION_NOT_FINITE,
    STATUS_PROJECTION_SINGULAR,
)

# ----------------------------------------------------------------------------- DOP853's tableau
#: Nodes c_s of the stages s = 1 .. 15 (C12 = 1: stage 12 is the solution's end).
C1, C2, C3, C4, C5, C6, C7, C8, C9, C10, C11, C12, C13, C14, C15 = (
    0.05260015195876773, 0.0789002279381516, 0.1183503419072274, 0.2816496580927726, 0.3333333333333333, 0.25,
    0.3076923076923077, 0.6512820512820513, 0.6, 0.8571428571428571, 1.0, 1.0, 0.1, 0.2, 0.7777777777777778,
)
#: The non-zero coefficients A[s, j] of the stages (row 12: the solution's weights b_j).
A1_0 = 0.05260015195876773
A2_0, A2_1 = 0.0197250569845379, 0.0591751709536137
A3_0, A3_2 = 0.02958758547680685, 0.08876275643042054
A4_0, A4_2, A4_3 = 0.2413651341592667, -0.8845494793282861, 0.924834003261792
A5_0, A5_3, A5_4 = 0.037037037037037035, 0.17082860872947386, 0.12546768756682242
A6_0, A6_3, A6_4, A6_5 = 0.037109375, 0.17025221101954405, 0.06021653898045596, -0.017578125
A7_0, A7_3, A7_4 = 0.03709200011850479, 0.17038392571223998, 0.10726203044637328
A7_5, A7_6 = -0.015319437748624402, 0.008273789163814023
A8_0, A8_3, A8_4 = 0.6241109587160757, -3.3608926294469414, -0.868219346841726
A8_5, A8_6, A8_7 = 27.59209969944671, 20.154067550477894, -43.48988418106996
A9_0, A9_3, A9_4 = 0.47766253643826434, -2.4881146199716677, -0.590290826836843
A9_5, A9_6, A9_7 = 21.230051448181193, 15.279233632882423, -33.28821096898486
A9_8 = -0.020331201708508627
A10_0, A10_3, A10_4 = -0.9371424300859873, 5.186372428844064, 1.0914373489967295
A10_5, A10_6, A10_7 = -8.149787010746927, -18.52006565999696, 22.739487099350505
A10_8, A10_9 = 2.4936055526796523, -3.0467644718982196
A11_0, A11_3, A11_4 = 2.273310147516538, -10.53449546673725, -2.0008720582248625
A11_5, A11_6, A11_7 = -17.9589318631188, 27.94888452941996, -2.8589982771350235
A11_8, A11_9, A11_10 = -8.87285693353063, 12.360567175794303, 0.6433927460157636
A12_0, A12_5, A12_6 = 0.054293734116568765, 4.450312892752409, 1.8915178993145003
A12_7, A12_8, A12_9 = -5.801203960010585, 0.3111643669578199, -0.1521609496625161
A12_10, A12_11 = 0.20136540080403034, 0.04471061572777259
A13_0, A13_6, A13_7 = 0.056167502283047954, 0.25350021021662483, -0.2462390374708025
A13_8, A13_9, A13_10 = -0.12419142326381637, 0.15329179827876568, 0.00820105229563469
A13_11, A13_12 = 0.007567897660545699, -0.008298
A14_0, A14_5, A14_6 = 0.03183464816350214, 0.028300909672366776, 0.053541988307438566
A14_7, A14_10, A14_11 = -0.05492374857139099, -0.00010834732869724932, 0.0003825710908356584
A14_12, A14_13 = -0.00034046500868740456, 0.1413124436746325
A15_0, A15_5, A15_6 = -0.42889630158379194, -4.697621415361164, 7.683421196062599
A15_7, A15_8, A15_12 = 4.06898981839711, 0.3567271874552811, -0.0013990241651590145
A15_13, A15_14 = 2.9475147891527724, -9.15095847217987
#: The error estimators: the differences from the embedded 5th- and 3rd-order solutions.
E5_0, E5_5, E5_6 = 0.01312004499419488, -1.2251564463762044, -0.4957589496572502
E5_7, E5_8, E5_9 = 1.6643771824549864, -0.35032884874997366, 0.3341791187130175
E5_10, E5_11 = 0.08192320648511571, -0.022355307863886294
E3_0, E3_5, E3_6 = -0.18980075407240762, 4.450312892752409, 1.8915178993145003
E3_7, E3_8, E3_9 = -5.801203960010585, -0.4226823213237919, -0.1521609496625161
E3_10, E3_11 = 0.20136540080403034, 0.02265179219836082
#: The coefficients of the order-7 dense output: F[r] = h sum_j D_r_j K[j], r = 3 .. 6.
D3_0, D3_5, D3_6 = -8.428938276109013, 0.5667149535193777, -3.0689499459498917
D3_7, D3_8, D3_9 = 2.38466765651207, 2.117034582445028, -0.871391583777973
D3_10, D3_11, D3_12 = 2.2404374302607883, 0.6315787787694688, -0.08899033645133331
D3_13, D3_14, D3_15 = 18.148505520854727, -9.194632392478356, -4.436036387594894
D4_0, D4_5, D4_6 = 10.427508642579134, 242.28349177525817, 165.20045171727028
D4_7, D4_8, D4_9 = -374.5467547226902, -22.113666853125306, 7.733432668472264
D4_10, D4_11, D4_12 = -30.674084731089398, -9.332130526430229, 15.697238121770845
D4_13, D4_14, D4_15 = -31.139403219565178, -9.35292435884448, 35.81684148639408
D5_0, D5_5, D5_6 = 19.985053242002433, -387.0373087493518, -189.17813819516758
D5_7, D5_8, D5_9 = 527.8081592054236, -11.57390253995963, 6.8812326946963
D5_10, D5_11, D5_12 = -1.0006050966910838, 0.7777137798053443, -2.778205752353508
D5_13, D5_14, D5_15 = -60.19669523126412, 84.32040550667716, 11.99229113618279
D6_0, D6_5, D6_6 = -25.69393346270375, -154.18974869023643, -231.5293791760455
D6_7, D6_8, D6_9 = 357.6391179106141, 93.40532418362432, -37.45832313645163
D6_10, D6_11, D6_12 = 104.0996495089623, 29.8402934266605, -43.53345659001114
D6_13, D6_14, D6_15 = 96.32455395918828, -39.17726167561544, -149.72683625798564


# ------------------------------------------------------------------ calls of the model's functions
@intrinsic
def _ptr(typingctx, arr, offset):
    """The address of arr.flat[offset] as a double* (no reference counting, unlike arr.ctypes: the
    array must stay alive while the pointer is used, so take it at the call)."""
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
    """rhs(t, x, u, p, dx, work) -> double (or project(t, x, u, p, work, drift) -> double), the model
    function at `addr`."""
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
def _er(typingctx, addr, t, x, u, p, e, count):
    """energy_rows(t, x, u, p, e, count), the model function at `addr`."""
    def codegen(context, builder, signature, args):
        _call(builder, args[0], ir.VoidType(), args[1:])
        return context.get_dummy_value()
    return types.void(types.intp, _PD, _PD, _PD, _PD, _PD, types.int64), codegen


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


# ------------------------------------------------------------------ formulas on LANES states at once
#: States whose dense output (the interpolant's coefficients, and its value at an output) is evaluated
#: together, as one <4 x double> (AVX's width). numba leaves LLVM's SLP vectorizer off, and its loop
#: vectorizer takes 8 doubles (AVX-512) or more at a time, so the loops over a small model's 4 states ran a
#: state at a time: the 20 s double pendulum's coefficients (464 steps) and 2001 rows took 35 us of scalar
#: arithmetic, 4 at a time 9 (A/B in one process: 497 -> 471 us a run with its 2001 outputs).
LANES = 4


class _Emit:
    """A value in the code being generated (at numba's code generation, not at run time): `width`
    doubles, as a <width x double> or (width 1) a double. The formulas below are plain arithmetic;
    called with _Emit values they emit their operations in their order on `width` states at once.
    Without fast-math LLVM keeps every operation as written (no reassociation, no fused multiply-add),
    so each lane has the bits of the same formula evaluated on floats (tests/numeric/test_kernels.py)."""

    __slots__ = ("b", "v")

    def __init__(self, b, v):
        self.b, self.v = b, v

    def _of(self, o):
        if isinstance(o, _Emit):
            return o.v
        t = self.v.type
        return ir.Constant(t, [float(o)] * t.count) if isinstance(t, ir.VectorType) else ir.Constant(t, float(o))

    def __add__(self, o):
        return _Emit(self.b, self.b.fadd(self.v, self._of(o)))

    def __radd__(self, o):
        return _Emit(self.b, self.b.fadd(self._of(o), self.v))

    def __sub__(self, o):
        return _Emit(self.b, self.b.fsub(self.v, self._of(o)))

    def __rsub__(self, o):
        return _Emit(self.b, self.b.fsub(self._of(o), self.v))

    def __mul__(self, o):
        return _Emit(self.b, self.b.fmul(self.v, self._of(o)))

    def __rmul__(self, o):
        return _Emit(self.b, self.b.fmul(self._of(o), self.v))


def _lanes_of(b, ptr, offset, width):
    """The `width` doubles at ptr[offset] on, as an _Emit (an unaligned load)."""
    ty = ir.DoubleType() if width == 1 else ir.VectorType(ir.DoubleType(), width)
    return _Emit(b, b.load(b.bitcast(b.gep(ptr, [offset]), ty.as_pointer()), align=8))


def _put(b, value, ptr, offset):
    """value (an _Emit) into ptr[offset] on."""
    b.store(value.v, b.bitcast(b.gep(ptr, [offset]), value.v.type.as_pointer()), align=8)


def _broadcast(b, x, width):
    """The double x in each of `width` lanes, as an _Emit."""
    if width == 1:
        return _Emit(b, x)
    ty = ir.VectorType(ir.DoubleType(), width)
    v = b.insert_element(ir.Constant(ty, None), x, ir.Constant(ir.IntType(32), 0))
    return _Emit(b, b.shuffle_vector(v, ir.Constant(ty, None), ir.Constant(ir.VectorType(ir.IntType(32), width),
                                                                           [0] * width)))


def interpolant(y, f0, f1, f2, f3, f4, f5, f6, s, s1):
    """DOP853's order-7 interpolant of one state, y + s (1 - s) (F1 + s (F2 + ...)) in Hairer's nested
    form (s = (t - t_step) / h, s1 = 1 - s)."""
    v = (0.0 + f6) * s
    v = (v + f5) * s1
    v = (v + f4) * s
    v = (v + f3) * s1
    v = (v + f2) * s
    v = (v + f1) * s1
    v = (v + f0) * s
    return y + v


def coefficients(h, dy, k0, k5, k6, k7, k8, k9, k10, k11, k12, k13, k14, k15):
    """The interpolant's coefficients F0 .. F6 of one state: dy its change over the step of size h, k its
    derivatives at the stages (SciPy's and Hairer's dense output; the sums in the order written)."""
    f3 = h * (D3_0 * k0 + D3_5 * k5 + D3_6 * k6 + D3_7 * k7
              + D3_8 * k8 + D3_9 * k9 + D3_10 * k10 + D3_11 * k11
              + D3_12 * k12 + D3_13 * k13 + D3_14 * k14 + D3_15 * k15)
    f4 = h * (D4_0 * k0 + D4_5 * k5 + D4_6 * k6 + D4_7 * k7
              + D4_8 * k8 + D4_9 * k9 + D4_10 * k10 + D4_11 * k11
              + D4_12 * k12 + D4_13 * k13 + D4_14 * k14 + D4_15 * k15)
    f5 = h * (D5_0 * k0 + D5_5 * k5 + D5_6 * k6 + D5_7 * k7
              + D5_8 * k8 + D5_9 * k9 + D5_10 * k10 + D5_11 * k11
              + D5_12 * k12 + D5_13 * k13 + D5_14 * k14 + D5_15 * k15)
    f6 = h * (D6_0 * k0 + D6_5 * k5 + D6_6 * k6 + D6_7 * k7
              + D6_8 * k8 + D6_9 * k9 + D6_10 * k10 + D6_11 * k11
              + D6_12 * k12 + D6_13 * k13 + D6_14 * k14 + D6_15 * k15)
    return dy, h * k0 - dy, 2.0 * dy - h * (k12 + k0), f3, f4, f5, f6


def _row(b, n, r, i):
    """The offset r n + i (i64 values; r an int)."""
    return b.add(b.mul(n, ir.Constant(n.type, r)), i)


def _literals(*args):
    """The values of numba's integer literals (None where one is not: numba then types the call again)."""
    if all(isinstance(a, types.IntegerLiteral) for a in args):
        return [a.literal_value for a in args]
    return None


@intrinsic
def _interpolant_at(typingctx, width, F, n, y, s, s1, out, i):
    """out[i + l] = interpolant(y[i + l], F[i + l], F[n + i + l], .., F[6 n + i + l], s, s1) for the lanes
    l < width (a literal; pointers: F the 7 rows of coefficients, each n long)."""
    if (w := _literals(width)) is None:
        return None
    w, = w

    def codegen(context, builder, signature, args):
        _, F, n, y, s, s1, out, i = args
        f = [_lanes_of(builder, F, _row(builder, n, r, i), w) for r in range(7)]
        _put(builder, interpolant(_lanes_of(builder, y, i, w), *f, _broadcast(builder, s, w),
                                  _broadcast(builder, s1, w)), out, i)
        return context.get_dummy_value()
    return types.void(width, _PD, types.int64, _PD, _D, _D, _PD, types.int64), codegen


@intrinsic
def _coefficients_at(typingctx, width, K, n, y, ynew, h, F, i):
    """F[r n + i + l] = coefficients(h, ynew[i + l] - y[i + l], K[i + l], K[5 n + i + l], .., K[15 n + i + l])[r]
    for the lanes l < width (a literal; pointers: K the 16 rows of stages, F the 7 rows of coefficients, each
    n long)."""
    if (w := _literals(width)) is None:
        return None
    w, = w

    def codegen(context, builder, signature, args):
        _, K, n, y, ynew, h, F, i = args
        dy = _lanes_of(builder, ynew, i, w) - _lanes_of(builder, y, i, w)
        k = [_lanes_of(builder, K, _row(builder, n, j, i), w) for j in (0, 5, 6, 7, 8, 9, 10, 11, 12, 13, 14, 15)]
        for r, value in enumerate(coefficients(_broadcast(builder, h, w), dy, *k)):
            _put(builder, value, F, _row(builder, n, r, i))
        return context.get_dummy_value()
    return types.void(width, _PD, types.int64, _PD, _PD, _D, _PD, types.int64), codegen


# the loops over the states, LANES at a time, then one by one (pointers and numbers: inlined without
# reference counts; numba's loops, measured steadier than loops written in the intrinsics)
@njit(cache=True, inline="always")
def _interpolate(F, n, y, s, s1, out):
    """out[i] = interpolant(y[i], F[0, i], .., F[6, i], s, s1) for the states i < n (pointers)."""
    for b in range(n // LANES):
        _interpolant_at(LANES, F, n, y, s, s1, out, LANES * b)
    for i in range(n - n % LANES, n):
        _interpolant_at(1, F, n, y, s, s1, out, i)


@njit(cache=True, inline="always")
def _coefficients(K, n, y, ynew, h, F):
    """F[:, i] = coefficients(h, ynew[i] - y[i], K[0, i], K[5, i], .., K[15, i]) for the states i < n
    (pointers)."""
    for b in range(n // LANES):
        _coefficients_at(LANES, K, n, y, ynew, h, F, LANES * b)
    for i in range(n - n % LANES, n):
        _coefficients_at(1, K, n, y, ynew, h, F, i)


# ------------------------------------------------------------------------------ input programs
@njit(cache=True)
def _sign(a):
    return 1.0 if a > 0.0 else (-1.0 if a < 0.0 else 0.0)


@njit(cache=True)
def _heaviside(a):
    return 1.0 if a > 0.0 else (0.5 if a == 0.0 else 0.0)


@njit(cache=True)
def _table(args, o, s):
    """A measured signal at s: its table is args[o:] = [n, times (n), 4 coefficients per interval,
    highest power first]; binary search for the interval, the end values held outside."""
    n = int(args[o])
    lo = 0
    hi = n - 1
    if s <= args[o + 1]:
        s = args[o + 1]
    elif s >= args[o + n]:
        s = args[o + n]
        lo = n - 2
    while hi - lo > 1:
        mid = (lo + hi) // 2
        if args[o + 1 + mid] <= s:
            lo = mid
        else:
            hi = mid
    d = s - args[o + 1 + lo]
    c = o + 1 + n + 4 * lo
    return ((args[c] * d + args[c + 1]) * d + args[c + 2]) * d + args[c + 3]


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
        elif op == 37:
            stack[top - 1] = _table(args, int(args[c]), stack[top - 1])
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


# -------------------------------------------------------------------------------- output stage
#: Output rows whose output stage (inputs and energy) dop853 evaluates together, by energy_rows (a call per
#: step, ~4 rows of a 20 s double pendulum output every 0.01 s, would leave the vectorized loop mostly idle).
OUTPUT_BLOCK = 64


@njit(cache=True)
def energies(energy, times, X, p, ops, args, starts, nstack, out, U, hold):
    """The Jacobi integral and the inputs at each row of (times, X); energy = (the address of the
    model's energy, of its energy_rows or 0); the sampled inputs (hold[i] = 1) are read from U, where
    the caller put their held values."""
    en, er = energy
    stack = np.empty(nstack)
    u = np.empty(max(1, starts.shape[0] - 1))
    modes = np.empty(max(1, ops.shape[0]))
    _outputs(en, er, 0, times.shape[0], times, X, p, ops, args, starts, stack, u, modes, U, out, hold)


@njit(cache=True, inline="always")
def _outputs(en, er, lo, hi, times, X, p, ops, args, starts, stack, u, modes, U, E, hold):
    """The output stage of the rows lo .. hi - 1 of a run: U[k, i] = input i at (times[k], X[k])
    (a sampled input, hold[i] = 1, is read from U[k, i], where the caller put its held value) and
    E[k] = the Jacobi integral there (en: the energy's address; er: energy_rows's, which evaluates
    the rows at once, or 0: row by row). Returns hi."""
    m = starts.shape[0] - 1
    nx = X.shape[1]
    if m:
        for k in range(lo, hi):
            xk = X[k]
            for i in range(m):
                if hold[i]:
                    u[i] = U[k, i]
                else:
                    u[i] = _run(ops, args, starts[i], starts[i + 1], times[k], xk, u, p, stack, modes, True)
                    U[k, i] = u[i]
    if er != 0 and hi > lo:
        _er(er, _ptr(times, lo), _ptr(X, lo * nx), _ptr(U, lo * m), _ptr(p, 0), _ptr(E, lo), hi - lo)
    for k in range(lo, hi):
        if er == 0 or E[k] != E[k]:  # (NaN: a row energy_rows leaves to energy)
            E[k] = _en(en, times[k], _ptr(X, k * nx), _ptr(U, k * m), _ptr(p, 0))
    return hi


# -------------------------------------------------------------------------------------- DOP853
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
def _projection_failed(code, t, x, info, stats, nfev, nstep, nrej, j):
    """The stop where a constrained model's projection returned `code` (SINGULAR or NOT_FINITE) at
    (t, x), x as the projection left it: info = [t, code, x...]; STATUS_PROJECTION_SINGULAR or
    STATUS_PROJECTION_NOT_FINITE."""
    _fail(code, t, x, info, stats, nfev, nstep, nrej, j)
    return STATUS_PROJECTION_SINGULAR if code == PROJECTION_SINGULAR else STATUS_PROJECTION_NOT_FINITE


@njit(cache=True)
def _dense_at(t, h, y, F, tq, out, k, L):
    """The order-7 interpolant of the step from (t, y) of size h, at tq: out[i] for the
    components y[i * L + k] (all of y for k = 0, L = 1; lane k in dop853_lanes),
    y + s (1 - s) (F1 + s (F2 + ... )) in Hairer's nested form, s = (tq - t) / h."""
    s = (tq - t) / h
    s1 = 1.0 - s
    for i in range(out.shape[0]):
        w = i * L + k
        v = (0.0 + F[6, w]) * s
        v = (v + F[5, w]) * s1
        v = (v + F[4, w]) * s
        v = (v + F[3, w]) * s1
        v = (v + F[2, w]) * s
        v = (v + F[1, w]) * s1
        v = (v + F[0, w]) * s
        out[i] = y[w] + v


@njit(cache=True)
def _dense(t, h, y, F, tq, out):
    """The order-7 interpolant of the step from (t, y) of size h, at tq."""
    _dense_at(t, h, y, F, tq, out, 0, 1)


@njit(cache=True, inline="always")
def _dense_row(t, h, y, F, tq, X, j):
    """_dense into the row X[j] of a 2-d array (the same numbers as _dense(..., X[j])), LANES states at a
    time (_interpolate), without the view of the row, whose reference counting costs an output of a small
    model as much as its interpolation; inlined (numba's inline="always"): a call passes its two 2-d arrays
    field by field."""
    s = (tq - t) / h
    nx = X.shape[1]
    _interpolate(_ptr(F, 0), nx, _ptr(y, 0), s, 1.0 - s, _ptr(X, j * nx))


@njit(cache=True)
def _dense_coefficients(rc, n, t, h, y, ynew, K, F, xs, p, ops, args, starts, stack, u, work, modes, live, hold,
                        held):
    """The three extra stages and the coefficients F of the order-7 interpolant (where a switch or an event
    needs them; dop853 has these lines written out where a step with outputs computes them)."""
    nx = 2 * n
    nin = starts.shape[0] - 1
    # stage 13
    for i in range(nx):
        xs[i] = y[i] + h * (A13_0 * K[0, i] + A13_6 * K[6, i] + A13_7 * K[7, i] + A13_8 * K[8, i]
                            + A13_9 * K[9, i] + A13_10 * K[10, i] + A13_11 * K[11, i] + A13_12 * K[12, i])
    ts = t + C13 * h
    if nin:
        eval_inputs(ts, xs, p, ops, args, starts, stack, u, modes, live, hold, held)
    _rc(rc, ts, _ptr(xs, 0), _ptr(u, 0), _ptr(p, 0), _ptr(K, 13 * nx), _ptr(work, 0))
    # stage 14
    for i in range(nx):
        xs[i] = y[i] + h * (A14_0 * K[0, i] + A14_5 * K[5, i] + A14_6 * K[6, i] + A14_7 * K[7, i]
                            + A14_10 * K[10, i] + A14_11 * K[11, i] + A14_12 * K[12, i] + A14_13 * K[13, i])
    ts = t + C14 * h
    if nin:
        eval_inputs(ts, xs, p, ops, args, starts, stack, u, modes, live, hold, held)
    _rc(rc, ts, _ptr(xs, 0), _ptr(u, 0), _ptr(p, 0), _ptr(K, 14 * nx), _ptr(work, 0))
    # stage 15
    for i in range(nx):
        xs[i] = y[i] + h * (A15_0 * K[0, i] + A15_5 * K[5, i] + A15_6 * K[6, i] + A15_7 * K[7, i]
                            + A15_8 * K[8, i] + A15_12 * K[12, i] + A15_13 * K[13, i] + A15_14 * K[14, i])
    ts = t + C15 * h
    if nin:
        eval_inputs(ts, xs, p, ops, args, starts, stack, u, modes, live, hold, held)
    _rc(rc, ts, _ptr(xs, 0), _ptr(u, 0), _ptr(p, 0), _ptr(K, 15 * nx), _ptr(work, 0))
    _coefficients(_ptr(K, 0), nx, _ptr(y, 0), _ptr(ynew, 0), h, _ptr(F, 0))


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
def dop853(model, x0, t_out, p, prog, control, events, sampling, out):
    """Integrate x' = f(t, x, u, p) from (t0, x0) with DOP853; X_out[j] = x(t_out[j]).

    The problem comes as tuples (see _kernels.py): model = (rhs, n, project, nwork, energy,
    energy_rows), the addresses of the model's functions (project: a constrained model's projection, or
    0; nwork: the size of the work array its rhs needs, 0: the default n * n + 2 n; energy: 0 for no
    output stage; energy_rows: 0 where the model has none or it is not compiled yet: numeric/_fast.py's
    EnergyRows compiles it where numba's cache on disk holds it, or once the model's rows evaluated one by
    one, by energy (the same numbers), have cost about as much as its compile, ENERGY_ROWS_AFTER rows);
    prog = (ops, args, starts, nstack), the inputs' programs; control = (t0, rtol, atol, max_step,
    first_step); events = (ops, args, starts, terminal, ev_t, ev_k, ev_x, ev_n); sampling = (hold,
    samples, which, hist); out = (X_out, info, stats, U_out, E_out, done).

    A constrained model's projection project(t, x, u, p, work, drift) is called on the state after
    every accepted step and on the outputs of the step (the step's last derivative is kept: see
    there); where it fails (a singular system, or values not finite) the run stops there with status
    STATUS_PROJECTION_SINGULAR or STATUS_PROJECTION_NOT_FINITE (info[1]: the projection's code), the
    output rows before kept.

    The output stage: with an energy address, U_out[j] and E_out[j] receive the inputs and the
    Jacobi integral at each output (t_out[j], X_out[j]), evaluated in the loop as the outputs are
    written (projected first), OUTPUT_BLOCK rows at a time with energy_rows (row by row without),
    without a second pass; done[0] counts them (the rows written where
    a run stops, at an event or a failure, are left to the caller: energies; the sampled inputs'
    values are the caller's, who then passes no energy address).

    Returns the status (see lagrangian.numeric._kernels.STATUS); unless 0, info = [t, inertia
    measure (or, status 4, the event's index), x...] where it stopped; stats = [nfev, accepted
    steps, rejected steps, outputs(, located switches)]. Event functions (programs of t, x, u, p)
    are watched at each step: each zero crossing is located on the interpolant and recorded in
    ev_t, ev_k (which event), ev_x (the state), ev_n[0] counting them (at most len(ev_t)); a
    crossing of an event with terminal[k] = 1 stops the integration there (status 4).

    Inputs are programs of (t, x, p). Their switches (comparisons in where, sign) are frozen
    during a step, so that each step integrates a smooth right-hand side; after the step they
    are evaluated live at its end, and when one has changed the change is located on the
    interpolant (bisection) and the step ends there: a discontinuous law costs a step, not a
    crawl. Where a switch changes back at once (a sliding mode), that step is taken again with
    the switches live, under the error control alone. Sampled inputs (hold[i] = 1) are
    evaluated at the times `samples` (those with which[s, i]) and held in between; no step
    crosses a sample time; hist[s] receives the held values at samples[s]."""
    rc, n, proj, nwork, en, er = model
    ops, args, starts, nstack = prog
    t0, rtol, atol, max_step, first_step = control
    eops, eargs, estarts, eterm, ev_t, ev_k, ev_x, ev_n = events
    hold, samples, which, hist = sampling
    X_out, info, stats, U_out, E_out, done = out
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
    uo = np.empty(max(1, nin))  # the output stage's inputs and switches (the integrator's stay as they are)
    mo = np.empty(max(1, ops.shape[0]))
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
            if tnew > t_end:  # noqa: PLR1730 (not min(): the same steps as before, NaN included)
                tnew = t_end
            if si < ns and tnew > samples[si]:
                tnew = samples[si]
            h = tnew - t
            h_abs = abs(h)
            # stage 1
            for i in range(nx):
                xs[i] = y[i] + h * (A1_0 * K[0, i])
            ts = t + C1 * h
            if nin:
                eval_inputs(ts, xs, p, ops, args, starts, stack, u, modes, live, hold, held)
            r = _rc(rc, ts, _ptr(xs, 0), _ptr(u, 0), _ptr(p, 0), _ptr(K, 1 * nx), _ptr(work, 0))
            nfev += 1
            if r < 0.0 or r <= SINGULAR_RATIO:
                if r < 0.0 and not live:  # a branch of a switch evaluated out of its region:
                    live = True           # take this step again with the switches live
                    continue
                return _fail(r, ts, xs, info, stats, nfev, nstep, nrej, j)
            # stage 2
            for i in range(nx):
                xs[i] = y[i] + h * (A2_0 * K[0, i] + A2_1 * K[1, i])
            ts = t + C2 * h
            if nin:
                eval_inputs(ts, xs, p, ops, args, starts, stack, u, modes, live, hold, held)
            r = _rc(rc, ts, _ptr(xs, 0), _ptr(u, 0), _ptr(p, 0), _ptr(K, 2 * nx), _ptr(work, 0))
            nfev += 1
            if r < 0.0 or r <= SINGULAR_RATIO:
                if r < 0.0 and not live:  # a branch of a switch evaluated out of its region:
                    live = True           # take this step again with the switches live
                    continue
                return _fail(r, ts, xs, info, stats, nfev, nstep, nrej, j)
            # stage 3
            for i in range(nx):
                xs[i] = y[i] + h * (A3_0 * K[0, i] + A3_2 * K[2, i])
            ts = t + C3 * h
            if nin:
                eval_inputs(ts, xs, p, ops, args, starts, stack, u, modes, live, hold, held)
            r = _rc(rc, ts, _ptr(xs, 0), _ptr(u, 0), _ptr(p, 0), _ptr(K, 3 * nx), _ptr(work, 0))
            nfev += 1
            if r < 0.0 or r <= SINGULAR_RATIO:
                if r < 0.0 and not live:  # a branch of a switch evaluated out of its region:
                    live = True           # take this step again with the switches live
                    continue
                return _fail(r, ts, xs, info, stats, nfev, nstep, nrej, j)
            # stage 4
            for i in range(nx):
                xs[i] = y[i] + h * (A4_0 * K[0, i] + A4_2 * K[2, i] + A4_3 * K[3, i])
            ts = t + C4 * h
            if nin:
                eval_inputs(ts, xs, p, ops, args, starts, stack, u, modes, live, hold, held)
            r = _rc(rc, ts, _ptr(xs, 0), _ptr(u, 0), _ptr(p, 0), _ptr(K, 4 * nx), _ptr(work, 0))
            nfev += 1
            if r < 0.0 or r <= SINGULAR_RATIO:
                if r < 0.0 and not live:  # a branch of a switch evaluated out of its region:
                    live = True           # take this step again with the switches live
                    continue
                return _fail(r, ts, xs, info, stats, nfev, nstep, nrej, j)
            # stage 5
            for i in range(nx):
                xs[i] = y[i] + h * (A5_0 * K[0, i] + A5_3 * K[3, i] + A5_4 * K[4, i])
            ts = t + C5 * h
            if nin:
                eval_inputs(ts, xs, p, ops, args, starts, stack, u, modes, live, hold, held)
            r = _rc(rc, ts, _ptr(xs, 0), _ptr(u, 0), _ptr(p, 0), _ptr(K, 5 * nx), _ptr(work, 0))
            nfev += 1
            if r < 0.0 or r <= SINGULAR_RATIO:
                if r < 0.0 and not live:  # a branch of a switch evaluated out of its region:
                    live = True           # take this step again with the switches live
                    continue
                return _fail(r, ts, xs, info, stats, nfev, nstep, nrej, j)
            # stage 6
            for i in range(nx):
                xs[i] = y[i] + h * (A6_0 * K[0, i] + A6_3 * K[3, i] + A6_4 * K[4, i] + A6_5 * K[5, i])
            ts = t + C6 * h
            if nin:
                eval_inputs(ts, xs, p, ops, args, starts, stack, u, modes, live, hold, held)
            r = _rc(rc, ts, _ptr(xs, 0), _ptr(u, 0), _ptr(p, 0), _ptr(K, 6 * nx), _ptr(work, 0))
            nfev += 1
            if r < 0.0 or r <= SINGULAR_RATIO:
                if r < 0.0 and not live:  # a branch of a switch evaluated out of its region:
                    live = True           # take this step again with the switches live
                    continue
                return _fail(r, ts, xs, info, stats, nfev, nstep, nrej, j)
            # stage 7
            for i in range(nx):
                xs[i] = y[i] + h * (A7_0 * K[0, i] + A7_3 * K[3, i] + A7_4 * K[4, i] + A7_5 * K[5, i] + A7_6 * K[6, i])
            ts = t + C7 * h
            if nin:
                eval_inputs(ts, xs, p, ops, args, starts, stack, u, modes, live, hold, held)
            r = _rc(rc, ts, _ptr(xs, 0), _ptr(u, 0), _ptr(p, 0), _ptr(K, 7 * nx), _ptr(work, 0))
            nfev += 1
            if r < 0.0 or r <= SINGULAR_RATIO:
                if r < 0.0 and not live:  # a branch of a switch evaluated out of its region:
                    live = True           # take this step again with the switches live
                    continue
                return _fail(r, ts, xs, info, stats, nfev, nstep, nrej, j)
            # stage 8
            for i in range(nx):
                xs[i] = y[i] + h * (A8_0 * K[0, i] + A8_3 * K[3, i] + A8_4 * K[4, i] + A8_5 * K[5, i] + A8_6 * K[6, i]
                                    + A8_7 * K[7, i])
            ts = t + C8 * h
            if nin:
                eval_inputs(ts, xs, p, ops, args, starts, stack, u, modes, live, hold, held)
            r = _rc(rc, ts, _ptr(xs, 0), _ptr(u, 0), _ptr(p, 0), _ptr(K, 8 * nx), _ptr(work, 0))
            nfev += 1
            if r < 0.0 or r <= SINGULAR_RATIO:
                if r < 0.0 and not live:  # a branch of a switch evaluated out of its region:
                    live = True           # take this step again with the switches live
                    continue
                return _fail(r, ts, xs, info, stats, nfev, nstep, nrej, j)
            # stage 9
            for i in range(nx):
                xs[i] = y[i] + h * (A9_0 * K[0, i] + A9_3 * K[3, i] + A9_4 * K[4, i] + A9_5 * K[5, i] + A9_6 * K[6, i]
                                    + A9_7 * K[7, i] + A9_8 * K[8, i])
            ts = t + C9 * h
            if nin:
                eval_inputs(ts, xs, p, ops, args, starts, stack, u, modes, live, hold, held)
            r = _rc(rc, ts, _ptr(xs, 0), _ptr(u, 0), _ptr(p, 0), _ptr(K, 9 * nx), _ptr(work, 0))
            nfev += 1
            if r < 0.0 or r <= SINGULAR_RATIO:
                if r < 0.0 and not live:  # a branch of a switch evaluated out of its region:
                    live = True           # take this step again with the switches live
                    continue
                return _fail(r, ts, xs, info, stats, nfev, nstep, nrej, j)
            # stage 10
            for i in range(nx):
                xs[i] = y[i] + h * (A10_0 * K[0, i] + A10_3 * K[3, i] + A10_4 * K[4, i] + A10_5 * K[5, i]
                                    + A10_6 * K[6, i] + A10_7 * K[7, i] + A10_8 * K[8, i] + A10_9 * K[9, i])
            ts = t + C10 * h
            if nin:
                eval_inputs(ts, xs, p, ops, args, starts, stack, u, modes, live, hold, held)
            r = _rc(rc, ts, _ptr(xs, 0), _ptr(u, 0), _ptr(p, 0), _ptr(K, 10 * nx), _ptr(work, 0))
            nfev += 1
            if r < 0.0 or r <= SINGULAR_RATIO:
                if r < 0.0 and not live:  # a branch of a switch evaluated out of its region:
                    live = True           # take this step again with the switches live
                    continue
                return _fail(r, ts, xs, info, stats, nfev, nstep, nrej, j)
            # stage 11
            for i in range(nx):
                xs[i] = y[i] + h * (A11_0 * K[0, i] + A11_3 * K[3, i] + A11_4 * K[4, i] + A11_5 * K[5, i]
                                    + A11_6 * K[6, i] + A11_7 * K[7, i] + A11_8 * K[8, i] + A11_9 * K[9, i]
                                    + A11_10 * K[10, i])
            ts = t + C11 * h
            if nin:
                eval_inputs(ts, xs, p, ops, args, starts, stack, u, modes, live, hold, held)
            r = _rc(rc, ts, _ptr(xs, 0), _ptr(u, 0), _ptr(p, 0), _ptr(K, 11 * nx), _ptr(work, 0))
            nfev += 1
            if r < 0.0 or r <= SINGULAR_RATIO:
                if r < 0.0 and not live:  # a branch of a switch evaluated out of its region:
                    live = True           # take this step again with the switches live
                    continue
                return _fail(r, ts, xs, info, stats, nfev, nstep, nrej, j)
            # stage 12
            for i in range(nx):
                xs[i] = y[i] + h * (A12_0 * K[0, i] + A12_5 * K[5, i] + A12_6 * K[6, i] + A12_7 * K[7, i]
                                    + A12_8 * K[8, i] + A12_9 * K[9, i] + A12_10 * K[10, i] + A12_11 * K[11, i])
            ts = t + C12 * h
            if nin:
                eval_inputs(ts, xs, p, ops, args, starts, stack, u, modes, live, hold, held)
            r = _rc(rc, ts, _ptr(xs, 0), _ptr(u, 0), _ptr(p, 0), _ptr(K, 12 * nx), _ptr(work, 0))
            nfev += 1
            if r < 0.0 or r <= SINGULAR_RATIO:
                if r < 0.0 and not live:  # a branch of a switch evaluated out of its region:
                    live = True           # take this step again with the switches live
                    continue
                return _fail(r, ts, xs, info, stats, nfev, nstep, nrej, j)
            rnew = r
            for i in range(nx):
                ynew[i] = xs[i]
            e5 = 0.0
            e3 = 0.0
            for i in range(nx):
                scl = atol + max(abs(y[i]), abs(ynew[i])) * rtol
                d5 = (E5_0 * K[0, i] + E5_5 * K[5, i] + E5_6 * K[6, i] + E5_7 * K[7, i] + E5_8 * K[8, i]
                      + E5_9 * K[9, i] + E5_10 * K[10, i] + E5_11 * K[11, i]) / scl
                d3 = (E3_0 * K[0, i] + E3_5 * K[5, i] + E3_6 * K[6, i] + E3_7 * K[7, i] + E3_8 * K[8, i]
                      + E3_9 * K[9, i] + E3_10 * K[10, i] + E3_11 * K[11, i]) / scl
                e5 += d5 * d5
                e3 += d3 * d3
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
                _dense_coefficients(rc, n, t, h, y, ynew, K, F, xs, p, ops, args, starts, stack, u, work, modes, False,
                                    hold, held)
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
            # _dense_coefficients written out (the same lines: tests/numeric/test_kernels.py compares them): a call
            # passes its 20 arrays field by field, numba's inline="always" adds a reference count per array and
            # step (30 atomic operations); 114 -> 98 us of the 20 s double pendulum's 2001 outputs
            # stage 13
            for i in range(nx):
                xs[i] = y[i] + h * (A13_0 * K[0, i] + A13_6 * K[6, i] + A13_7 * K[7, i] + A13_8 * K[8, i]
                                    + A13_9 * K[9, i] + A13_10 * K[10, i] + A13_11 * K[11, i] + A13_12 * K[12, i])
            ts = t + C13 * h
            if nin:
                eval_inputs(ts, xs, p, ops, args, starts, stack, u, modes, live, hold, held)
            _rc(rc, ts, _ptr(xs, 0), _ptr(u, 0), _ptr(p, 0), _ptr(K, 13 * nx), _ptr(work, 0))
            # stage 14
            for i in range(nx):
                xs[i] = y[i] + h * (A14_0 * K[0, i] + A14_5 * K[5, i] + A14_6 * K[6, i] + A14_7 * K[7, i]
                                    + A14_10 * K[10, i] + A14_11 * K[11, i] + A14_12 * K[12, i] + A14_13 * K[13, i])
            ts = t + C14 * h
            if nin:
                eval_inputs(ts, xs, p, ops, args, starts, stack, u, modes, live, hold, held)
            _rc(rc, ts, _ptr(xs, 0), _ptr(u, 0), _ptr(p, 0), _ptr(K, 14 * nx), _ptr(work, 0))
            # stage 15
            for i in range(nx):
                xs[i] = y[i] + h * (A15_0 * K[0, i] + A15_5 * K[5, i] + A15_6 * K[6, i] + A15_7 * K[7, i]
                                    + A15_8 * K[8, i] + A15_12 * K[12, i] + A15_13 * K[13, i] + A15_14 * K[14, i])
            ts = t + C15 * h
            if nin:
                eval_inputs(ts, xs, p, ops, args, starts, stack, u, modes, live, hold, held)
            _rc(rc, ts, _ptr(xs, 0), _ptr(u, 0), _ptr(p, 0), _ptr(K, 15 * nx), _ptr(work, 0))
            _coefficients(_ptr(K, 0), nx, _ptr(y, 0), _ptr(ynew, 0), h, _ptr(F, 0))
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
                                        modes, live, hold, held)
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
                _dense_row(t, h, y, F, t_out[j], X_out, j)
            j += 1
        if proj != 0:  # onto the constraints: the outputs, then the state the next step starts from
            for jj in range(j0, j):
                for i in range(nx):
                    xs[i] = X_out[jj, i]
                code = _rc(proj, t_out[jj], _ptr(xs, 0), _ptr(u, 0), _ptr(p, 0), _ptr(work, 0), _ptr(drift, 0))
                if code != PROJECTION_MET:  # a failed projection stops the run (the rows before this one kept)
                    return _projection_failed(code, t_out[jj], xs, info, stats, nfev, nstep, nrej, jj)
                for i in range(nx):
                    X_out[jj, i] = xs[i]
            # the next step starts from the projected state with the derivative of the step's end (first
            # same as last): they differ by the projection's correction, of the size of the local error,
            # so the stale derivative adds an error h L |correction|, of higher order than the step's
            code = _rc(proj, tnew, _ptr(ynew, 0), _ptr(u, 0), _ptr(p, 0), _ptr(work, 0), _ptr(drift, 0))
            if code != PROJECTION_MET:
                return _projection_failed(code, tnew, ynew, info, stats, nfev, nstep, nrej, j)
        if en != 0 and j > done[0] and (er == 0 or j - done[0] >= OUTPUT_BLOCK or j == nout):  # the rows' output
            # stage (none in most steps of a run with few outputs: row by row, the call cost 7 us in 650 steps)
            done[0] = _outputs(en, er, done[0], j, t_out, X_out, p, ops, args, starts, stack, uo, mo, U_out, E_out,
                               hold)
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



# ---------------------------------------------------------------------------------------- batches
@njit(cache=True)
def _single_run(model, x0, t_out, p, prog, control, X_out, info, stats):
    """dop853 of one run of a batch: no events, no sampled inputs, no output stage (the same types as
    run_dop853's call, so that numba compiles dop853 once)."""
    n = model[1]
    nin = prog[2].shape[0] - 1
    events = (np.zeros(1, np.int64), np.zeros(1), np.zeros(1, np.int64), np.zeros(1, np.int64), np.zeros(1),
              np.zeros(1, np.int64), np.zeros((1, 2 * n)), np.zeros(1, np.int64))
    sampling = (np.zeros(max(1, nin), np.int64), np.zeros(0), np.zeros((1, 1), np.int64), np.zeros((1, max(1, nin))))
    return dop853(model, x0, t_out, p, prog, control, events, sampling,  # model: its energy addresses 0
                  (X_out, info, stats, np.zeros((1, 1)), np.zeros(1), np.zeros(1, np.int64)))


@njit(cache=True, parallel=True)
def dop853_batch(model, X0, t_out, P, prog, control, X_out, INFO, STATS, STATUS):
    """dop853 for each row of X0 (initial states) and P (parameters), in parallel; model = (rhs, n,
    project, nwork, 0, 0) as dop853 takes it; X_out, INFO, STATS and STATUS: a row per run. (The result
    arrays come one by one, not as a tuple: numba's parallel loops lose the writes to an array
    unpacked from a tuple argument.)"""
    for b in prange(X0.shape[0]):
        STATUS[b] = _single_run(model, X0[b], t_out, P[b], prog, control, X_out[b], INFO[b], STATS[b])


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
def _lane_dense_coefficients(rc, L, nx, T, H, HW, y, ynew, K, F, xs, TS, P, PL, ops, args, starts, stack, u1, U,
                             work, lm, lh):
    """_dense_coefficients of dop853_lanes: every lane's, each of its own step."""
    W = nx * L
    nin = starts.shape[0] - 1
    # stage 13
    for w in range(W):
        xs[w] = y[w] + HW[w] * (A13_0 * K[0, w] + A13_6 * K[6, w] + A13_7 * K[7, w] + A13_8 * K[8, w]
                                + A13_9 * K[9, w] + A13_10 * K[10, w] + A13_11 * K[11, w] + A13_12 * K[12, w])
    for k in range(L):
        TS[k] = T[k] + C13 * H[k]
    if nin:
        _lane_inputs(TS, P, ops, args, starts, stack, u1, U, lm, lh)
    _rl(rc, _ptr(TS, 0), _ptr(xs, 0), _ptr(U, 0), _ptr(PL, 0), _ptr(K, 13 * W), _ptr(work, 0), L)
    # stage 14
    for w in range(W):
        xs[w] = y[w] + HW[w] * (A14_0 * K[0, w] + A14_5 * K[5, w] + A14_6 * K[6, w] + A14_7 * K[7, w]
                                + A14_10 * K[10, w] + A14_11 * K[11, w] + A14_12 * K[12, w] + A14_13 * K[13, w])
    for k in range(L):
        TS[k] = T[k] + C14 * H[k]
    if nin:
        _lane_inputs(TS, P, ops, args, starts, stack, u1, U, lm, lh)
    _rl(rc, _ptr(TS, 0), _ptr(xs, 0), _ptr(U, 0), _ptr(PL, 0), _ptr(K, 14 * W), _ptr(work, 0), L)
    # stage 15
    for w in range(W):
        xs[w] = y[w] + HW[w] * (A15_0 * K[0, w] + A15_5 * K[5, w] + A15_6 * K[6, w] + A15_7 * K[7, w]
                                + A15_8 * K[8, w] + A15_12 * K[12, w] + A15_13 * K[13, w] + A15_14 * K[14, w])
    for k in range(L):
        TS[k] = T[k] + C15 * H[k]
    if nin:
        _lane_inputs(TS, P, ops, args, starts, stack, u1, U, lm, lh)
    _rl(rc, _ptr(TS, 0), _ptr(xs, 0), _ptr(U, 0), _ptr(PL, 0), _ptr(K, 15 * W), _ptr(work, 0), L)
    for i in range(nx):
        for k in range(L):
            w = i * L + k
            dy = ynew[w] - y[w]
            F[0, w] = dy
            F[1, w] = H[k] * K[0, w] - dy
            F[2, w] = 2.0 * dy - H[k] * (K[12, w] + K[0, w])
            F[3, w] = H[k] * (D3_0 * K[0, w] + D3_5 * K[5, w] + D3_6 * K[6, w] + D3_7 * K[7, w] + D3_8 * K[8, w]
                + D3_9 * K[9, w] + D3_10 * K[10, w] + D3_11 * K[11, w] + D3_12 * K[12, w] + D3_13 * K[13, w]
                + D3_14 * K[14, w] + D3_15 * K[15, w])
            F[4, w] = H[k] * (D4_0 * K[0, w] + D4_5 * K[5, w] + D4_6 * K[6, w] + D4_7 * K[7, w] + D4_8 * K[8, w]
                + D4_9 * K[9, w] + D4_10 * K[10, w] + D4_11 * K[11, w] + D4_12 * K[12, w] + D4_13 * K[13, w]
                + D4_14 * K[14, w] + D4_15 * K[15, w])
            F[5, w] = H[k] * (D5_0 * K[0, w] + D5_5 * K[5, w] + D5_6 * K[6, w] + D5_7 * K[7, w] + D5_8 * K[8, w]
                + D5_9 * K[9, w] + D5_10 * K[10, w] + D5_11 * K[11, w] + D5_12 * K[12, w] + D5_13 * K[13, w]
                + D5_14 * K[14, w] + D5_15 * K[15, w])
            F[6, w] = H[k] * (D6_0 * K[0, w] + D6_5 * K[5, w] + D6_6 * K[6, w] + D6_7 * K[7, w] + D6_8 * K[8, w]
                + D6_9 * K[9, w] + D6_10 * K[10, w] + D6_11 * K[11, w] + D6_12 * K[12, w] + D6_13 * K[13, w]
                + D6_14 * K[14, w] + D6_15 * K[15, w])


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
def dop853_lanes(rc, n, X0, t_out, P, prog, control, X_out, STATS):
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
    ops, args, starts, nstack = prog
    t0, rtol, atol, max_step, _ = control
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
    ERR5 = np.zeros(W)
    ERR3 = np.zeros(W)
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
    r = _rl(rc, _ptr(TS, 0), _ptr(y, 0), _ptr(U, 0), _ptr(PL, 0), _ptr(K, 0), _ptr(work, 0), L)
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
        r = _rl(rc, _ptr(TS, 0), _ptr(xs, 0), _ptr(U, 0), _ptr(PL, 0), _ptr(K, W), _ptr(work, 0), L)
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
        # stage 1
        for w in range(W):
            xs[w] = y[w] + HW[w] * (A1_0 * K[0, w])
        for k in range(L):
            TS[k] = T[k] + C1 * H[k]
        if nin:
            _lane_inputs(TS, P, ops, args, starts, stack, u1, U, lm, lh)
        r = _rl(rc, _ptr(TS, 0), _ptr(xs, 0), _ptr(U, 0), _ptr(PL, 0), _ptr(K, 1 * W), _ptr(work, 0), L)
        if r < EVENT_RATIO:
            return 1
        # stage 2
        for w in range(W):
            xs[w] = y[w] + HW[w] * (A2_0 * K[0, w] + A2_1 * K[1, w])
        for k in range(L):
            TS[k] = T[k] + C2 * H[k]
        if nin:
            _lane_inputs(TS, P, ops, args, starts, stack, u1, U, lm, lh)
        r = _rl(rc, _ptr(TS, 0), _ptr(xs, 0), _ptr(U, 0), _ptr(PL, 0), _ptr(K, 2 * W), _ptr(work, 0), L)
        if r < EVENT_RATIO:
            return 1
        # stage 3
        for w in range(W):
            xs[w] = y[w] + HW[w] * (A3_0 * K[0, w] + A3_2 * K[2, w])
        for k in range(L):
            TS[k] = T[k] + C3 * H[k]
        if nin:
            _lane_inputs(TS, P, ops, args, starts, stack, u1, U, lm, lh)
        r = _rl(rc, _ptr(TS, 0), _ptr(xs, 0), _ptr(U, 0), _ptr(PL, 0), _ptr(K, 3 * W), _ptr(work, 0), L)
        if r < EVENT_RATIO:
            return 1
        # stage 4
        for w in range(W):
            xs[w] = y[w] + HW[w] * (A4_0 * K[0, w] + A4_2 * K[2, w] + A4_3 * K[3, w])
        for k in range(L):
            TS[k] = T[k] + C4 * H[k]
        if nin:
            _lane_inputs(TS, P, ops, args, starts, stack, u1, U, lm, lh)
        r = _rl(rc, _ptr(TS, 0), _ptr(xs, 0), _ptr(U, 0), _ptr(PL, 0), _ptr(K, 4 * W), _ptr(work, 0), L)
        if r < EVENT_RATIO:
            return 1
        # stage 5
        for w in range(W):
            xs[w] = y[w] + HW[w] * (A5_0 * K[0, w] + A5_3 * K[3, w] + A5_4 * K[4, w])
        for k in range(L):
            TS[k] = T[k] + C5 * H[k]
        if nin:
            _lane_inputs(TS, P, ops, args, starts, stack, u1, U, lm, lh)
        r = _rl(rc, _ptr(TS, 0), _ptr(xs, 0), _ptr(U, 0), _ptr(PL, 0), _ptr(K, 5 * W), _ptr(work, 0), L)
        if r < EVENT_RATIO:
            return 1
        # stage 6
        for w in range(W):
            xs[w] = y[w] + HW[w] * (A6_0 * K[0, w] + A6_3 * K[3, w] + A6_4 * K[4, w] + A6_5 * K[5, w])
        for k in range(L):
            TS[k] = T[k] + C6 * H[k]
        if nin:
            _lane_inputs(TS, P, ops, args, starts, stack, u1, U, lm, lh)
        r = _rl(rc, _ptr(TS, 0), _ptr(xs, 0), _ptr(U, 0), _ptr(PL, 0), _ptr(K, 6 * W), _ptr(work, 0), L)
        if r < EVENT_RATIO:
            return 1
        # stage 7
        for w in range(W):
            xs[w] = y[w] + HW[w] * (A7_0 * K[0, w] + A7_3 * K[3, w] + A7_4 * K[4, w] + A7_5 * K[5, w] + A7_6 * K[6, w])
        for k in range(L):
            TS[k] = T[k] + C7 * H[k]
        if nin:
            _lane_inputs(TS, P, ops, args, starts, stack, u1, U, lm, lh)
        r = _rl(rc, _ptr(TS, 0), _ptr(xs, 0), _ptr(U, 0), _ptr(PL, 0), _ptr(K, 7 * W), _ptr(work, 0), L)
        if r < EVENT_RATIO:
            return 1
        # stage 8
        for w in range(W):
            xs[w] = y[w] + HW[w] * (A8_0 * K[0, w] + A8_3 * K[3, w] + A8_4 * K[4, w] + A8_5 * K[5, w] + A8_6 * K[6, w]
                                    + A8_7 * K[7, w])
        for k in range(L):
            TS[k] = T[k] + C8 * H[k]
        if nin:
            _lane_inputs(TS, P, ops, args, starts, stack, u1, U, lm, lh)
        r = _rl(rc, _ptr(TS, 0), _ptr(xs, 0), _ptr(U, 0), _ptr(PL, 0), _ptr(K, 8 * W), _ptr(work, 0), L)
        if r < EVENT_RATIO:
            return 1
        # stage 9
        for w in range(W):
            xs[w] = y[w] + HW[w] * (A9_0 * K[0, w] + A9_3 * K[3, w] + A9_4 * K[4, w] + A9_5 * K[5, w] + A9_6 * K[6, w]
                                    + A9_7 * K[7, w] + A9_8 * K[8, w])
        for k in range(L):
            TS[k] = T[k] + C9 * H[k]
        if nin:
            _lane_inputs(TS, P, ops, args, starts, stack, u1, U, lm, lh)
        r = _rl(rc, _ptr(TS, 0), _ptr(xs, 0), _ptr(U, 0), _ptr(PL, 0), _ptr(K, 9 * W), _ptr(work, 0), L)
        if r < EVENT_RATIO:
            return 1
        # stage 10
        for w in range(W):
            xs[w] = y[w] + HW[w] * (A10_0 * K[0, w] + A10_3 * K[3, w] + A10_4 * K[4, w] + A10_5 * K[5, w]
                                    + A10_6 * K[6, w] + A10_7 * K[7, w] + A10_8 * K[8, w] + A10_9 * K[9, w])
        for k in range(L):
            TS[k] = T[k] + C10 * H[k]
        if nin:
            _lane_inputs(TS, P, ops, args, starts, stack, u1, U, lm, lh)
        r = _rl(rc, _ptr(TS, 0), _ptr(xs, 0), _ptr(U, 0), _ptr(PL, 0), _ptr(K, 10 * W), _ptr(work, 0), L)
        if r < EVENT_RATIO:
            return 1
        # stage 11
        for w in range(W):
            xs[w] = y[w] + HW[w] * (A11_0 * K[0, w] + A11_3 * K[3, w] + A11_4 * K[4, w] + A11_5 * K[5, w]
                                    + A11_6 * K[6, w] + A11_7 * K[7, w] + A11_8 * K[8, w] + A11_9 * K[9, w]
                                    + A11_10 * K[10, w])
        for k in range(L):
            TS[k] = T[k] + C11 * H[k]
        if nin:
            _lane_inputs(TS, P, ops, args, starts, stack, u1, U, lm, lh)
        r = _rl(rc, _ptr(TS, 0), _ptr(xs, 0), _ptr(U, 0), _ptr(PL, 0), _ptr(K, 11 * W), _ptr(work, 0), L)
        if r < EVENT_RATIO:
            return 1
        # stage 12
        for w in range(W):
            xs[w] = y[w] + HW[w] * (A12_0 * K[0, w] + A12_5 * K[5, w] + A12_6 * K[6, w] + A12_7 * K[7, w]
                                    + A12_8 * K[8, w] + A12_9 * K[9, w] + A12_10 * K[10, w] + A12_11 * K[11, w])
        for k in range(L):
            TS[k] = T[k] + C12 * H[k]
        if nin:
            _lane_inputs(TS, P, ops, args, starts, stack, u1, U, lm, lh)
        r = _rl(rc, _ptr(TS, 0), _ptr(xs, 0), _ptr(U, 0), _ptr(PL, 0), _ptr(K, 12 * W), _ptr(work, 0), L)
        if r < EVENT_RATIO:
            return 1
        for w in range(W):
            ynew[w] = xs[w]
            scl = atol + max(abs(y[w]), abs(xs[w])) * rtol
            ERR5[w] = (E5_0 * K[0, w] + E5_5 * K[5, w] + E5_6 * K[6, w] + E5_7 * K[7, w] + E5_8 * K[8, w]
                      + E5_9 * K[9, w] + E5_10 * K[10, w] + E5_11 * K[11, w]) / scl
            ERR3[w] = (E3_0 * K[0, w] + E3_5 * K[5, w] + E3_6 * K[6, w] + E3_7 * K[7, w] + E3_8 * K[8, w]
                      + E3_9 * K[9, w] + E3_10 * K[10, w] + E3_11 * K[11, w]) / scl
        for k in range(L):
            e5 = 0.0
            e3 = 0.0
            for i in range(nx):
                e5 += ERR5[i * L + k] ** 2
                e3 += ERR3[i * L + k] ** 2
            ERR[k] = 0.0 if (e5 == 0.0 and e3 == 0.0) else HA[k] * e5 / math.sqrt((e5 + 0.01 * e3) * nx)
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
            _lane_dense_coefficients(rc, L, nx, T, H, HW, y, ynew, K, F, xs, TS, P, PL, ops, args, starts, stack,
                                     u1, U, work, lm, lh)
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
def dop853_batch_lanes(model, rcl, lanes, X0, t_out, P, prog, control, X_out, INFO, STATS, STATUS):
    """dop853_batch in blocks of `lanes` runs integrated together by dop853_lanes (rcl: the
    address of rhs_lanes for blocks of `lanes`), in parallel. The runs left over after the
    last full block, and a block that dop853_lanes hands back, are run one by one by dop853
    (model: as dop853_batch's), so that each of them stops or fails as alone."""
    n = model[1]
    B = X0.shape[0]
    for b in prange((B + lanes - 1) // lanes):
        a = b * lanes
        e = min(B, a + lanes)
        if e - a == lanes and dop853_lanes(rcl, n, X0[a:e], t_out, P[a:e], prog, control, X_out[a:e],
                                           STATS[a:e]) == 0:
            for q in range(a, e):
                STATUS[q] = 0
            continue
        for q in range(a, e):
            STATUS[q] = _single_run(model, X0[q], t_out, P[q], prog, control, X_out[q], INFO[q], STATS[q])


# ------------------------------------------------------------------------------- variational
@njit(cache=True)
def variational(model, x0, t0, h, nsteps, every, p, prog, out):
    """The midpoint variational integrator: the discrete Lagrangian
    L_d(q0, q1) = h L(t + h/2, (q0 + q1)/2, (q1 - q0)/h), with the non-conservative forces
    -dD/dq_dot + Q at the midpoint (discrete Lagrange-d'Alembert principle). In position-momentum
    form, with v = (q1 - q0)/h and the midpoint qm = q0 + h v / 2, F = dL/dq - dD/dq_dot + Q:

        p0 = dL/dq_dot(qm, v) - h/2 F(qm, v)     (solved for v by Newton's method, with the
        p1 = dL/dq_dot(qm, v) + h/2 F(qm, v)      Jacobian approximated by M(qm))

    X_out[k] = x at t0 + k * every * h, k = 0 .. nsteps // every; velocities from
    M q_dot = p - dL/dq_dot(q, 0) (T quadratic in the velocities).

    model = (mass_forcing, lagrange_parts, n), the addresses of the model's functions; prog = (ops, args,
    starts, nstack), the inputs' programs; out = (X_out, info, stats) as dop853's."""
    mf, lp, n = model
    ops, args, starts, nstack = prog
    X_out, info, stats = out
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
