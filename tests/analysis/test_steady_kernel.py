"""The compiled steady-state residual (analysis._steady_kernel) against the single-point NumPy path it
replaces in the search: the residual rows equal ``SteadyState.values`` (the saddle-point solve of
numeric._constrained, LAPACK) at random points, the Jacobian equals central differences of those
rows, and its pieces (Jacobi SVD least squares, Householder QR, Cholesky) equal NumPy's."""

import numpy as np
import pytest

import lagrangian as lg
from lagrangian.analysis import _steady_kernel as K
from lagrangian.analysis._constrained_steady import steady_problem
from lagrangian.analysis._setting import resolve_setting


def _evaluator(eqs, given):
    setting = resolve_setting(eqs, None, None, 0.0)
    return steady_problem(eqs, setting, given).evaluator, setting


def _check_against_values(ev, setting, n, seed, points=12):
    rng = np.random.default_rng(seed)
    checked = 0
    for _ in range(points):
        q = rng.uniform(-1.5, 1.5, n)
        r, J = ev(setting, q)
        want = ev.values(setting, q)[3]
        if not np.all(np.isfinite(want)):
            assert not np.all(np.isfinite(r))
            continue
        scale = 1.0 + np.abs(want).max()
        assert np.allclose(r, want, rtol=0, atol=1e-11 * scale)
        # the Jacobian: central differences of the single-point rows, with the kernel's steps
        z = q[ev.shape]
        h = 1e-5 * (1.0 + np.abs(z))
        for j, i in enumerate(ev.shape):
            up, down = q.copy(), q.copy()
            up[i] += h[j]
            down[i] -= h[j]
            col = (ev.values(setting, up)[3] - ev.values(setting, down)[3]) / (2 * h[j])
            assert np.allclose(J[:, j], col, rtol=0, atol=1e-7 * (1.0 + np.abs(col).max()))
        checked += 1
    assert checked >= points // 2


def test_the_rolling_coins_compiled_residual_equals_the_numpy_saddle_point_solve():
    eqs = lg.derive(lg.load("rolling-disk"))
    names = [c.name for c in eqs.coordinates]
    for given in ({}, {names.index("psi"): 2.0, names.index("theta"): 20.0}, {names.index("theta"): 5.0}):
        ev, setting = _evaluator(eqs, given)
        _check_against_values(ev, setting, eqs.n, seed=len(given))


@pytest.mark.slow
def test_the_bicycles_compiled_residual_equals_the_numpy_saddle_point_solve():
    eqs = lg.derive(lg.load("whipple-bicycle"))
    names = [c.name for c in eqs.coordinates]
    for given in ({}, {names.index("thetaR"): 5 / 0.3}, {names.index("thetaR"): 5 / 0.3, names.index("psi"): 0.5}):
        ev, setting = _evaluator(eqs, given)
        _check_against_values(ev, setting, eqs.n, seed=3 + len(given), points=8)


@pytest.mark.parametrize("shape, rank", [((5, 5), 5), ((5, 4), 4), ((3, 5), 3), ((5, 5), 3), ((4, 3), 1)])
def test_the_free_rates_are_numpys_least_squares_with_the_same_cut_off(shape, rank):
    rng = np.random.default_rng(sum(shape) + rank)
    m, nf = shape
    n = nf + 2
    free = np.arange(1, nf + 1, dtype=np.int64)
    W = np.zeros((m, n))
    W[:, free] = rng.standard_normal((m, rank)) @ rng.standard_normal((rank, nf))
    W[:, 0] = rng.standard_normal(m)
    g, w = rng.standard_normal(m), rng.standard_normal(m)
    C = np.concatenate((W.ravel(), g, w))[None, :]
    X = np.zeros((1, 1 + 2 * n))
    bad = np.zeros(1, dtype=np.bool_)
    w_after = K.free_rates(C, X, free, n, m, bad)
    want = np.linalg.pinv(W[:, free], rcond=1e-10 * np.abs(W).max() / np.linalg.norm(W[:, free], 2)) @ -w
    assert not bad[0]
    assert np.allclose(X[0, 1 + n + free], want, rtol=0, atol=1e-12 * (1 + np.abs(want).max()))
    assert np.allclose(w_after[0], w + W[:, free] @ want, atol=1e-12)


def test_a_row_that_is_not_finite_is_bad_and_its_rates_stay_zero():
    n, m = 3, 2
    C = np.ones((1, m * n + 2 * m))
    C[0, 1] = np.nan
    X = np.zeros((1, 1 + 2 * n))
    bad = np.zeros(1, dtype=np.bool_)
    K.free_rates(C, X, np.array([1, 2], dtype=np.int64), n, m, bad)
    assert bad[0] and np.all(X == 0.0)


def test_the_factorizations_equal_numpys():
    rng = np.random.default_rng(5)
    n, m = 8, 5
    A = rng.standard_normal((n, n))
    M = A @ A.T + n * np.eye(n)
    L = np.zeros((n, n))
    assert K._cholesky(M, L)
    assert np.allclose(L, np.linalg.cholesky(M), atol=1e-13)
    assert not K._cholesky(-M, np.zeros((n, n)))
    B = rng.standard_normal((n, m))
    Q, R = np.empty((n, m)), np.empty((m, m))
    K._householder_qr(B, Q, R, np.empty((n, m)), np.empty((n, m)), np.empty(m))
    assert np.allclose(Q @ R, B, atol=1e-13) and np.allclose(Q.T @ Q, np.eye(m), atol=1e-13)
    assert np.allclose(np.abs(np.diag(R)), np.abs(np.diag(np.linalg.qr(B)[1])), atol=1e-13)
    assert np.allclose(np.triu(R), R)


def test_the_batch_evaluated_point_by_point_is_the_call_of_the_compiled_functions():
    """SteadyState._batch: after its first call, SymEngine's unsafe_eval into a buffer, the same numbers
    bit for bit as calling the function on the batch (the residual and its Jacobian at random shapes);
    a batch of another width goes to the call again (which refuses it)."""
    eqs = lg.derive(lg.load("rolling-disk"))
    ev, setting = _evaluator(eqs, {})
    rng = np.random.default_rng(5)
    points = []
    for _ in range(20):
        q = np.zeros(eqs.n)
        q[ev.shape] = rng.uniform(-1.5, 1.5, len(ev.shape))
        points.append(q)
    fast = [ev(setting, q) for q in points]
    assert len(ev._sizes) == 2  # the constraints' and the saddle-point parts' functions
    plain = _evaluator(lg.derive(lg.load("rolling-disk")), {})[0]
    plain._batch = lambda fun, A: np.asarray(fun(A), float).reshape(len(A), -1)
    for q, (r, J) in zip(points, fast):
        r0, J0 = plain(setting, q)
        assert np.array_equal(r, r0, equal_nan=True) and np.array_equal(J, J0, equal_nan=True)
    A = rng.uniform(-1, 1, (3, 1 + 2 * eqs.n + len(eqs.inputs) + len(eqs.parameters)))
    f = ev.cm._parts
    assert np.array_equal(ev._batch(f, A), np.asarray(f(A), float).reshape(3, -1))
    wider = np.hstack((A, A))  # not a point a row: refused by the call, never read past by unsafe_eval
    with pytest.raises(ValueError, match="len\\(args\\)"):
        ev._batch(f, wider)
