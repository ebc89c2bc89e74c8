"""One linearization (analysis/_linearize.py::linearize_at): in the coordinates z of the constraints'
tangent space, dq = T dz, with T = I and no constraint forces at m = 0.

- m = 0: the merged code gives the answers of the unconstrained linearization before the merge
  (numbers recorded from it, to 1e-14), SymPy's derivatives of M q_ddot - f at the point, and the
  same matrices when the reduction is run with T = I explicitly;
- m > 0: the four-bar's frequency at its stable equilibria against a reduction by hand (one
  coordinate th1; th2 and th3 eliminated by differentiating the loop closure with SymPy: the
  effective inertia J(th1) and the reduced potential V(th1), omega^2 = V''/J);
- the exact (symbolic) linearization of a constrained model is refused with its reason.
"""

from __future__ import annotations

import math

import numpy as np
import pytest
import sympy as sp

import lagrangian as lg
from lagrangian.analysis._linearize import assembled

#: The unconstrained linearization before the merge (commit 54a26e4), away from equilibrium (q_ddot != 0).
BEFORE = {
    "cart-pendulum": ({"q2": 0.3, "q2_dot": 0.2}, {"F": 0.5}, {
        "M": [[1.5, -0.14776010333066977], [-0.14776010333066977, 0.5]],
        "C": [[0.0, 0.0], [0.0, 0.0]],
        "G": [[0.0, -0.19106729782512122], [0.0, 0.0]],
        "K": [[0.0, 4.566455173011307], [0.0, -1.1655894363821233]],
        "input_matrix": [[1.0], [0.0]],
        "A": [[0.0, 0.0, 1.0, 0.0], [0.0, 0.0, 0.0, 1.0], [0.0, -2.8990603947922744, 0.0, 0.13119745227114005],
              [0.0, 1.474447945771529, 0.0, 0.03877149820860854]],
        "B": [[0.0], [0.0], [0.686655716412662], [0.20292063921946]],
        "accelerations": [-0.5944233901326794, -9.547515081418538]}),
    "double-pendulum": ({"theta1": 0.2, "theta2": -0.4, "theta1_dot": 0.3}, None, {
        "M": [[2.0, 0.8253356149096783], [0.8253356149096783, 1.0]],
        "C": [[0.0, 0.0], [0.0, 0.0]],
        "G": [[0.0, 0.0], [-0.33878548403702125, 0.0]],
        "K": [[14.536860324925755, 4.692045932319406], [2.96243386826208, 6.073174482906223]],
        "input_matrix": [[], []],
        "A": [[0.0, 0.0, 1.0, 0.0], [0.0, 0.0, 0.0, 1.0], [-9.168687047803411, 0.24291487181591373,
                                                             -0.21201641448132857, 0.0],
              [4.604810094251151, -6.273660778007115, 0.5137701818539138, 0.0]],
        "B": [[], [], [], []],
        "accelerations": [-5.378118396487336, 8.309764414475344]}),
}


def _close(actual, expected, tol=1e-14) -> bool:
    a, e = np.asarray(actual, float), np.asarray(expected, float)
    return a.shape == e.shape and bool(np.all(np.abs(a - e) <= tol * max(1.0, float(np.abs(e).max(initial=0.0)))))


@pytest.mark.parametrize("name", sorted(BEFORE))
def test_the_m0_case_gives_the_unconstrained_answers_of_before_the_merge(name):
    at, inputs, before = BEFORE[name]
    lin = lg.linearize(lg.derive(lg.load(name)), at, inputs=inputs)
    for key, expected in before.items():
        assert _close(getattr(lin, key), expected), key
    assert not lin.constrained and lin.state_names == lin.equations.state_names
    # an independent path agrees: SymPy's derivatives of M q_ddot - f, evaluated at the point
    eqs = lin.equations
    point = {sp.Symbol(k): v for k, v in lin.operating_point.items()} | {p: v for p, v in eqs.parameters.items()}
    point |= {sp.Symbol(k): v for k, v in lin.input_values.items()}
    M, f = sp.Matrix(eqs.mass_matrix), sp.Matrix(eqs.forcing)
    M0 = np.array(M.subs(point).evalf(30), float)
    qdd = np.linalg.solve(M0, np.array(f.subs(point).evalf(30), float).ravel())
    a = sp.symbols(f"a0:{eqs.n}")
    residual = M * sp.Matrix(a) - f
    at = point | dict(zip(a, qdd))
    K = np.array(residual.jacobian(list(eqs.coordinates)).subs(at).evalf(30), float)
    D = np.array(residual.jacobian(list(eqs.velocities)).subs(at).evalf(30), float)
    A = np.block([[np.zeros((eqs.n, eqs.n)), np.eye(eqs.n)], [-np.linalg.solve(M0, K), -np.linalg.solve(M0, D)]])
    assert _close(lin.M, M0, 1e-12) and _close(lin.K, K, 1e-12) and _close(lin.A, A, 1e-12)
    assert _close(lin.accelerations, qdd, 1e-12)


@pytest.mark.parametrize("name", sorted(BEFORE))
def test_the_reduction_with_T_the_identity_is_the_unconstrained_assembly(name):
    at, inputs, _ = BEFORE[name]
    lin = lg.linearize(lg.derive(lg.load(name)), at, inputs=inputs)
    # undo the assembly: D = C + G, and reassemble with T = None (m = 0) and T = I
    M, K, D, B0 = lin.M, lin.K, lin.C + lin.G, lin.input_matrix
    damping = np.array(lin.C)
    none = assembled(M, K, D, B0, damping)
    identity = assembled(M, K, D, B0, damping, np.eye(lin.n))
    for a, b, key in zip(none, identity, ("M", "C", "G", "K", "B0", "A", "B")):
        assert _close(a, b), key
    assert _close(none[5], lin.A) and _close(none[6], lin.B)


# ----------------------------------------------------------------------------- the four-bar by hand
def _four_bar_by_hand(values: dict, th1: float, th2: float, th3: float) -> tuple[float, float]:
    """(J, V''): the effective inertia and the reduced potential's curvature in th1, with th2 and th3
    functions of th1 through the loop closure (their derivatives by implicit differentiation)."""
    a, b, c, d, ma, mb, mc, g = (sp.Float(values[k], 30) for k in ("a", "b", "c", "d", "ma", "mb", "mc", "g"))
    t = sp.Symbol("th1")
    f2, f3 = sp.Function("th2")(t), sp.Function("th3")(t)
    loop = [a * sp.cos(t) + b * sp.cos(f2) - d - c * sp.cos(f3), a * sp.sin(t) + b * sp.sin(f2) - c * sp.sin(f3)]
    first = sp.solve([sp.diff(e, t) for e in loop], [f2.diff(t), f3.diff(t)], dict=True)[0]
    second = sp.solve([sp.diff(e, t, 2) for e in loop], [f2.diff(t, 2), f3.diff(t, 2)], dict=True)[0]
    bodies = [  # (mass, inertia about the centre, centre x, centre y, angle)
        (ma, ma * a**2 / 12, a / 2 * sp.cos(t), a / 2 * sp.sin(t), t),
        (mb, mb * b**2 / 12, a * sp.cos(t) + b / 2 * sp.cos(f2), a * sp.sin(t) + b / 2 * sp.sin(f2), f2),
        (mc, mc * c**2 / 12, d + c / 2 * sp.cos(f3), c / 2 * sp.sin(f3), f3),
    ]
    J = sum(m * (sp.diff(x, t) ** 2 + sp.diff(y, t) ** 2) + inertia * sp.diff(angle, t) ** 2
            for m, inertia, x, y, angle in bodies)
    V = sum(m * g * y for m, _, _, y, _ in bodies)
    point = {f2: th2, f3: th3, t: th1}

    def at(expr):
        expr = expr.subs({f2.diff(t, 2): second[f2.diff(t, 2)], f3.diff(t, 2): second[f3.diff(t, 2)]})
        expr = expr.subs({f2.diff(t): first[f2.diff(t)], f3.diff(t): first[f3.diff(t)]})
        return float(expr.subs(point).evalf(30))

    assert abs(at(sp.diff(V, t))) < 1e-9  # the equilibrium: the reduced potential is stationary there
    return at(J), at(sp.diff(V, t, 2))


@pytest.fixture(scope="module")
def four_bar():
    """The four-bar's equations and its equilibria (found numerically: several seconds)."""
    eqs = lg.derive(lg.load("four-bar"))
    return eqs, lg.equilibria(eqs)


@pytest.mark.slow
def test_the_four_bar_oscillates_at_the_frequency_of_its_reduction_by_hand(four_bar):
    eqs, found = four_bar
    values = {p.name: float(v) for p, v in eqs.parameters.items()}
    stable = [e for e in found if e.stable]
    assert len(stable) == 2
    for e in stable:
        lin = e.linear_model
        J, curvature = _four_bar_by_hand(values, *e.coordinates.values())
        assert lin.coordinate_names == ("th1",) and lin.state_names == ("th1", "th1_dot")
        assert lin.M[0, 0] == pytest.approx(J, rel=1e-12)
        assert lin.K[0, 0] == pytest.approx(curvature, rel=1e-9)
        omega = math.sqrt(curvature / J)
        assert sorted(z.imag for z in lin.eigenvalues) == pytest.approx([-omega, omega], rel=1e-9)
        assert np.all(lin.eigenvalues.real == 0)
        # the same through linearize at the equilibrium's coordinates
        again = lg.linearize(eqs, e.coordinates)
        assert _close(again.A, lin.A) and _close(again.M, lin.M) and _close(again.K, lin.K)


@pytest.mark.slow
def test_the_four_bar_basis_spans_the_null_space_of_the_constraint_jacobian(four_bar):
    eqs, found = four_bar
    e = next(e for e in found if e.stable)
    T = np.array(e.linear_model.constrained["basis"])
    values = {p: v for p, v in eqs.parameters.items()} | {sp.Symbol(k): v for k, v in e.coordinates.items()}
    G = np.array(sp.Matrix(eqs.constraint_jacobian).subs(values).evalf(), float)
    assert T.shape == (3, 1) and T[0, 0] == 1.0  # dq = T dth1: th1's row is the identity
    assert np.abs(G @ T).max() < 1e-12


def test_the_exact_linearization_of_a_constrained_model_is_refused_with_its_reason():
    cartesian = lg.derive(lg.load("cartesian-pendulum"))
    lin = lg.linearize(cartesian, {"x": 0.0, "y": -1.0})
    with pytest.raises(lg.ModelError, match=r"the exact \(symbolic\) linearization does not handle constraints yet.*"
                                            r"its numeric linearization \(A, B, M, C, K\) is in the independent "
                                            r"coordinates; an exact one needs the dependent coordinates at the point "
                                            r"as exact roots of g\(q\) = 0, functions of the symbolic parameters, "
                                            r"and the tangent basis T = \[I; -G_d\^-1 G_i\], a symbolic inverse of the "
                                            r"constraints' Jacobian: g\(q\) = 0 has no closed-form solution in general "
                                            r"\(a four-bar's loop closes where two circles meet\), so the constraints "
                                            r"are eliminated numerically at the point. Use the numeric matrices, or "
                                            r"write the model in independent coordinates without constraints"):
        lin.symbolic  # noqa: B018
