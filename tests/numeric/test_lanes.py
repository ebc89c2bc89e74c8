"""The generated code's own sine and cosine (_sincos), the vectorized right-hand side of several
states at once (rhs_lanes), and batch runs in blocks of lanes (simulate_batch(lanes=...)), each
checked against an independent evaluation: libm, the one-state rhs, and runs integrated alone."""

from __future__ import annotations

import math

import mpmath
import numpy as np
import pytest

import lagrangian as lg
from lagrangian.errors import ModelError
from lagrangian.numeric import _codegen
from lagrangian.numeric._fast import _module, compile_numba, kernels

ULP = np.finfo(float).eps


@pytest.fixture(scope="module")
def dp():
    return lg.derive(lg.load("double-pendulum"))


@pytest.fixture(scope="module")
def trig(dp):
    """The generated module's _sincos and _sincos_poly, vectorized over an array."""
    from numba import njit

    module = _module(dp, "main")[2]
    one, poly = module._sincos, module._sincos_poly

    @njit
    def both(a):
        s = np.empty(a.shape[0])
        c = np.empty(a.shape[0])
        sp = np.empty(a.shape[0])
        cp = np.empty(a.shape[0])
        for i in range(a.shape[0]):
            s[i], c[i] = one(a[i])
            sp[i], cp[i] = poly(a[i])
        return s, c, sp, cp

    return both


def test_the_parts_of_pi_over_2_are_exact():
    # Cody and Waite: the first two parts have 33 significant bits, so k * part is exact for
    # |k| < 2**20; the three add up to pi/2 within the third's rounding
    p1, p2, p3 = _codegen.PIO2_PARTS
    for part in (p1, p2):
        mantissa = math.frexp(part)[0] * 2.0 ** 53
        assert mantissa == int(mantissa) and int(mantissa) % 2 ** 20 == 0
    mpmath.mp.prec = 200
    rest = mpmath.pi / 2 - mpmath.mpf(p1) - mpmath.mpf(p2) - mpmath.mpf(p3)
    assert abs(rest) < 2.0 ** -120
    assert _codegen.SINCOS_BOUND * 2 / math.pi < 2 ** 20


def test_sincos_is_within_an_ulp_or_two_of_libm(trig):
    rng = np.random.default_rng(3)
    k = rng.integers(-60000, 60000, 20000)
    a = np.concatenate([
        rng.uniform(-4, 4, 50000), rng.uniform(-1e3, 1e3, 50000),
        rng.uniform(-_codegen.SINCOS_BOUND, _codegen.SINCOS_BOUND, 50000),
        k * (math.pi / 2) + rng.uniform(-1e-6, 1e-6, k.size),  # near the zeros of sin and cos
        k * (math.pi / 4),  # the ends of the reduced interval
        np.array([0.0, -0.0, 1e-300, -1e-300, 5e-324, 1e-8]),
    ])
    s, c, sp, cp = trig(a)
    for ours, ref in ((s, np.sin(a)), (c, np.cos(a))):
        # relative to the value, with an absolute floor at the argument's own rounding
        scale = np.maximum(np.abs(ref), ULP * np.maximum(np.abs(a), 1.0) / 2)
        assert np.max(np.abs(ours - ref) / scale) <= 2 * ULP
    assert np.array_equal(s, sp) and np.array_equal(c, cp)  # the polynomial throughout
    assert s[-6] == 0.0 and s[-5] == 0.0 and c[-6] == 1.0 and s[-2] == 5e-324  # exact at 0


def test_sincos_uses_libm_beyond_the_bound_and_for_inf_and_nan(trig):
    a = np.array([_codegen.SINCOS_BOUND * 1.5, -3e7, 1e300, math.inf, -math.inf, math.nan])
    s, c, _, _ = trig(a)
    assert np.array_equal(s[:3], np.sin(a[:3])) and np.array_equal(c[:3], np.cos(a[:3]))
    assert np.all(np.isnan(s[3:])) and np.all(np.isnan(c[3:]))


def test_each_distinct_angle_costs_one_sincos():
    # a chain's M and f hold sin and cos of q_i - q_j for every pair: the addition theorems
    # leave one (sin, cos) pair per coordinate
    for n in (2, 3, 6):
        eqs = lg.derive(lg.load(f"pendulum-chain-{n}"))
        src = _codegen.numba_source(eqs)
        body = src[src.index("def rhs("):src.index("def energy(")]
        assert body.count("_sincos(") == n and "math.sin(" not in body and "math.cos(" not in body


def forced_pendulum():
    """A pendulum on a cart driven by a time-dependent force: t, an input and parameters all
    enter the right-hand side."""
    return lg.derive(lg.load("cart-pendulum"))


def test_rhs_lanes_equals_rhs_at_random_states():
    from numba import njit

    eqs = forced_pendulum()
    cm = compile_numba(eqs)
    K = kernels()
    n, nu, npar = eqs.n, len(cm.input_names), len(cm.parameter_names)
    assert nu == 1

    @njit
    def lanes(rc, T, X, U, P, L):
        dx = np.empty(X.shape[0])
        work = np.empty(2 * L)
        r = K._rl(rc, K._ptr(T, 0), K._ptr(X, 0), K._ptr(U, 0), K._ptr(P, 0), K._ptr(dx, 0), K._ptr(work, 0), L)
        return dx, r

    rng = np.random.default_rng(5)
    for L in (5, 16):
        T = rng.uniform(0, 10, L)
        X = rng.uniform(-3, 3, (L, 2 * n))
        U = rng.uniform(-2, 2, (L, nu))
        P = cm.parameter_values * rng.uniform(0.5, 1.5, (L, npar))
        dx, r = lanes(cm.rhs_lanes_address(L), T, X.T.ravel().copy(), U.T.ravel().copy(), P.T.ravel().copy(), L)
        dx = dx.reshape(2 * n, L).T
        measures = []
        for k in range(L):
            one, measure = cm.solve(T[k], X[k], U[k], P[k])
            assert np.allclose(dx[k, n:], one, rtol=1e-13, atol=1e-13)
            assert np.array_equal(dx[k, :n], X[k, n:])
            measures.append(measure)
        assert r == pytest.approx(min(measures), rel=1e-12)


def runs(dp, B, seed, **kw):
    rng = np.random.default_rng(seed)
    X0 = np.zeros((B, 4))
    X0[:, :2] = rng.uniform(-2, 2, (B, 2))
    l2 = rng.uniform(0.5, 1.5, B)
    return X0, dict(params={"l2": l2}, dt=0.1, rtol=1e-9, atol=1e-9, progress=False, **kw)


def test_lanes_take_the_steps_each_run_takes_alone(dp):
    # 37 runs: two full blocks of 16 and one of 5; each run keeps its own steps
    X0, kw = runs(dp, 37, 11)
    alone = lg.simulate_batch(dp, 4.0, X0, lanes=1, **kw)
    together = lg.simulate_batch(dp, 4.0, X0, lanes=16, **kw)
    assert np.all(together.ok)
    assert np.array_equal(together.nfev, alone.nfev)
    # the same steps; the states differ by rounding only (rhs_lanes fuses multiply-adds), grown
    # by the chaotic motion to far below the tolerance
    assert np.max(np.abs(together.x - alone.x)) <= 1e-10


def test_lanes_with_inputs_of_time_and_parameters():
    eqs = forced_pendulum()
    rng = np.random.default_rng(2)
    B = 21
    X0 = np.zeros((B, 4))
    X0[:, 1] = rng.uniform(-1, 1, B)
    kw = dict(params={"M2": rng.uniform(0.3, 1, B)}, inputs={"F": "M2*sin(3*t)"}, dt=0.25, rtol=1e-9, atol=1e-9)
    alone = lg.simulate_batch(eqs, 3.0, X0, lanes=1, **kw)
    together = lg.simulate_batch(eqs, 3.0, X0, lanes=16, **kw)
    assert np.all(together.ok) and np.array_equal(together.nfev, alone.nfev)
    assert np.max(np.abs(together.x - alone.x)) <= 1e-12
    # the forcing matters: without it the runs differ
    free = lg.simulate_batch(eqs, 3.0, X0, lanes=16, **{**kw, "inputs": {"F": "0"}})
    assert np.max(np.abs(free.x - together.x)) > 1e-3


def test_a_block_with_a_huge_angle_is_run_one_by_one(dp):
    # an angle beyond the polynomial's range: the block is handed back and run alone with libm
    X0, kw = runs(dp, 20, 4)
    X0[3, 0] = 3e5 + 0.25
    alone = lg.simulate_batch(dp, 2.0, X0, lanes=1, **kw)
    together = lg.simulate_batch(dp, 2.0, X0, lanes=16, **kw)
    assert np.all(together.ok) and np.array_equal(together.nfev, alone.nfev)
    assert np.max(np.abs(together.x - alone.x)) <= 1e-12


def test_lanes_must_be_a_positive_integer(dp):
    for bad in (0, -3, 2.5, True, "8"):
        with pytest.raises(ModelError, match=f"lanes must be a positive integer, got {bad!r}"):
            lg.simulate_batch(dp, 1.0, np.zeros((2, 4)), lanes=bad)


def test_default_lanes_fit_the_cache_and_the_cores():
    import numba

    from lagrangian.numeric._batch import default_lanes

    cores = numba.get_num_threads()
    assert default_lanes(2, 10_000) == 64  # 16 stages of 4 x 64 numbers: 32 KiB
    assert default_lanes(4, 10_000) == 32
    assert default_lanes(6, 10_000) == 16
    assert default_lanes(2, 32 * cores) == 32  # a block for each core
    assert default_lanes(2, 15) == 1
