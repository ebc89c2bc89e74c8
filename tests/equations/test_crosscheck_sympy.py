"""Cross-check against sympy.physics.mechanics.LagrangesMethod (a test-only dependency).

Each system is built twice: with `lagrangian` (plain symbols q, q_dot, q_ddot) and with
SymPy's mechanics module (dynamicsymbols, frames, points, a force list).  SymPy's results
are mapped to our plain symbols, and our mass matrix and forcing must equal
LagrangesMethod's `mass_matrix` and `forcing` (M q_ddot = f in both), symbolically, and
numerically at random points as a second, independent check.
"""

from __future__ import annotations

import numpy as np
import pytest
import sympy as sp
from sympy.physics.mechanics import (LagrangesMethod, Lagrangian, Particle, Point, ReferenceFrame,
                                     RigidBody, dynamicsymbols, inertia, msubs)

import lagrangian as lg

T_ = dynamicsymbols._t
assert T_ == lg.t, "SymPy's time symbol and ours are both Symbol('t')"


def to_plain(expr, names):
    """Replace q(t)'' -> q_ddot, q(t)' -> q_dot, q(t) -> q (in that order)."""
    qs = [dynamicsymbols(n) for n in names]
    sub2 = {q.diff(T_, 2): sp.Symbol(f"{n}_ddot") for q, n in zip(qs, names)}
    sub1 = {q.diff(T_): sp.Symbol(f"{n}_dot") for q, n in zip(qs, names)}
    sub0 = {q: sp.Symbol(n) for q, n in zip(qs, names)}
    return msubs(msubs(msubs(sp.Matrix(expr), sub2), sub1), sub0)


def is_zero(e):
    e = sp.expand(e)
    if e == 0:
        return True
    e = sp.expand(sp.expand_trig(e))
    return e == 0 or sp.simplify(e) == 0


def sample_range(name, coordinates, ranges):
    if name in ranges:
        return ranges[name]
    if name in coordinates:
        return (-1.5, 1.5)
    if name.endswith(("_dot", "_ddot")):
        return (-2.0, 2.0)
    return (0.5, 2.0)  # parameters (positive), inputs and t


def check(eqs, lm, names, *, ranges=None, symbolic=True):
    """Our M and f against LagrangesMethod's, symbolically and at random numeric points."""
    assert [c.name for c in eqs.coordinates] == list(names)
    lm.form_lagranges_equations()
    M_ref = to_plain(lm.mass_matrix, names)
    f_ref = to_plain(lm.forcing, names)
    M, f = sp.Matrix(eqs.mass_matrix), sp.Matrix(eqs.forcing)
    assert M.shape == M_ref.shape and f.shape == f_ref.shape
    # no leftover functions of t on SymPy's side: the mapping is complete
    assert not M_ref.atoms(sp.Function) - M_ref.atoms(sp.sin, sp.cos)
    assert not f_ref.atoms(sp.Derivative)
    syms = sorted((M.free_symbols | f.free_symbols | M_ref.free_symbols | f_ref.free_symbols), key=str)
    fn = sp.lambdify(syms, [M, f, M_ref, f_ref], "numpy")
    rng = np.random.default_rng(7)
    ranges = ranges or {}
    for _ in range(6):
        vals = [rng.uniform(*sample_range(s.name, names, ranges)) for s in syms]
        a, b, c, d = (np.array(x, dtype=float) for x in fn(*vals))
        assert np.allclose(a, c, rtol=1e-10, atol=1e-10), ("M", a, c)
        assert np.allclose(b, d, rtol=1e-10, atol=1e-10), ("f", b, d)
        assert np.any(np.abs(d) > 1e-8), "a forcing that vanishes at random points tests little"
    if symbolic:
        bad = [(i, j) for i in range(M.rows) for j in range(M.cols) if not is_zero(M[i, j] - M_ref[i, j])]
        assert not bad, f"M differs at {bad}"
        bad = [i for i in range(f.rows) if not is_zero(f[i] - f_ref[i])]
        assert not bad, f"forcing differs at {bad}: ours {f}, SymPy's {f_ref}"


def pendulum_frame():
    N = ReferenceFrame("N")
    O = Point("O")
    O.set_vel(N, 0)
    return N, O


def moving_point(name, O, N, pos):
    P = O.locatenew(name, pos)
    P.set_vel(N, P.pos_from(O).dt(N))
    return P


# ------------------------------------------------------------------------ double pendulum
def test_double_pendulum():
    m1, m2, l1, l2, g = sp.symbols("m1 m2 l1 l2 g")
    # ours
    m = lg.Model("dp", coordinates=["q1", "q2"],
                 parameters={n: None for n in ("m1", "m2", "l1", "l2", "g")})
    q1, q2 = m.q
    m.add_particle(m1, (l1 * sp.sin(q1), -l1 * sp.cos(q1)), name="a")
    m.add_particle(m2, (l1 * sp.sin(q1) + l2 * sp.sin(q2), -l1 * sp.cos(q1) - l2 * sp.cos(q2)), name="b")
    m.add_gravity(g)
    # SymPy's
    Q1, Q2 = dynamicsymbols("q1 q2")
    N, O = pendulum_frame()
    P1 = moving_point("P1", O, N, l1 * sp.sin(Q1) * N.x - l1 * sp.cos(Q1) * N.y)
    P2 = moving_point("P2", P1, N, l2 * sp.sin(Q2) * N.x - l2 * sp.cos(Q2) * N.y)
    P2.set_vel(N, P2.pos_from(O).dt(N))
    a, b = Particle("a", P1, m1), Particle("b", P2, m2)
    a.potential_energy = m1 * g * P1.pos_from(O).dot(N.y)
    b.potential_energy = m2 * g * P2.pos_from(O).dot(N.y)
    lm = LagrangesMethod(Lagrangian(N, a, b), [Q1, Q2])
    check(lg.derive(m), lm, ["q1", "q2"])


# ---------------------------------------------------------- cart with inverted pendulum
def test_cart_inverted_pendulum_with_force_on_cart():
    mc, mb, l, g = sp.symbols("mc mb l g")
    m = lg.Model("cart", coordinates=["x", "theta"], parameters={n: None for n in ("mc", "mb", "l", "g")},
                 inputs=["F"])
    x, th = m.q
    F = m.symbol("F")
    m.add_particle(mc, (x, 0), name="cart")
    m.add_particle(mb, (x + l * sp.sin(th), l * sp.cos(th)), name="bob")  # upright at theta = 0
    m.add_gravity(g)
    m.add_force((F, 0), at="cart")
    eqs = lg.derive(m)

    X, TH = dynamicsymbols("x theta")
    N, O = pendulum_frame()
    Pc = moving_point("Pc", O, N, X * N.x)
    Pb = moving_point("Pb", O, N, (X + l * sp.sin(TH)) * N.x + l * sp.cos(TH) * N.y)
    T = mc / 2 * Pc.vel(N).dot(Pc.vel(N)) + mb / 2 * Pb.vel(N).dot(Pb.vel(N))
    V = mb * g * l * sp.cos(TH)
    lm = LagrangesMethod(T - V, [X, TH], forcelist=[(Pc, F * N.x)], frame=N)
    check(eqs, lm, ["x", "theta"])
    assert eqs.input_matrix == sp.Matrix([[1], [0]])


# --------------------------------------------------------------- sliding-mass pendulum
def test_sliding_mass_pendulum_with_spring():
    mass, k, g = sp.symbols("m k g")
    m = lg.Model("smp", coordinates=["q1", "q2"], parameters={"m": None, "k": None, "g": None})
    q1, q2 = m.q
    m.add_point("O", (0, 0))
    m.add_particle(mass, (q1 * sp.sin(q2), -q1 * sp.cos(q2)), name="mass")
    m.add_spring(k, between=("O", "mass"))
    m.add_gravity(g)

    Q1, Q2 = dynamicsymbols("q1 q2")
    N, O = pendulum_frame()
    P = moving_point("P", O, N, Q1 * sp.sin(Q2) * N.x - Q1 * sp.cos(Q2) * N.y)
    L = mass / 2 * P.vel(N).dot(P.vel(N)) - (mass * g * P.pos_from(O).dot(N.y) + k / 2 * Q1**2)
    check(lg.derive(m), LagrangesMethod(L, [Q1, Q2]), ["q1", "q2"], ranges={"q1": (0.3, 2.0)})


def test_sliding_mass_pendulum_with_spring_rest_length_and_radial_damper():
    # spring with rest length (V = k (|r| - r0)^2 / 2) and a damper along the rod; q1 > 0
    mass, k, g, r0, c = sp.symbols("m k g r0 c")
    m = lg.Model("smp2", coordinates=["q1", "q2"], parameters={n: None for n in ("m", "k", "g", "r0", "c")})
    q1, q2 = m.q
    m.add_point("O", (0, 0))
    m.add_particle(mass, (q1 * sp.sin(q2), -q1 * sp.cos(q2)), name="mass")
    m.add_spring(k, between=("O", "mass"), rest_length=r0)
    m.add_damper(c, between=("O", "mass"))
    m.add_gravity(g)

    Q1, Q2 = dynamicsymbols("q1 q2")
    N, O = pendulum_frame()
    P = moving_point("P", O, N, Q1 * sp.sin(Q2) * N.x - Q1 * sp.cos(Q2) * N.y)
    er = P.pos_from(O) / Q1
    L = mass / 2 * P.vel(N).dot(P.vel(N)) - (mass * g * P.pos_from(O).dot(N.y) + k / 2 * (Q1 - r0) ** 2)
    lm = LagrangesMethod(L, [Q1, Q2], forcelist=[(P, -c * Q1.diff(T_) * er)], frame=N)
    # numeric only: our spring length is sqrt(q1**2) = |q1|, equal to SymPy's q1 only for q1 > 0
    check(lg.derive(m), lm, ["q1", "q2"], ranges={"q1": (0.3, 2.0)}, symbolic=False)


# -------------------------------------------------------------------------- 3-link chain
@pytest.mark.slow
def test_three_link_chain():
    g = sp.Symbol("g")
    ms, ls = sp.symbols("m1:4"), sp.symbols("l1:4")
    m = lg.Model("chain", coordinates=["q1", "q2", "q3"],
                 parameters={s.name: None for s in (*ms, *ls, g)})
    x = y = sp.Integer(0)
    for i, q in enumerate(m.q):
        x, y = x + ls[i] * sp.sin(q), y - ls[i] * sp.cos(q)
        m.add_particle(ms[i], (x, y), name=f"bob{i + 1}")
    m.add_gravity(g)

    Qs = dynamicsymbols("q1:4")
    N, O = pendulum_frame()
    parts, prev = [], O
    for i, Q in enumerate(Qs):
        P = prev.locatenew(f"P{i + 1}", ls[i] * sp.sin(Q) * N.x - ls[i] * sp.cos(Q) * N.y)
        P.set_vel(N, P.pos_from(O).dt(N))
        p = Particle(f"bob{i + 1}", P, ms[i])
        p.potential_energy = ms[i] * g * P.pos_from(O).dot(N.y)
        parts.append(p)
        prev = P
    lm = LagrangesMethod(Lagrangian(N, *parts), list(Qs))
    check(lg.derive(m), lm, ["q1", "q2", "q3"])


# ------------------------------------------------------------------------------ damping
def test_two_mass_spring_damper_with_input():
    m1, m2, k1, k2, c1, c2 = sp.symbols("m1 m2 k1 k2 c1 c2")
    m = lg.Model("msd", coordinates=["x1", "x2"],
                 parameters={s.name: None for s in (m1, m2, k1, k2, c1, c2)}, inputs=["F"])
    x1, x2 = m.q
    F = m.symbol("F")
    m.add_point("O", (0, 0))
    m.add_particle(m1, (x1, 0), name="a")
    m.add_particle(m2, (x2, 0), name="b")
    m.add_spring(k1, between=("O", "a"))
    m.add_spring(k2, between=("a", "b"))
    m.add_damper(c1, length=x1)
    m.add_damper(c2, between=("a", "b"))
    m.add_force((F, 0), at="b")

    X1, X2 = dynamicsymbols("x1 x2")
    N, O = pendulum_frame()
    P1, P2 = moving_point("P1", O, N, X1 * N.x), moving_point("P2", O, N, X2 * N.x)
    rel = X2.diff(T_) - X1.diff(T_)
    L = m1 / 2 * X1.diff(T_) ** 2 + m2 / 2 * X2.diff(T_) ** 2 - k1 / 2 * X1**2 - k2 / 2 * (X2 - X1) ** 2
    forces = [(P1, -c1 * X1.diff(T_) * N.x), (P1, c2 * rel * N.x), (P2, -c2 * rel * N.x), (P2, F * N.x)]
    check(lg.derive(m), LagrangesMethod(L, [X1, X2], forcelist=forces, frame=N), ["x1", "x2"])


@pytest.mark.slow
def test_double_pendulum_with_damper_from_pivot_to_second_bob():
    # a damper between the fixed pivot and the second bob: its force -c (d|r|/dt) r/|r| acts
    # along a direction that turns with the configuration (a nonlinear D)
    m1, m2, l1, l2, g, c = sp.symbols("m1 m2 l1 l2 g c")
    m = lg.Model("dpd", coordinates=["q1", "q2"], parameters={s.name: None for s in (m1, m2, l1, l2, g, c)})
    q1, q2 = m.q
    m.add_point("O", (0, 0))
    m.add_particle(m1, (l1 * sp.sin(q1), -l1 * sp.cos(q1)), name="a")
    m.add_particle(m2, (l1 * sp.sin(q1) + l2 * sp.sin(q2), -l1 * sp.cos(q1) - l2 * sp.cos(q2)), name="b")
    m.add_damper(c, between=("O", "b"))
    m.add_gravity(g)

    Q1, Q2 = dynamicsymbols("q1 q2")
    N, O = pendulum_frame()
    P1 = moving_point("P1", O, N, l1 * sp.sin(Q1) * N.x - l1 * sp.cos(Q1) * N.y)
    P2 = moving_point("P2", O, N, (l1 * sp.sin(Q1) + l2 * sp.sin(Q2)) * N.x
                      - (l1 * sp.cos(Q1) + l2 * sp.cos(Q2)) * N.y)
    r = P2.pos_from(O)
    dist = sp.sqrt(r.dot(r))
    rate = r.dot(P2.vel(N)) / dist
    L = (m1 / 2 * P1.vel(N).dot(P1.vel(N)) + m2 / 2 * P2.vel(N).dot(P2.vel(N))
         - m1 * g * P1.pos_from(O).dot(N.y) - m2 * g * r.dot(N.y))
    lm = LagrangesMethod(L, [Q1, Q2], forcelist=[(P2, -c * rate * r / dist)], frame=N)
    check(lg.derive(m), lm, ["q1", "q2"])


# ---------------------------------------------------- rigid body, torque, time dependence
def test_cart_with_rigid_body_pendulum_and_torque():
    mc, mb, I, l, g = sp.symbols("mc mb I l g")
    m = lg.Model("crb", coordinates=["x", "theta"], parameters={s.name: None for s in (mc, mb, I, l, g)},
                 inputs=["tau"])
    x, th = m.q
    tau = m.symbol("tau")
    m.add_particle(mc, (x, 0), name="cart")
    m.add_rigid_body(mb, I, (x + l * sp.sin(th), -l * sp.cos(th)), th, name="rod")
    m.add_torque(tau, body="rod")
    m.add_gravity(g)

    X, TH = dynamicsymbols("x theta")
    N, O = pendulum_frame()
    B = N.orientnew("B", "Axis", [TH, N.z])
    Pc = moving_point("Pc", O, N, X * N.x)
    G = moving_point("G", O, N, (X + l * sp.sin(TH)) * N.x - l * sp.cos(TH) * N.y)
    cart = Particle("cart", Pc, mc)
    rod = RigidBody("rod", G, B, mb, (inertia(B, 0, 0, I), G))
    rod.potential_energy = mb * g * G.pos_from(O).dot(N.y)
    lm = LagrangesMethod(Lagrangian(N, cart, rod), [X, TH], forcelist=[(B, tau * N.z)], frame=N)
    check(lg.derive(m), lm, ["x", "theta"])


def test_rotating_pendulum_time_dependent_position():
    mass, l, g, W = sp.symbols("m l g Omega")
    m = lg.Model("rot", coordinates=["theta"], parameters={s.name: None for s in (mass, l, g, W)})
    (th,) = m.q
    t = lg.t
    m.add_particle(mass, (l * sp.sin(th) * sp.cos(W * t), l * sp.sin(th) * sp.sin(W * t), -l * sp.cos(th)),
                   name="bob")
    m.add_gravity(g)

    TH = dynamicsymbols("theta")
    N, O = pendulum_frame()
    P = moving_point("P", O, N, l * sp.sin(TH) * sp.cos(W * T_) * N.x
                     + l * sp.sin(TH) * sp.sin(W * T_) * N.y - l * sp.cos(TH) * N.z)
    L = mass / 2 * P.vel(N).dot(P.vel(N)) - mass * g * P.pos_from(O).dot(N.z)
    check(lg.derive(m), LagrangesMethod(L, [TH]), ["theta"])


def test_rotating_frame_particle_with_t1_term():
    mass, W, k = sp.symbols("m Omega k")
    m = lg.Model("rf", coordinates=["x", "y"], parameters={"m": None, "Omega": None, "k": None},
                 T="m/2*((x_dot - Omega*y)**2 + (y_dot + Omega*x)**2)", V="k/2*(x**2 + y**2)")
    X, Y = dynamicsymbols("x y")
    xd, yd = X.diff(T_), Y.diff(T_)
    L = mass / 2 * ((xd - W * Y) ** 2 + (yd + W * X) ** 2) - k / 2 * (X**2 + Y**2)
    check(lg.derive(m), LagrangesMethod(L, [X, Y]), ["x", "y"])
