"""The one root search (lagrangian/equations/_search.py): its parts on problems with known answers,
and that the four searches (equilibria, det M, the constraint Jacobian's rank, the consistent state)
use it and no angle-wrapping helper of their own."""

from __future__ import annotations

import ast
import math
from pathlib import Path

import numpy as np
import pytest
import sympy

from lagrangian.equations import _search as search

SOURCE = Path(__file__).resolve().parents[2] / "src" / "lagrangian"


# ----------------------------------------------------------------------------- angles
def test_wrap_angles_into_the_half_open_interval_with_round_off_as_zero():
    q = search.wrap_angles([3 * math.pi / 2, -math.pi, 7.0, 1e-17, 2.5], [True, True, False, True, True])
    assert q[0] == pytest.approx(-math.pi / 2, abs=1e-15)
    assert q[1] == math.pi  # -pi is given as pi: (-pi, pi]
    assert q[2] == 7.0  # not an angle: kept
    assert q[3] == 0.0  # cos(pi/2)'s round-off is an exact zero
    assert q[4] == 2.5
    assert search.wrap_angles([math.inf], [True])[0] == math.inf  # not finite: left for the caller to refuse


def test_wrap_angle_keeps_exact_numbers_exact():
    assert search.wrap_angle(3 * sympy.pi / 2) == -sympy.pi / 2
    assert search.wrap_angle(-sympy.pi) == sympy.pi
    assert search.wrap_angle(sympy.Rational(1, 2)) == sympy.Rational(1, 2)
    x = sympy.Symbol("x")
    assert search.wrap_angle(x) == x
    assert search.wrap_angle(-3 * math.pi / 2) == pytest.approx(math.pi / 2, abs=1e-15)


def test_same_point_modulo_a_turn_in_angles_only():
    angles = [True, False]
    assert search.same_point(np.array([math.pi - 1e-9, 1.0]), np.array([-math.pi + 1e-9, 1.0]), angles)
    assert not search.same_point(np.array([1.0, 0.0]), np.array([1.0, 2 * math.pi]), angles)
    assert search.same_point(np.array([0.0, 1.0]), np.array([0.0, 1.0 + 5e-7]), angles)
    assert not search.same_point(np.array([0.0, 1.0]), np.array([0.0, 1.0 + 5e-6]), angles)
    d = search.angle_difference([0.1, 3.0], [2 * math.pi - 0.1, 1.0], angles)
    assert d == pytest.approx([0.2, 2.0], abs=1e-15)
    kept = search.distinct([[0.5, 1.0], [0.5 + 2 * math.pi, 1.0], [-0.5, 1.0]], angles)
    assert len(kept) == 2 and kept[0] == pytest.approx([0.5, 1.0], abs=1e-15)


# ----------------------------------------------------------------------------- solves
def _circle_and_line(z):
    """x^2 + y^2 = 1 and y = x / 2: the roots +-(2, 1)/sqrt(5)."""
    x, y = z
    return np.array([x * x + y * y - 1.0, y - x / 2]), np.array([[2 * x, 2 * y], [-0.5, 1.0]])


def test_newton_finds_the_root_of_a_square_system_and_the_least_squares_point_of_an_overdetermined_one():
    z = search.newton(_circle_and_line, [1.0, 0.3], 2)
    assert z == pytest.approx([2 / math.sqrt(5), 1 / math.sqrt(5)], abs=1e-14)

    def three_rows(z):  # the same two rows and a third that holds at the root as well
        r, J = _circle_and_line(z)
        return np.append(r, z[0] - 2 * z[1]), np.vstack((J, [1.0, -2.0]))

    z = search.newton(three_rows, [1.0, 0.3], 3)
    assert z == pytest.approx([2 / math.sqrt(5), 1 / math.sqrt(5)], abs=1e-12)

    def one_row(z):  # one row in two unknowns (zero rows added): a point of the circle
        r, J = _circle_and_line(z)
        return r[:1], J[:1]

    z = search.newton(one_row, [1.0, 1.0], 1)
    assert z[0] ** 2 + z[1] ** 2 == pytest.approx(1.0, abs=1e-12)


def test_least_squares_reaches_a_singular_root_to_round_off():
    def double_root(z):  # (x - 1)^2 = 0: dr/dx vanishes at the root, Newton converges linearly
        return np.array([(z[0] - 1.0) ** 2]), np.array([[2 * (z[0] - 1.0)]])

    z = search.least_squares(double_root, [3.0], 1)
    assert abs(z[0] - 1.0) < 1e-7  # |r| at round-off: (x - 1)^2 <= 1e-15


def test_gauss_newton_holds_the_coordinates_it_is_not_given_and_takes_the_smallest_step():
    def circle(z):
        return np.array([z[0] ** 2 + z[1] ** 2 - 1.0]), np.array([[2 * z[1]]])  # column of y only

    z, ok = search.gauss_newton(circle, [0.6, 0.5], [1], iterations=50, small=1e-15, polish=3, step_tol=1e-16)
    assert ok and z[0] == 0.6 and z[1] == pytest.approx(0.8, abs=1e-15)

    def both(z):
        return np.array([z[0] ** 2 + z[1] ** 2 - 1.0]), np.array([[2 * z[0], 2 * z[1]]])

    z, ok = search.gauss_newton(both, [3.0, 4.0], iterations=50, small=1e-15, polish=2)
    assert ok and z == pytest.approx([0.6, 0.8], abs=1e-15)  # along the gradient: the nearest point

    # a flat start (the gradient 0 at the centre) is nudged off; without a nudge it stops, not converged
    z, ok = search.gauss_newton(both, [0.0, 0.0], iterations=60, small=1e-14, nudge=1e-3)
    assert ok and math.hypot(*z) == pytest.approx(1.0, abs=1e-14)
    z, ok = search.gauss_newton(both, [0.0, 0.0], iterations=60, small=1e-14)
    assert not ok and list(z) == [0.0, 0.0]
    # steps of at most max_step: from far away it walks
    z, ok = search.gauss_newton(both, [100.0, 0.0], iterations=3, small=1e-14, max_step=1.0)
    assert not ok and z[0] == pytest.approx(97.0, abs=1e-12)


def test_multistart_keeps_each_root_once_modulo_a_turn():
    def solve(start):  # sin(th) = 0 from each start: the nearest multiple of pi, unwrapped
        th = round(start[0] / math.pi) * math.pi
        return np.array([th]) if abs(th - start[0]) < 1.2 else None

    starts = [[0.1], [3.0], [2 * math.pi + 0.2], [-3.2], [9.9], [1.6]]
    found = search.multistart(solve, starts, [True])
    assert len(found) == 2  # 0 and pi (2 pi is 0, -pi is pi); the start 1.6 finds none
    assert search.multistart(solve, starts, first=True) == [np.array([0.0])]
    assert len(search.multistart(solve, starts)) == 5  # without angles every root is kept


def test_multistart_solves_a_repeated_start_that_gave_a_root_once():
    """With angles, a start equal to an earlier one that gave a root is not solved again (its root would
    be dropped as the same point); one that gave none is (the caller may count its failures); without
    angles, where every root is kept, every start is solved."""
    calls = []

    def solve(start):
        calls.append(float(start[0]))
        th = round(start[0] / math.pi) * math.pi
        return np.array([th]) if abs(th - start[0]) < 1.2 else None

    starts = [[0.1], [1.6], [0.1], [3.0], [1.6], [0.1], [3.0]]
    found = search.multistart(solve, starts, [True])
    assert [float(z[0]) for z in found] == [0.0, math.pi]
    assert calls == [0.1, 1.6, 3.0, 1.6]
    calls.clear()
    assert len(search.multistart(solve, starts)) == 5
    assert len(calls) == 7


def test_minimize_drives_a_measure_to_zero():
    x, value = search.minimize(lambda x: float((x[0] - 0.25) ** 2), [1.0], method="Nelder-Mead",
                               options={"xatol": 1e-12, "fatol": 1e-30})
    assert x[0] == pytest.approx(0.25, abs=1e-10) and value < 1e-20


# ----------------------------------------------------------------------------- one module for four searches
USERS = {
    "analysis/_roots.py": {"newton", "gauss_newton", "multistart", "wrap_angles", "same_point", "angle_difference"},
    "equations/_singular.py": {"minimize", "multistart", "wrap_angle", "wrap_angles"},
    "equations/_constraint_singular.py": {"least_squares", "gauss_newton", "distinct", "wrap_angles",
                                          "angle_difference"},
    "numeric/_constrained.py": {"gauss_newton"},
}


@pytest.mark.parametrize("path", sorted(USERS))
def test_each_search_uses_the_one_module_and_wraps_no_angle_of_its_own(path):
    source = (SOURCE / path).read_text()
    tree = ast.parse(source)
    imported = {alias.name for node in ast.walk(tree) if isinstance(node, ast.ImportFrom)
                and (node.module or "").endswith("_search") for alias in node.names}
    assert USERS[path] <= imported
    calls = {node.func.attr for node in ast.walk(tree) if isinstance(node, ast.Call)
             and isinstance(node.func, ast.Attribute)}
    assert "remainder" not in calls  # math.remainder(x, 2 pi): the angle rule is search.angle_difference
    assert "% (2 * np.pi)" not in source and "scipy.optimize" not in source and "from scipy.optimize" not in source
    defined = {node.name for node in ast.walk(tree) if isinstance(node, ast.FunctionDef)}
    assert not defined & {"_wrap", "wrap_angles", "same_point", "_distinct"}


@pytest.mark.parametrize("seed", range(6))
def test_least_squares_by_leastsq_is_least_squares_iterate_for_iterate(seed, monkeypatch):
    """Where SciPy's least_squares(method="lm") calls MINPACK with diag=None (SciPy >= 1.16), the search calls it
    through leastsq: the same answer bit for bit (a system with more rows than unknowns, one with fewer, padded,
    and one singular at its root), and None where least_squares raises (a start or its residuals not finite)."""
    from lagrangian.equations import _search

    if not _search._lm_diag_none():
        pytest.skip("SciPy before 1.16: least_squares scales by diag=1, and is called itself")
    rng = np.random.default_rng(seed)
    A = rng.normal(size=(5, 3))

    def over(z):  # 5 rows, 3 unknowns, nonlinear
        return np.tanh(A @ z) + 0.1 * z.sum() ** 2 - 0.3, (1 - np.tanh(A @ z) ** 2)[:, None] * A + 0.2 * z.sum()

    def under(z):  # 2 rows, 3 unknowns: padded
        return np.array([z[0] ** 2 + z[1] - 1.0, np.sin(z[2]) * z[0]]), np.array(
            [[2 * z[0], 1.0, 0.0], [np.sin(z[2]), 0.0, z[0] * np.cos(z[2])]])

    def singular(z):  # (z0 - 1)^2 = 0: linear convergence to round-off
        return np.array([(z[0] - 1.0) ** 2, z[1] - 2.0]), np.array([[2 * (z[0] - 1.0), 0.0], [0.0, 1.0]])

    for fun, k, rows in ((over, 3, 5), (under, 3, 2), (singular, 2, 2)):
        z0 = rng.uniform(-2, 2, k)
        fast = _search.least_squares(fun, z0, rows)
        monkeypatch.setattr(_search, "_lm_diag_none", lambda: False)
        slow = _search.least_squares(fun, z0, rows)
        monkeypatch.undo()
        assert np.array_equal(fast, slow)
    bad = lambda z: (np.array([np.nan, z[0]]), np.eye(2))  # noqa: E731
    assert _search.least_squares(bad, np.zeros(2), 2) is None
    assert _search.least_squares(singular, np.array([np.inf, 0.0]), 2) is None


@pytest.mark.parametrize("seed", range(6))
def test_newton_is_scipys_root_iterate_for_iterate(seed):
    """newton calls MINPACK's hybrj and lmder through fsolve and leastsq as scipy.optimize.root(jac=True,
    method="hybr" or "lm") calls them: the same answer bit for bit (a square system, one with fewer rows,
    padded, one with more rows, one singular at its root), and None where root raises (a residual that is
    not finite at the start)."""
    import scipy.optimize

    from lagrangian.equations import _search

    rng = np.random.default_rng(seed)
    A = rng.normal(size=(5, 3))
    B = A[:3]

    def square(z):
        return np.tanh(B @ z) + 0.1 * z.sum() ** 2 - 0.3, (1 - np.tanh(B @ z) ** 2)[:, None] * B + 0.2 * z.sum()

    def over(z):
        return np.tanh(A @ z) + 0.1 * z.sum() ** 2 - 0.3, (1 - np.tanh(A @ z) ** 2)[:, None] * A + 0.2 * z.sum()

    def under(z):
        return np.array([z[0] ** 2 + z[1] - 1.0, np.sin(z[2]) * z[0]]), np.array(
            [[2 * z[0], 1.0, 0.0], [np.sin(z[2]), 0.0, z[0] * np.cos(z[2])]])

    def singular(z):
        return np.array([(z[0] - 1.0) ** 2, z[1] - 2.0]), np.array([[2 * (z[0] - 1.0), 0.0], [0.0, 1.0]])

    for fun, k, rows in ((square, 3, 3), (over, 3, 5), (under, 3, 2), (singular, 2, 2)):
        z0 = rng.uniform(-2, 2, k)
        solve = _search._padded(fun, k, rows)
        with np.errstate(all="ignore"):
            if rows <= k:
                want = scipy.optimize.root(solve, z0, jac=True, method="hybr", options={"xtol": _search.NEWTON_XTOL}).x
            else:
                want = scipy.optimize.root(solve, z0, jac=True, method="lm",
                                           options={"xtol": _search.NEWTON_XTOL, "ftol": _search.PRECISE}).x
        assert np.array_equal(_search.newton(fun, z0, rows), want)

    def bad(z):
        raise ValueError("not finite")

    assert _search.newton(lambda z: bad(z), np.zeros(2), 2) is None


def test_padded_rows_are_the_concatenated_zeros():
    from lagrangian.equations import _search

    def fun(z):
        return np.array([z[0] - 1.0, np.nan]), np.array([[1.0, 2.0, 3.0], [np.inf, -0.0, 5.0]])

    r, J = _search._padded(fun, 3, 2)(np.zeros(3))
    r0, J0 = fun(np.zeros(3))
    want_r, want_J = np.concatenate((r0, np.zeros(1))), np.vstack((J0, np.zeros((1, 3))))
    assert r.tobytes() == want_r.tobytes() and J.tobytes() == want_J.tobytes() and J.shape == (3, 3)
    assert _search._padded(fun, 2, 2) is fun
