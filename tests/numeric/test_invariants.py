"""Structural invariants of derived equations, on systems built in Python with symbolic parameters.

Every system below is described by elements or energies whose parameters have no values, so
each identity is checked for all parameter values (symbolically) or at random positive ones
(numerically).  The convention checked is the one of `lagrangian.equations._equations`:

    M q_ddot + C q_dot + G = Q + gyroscopic_forces + centrifugal_forces + damping_forces
                             + rheonomic_forces,

with the residual E = left side - right side.
"""

from __future__ import annotations

from functools import lru_cache

import numpy as np
import pytest
import sympy as sp

import lagrangian as lg

S = sp.Symbol
cos, sin = lg.cos, lg.sin


# ------------------------------------------------------------------------------- systems
def double_pendulum():
    m = lg.Model("double-pendulum")
    q1, q2 = m.coordinate("q1", "q2")
    m1, m2, l1, l2, g = (m.parameter(n) for n in ("m1", "m2", "l1", "l2", "g"))
    m.add_particle(m1, (l1 * sin(q1), -l1 * cos(q1)), name="bob1")
    m.add_particle(m2, (l1 * sin(q1) + l2 * sin(q2), -l1 * cos(q1) - l2 * cos(q2)), name="bob2")
    m.add_gravity(g)
    return m


def chain3():
    m = lg.Model("chain3")
    qs = m.coordinate("q1", "q2", "q3")
    g = m.parameter("g")
    x = y = sp.Integer(0)
    for i, q in enumerate(qs, start=1):
        mi, li = m.parameter(f"m{i}"), m.parameter(f"l{i}")
        x, y = x + li * sin(q), y - li * cos(q)
        m.add_particle(mi, (x, y), name=f"bob{i}")
    m.add_gravity(g)
    return m


def sliding_mass_pendulum():
    m = lg.Model("sliding-mass-pendulum")
    q1, q2 = m.coordinate("q1", "q2")
    mass, k, g = (m.parameter(n) for n in ("m", "k", "g"))
    m.add_point("O", (0, 0))
    m.add_particle(mass, (q1 * sin(q2), -q1 * cos(q2)), name="mass")
    m.add_spring(k, between=("O", "mass"))
    m.add_gravity(g)
    return m


def cart_rigid_pendulum():
    """A cart (particle) carrying a planar rigid-body pendulum, a torsional damper at the hinge,
    a horizontal force input F on the cart and a torque input tau on the body."""
    m = lg.Model("cart-rigid-pendulum")
    x, th = m.coordinate("x", "theta")
    mc, mb, inertia, l, g, c = (m.parameter(n) for n in ("mc", "mb", "I", "l", "g", "c"))
    F, tau = m.input("F"), m.input("tau")
    m.add_particle(mc, (x, 0), name="cart")
    m.add_rigid_body(mb, inertia, (x + l * sin(th), -l * cos(th)), th, name="rod")
    m.add_gravity(g)
    m.add_damper(c, length=th)
    m.add_force((F, 0), at="cart")
    m.add_torque(tau, body="rod")
    return m


def rotating_pendulum():
    """Preumont Fig. 1.9: a bob on a rod whose pivot spins about the vertical at rate Omega;
    the 3D position depends on t."""
    m = lg.Model("rotating-pendulum")
    th = m.coordinate("theta")
    mass, l, g, W = (m.parameter(n) for n in ("m", "l", "g", "Omega"))
    t = lg.t
    m.add_particle(mass, (l * sin(th) * cos(W * t), l * sin(th) * sin(W * t), -l * cos(th)), name="bob")
    m.add_gravity(g)
    return m


def rotating_frame():
    """A particle on a spring, written in a frame rotating at Omega: T* has a T1 term."""
    return lg.Model("rotating-frame", coordinates=["x", "y"],
                    parameters={"m": None, "Omega": None, "k": None},
                    T="m/2*((x_dot - Omega*y)**2 + (y_dot + Omega*x)**2)", V="k/2*(x**2 + y**2)")


def rotating_frame_damped_forced():
    m = rotating_frame()
    c = m.parameter("c")
    Fx = m.input("Fx")
    m.add_energy(D=c / 2 * (m.symbol("x_dot") ** 2 + m.symbol("y_dot") ** 2))
    m.add_generalized_force("x", Fx)
    return m


def shaken_pendulum():
    """A pendulum whose pivot moves as A sin(w t): T1 = a(theta, t) theta_dot with da/dt != 0."""
    m = lg.Model("shaken-pendulum")
    th = m.coordinate("theta")
    mass, l, g, A, w = (m.parameter(n) for n in ("m", "l", "g", "A", "w"))
    m.add_particle(mass, (A * sin(w * lg.t) + l * sin(th), -l * cos(th)), name="bob")
    m.add_gravity(g)
    return m


def telescoping_pendulum():
    """A pendulum whose rod length grows as l0 + b t: M = m (l0 + b t)^2 depends on t."""
    m = lg.Model("telescoping-pendulum")
    th = m.coordinate("theta")
    mass, l0, b, g = (m.parameter(n) for n in ("m", "l0", "b", "g"))
    r = l0 + b * lg.t
    m.add_particle(mass, (r * sin(th), -r * cos(th)), name="bob")
    m.add_gravity(g)
    return m


SYSTEMS = {
    "double_pendulum": double_pendulum,
    "chain3": chain3,
    "sliding_mass_pendulum": sliding_mass_pendulum,
    "cart_rigid_pendulum": cart_rigid_pendulum,
    "rotating_pendulum": rotating_pendulum,
    "rotating_frame": rotating_frame,
    "rotating_frame_damped_forced": rotating_frame_damped_forced,
    "shaken_pendulum": shaken_pendulum,
    "telescoping_pendulum": telescoping_pendulum,
}
# coordinate ranges for random points (default: an angle in (-1.5, 1.5))
RANGES = {"sliding_mass_pendulum": {"q1": (0.3, 2.0)}}


@lru_cache(maxsize=None)
def eqs(name):
    return lg.derive(SYSTEMS[name]())


def all_symbols(e):
    return [e.t, *e.coordinates, *e.velocities, *e.accelerations, *e.parameters, *e.inputs]


def random_point(name, rng):
    """Numeric values for t, q, q_dot, q_ddot, positive parameters and inputs."""
    e = eqs(name)
    ranges = RANGES.get(name, {})
    vals = [rng.uniform(0.0, 3.0)]
    vals += [rng.uniform(*ranges.get(c.name, (-1.5, 1.5))) for c in e.coordinates]
    vals += list(rng.uniform(-2.0, 2.0, 2 * e.n))
    vals += list(rng.uniform(0.5, 2.0, len(e.parameters)))
    vals += list(rng.uniform(-2.0, 2.0, len(e.inputs)))
    return vals


def numeric(name, expr, point):
    f = sp.lambdify(all_symbols(eqs(name)), sp.Matrix(expr), "numpy")
    return np.array(f(*point), dtype=float)


def is_zero(expr):
    """Symbolic zero test: expand first (cheap), simplify only if needed."""
    e = sp.expand(expr)
    return e == 0 or sp.simplify(sp.expand_trig(e)) == 0


def assert_zero_matrix(A, what):
    bad = [(i, j, A[i, j]) for i in range(A.rows) for j in range(A.cols) if not is_zero(A[i, j])]
    assert not bad, f"{what}: nonzero entries {bad}"


def assert_same(a, b, what):
    assert is_zero(sp.sympify(a) - sp.sympify(b)), f"{what}: {a} != {b}"


ALL = list(SYSTEMS)


# ---------------------------------------------------------------------- mass matrix
@pytest.mark.parametrize("name", ALL)
def test_mass_matrix_symmetric(name):
    M = eqs(name).mass_matrix
    assert M.shape == (eqs(name).n, eqs(name).n)
    assert M == M.T
    assert M.free_symbols.isdisjoint(eqs(name).velocities), "M must not depend on the velocities"
    assert M.free_symbols.isdisjoint(eqs(name).accelerations)


@pytest.mark.parametrize("name", ALL)
def test_mass_matrix_positive_definite_at_random_points(name):
    rng = np.random.default_rng(1)
    e = eqs(name)
    for _ in range(5):
        M = numeric(name, e.mass_matrix, random_point(name, rng))
        assert np.allclose(M, M.T, rtol=1e-13, atol=1e-13)
        eig = np.linalg.eigvalsh(M)
        assert np.all(eig > 1e-9), f"eigenvalues {eig}"


# ------------------------------------------------------------------- Coriolis matrix
@pytest.mark.parametrize("name", ALL)
def test_mdot_minus_2c_is_skew_symmetric(name):
    e = eqs(name)
    M, C = e.mass_matrix, e.coriolis_matrix
    Mdot = sp.zeros(e.n, e.n)
    for qk, vk in zip(e.coordinates, e.velocities):
        Mdot += M.diff(qk) * vk
    N = Mdot - 2 * C
    assert_zero_matrix(N + N.T, "dM/dt - 2C + (dM/dt - 2C)^T")


@pytest.mark.parametrize("name", ["double_pendulum", "chain3", "sliding_mass_pendulum"])
def test_coriolis_matrix_gives_the_velocity_terms(name):
    # for a natural system (T* = T2, scleronomic) C q_dot = dM/dt q_dot - d(q_dot^T M q_dot / 2)/dq
    e = eqs(name)
    M, qd = e.mass_matrix, sp.Matrix(e.velocities)
    Mdot = sp.zeros(e.n, e.n)
    for qk, vk in zip(e.coordinates, e.velocities):
        Mdot += M.diff(qk) * vk
    quad = (qd.T * M * qd)[0, 0] / 2
    expected = Mdot * qd - sp.Matrix([quad.diff(qk) for qk in e.coordinates])
    assert_zero_matrix(e.coriolis_matrix * qd - expected, "C q_dot")
    assert e.coriolis_matrix != sp.zeros(e.n, e.n)


# ----------------------------------------------------------------- matrix-form identity
@pytest.mark.parametrize("name", ALL)
def test_residual_equals_matrix_form(name):
    e = eqs(name)
    qdd, qd = sp.Matrix(e.accelerations), sp.Matrix(e.velocities)
    E = sp.Matrix(e.equations)
    rhs_parts = (e.generalized_forces + e.gyroscopic_forces + e.centrifugal_forces
                 + e.damping_forces + e.rheonomic_forces)
    form = e.mass_matrix * qdd + e.coriolis_matrix * qd + e.potential_gradient - rhs_parts
    forcing_form = e.mass_matrix * qdd - e.forcing
    rng = np.random.default_rng(2)
    for _ in range(5):
        pt = random_point(name, rng)
        lhs = numeric(name, E, pt)
        for other in (form, forcing_form):
            rhs = numeric(name, other, pt)
            assert np.allclose(lhs, rhs, rtol=1e-9, atol=1e-9), (lhs, rhs)
        assert np.any(np.abs(lhs) > 1e-6), "a residual that vanishes everywhere tests nothing"


@pytest.mark.parametrize("name", ALL)
def test_residuals_are_linear_in_accelerations_with_mass_matrix(name):
    e = eqs(name)
    E = sp.Matrix(e.equations)
    J = E.jacobian(e.accelerations)
    assert_zero_matrix(J - e.mass_matrix, "dE/dq_ddot - M")


# ----------------------------------------------------------------- rotating frame (T1)
def test_gyroscopic_matrix_of_rotating_frame():
    # T* = m/2 (x_dot^2 + y_dot^2) + m Omega (x y_dot - y x_dot) + m Omega^2 (x^2 + y^2)/2,
    # so T1 = a . q_dot with a = (-m Omega y, m Omega x).  By the docstring's definition
    # Gamma_ij = da_i/dq_j - da_j/dq_i:
    #   Gamma_xy = d(-m Omega y)/dy - d(m Omega x)/dx = -2 m Omega,  Gamma_yx = +2 m Omega,
    # i.e. Gamma = 2 m Omega [[0, -1], [1, 0]].  The gyroscopic forces -Gamma q_dot are then
    # (2 m Omega y_dot, -2 m Omega x_dot) = -2 m Omega_vec x v, the Coriolis force of the
    # rotating frame (Omega_vec = Omega e_z), which is what Lagrange's equation gives directly:
    # m x_ddot - 2 m Omega y_dot - m Omega^2 x + k x = 0.
    e = eqs("rotating_frame")
    m, W = S("m"), S("Omega")
    G = e.gyroscopic_matrix
    assert_zero_matrix(G - 2 * m * W * sp.Matrix([[0, -1], [1, 0]]), "gyroscopic matrix")
    assert_zero_matrix(G + G.T, "skew-symmetry of the gyroscopic matrix")
    assert G != sp.zeros(2, 2)
    xd, yd = S("x_dot"), S("y_dot")
    assert_zero_matrix(e.gyroscopic_forces - sp.Matrix([2 * m * W * yd, -2 * m * W * xd]), "gyroscopic forces")
    # gyroscopic forces do no work
    assert is_zero((sp.Matrix([[xd, yd]]) * e.gyroscopic_forces)[0, 0])


def test_centrifugal_forces_of_rotating_frame():
    e = eqs("rotating_frame")
    m, W, x, y = S("m"), S("Omega"), S("x"), S("y")
    assert_zero_matrix(e.centrifugal_forces - sp.Matrix([m * W**2 * x, m * W**2 * y]), "centrifugal forces")
    assert_zero_matrix(e.rheonomic_forces, "rheonomic forces")
    assert_zero_matrix(e.damping_forces, "damping forces")
    assert e.mass_matrix == sp.Matrix([[m, 0], [0, m]])
    assert_zero_matrix(e.coriolis_matrix, "C (M is constant)")


def test_rotating_frame_equations_by_hand():
    e = eqs("rotating_frame")
    m, W, k = S("m"), S("Omega"), S("k")
    x, y, xd, yd, xdd, ydd = (S(n) for n in ("x", "y", "x_dot", "y_dot", "x_ddot", "y_ddot"))
    assert_same(e.equations[0], m * xdd - 2 * m * W * yd - m * W**2 * x + k * x, "x equation")
    assert_same(e.equations[1], m * ydd + 2 * m * W * xd - m * W**2 * y + k * y, "y equation")


def test_damped_forced_rotating_frame_parts():
    e = eqs("rotating_frame_damped_forced")
    c, Fx = S("c"), S("Fx")
    xd, yd = S("x_dot"), S("y_dot")
    assert_zero_matrix(e.damping_forces - sp.Matrix([-c * xd, -c * yd]), "damping forces")
    assert_zero_matrix(e.generalized_forces - sp.Matrix([Fx, 0]), "Q")
    assert e.input_matrix == sp.Matrix([[1], [0]])
    assert not e.is_conservative


def test_gyroscopic_matrix_zero_without_t1():
    for name in ("double_pendulum", "chain3", "sliding_mass_pendulum", "cart_rigid_pendulum"):
        e = eqs(name)
        assert_zero_matrix(e.gyroscopic_matrix, f"{name}: gyroscopic matrix")
        assert_zero_matrix(e.centrifugal_forces, f"{name}: centrifugal forces")
        assert_zero_matrix(e.rheonomic_forces, f"{name}: rheonomic forces")


# ------------------------------------------------------------------- rheonomic systems
def test_rotating_pendulum_parts():
    e = eqs("rotating_pendulum")
    m, l, g, W, th = S("m"), S("l"), S("g"), S("Omega"), S("theta")
    assert_same(e.mass_matrix[0, 0], m * l**2, "M")
    assert_same(e.centrifugal_forces[0], m * W**2 * l**2 * sp.sin(th) * sp.cos(th), "centrifugal")
    assert_same(e.potential_gradient[0], m * g * l * sp.sin(th), "G")
    assert_zero_matrix(e.rheonomic_forces, "rheonomic forces")
    assert_zero_matrix(e.gyroscopic_matrix, "gyroscopic matrix")


def test_shaken_pendulum_rheonomic_forces():
    # a = dT*/dtheta_dot at theta_dot = 0 = m A w l cos(w t) cos(theta), so
    # rheonomic = -da/dt = m A w^2 l sin(w t) cos(theta): the inertial force of the pivot's
    # acceleration -A w^2 sin(w t), times dx/dtheta = l cos(theta).
    e = eqs("shaken_pendulum")
    m, l, A, w, th, t = S("m"), S("l"), S("A"), S("w"), S("theta"), lg.t
    assert_same(e.rheonomic_forces[0], m * A * w**2 * l * sp.sin(w * t) * sp.cos(th), "rheonomic")
    assert not e.is_scleronomic
    assert not e.is_conservative


def test_telescoping_pendulum_rheonomic_forces():
    # M = m (l0 + b t)^2, so -(dM/dt) theta_dot = -2 m b (l0 + b t) theta_dot
    e = eqs("telescoping_pendulum")
    m, l0, b, thd, t = S("m"), S("l0"), S("b"), S("theta_dot"), lg.t
    assert_same(e.mass_matrix[0, 0], m * (l0 + b * t) ** 2, "M")
    assert_same(e.rheonomic_forces[0], -2 * m * b * (l0 + b * t) * thd, "rheonomic")
    assert not e.is_scleronomic


# ------------------------------------------------------------------------ linear form
def mass_spring_damper_2dof():
    ms = lg.Model("msd2")
    x1, x2 = ms.coordinate("x1", "x2")
    m1, m2, k1, k2, c1, c2 = (ms.parameter(n) for n in ("m1", "m2", "k1", "k2", "c1", "c2"))
    F = ms.input("F")
    ms.add_point("O", (0, 0))
    ms.add_particle(m1, (x1, 0), name="a")
    ms.add_particle(m2, (x2, 0), name="b")
    ms.add_spring(k1, between=("O", "a"))
    ms.add_spring(k2, between=("a", "b"))
    ms.add_damper(c1, length=x1)
    ms.add_damper(c2, between=("a", "b"))
    ms.add_force((F, 0), at="b")
    return ms


def test_linear_mass_spring_damper():
    e = lg.derive(mass_spring_damper_2dof())
    m1, m2, k1, k2, c1, c2, F = (S(n) for n in ("m1", "m2", "k1", "k2", "c1", "c2", "F"))
    lin = e.linear
    assert lin is not None and e.is_linear
    assert_zero_matrix(lin.M - sp.Matrix([[m1, 0], [0, m2]]), "M")
    assert_zero_matrix(lin.C - sp.Matrix([[c1 + c2, -c2], [-c2, c2]]), "C")
    assert_zero_matrix(lin.K - sp.Matrix([[k1 + k2, -k2], [-k2, k2]]), "K")
    assert_zero_matrix(lin.f - sp.Matrix([0, F]), "f")
    assert e.input_matrix == sp.Matrix([[0], [1]])
    assert_zero_matrix(e.damping_forces + lin.C * sp.Matrix(e.velocities), "damping forces = -C q_dot")


def test_linear_rotating_frame_has_gyroscopic_c():
    e = eqs("rotating_frame")
    m, W, k = S("m"), S("Omega"), S("k")
    lin = e.linear
    assert lin is not None
    assert_zero_matrix(lin.C - e.gyroscopic_matrix, "C of the linear form")
    assert_zero_matrix(lin.K - (k - m * W**2) * sp.eye(2), "K of the linear form")
    assert lin.f == sp.zeros(2, 1)


@pytest.mark.parametrize("name", ["double_pendulum", "sliding_mass_pendulum", "rotating_pendulum",
                                  "cart_rigid_pendulum", "shaken_pendulum"])
def test_nonlinear_systems_have_no_linear_form(name):
    assert eqs(name).linear is None
    assert not eqs(name).is_linear


def test_simple_pendulum_is_not_linear():
    m = lg.Model("pendulum", coordinates=["theta"], parameters={"m": None, "l": None, "g": None},
                 T="m*l**2*theta_dot**2/2", V="-m*g*l*cos(theta)")
    assert lg.derive(m).linear is None


# ----------------------------------------------------------------------- input matrix
def test_input_matrix_force_and_torque():
    e = eqs("cart_rigid_pendulum")
    assert [u.name for u in e.inputs] == ["F", "tau"]
    assert e.input_matrix == sp.Matrix([[1, 0], [0, 1]])
    assert_zero_matrix(e.generalized_forces - sp.Matrix([S("F"), S("tau")]), "Q")
    assert_zero_matrix(e.damping_forces - sp.Matrix([0, -S("c") * S("theta_dot")]), "damping forces")


def test_input_matrix_of_force_on_the_bob():
    # a horizontal force F at the bob (x + l sin(theta), -l cos(theta)): Q = F (1, l cos(theta))
    m = lg.Model("cart-pendulum-force")
    x, th = m.coordinate("x", "theta")
    mc, mb, l = (m.parameter(n) for n in ("mc", "mb", "l"))
    F = m.input("F")
    m.add_particle(mc, (x, 0), name="cart")
    m.add_particle(mb, (x + l * sin(th), -l * cos(th)), name="bob")
    m.add_force((F, 0), at="bob")
    e = lg.derive(m)
    assert_zero_matrix(e.input_matrix - sp.Matrix([[1], [l * sp.cos(th)]]), "B")
    assert e.input_matrix.shape == (2, 1)


# -------------------------------------------------------------------- Jacobi integral
def test_jacobi_integral_rotating_pendulum():
    e = eqs("rotating_pendulum")
    m, l, g, W, th, thd = (S(n) for n in ("m", "l", "g", "Omega", "theta", "theta_dot"))
    expected = m / 2 * (l * thd) ** 2 - m / 2 * (l * W * sp.sin(th)) ** 2 - g * m * l * sp.cos(th)
    assert_same(e.jacobi_integral, expected, "Jacobi integral")
    # it is not the energy T* + V
    assert not is_zero(e.jacobi_integral - (e.T + e.V))


def test_jacobi_integral_rotating_pendulum_from_energies():
    m = lg.Model("rotating-pendulum-energy", coordinates=["theta"],
                 parameters={"m": None, "l": None, "g": None, "Omega": None},
                 T="m/2*((l*theta_dot)**2 + (l*Omega*sin(theta))**2)", V="-g*m*l*cos(theta)")
    e = lg.derive(m)
    mm, l, g, W, th, thd = (S(n) for n in ("m", "l", "g", "Omega", "theta", "theta_dot"))
    expected = mm / 2 * (l * thd) ** 2 - mm / 2 * (l * W * sp.sin(th)) ** 2 - g * mm * l * sp.cos(th)
    assert_same(e.jacobi_integral, expected, "Jacobi integral")
    assert e.is_conservative


def test_jacobi_integral_is_energy_for_natural_systems():
    e = eqs("double_pendulum")
    assert_same(e.jacobi_integral, e.T + e.V, "h = T + V")
    assert e.is_conservative


@pytest.mark.parametrize("name", ["double_pendulum", "chain3", "rotating_pendulum", "rotating_frame"])
def test_jacobi_integral_is_conserved_along_motions(name):
    # dh/dt = sum dh/dq q_dot + dh/dq_dot q_ddot with q_ddot = M^-1 f must vanish (L free of t, D = Q = 0)
    e = eqs(name)
    h = e.jacobi_integral
    grad_q = sp.Matrix([h.diff(q) for q in e.coordinates])
    grad_v = sp.Matrix([h.diff(v) for v in e.velocities])
    rng = np.random.default_rng(3)
    for _ in range(3):
        pt = random_point(name, rng)
        gq, gv = numeric(name, grad_q, pt).ravel(), numeric(name, grad_v, pt).ravel()
        M, f = numeric(name, e.mass_matrix, pt), numeric(name, e.forcing, pt).ravel()
        qd = np.array(pt[1 + e.n: 1 + 2 * e.n])
        hdot = gq @ qd + gv @ np.linalg.solve(M, f) + float(numeric(name, sp.Matrix([h.diff(e.t)]), pt)[0, 0])
        assert abs(hdot) < 1e-9 * (1 + np.abs(gq @ qd)), hdot


def test_is_conservative_flags():
    assert eqs("double_pendulum").is_conservative
    assert eqs("chain3").is_conservative
    assert eqs("rotating_frame").is_conservative
    assert not eqs("cart_rigid_pendulum").is_conservative  # damper and inputs
    assert not eqs("telescoping_pendulum").is_conservative  # L depends on t
    assert not eqs("shaken_pendulum").is_conservative
    assert eqs("shaken_pendulum").explicit_time and eqs("telescoping_pendulum").explicit_time
    assert not eqs("double_pendulum").explicit_time


def test_rotating_pendulum_from_elements_is_conservative():
    e = eqs("rotating_pendulum")
    # the position depends on t, but sin(W t)**2 + cos(W t)**2 cancels: L has no explicit t ...
    assert sp.simplify(e.L.diff(e.t)) == 0
    assert not e.explicit_time
    assert e.is_conservative  # ... so the Jacobi integral is conserved


@pytest.mark.parametrize("T, V, D", [
    ("x_dot**2/2", "(1 + A*cos(t))*x**2/2", "0"),
    ("(1 + t**2)*x_dot**2/2", "x**2/2", "0"),
    ("x_dot**2/2", "x**2/2", "u*x_dot**2/2"),
])
def test_linear_requires_constant_coefficients(T, V, D):
    m = lg.Model("time-varying", coordinates=["x"], parameters={"A": None}, inputs=["u"], T=T, V=V, D=D)
    assert lg.derive(m).linear is None
