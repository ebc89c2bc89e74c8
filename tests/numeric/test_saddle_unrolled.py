"""The saddle-point template written out (n, m <= UNROLL_MAX: constant indices, the dot products
summed pairwise, one helper per size) against its loop form and a dense solve of the KKT system.
The generated Python is run as plain Python (no numba): the same text numba compiles."""

from __future__ import annotations

import math

import numpy as np
import pytest

from lagrangian.numeric import _codegen_constrained as cc


def _helpers(n: int, m: int, unroll: bool) -> tuple[dict, str]:
    consts = {"N": n, "M": m, "MH": 0, **{k: v for k, v in cc.layout(n, m).items() if k != "size"},
              "SINGULAR_RATIO": cc.SINGULAR_RATIO, "PROJECTION_STEPS": cc.PROJECTION_STEPS,
              "PROJECTION_TOL": cc.PROJECTION_TOL, "NEWTON_EXIT": cc.NEWTON_EXIT, "MET": cc.MET,
              "SINGULAR": cc.SINGULAR, "NOT_FINITE": cc.NOT_FINITE}
    e = cc._Emit("py", consts, unroll=unroll)
    cc._algorithm(e, 0)
    text = "\n".join(e.lines)
    space = {"math": math, "njit": lambda **kw: (lambda f: f)}
    exec(compile(text, "<template>", "exec"), space)  # noqa: S102 (the template's own text)
    return space, text


def _work(n, m, M, f, G, c):
    at = cc.layout(n, m)
    work = np.full(at["size"], np.nan)
    for i in range(n):
        for j in range(i + 1):
            work[i * n + j] = M[i, j]
    work[at["F0"]:at["F0"] + n] = f
    work[at["G0"]:at["G0"] + m * n] = G.ravel()
    work[at["C0"]:at["C0"] + m] = c
    return work, at


@pytest.mark.parametrize(("n", "m"), [(8, 5), (3, 2), (12, 12 - 1), (1, 1)])
def test_the_written_out_solve_is_the_loop_solve_and_the_kkt_solution(n, m):
    rng = np.random.default_rng(n * 100 + m)
    A = rng.normal(size=(n, n))
    M = A @ A.T + n * np.eye(n)
    f, G, c = rng.normal(size=n), rng.normal(size=(m, n)), rng.normal(size=m)
    kkt = np.block([[M, G.T], [G, np.zeros((m, m))]])
    sol = np.linalg.solve(kkt, np.concatenate([f, c]))
    qdd, lam = sol[:n], -sol[n:]
    out = {}
    for unroll in (False, True):
        space, text = _helpers(n, m, unroll)
        work, at = _work(n, m, M, f, G, c)
        r = space["lg_saddle"](work)
        out[unroll] = r, work[at["A0"]:at["A0"] + n].copy(), work[at["L0"]:at["L0"] + m].copy()
        loops = text.split("def lg_saddle")[1].split("def ")[0].count("for ")
        assert loops == 1 if unroll else loops > 1  # written out: only the test of f, G, c (finite) loops
    (r0, a0, l0), (r1, a1, l1) = out[False], out[True]
    assert 0.0 < r1 <= 1.0 and r1 == pytest.approx(r0, rel=1e-12)
    np.testing.assert_allclose(a1, a0, rtol=0, atol=1e-12 * np.max(np.abs(a0)))
    np.testing.assert_allclose(l1, l0, rtol=0, atol=1e-12 * np.max(np.abs(l0)))
    np.testing.assert_allclose(a1, qdd, rtol=0, atol=1e-10 * np.max(np.abs(qdd)))
    np.testing.assert_allclose(l1, lam, rtol=0, atol=1e-10 * np.max(np.abs(lam)))


def test_the_written_out_solve_decides_dependent_constraints_and_non_finite_parts_as_the_loop():
    n, m = 6, 3
    rng = np.random.default_rng(7)
    A = rng.normal(size=(n, n))
    M, f, c = A @ A.T + n * np.eye(n), rng.normal(size=n), rng.normal(size=m)
    G = rng.normal(size=(m, n))
    G[2] = 2.0 * G[0] - G[1]  # dependent: a dead point
    bad_f = f.copy()
    bad_f[4] = np.inf
    for unroll in (False, True):
        space, _ = _helpers(n, m, unroll)
        assert space["lg_saddle"](_work(n, m, M, f, G, c)[0]) <= cc.SINGULAR_RATIO
        with np.errstate(invalid="ignore"):  # inf * 0.0 (numba's error_model="numpy" does not warn)
            assert space["lg_saddle"](_work(n, m, M, bad_f, rng.normal(size=(m, n)), c)[0]) == -1.0


def test_a_helper_is_written_once_per_size_it_is_called_with():
    _, text = _helpers(8, 5, True)
    assert text.count("def lg_qr(") == 1 and "def lg_qr_" not in text  # MH = 0: no projection of q
    assert "work[b + 3]" in text and "range(" not in text.split("def lg_qr(")[1].split("\ndef ")[0]
