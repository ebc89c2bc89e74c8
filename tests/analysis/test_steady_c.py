"""The steady residual's loops in C (analysis._steady_c) against numba's (analysis._steady_kernel): the same
numbers bit for bit on random batches (singular, indefinite and non-finite points among them), the same
equilibria and steady motions by either, the search's workspace path equal to the whole path, and no numba
started by a constrained model's equilibria where a C compiler is present."""

import subprocess
import sys

import numpy as np
import pytest

import lagrangian as lg
from lagrangian.analysis import _constrained_steady as CS
from lagrangian.analysis import _steady_c as SC
from lagrangian.analysis._constrained_steady import steady_problem
from lagrangian.analysis._setting import resolve_setting

C = SC.kernels()
needs_c = pytest.mark.skipif(C is None, reason="no C compiler: the steady residual uses numba's kernels")


def _bits(a, b) -> bool:
    a, b = np.asarray(a), np.asarray(b)
    return a.shape == b.shape and a.dtype == b.dtype and a.tobytes() == b.tobytes()


@needs_c
@pytest.mark.parametrize("seed", range(4))
def test_each_kernel_equals_numbas_bit_for_bit(seed):
    K = pytest.importorskip("lagrangian.analysis._steady_kernel", reason="numba's kernels need numba")
    rng = np.random.default_rng(seed)
    singular = 0
    for trial in range(150):
        n = int(rng.integers(1, 9))
        m = int(rng.integers(0, n + 1))
        nu, npar = int(rng.integers(0, 3)), int(rng.integers(0, 5))
        ks = int(rng.integers(1, n + 1))
        shape = np.sort(rng.choice(n, ks, replace=False)).astype(np.int64)
        given = rng.choice(n, int(rng.integers(0, n + 1)), replace=False).astype(np.int64)
        values = rng.normal(size=len(given))
        q = rng.normal(size=n)
        h = 1e-5 * (1.0 + np.abs(q[shape]))
        u, p = rng.normal(size=nu), rng.normal(size=npar)
        rows = 2 * ks + 1
        A1 = np.full((rows, 1 + 2 * n + nu + npar), 7.0)
        A2 = A1.copy()
        K.points(A1, 0.3, u, p, q, shape, h, given, values)
        C.points(A2, 0.3, u, p, q, shape, h, given, values)
        assert _bits(A1, A2)
        free = rng.choice(n, int(rng.integers(0, n + 1)), replace=False).astype(np.int64)
        W = rng.normal(size=(rows, m * n + 2 * m))
        if trial % 5 == 0 and W.size:
            W[rng.integers(rows), rng.integers(W.shape[1])] = (np.nan, np.inf)[trial % 2]
        if trial % 7 == 0 and m:
            W[:, m * n + m:] = 0.0  # at rest: the free rates stay 0
        if trial % 3 == 0 and len(free) > 1 and m:
            W[:, free[0]] = 2 * W[:, free[-1]]  # rank-deficient columns: the cut-off decides
        bad1, bad2 = np.zeros(rows, np.bool_), np.zeros(rows, np.bool_)
        X1, X2 = A1.copy(), A1.copy()
        w1, w2 = K.free_rates(W, X1, free, n, m, bad1), C.free_rates(W, X2, free, n, m, bad2)
        assert _bits(w1, w2) and _bits(X1, X2) and _bits(bad1, bad2)
        P = rng.normal(size=(rows, n * n + n + m * n + m))
        for i in range(rows):
            B = rng.normal(size=(n, n))
            M = B @ B.T + (0.01 if trial % 4 else 1e-13) * np.eye(n)  # some nearly singular
            if trial % 11 == 0 and i == 1:
                M[0, 0] = -1.0  # not positive definite
            P[i, :n * n] = M.ravel()
        if trial % 13 == 0:
            P[0, -1] = np.nan
        held = np.sort(rng.choice(n, int(rng.integers(0, n + 1)), replace=False)).astype(np.int64)
        hol = np.arange(int(rng.integers(0, m + 1)), dtype=np.int64)
        g = W[:, m * n:m * n + m]  # a strided view, as the search passes it
        R1, R2 = np.empty((rows, len(held) + len(hol) + m)), np.empty((rows, len(held) + len(hol) + m))
        s1, s2 = np.empty(rows), np.empty(rows)
        K.steady_rows(P, w1, g, held, hol, n, m, 1e-12, bad1, R1, s1)
        C.steady_rows(P, w2, g, held, hol, n, m, 1e-12, bad2, R2, s2)
        assert _bits(R1, R2) and _bits(s1, s2) and _bits(bad1, bad2)
        singular += int(bad1.sum())
        Ws = W[:, :m * n].reshape(rows, m, n)
        R = np.where(np.isfinite(R1), R1, 0.5) if trial % 2 else R1
        J1, J2 = np.zeros((R1.shape[1], ks)), np.zeros((R1.shape[1], ks))
        assert (K.central_jacobian(R, X1, Ws, s1, q, h, n, len(held), len(hol), J1)
                == C.central_jacobian(R, X1, Ws, s1, q, h, n, len(held), len(hol), J2))
        assert _bits(J1, J2)
        floor = np.abs(rng.normal(size=R1.shape[1]))
        K.differences(R, h, floor, J1)
        C.differences(R, h, floor, J2)
        assert _bits(J1, J2)
    assert singular > 0  # the singular and non-finite ways were taken


def _evaluator(eqs, given):
    setting = resolve_setting(eqs, None, None, 0.0)
    return steady_problem(eqs, setting, given).evaluator, setting


@needs_c
def test_the_searchs_workspace_path_equals_the_whole_path():
    """SteadyState.__call__ through the Workspace (arrays allocated once) gives the whole path's r and dr/dz
    bit for bit, at random shapes, at rest and rolling; a point where the batch is not finite takes the whole
    path there (the same answer as an evaluator without the workspace)."""
    eqs = lg.derive(lg.load("rolling-disk"))
    names = [c.name for c in eqs.coordinates]
    rng = np.random.default_rng(2)
    for given in ({}, {names.index("psi"): 2.0, names.index("theta"): 20.0}):
        ev, setting = _evaluator(eqs, given)
        plain, _ = _evaluator(eqs, given)
        plain._new_workspace = lambda u, p: None  # the whole path at every call
        qs = [rng.uniform(-1.5, 1.5, eqs.n) for _ in range(15)]
        qs.append(np.full(eqs.n, np.pi / 2))  # the disk flat on the ground: singular
        for q in qs:
            r, J = ev(setting, q)
            r0, J0 = plain(setting, q)
            assert _bits(r, r0) and _bits(J, J0)
        assert ev._workspace and plain._workspace is False


def test_without_a_compiler_the_steady_residual_uses_numbas_kernels(monkeypatch):
    monkeypatch.setattr("lagrangian.numeric._cbackend.c_compiler", lambda: None)
    assert SC._library() is None
    monkeypatch.setattr(SC, "kernels", lambda: None)
    K = CS.steady_kernels()
    assert K.__name__ == "lagrangian.analysis._steady_kernel"


def test_a_compiler_that_fails_leaves_no_library(monkeypatch, tmp_path):
    monkeypatch.setenv("LAGRANGIAN_CACHE_DIR", str(tmp_path))
    monkeypatch.setattr("lagrangian.numeric._cbackend.c_compiler", lambda: "false")
    assert SC._library() is None
    assert not list(tmp_path.glob("*.so"))


@needs_c
def test_a_broken_library_in_the_cache_is_removed_and_built_again(monkeypatch, tmp_path):
    monkeypatch.setenv("LAGRANGIAN_CACHE_DIR", str(tmp_path / "first"))
    assert SC._library() is not None
    (built,) = (tmp_path / "first").glob("lagrangian_steady_*.so")
    broken = tmp_path / "second" / built.name  # a path this process has not loaded
    broken.parent.mkdir()
    broken.write_bytes(b"not a library")
    monkeypatch.setenv("LAGRANGIAN_CACHE_DIR", str(broken.parent))
    assert SC._library() is None and not broken.exists()  # removed, never reused
    assert SC._library() is not None and broken.exists()


@needs_c
@pytest.mark.parametrize("model", ["rolling-disk"])
def test_the_equilibria_and_steady_motions_are_the_same_with_numbas_kernels(model, monkeypatch):
    pytest.importorskip("numba", reason="numba's kernels need numba")
    eqs = lg.derive(lg.load(model))
    names = [c.name for c in eqs.coordinates]
    with_c = (lg.equilibria(eqs).text(), lg.steady_motions(eqs, velocities={"theta_dot": 20.0}).text())
    assert names  # a model with coordinates
    from lagrangian.analysis import _steady_kernel

    monkeypatch.setattr(CS, "steady_kernels", lambda: _steady_kernel)
    with_numba = (lg.equilibria(lg.derive(lg.load(model))).text(),
                  lg.steady_motions(lg.derive(lg.load(model)), velocities={"theta_dot": 20.0}).text())
    assert with_c == with_numba


@needs_c
def test_a_constrained_models_equilibria_start_no_numba():
    code = ("import sys, lagrangian as lg\n"
            "eqs = lg.derive(lg.load('rolling-disk'))\n"
            "found = lg.equilibria(eqs)\n"
            "assert len(found) > 0, found\n"
            "print('numba' in sys.modules)\n")
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, check=True)
    assert out.stdout.strip() == "False"


@needs_c
def test_a_library_others_can_write_is_not_loaded(monkeypatch, tmp_path):
    folder = tmp_path / "cache"
    monkeypatch.setenv("LAGRANGIAN_CACHE_DIR", str(folder))
    assert SC._library() is not None
    (built,) = folder.glob("lagrangian_steady_*.so")
    other = tmp_path / "other"
    other.mkdir()
    (other / built.name).write_bytes(built.read_bytes())
    (other / built.name).chmod(0o666)  # writable by anyone: machine code not to run
    monkeypatch.setenv("LAGRANGIAN_CACHE_DIR", str(other))
    assert SC._library() is None


@needs_c
def test_the_workspace_follows_the_setting():
    """One evaluator asked at two parameter settings in turn: each answer the whole path's at its setting."""
    eqs = lg.derive(lg.load("rolling-disk"))
    ev, earth = _evaluator(eqs, {})
    moon = resolve_setting(eqs, {"g": 1.62, "r": 0.5}, None, 0.0)
    plain, _ = _evaluator(eqs, {})
    plain._new_workspace = lambda u, p: None
    rng = np.random.default_rng(4)
    for k in range(12):
        setting = (earth, moon)[k % 2]
        q = rng.uniform(-1.2, 1.2, eqs.n)
        r, J = ev(setting, q)
        r0, J0 = plain(setting, q)
        assert _bits(r, r0) and _bits(J, J0)
    assert ev._workspace
