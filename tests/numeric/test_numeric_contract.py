"""The one numeric model contract (numeric._compiled.NumericContract): every backend gives it in the
argument order (t, x, u, p), with one failure value, the constraint parts (empty at m = 0) and the
Jacobians analysis needs, checked against closed forms and finite differences; one cache per
Equations; and the continuation of constrained models (a bead on a rotating hoop in Cartesian
coordinates: a pitchfork at Omega^2 = g/R)."""

from __future__ import annotations

import importlib.util
import math

import numpy as np
import pytest
import sympy

import lagrangian as lg
from lagrangian.numeric._cache import CACHE
from lagrangian.numeric._cbackend import c_compiler
from lagrangian.numeric._compiled import (
    NOT_FINITE,
    SINGULAR_RATIO,
    NumericContract,
    NumericModel,
)

HAVE_C = importlib.util.find_spec("cffi") is not None and c_compiler() is not None
BACKENDS = ["scipy", "numba"] + (["c"] if HAVE_C else [])


@pytest.fixture(scope="module")
def double():
    return lg.derive(lg.load("double-pendulum"))


@pytest.fixture(scope="module")
def cartesian():
    return lg.derive(lg.load("cartesian-pendulum"))


def hoop(**values) -> lg.Model:
    """A bead of mass m on a hoop of radius R turning at Omega about its vertical diameter, in the
    hoop's frame: (x, y) on x^2 + y^2 = R^2, the centrifugal potential -m Omega^2 x^2 / 2."""
    params = {"m": 1.0, "g": 9.81, "R": 0.5, "Omega": 3.0, **values}
    m = lg.Model("hoop", coordinates=["x", "y"], parameters=params,
                 T="m*(x_dot**2 + y_dot**2)/2 + m*Omega**2*x**2/2", V="m*g*y")
    m.add_constraint("x**2 + y**2 - R**2", name="hoop")
    return m


@pytest.mark.parametrize("backend", BACKENDS)
def test_every_backend_implements_the_contract_in_t_x_u_p(double, backend):
    nm = lg.compile(double, backend=backend)
    assert isinstance(nm, NumericContract) and lg.numeric.NumericContract is NumericContract
    portable = lg.compile(double, backend="scipy")
    rng = np.random.default_rng(3)
    p = nm.parameter_values
    for _ in range(3):
        t, x = float(rng.uniform(0, 2)), rng.uniform(-1, 1, 4)
        qdd, ratio = nm.solve(t, x, [], p)
        assert ratio > SINGULAR_RATIO
        assert np.allclose(qdd, portable.solve(t, x, [], p)[0], rtol=1e-12, atol=1e-12)
        assert np.allclose(nm.rhs(t, x, [], p), np.concatenate((x[2:], qdd)), rtol=1e-12, atol=1e-12)
        G, c, g, w = nm.constraint_parts(t, x, [], p)  # m = 0: empty arrays of the right shapes
        assert (G.shape, c.shape, g.shape, w.shape) == ((0, 2), (0,), (0,), (0,)) and nm.m == 0
        for name in ("jacobians", "momenta", "damping", "state_jacobians"):
            a, b = getattr(nm, name)(t, x, [], p), getattr(portable, name)(t, x, [], p)
            a, b = ((list(a.values()), list(b.values())) if isinstance(a, dict) else
                    ([a], [b]) if isinstance(a, np.ndarray) else (list(a), list(b)))
            assert len(a) == len(b) and all(np.array_equal(u, v) for u, v in zip(a, b))


@pytest.mark.parametrize("backend", BACKENDS)
def test_one_failure_value_for_every_backend(backend):
    """A singular M: (NaN, ratio <= SINGULAR_RATIO); f not finite: (NaN, -1.0); nothing raises."""
    eqs = lg.derive(lg.load("cart-pendulum-massless"))
    nm = lg.compile(eqs, backend=backend)
    x = np.zeros(4)
    x[eqs.state_names.index("q2")] = -math.pi / 2
    qdd, ratio = nm.solve(0.0, x, [], nm.parameter_values)
    assert ratio <= SINGULAR_RATIO and np.all(np.isnan(qdd))
    assert np.all(np.isnan(nm.rhs(0.0, x, [], nm.parameter_values)[2:]))
    root = lg.derive(lg.Model("root", coordinates=["x"], parameters={"k": 1.0}, T="x_dot**2/2", V="k*x*sqrt(x)"))
    nm = lg.compile(root, backend=backend)
    qdd, ratio = nm.solve(0.0, [-1.0, 0.0], [], [1.0])  # sqrt of a negative number
    assert ratio == NOT_FINITE == -1.0 and np.all(np.isnan(qdd))
    assert nm.solve(0.0, [4.0, 0.0], [], [1.0])[0] == pytest.approx([-3.0])  # f = -(3/2) k sqrt(x)


def test_state_jacobians_against_central_differences(double):
    nm = lg.compile(double, backend="scipy")
    p = nm.parameter_values
    x = np.array([0.4, -0.9, 0.7, 0.2])
    A, B = nm.state_jacobians(0.0, x, [], p)
    h = 1e-6
    fd = np.column_stack([(nm.rhs(0.0, x + h * e, [], p) - nm.rhs(0.0, x - h * e, [], p)) / (2 * h) for e in np.eye(4)])
    assert np.allclose(A, fd, rtol=1e-7, atol=1e-7)
    assert B.shape == (4, 0)
    mck = lg.derive(lg.load("mck"))  # linear: A = [[0, I], [-M^-1 K, -M^-1 C]], B = [[0], [M^-1 b]]
    nm = lg.compile(mck, backend="numba")
    A, B = nm.state_jacobians(0.0, np.zeros(4), [0.0], nm.parameter_values)
    M, K, C = np.diag([1.0, 0.5]), np.array([[150.0, -50.0], [-50.0, 50.0]]), np.array([[0.6, -0.2], [-0.2, 0.2]])
    assert np.allclose(A[2:, :2], -np.linalg.solve(M, K), rtol=1e-13)
    assert np.allclose(A[2:, 2:], -np.linalg.solve(M, C), rtol=1e-13)
    assert np.allclose(B[:, 0], [0, 0, 0, 2.0], rtol=1e-13)
    assert np.allclose(nm.damping(0.0, np.zeros(4), [0.0], nm.parameter_values), C, rtol=1e-13)


def test_state_jacobians_of_a_constrained_model_say_why_not(cartesian):
    nm = lg.compile(cartesian, backend="scipy")
    with pytest.raises(lg.ModelError, match=r"cartesian-pendulum has 1 constraint: its state moves on the "
                                            r"constraints g = 0, G q_dot \+ b = 0, so d rhs/dx in all 2n state "
                                            r"variables is not its linearization; use lagrangian.linearize"):
        nm.state_jacobians(0.0, [0.6, -0.8, 0.0, 0.0], [], nm.parameter_values)


@pytest.mark.parametrize("backend", BACKENDS)
def test_constraint_parts_and_statics_of_the_cartesian_pendulum(cartesian, backend):
    """g = l - r, G = -(x, y)/r, w = G q_dot, c = |v|^2/r - (r . v)^2/r^3 (G q_ddot = c); at rest
    F = f + G^T lambda = (-lambda x/r, -m g - lambda y/r)."""
    nm = lg.compile(cartesian, backend=backend)
    p = nm.parameter_values  # m = 1, l = 1, g = 9.81
    x, y, vx, vy = 0.6, -0.7, 0.3, -0.5
    r = math.hypot(x, y)
    G, c, g, w = nm.constraint_parts(0.0, [x, y, vx, vy], [], p)
    assert nm.m == 1
    assert np.allclose(G, [[-x / r, -y / r]], rtol=1e-14)
    assert g == pytest.approx([1.0 - r], rel=1e-14)
    assert w == pytest.approx([-(x * vx + y * vy) / r], rel=1e-14)
    assert c == pytest.approx([(vx**2 + vy**2) / r - (x * vx + y * vy) ** 2 / r**3], rel=1e-13)
    G1, g1, w1 = nm.constraint_residuals(0.0, [x, y, vx, vy], [], p)  # the same without c
    assert np.array_equal(G1, G) and np.array_equal(g1, g) and np.array_equal(w1, w)
    qdd, ratio = nm.solve(0.0, [x, y, vx, vy], [], p)
    assert ratio > SINGULAR_RATIO and G @ qdd == pytest.approx(c, rel=1e-12)
    X, Y, L = sympy.symbols("x y l")
    radius = nm.function("radius and its excess", lambda: [sympy.sqrt(X**2 + Y**2), sympy.sqrt(X**2 + Y**2) - L])
    assert radius(0.0, [x, y, vx, vy], [], p) == pytest.approx([r, r - 1.0], rel=1e-14)
    F, g0, J, G0 = nm.statics(0.0, [0.0, -1.0, 9.81], [], p)  # the bob at rest at the bottom, lambda = m g
    assert np.allclose(F, 0.0, atol=1e-14) and g0 == pytest.approx([0.0], abs=1e-15)
    assert np.allclose(G0, [[0.0, 1.0]], atol=1e-15)
    assert np.allclose(J, [[-9.81, 0.0], [0.0, 0.0]], atol=1e-13)  # -lambda d(x/r, y/r)/dq at (0, -1)


def test_one_cache_holds_every_backend_of_an_equations_object(double):
    nm = lg.compile(double, backend="scipy")
    assert isinstance(nm, NumericModel) and lg.compile(double, backend="scipy") is nm
    fast = lg.compile(double)  # the default is the fastest backend: numba's compiled code
    assert isinstance(fast, lg.CompiledModel) and fast.backend == "numba" and fast.numeric is nm
    assert CACHE[double]["scipy"] is nm and CACHE[double]["numba"] is fast


# ------------------------------------------------------------------------- continuation with constraints
@pytest.mark.parametrize("exact", [True, False])
def test_continuation_of_the_bead_on_a_rotating_hoop(exact):
    """Bottom (0, -R) stable below Omega^2 = g/R, unstable above, where the two side branches
    x = +-sqrt(R^2 - g^2/Omega^4), y = -g/Omega^2, lambda = -m Omega^2/2 start, stable; the top
    (0, R) is unstable throughout."""
    g, R = 9.81, 0.5
    eqs = lg.derive(hoop())
    sweep = lg.continuation(eqs, "Omega", np.linspace(1.0, 8.0, 36), exact=exact)
    critical = math.sqrt(g / R)
    assert len(sweep.critical_values) == 1
    assert sweep.critical_values[0] == pytest.approx(critical, abs=1e-6)
    if exact:
        assert sweep.critical_exact[0] is not None and float(sweep.critical_exact[0].subs({"g": g, "R": R})) \
            == pytest.approx(critical, rel=1e-14)
    assert len(sweep.branches) == 4
    sides = 0
    for b in sweep.branches:
        X, Y, O = b.coordinate("x"), b.coordinate("y"), b.params
        lam = np.array([p.multipliers["lambda_hoop"] for p in b.points])
        if np.all(np.abs(X) < 1e-9) and np.all(Y > 0):  # the top
            assert np.allclose(Y, R, rtol=1e-9) and np.allclose(lam, g / (2 * R), rtol=1e-9)
            assert not b.stable.any()
        elif np.all(np.abs(X) < 1e-9):  # the bottom
            assert np.allclose(Y, -R, rtol=1e-9) and np.allclose(lam, -g / (2 * R), rtol=1e-9)
            away = np.abs(O - critical) > 1e-6  # (at the critical value itself, the exact branches meet)
            assert np.array_equal(b.stable[away], O[away] < critical)
        else:
            sides += 1
            assert np.all(O >= critical - 1e-12)
            assert np.allclose(np.abs(X), np.sqrt(np.maximum(R**2 - g**2 / O**4, 0.0)), rtol=1e-8, atol=1e-8)
            assert np.allclose(Y, -g / O**2, rtol=1e-8)
            assert np.allclose(lam, -O**2 / 2, rtol=1e-8)
            assert b.stable[O > critical + 1e-6].all()
    assert sides == 2
    point = sweep.to_dict()["branches"][0][0]
    assert set(point) == {"param", "coordinates", "stable", "multipliers"}
    assert set(point["multipliers"]) == {"lambda_hoop"}


def test_continuation_of_the_cartesian_pendulum_in_g(cartesian):
    """The bottom is stable with the rod's tension m g, the top unstable; no critical value."""
    sweep = lg.continuation(cartesian, "g", [1.0, 2.0, 3.0])
    assert sweep.critical_values == ()
    bottom = [b for b in sweep.branches if b.coordinate("y")[0] < 0]
    assert len(bottom) == 1 and bottom[0].stable.all()
    assert np.allclose(bottom[0].coordinate("y"), -1.0) and np.allclose(bottom[0].coordinate("x"), 0.0, atol=1e-12)
    assert [p.multipliers["lambda_rod"] for p in bottom[0].points] == pytest.approx([1.0, 2.0, 3.0], rel=1e-12)
    assert not any(b.stable.any() for b in sweep.branches if b.coordinate("y")[0] > 0)


def test_continuation_refuses_velocity_constraints_and_says_why():
    disk = lg.derive(lg.load("rolling-disk"))
    name = next(p.name for p in disk.parameters)
    with pytest.raises(lg.ModelError, match=r"rolling-disk: the continuation of equilibria follows the solutions of "
                                            r"f\(q\) \+ G\(q\)\^T lambda = 0, g\(q\) = 0 \(holonomic constraints\), "
                                            r"and velocity constraints .* \(a\(q\) \. q_dot \+ b = 0, not the "
                                            r"derivative of any g\(q\) = 0\) leave the coordinates they do not hold "
                                            r"free: .* call equilibria\(equations, params=\{\.\.\.\}\) at each value"):
        lg.continuation(disk, name, [1.0, 2.0])
