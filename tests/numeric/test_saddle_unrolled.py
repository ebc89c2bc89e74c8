"""The saddle-point template written out (n, m <= UNROLL_MAX: constant indices, the dot products
summed pairwise, one helper per size) against its loop form and a dense solve of the KKT system.
The generated Python is run as plain Python (no numba): the same text numba compiles."""

from __future__ import annotations

import math

import numpy as np
import pytest

from lagrangian.numeric import _codegen_constrained as cc


def _consts(n: int, m: int) -> dict:
    return {"N": n, "M": m, "MH": 0, **{k: v for k, v in cc.layout(n, m).items() if k != "size"},
            "SINGULAR_RATIO": cc.SINGULAR_RATIO, "PROJECTION_STEPS": cc.PROJECTION_STEPS,
            "PROJECTION_TOL": cc.PROJECTION_TOL, "NEWTON_EXIT": cc.NEWTON_EXIT, "MET": cc.MET,
            "SINGULAR": cc.SINGULAR, "NOT_FINITE": cc.NOT_FINITE}


def _helpers(n: int, m: int, unroll: bool, split: bool = False, zeros=None) -> tuple[dict, str]:
    consts = _consts(n, m)
    e = cc._Emit("py", consts, unroll=unroll, zeros=zeros)
    cc._algorithm(e, 0, split=split)
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


def _split_solve(space: dict, work: np.ndarray) -> float:
    """What numba's rhs does where f and c need many statements (constrained_main): lg_ldl and
    lg_range after M and G, lg_solve after f and c."""
    r = space["lg_ldl"](work)
    if r <= cc.SINGULAR_RATIO:
        return r
    rho = space["lg_range"](work)
    return space["lg_solve"](work, min(r, rho))


@pytest.mark.parametrize("unroll", [False, True])
def test_the_split_solve_gives_lg_saddles_numbers_and_decisions_bit_for_bit(unroll):
    n, m = 8, 5
    rng = np.random.default_rng(20)
    space, text = _helpers(n, m, unroll, split=True)
    assert "def lg_range(" in text and "def lg_solve(" in text
    A = rng.normal(size=(n, n))
    M, f, G, c = A @ A.T + n * np.eye(n), rng.normal(size=n), rng.normal(size=(m, n)), rng.normal(size=m)
    dependent = G.copy()
    dependent[4] = 2.0 * G[0] - G[3]  # a dead point: the QR's measure falls
    singular = M.copy()
    singular[5, :] = singular[:, 5] = 0.0  # M not positive definite: the LDL^T's measure is 0
    cases = {"regular": (M, f, G, c), "dependent": (M, f, dependent, c), "singular M": (singular, f, G, c),
             "f not finite": (M, np.r_[f[:7], np.inf], G, c), "G not finite": (M, f, np.where(G > 1.5, np.nan, G), c),
             "c not finite": (M, f, G, np.r_[c[:4], np.nan]), "dependent, f not finite": (M, np.r_[np.inf, f[1:]],
                                                                                           dependent, c)}
    expected = {"regular": "r", "dependent": "S", "singular M": 0.0, "f not finite": -1.0, "G not finite": -1.0,
                "c not finite": -1.0, "dependent, f not finite": -1.0}
    for name, parts in cases.items():
        at = cc.layout(n, m)
        with np.errstate(invalid="ignore", over="ignore"):
            one, _ = _work(n, m, *parts)
            r_one = space["lg_saddle"](one)
            two, _ = _work(n, m, *parts)
            r_two = _split_solve(space, two)
        assert r_two == r_one, name
        if expected[name] == "r":
            assert 0.0 < r_one <= 1.0
            for part in ("A0", "L0"):  # q_ddot and lambda: the same operations in the same order
                size = n if part == "A0" else m
                assert np.array_equal(two[at[part]:at[part] + size], one[at[part]:at[part] + size]), name
        elif expected[name] == "S":
            assert 0.0 <= r_one <= cc.SINGULAR_RATIO, name
        else:
            assert r_one == expected[name], name


# the Whipple bicycle's patterns of M and G (n = 8, m = 5: 46 of 64 and 25 of 40 entries not 0)
_BIKE_M = ["10111010", "01111010", "11111111", "11111011", "11111111", "00101100", "11111010", "00111001"]
_BIKE_G = ["10111100", "01111100", "00011010", "10111011", "01111011"]


def _sparse_parts(rng, Mnz, Gnz):
    n, m = len(Mnz), len(Gnz)
    A = np.where(Mnz, rng.normal(size=(n, n)), 0.0)
    M = np.tril(A, -1) + np.tril(A, -1).T
    M += np.diag(np.sum(np.abs(M), axis=1) + 1.0 + rng.uniform(size=n))  # positive definite, M's pattern
    return M, rng.normal(size=n), np.where(Gnz, rng.normal(size=(m, n)), 0.0), rng.normal(size=m)


def test_the_structural_zeros_are_left_out_and_the_solve_is_the_same():
    """M's and G's structural zeros (_structure): L's fill-in, Z = L^-1 G^T's, the QR's. The written-out
    solve leaves their products out (fewer terms in the text) and gives the loop form's q_ddot, lambda
    and measure, and the KKT system's solution; with a dependent row, the same decision."""
    Mnz = np.array([[c == "1" for c in row] for row in _BIKE_M])
    Gnz = np.array([[c == "1" for c in row] for row in _BIKE_G])
    n, m = Gnz.shape[1], Gnz.shape[0]
    zeros = cc.structural_zeros(Mnz, Gnz, [2], {**_consts(n, m), "MH": 1})
    at = cc.layout(n, m)
    L_zeros = {k for k in zeros[m] if k < n * n}
    assert len(L_zeros) == 28 - 23 and len(zeros[m] & set(range(at["G0"], at["C0"]))) == 40 - 25
    assert set(zeros[1]) >= L_zeros and len(zeros[1]) == 5 + 15 + 5  # the holonomic row's QR: 3 of 8 not 0
    full, text_full = _helpers(n, m, True)
    sparse, text = _helpers(n, m, True, zeros=zeros)
    assert text.count(" * ") <= text_full.count(" * ") - 90  # 774 -> 678 multiplications written
    loop, _ = _helpers(n, m, False)
    rng = np.random.default_rng(5)
    for _ in range(5):
        M, f, G, c = _sparse_parts(rng, Mnz, Gnz)
        results = {}
        for name, space in (("sparse", sparse), ("full", full), ("loop", loop)):
            work, _ = _work(n, m, M, f, G, c)
            r = space["lg_saddle"](work)
            results[name] = r, work[at["A0"]:at["A0"] + n].copy(), work[at["L0"]:at["L0"] + m].copy()
        r0, a0, l0 = results["loop"]
        for name in ("sparse", "full"):
            r, a, lam = results[name]
            assert 0.0 < r <= 1.0 and r == pytest.approx(r0, rel=1e-12), name
            np.testing.assert_allclose(a, a0, rtol=0, atol=1e-12 * np.max(np.abs(a0)), err_msg=name)
            np.testing.assert_allclose(lam, l0, rtol=0, atol=1e-12 * np.max(np.abs(l0)), err_msg=name)
        kkt = np.block([[M, G.T], [G, np.zeros((m, m))]])
        sol = np.linalg.solve(kkt, np.concatenate([f, c]))
        np.testing.assert_allclose(results["sparse"][1], sol[:n], rtol=0, atol=1e-10 * np.max(np.abs(sol[:n])))
        np.testing.assert_allclose(results["sparse"][2], -sol[n:], rtol=0, atol=1e-10 * np.max(np.abs(sol[n:])))
    # a dead point inside the patterns: row 4 equal to row 1 (values 0 where one pattern allows more)
    G[1, 5] = 0.0
    G[4] = G[1]
    for space in (sparse, full, loop):
        assert space["lg_saddle"](_work(n, m, M, f, G, c)[0]) <= cc.SINGULAR_RATIO
