"""Constrained systems cross-checked against sympy.physics.mechanics (a test-only dependency).

Each system is built twice: with `lagrangian` (plain symbols, its own elements and constraints)
and with SymPy's mechanics module (frames, points, particles, rigid bodies, the constraints read
off its own vector algebra where the system has a geometry to read them from). SymPy's
LagrangesMethod writes the constrained equations as

    [ M  -G^T ] [ q_ddot ]   [ f ]
    [ G    0  ] [ lambda ] = [ c ]      (the rows n..2n and 2n.. of mass_matrix_full, forcing_full)

with G the Jacobian of its constraints at velocity level and c from their time derivative, the
same multipliers as ours (M q_ddot = f + G^T lambda, G q_ddot = c). For each system:

- M, f, G and c equal SymPy's at random points (parameters, inputs, t and a state that need not
  meet the constraints) to 1e-10, and symbolically where SymPy simplifies them in good time;
- at random *consistent* states (the coordinates moved onto g(q, t) = 0 and the velocities onto
  G q_dot + b = 0 by SymPy's own constraint functions), the accelerations and multipliers of the
  simulation's numeric solve equal those of SymPy's system to 1e-9, sign included;
- where a closed form or a model without constraints exists (a compound pendulum, the
  double pendulum and the heavy top in angles), our constrained accelerations equal it too.
"""

from __future__ import annotations

import numpy as np
import pytest
import sympy as sp
from sympy.physics.mechanics import LagrangesMethod, Lagrangian, Particle, RigidBody, dynamicsymbols, inertia

import lagrangian as lg
from lagrangian.numeric._compiled import compile_equations
from lagrangian.numeric._constrained import constrained_model
from test_crosscheck_sympy import T_, is_zero, moving_point, pendulum_frame, to_plain


# ------------------------------------------------------------------------------- helpers
def plain(expr, names):
    """q(t)'' -> q_ddot, q(t)' -> q_dot, q(t) -> q in a matrix or a list, every one mapped."""
    out = to_plain(expr, names)
    assert not out.atoms(sp.Derivative), "the mapping to plain symbols is complete"
    return out


def sympy_parts(lm, names, hol=(), nonhol=()):
    """M, f, G, c, the multipliers' coefficients and the constraint functions of SymPy's system,
    in plain symbols. `hol` and `nonhol` are the constraints given to LagrangesMethod."""
    lm.form_lagranges_equations()
    n = len(names)
    MM, FF = lm.mass_matrix_full, lm.forcing_full
    assert MM.shape == (2 * n + len(hol) + len(nonhol),) * 2
    qs = [dynamicsymbols(k) for k in names]
    w = [sp.diff(g, T_) for g in hol] + list(nonhol)  # the velocity residuals, hol first as in SymPy
    return {"M": plain(MM[n:2 * n, n:2 * n], names), "f": plain(FF[n:2 * n, :], names),
            "G": plain(MM[2 * n:, n:2 * n], names), "c": plain(FF[2 * n:, :], names),
            "lambda_coefficients": plain(MM[n:2 * n, 2 * n:], names),
            "g": plain(list(hol), names) if hol else sp.zeros(0, 1), "w": plain(w, names), "q": qs}


def ours_parts(eq):
    return {"M": sp.Matrix(eq.mass_matrix), "f": sp.Matrix(eq.forcing), "G": sp.Matrix(eq.constraint_jacobian),
            "c": sp.Matrix(eq.constraint_acceleration)}


def numeric(matrix):
    """A function of {name: value} giving the matrix as a float array."""
    syms = sorted(matrix.free_symbols, key=str)
    fn = sp.lambdify(syms, matrix, "numpy")
    return lambda values: np.array(fn(*[values[s.name] for s in syms]), dtype=float)


class System:
    """One constrained system built twice, with the ranges its random points are drawn from."""

    def __init__(self, eq, lm, names, *, hol=(), nonhol=(), params, inputs=None, coordinates=None, t=(0.0, 3.0)):
        self.eq, self.names = eq, list(names)
        assert [c.name for c in eq.coordinates] == self.names
        self.ours = ours_parts(eq)
        self.theirs = sympy_parts(lm, names, hol, nonhol)
        self.params, self.inputs = params, inputs or {}
        self.coordinates = coordinates or {}
        self.t = t
        self.n, self.m = len(names), len(hol) + len(nonhol)
        assert [c.name for c in eq.model.constraints] and len(eq.model.constraints) == self.m
        self.rng = np.random.default_rng(11)

    def point(self):
        """Random values of every name: parameters, inputs, t, coordinates, velocities."""
        r = self.rng
        v = {k: r.uniform(*rg) for k, rg in self.params.items()}
        v.update({k: r.uniform(*rg) for k, rg in self.inputs.items()})
        v["t"] = r.uniform(*self.t)
        for k in self.names:
            v[k] = r.uniform(*self.coordinates.get(k, (-1.5, 1.5)))
            v[k + "_dot"] = r.uniform(-2.0, 2.0)
        return v

    def consistent(self, v):
        """`v` with its coordinates moved onto g(q, t) = 0 (Gauss-Newton, smallest change) and its
        velocities onto the velocity constraints (smallest change), by SymPy's constraint functions."""
        th = self.theirs
        q = sp.Matrix([sp.Symbol(k) for k in self.names])
        qd = sp.Matrix([sp.Symbol(k + "_dot") for k in self.names])
        v = dict(v)
        if th["g"].rows:
            g, Gq = numeric(th["g"]), numeric(th["g"].jacobian(q))
            for _ in range(50):
                r = g(v).ravel()
                if np.max(np.abs(r)) < 1e-15:
                    break
                step = np.linalg.lstsq(Gq(v), r, rcond=None)[0]
                for k, d in zip(self.names, step):
                    v[k] -= d
            assert np.max(np.abs(g(v))) < 1e-13
        w = th["w"]
        Gw, b = numeric(w.jacobian(qd)), numeric(w.subs({s: 0 for s in qd}))
        step = np.linalg.lstsq(Gw(v), (Gw(v) @ np.array([v[k + "_dot"] for k in self.names]) + b(v).ravel()),
                               rcond=None)[0]
        for k, d in zip(self.names, step):
            v[k + "_dot"] -= d
        assert np.max(np.abs(numeric(w)(v))) < 1e-12
        return v

    def state(self, v):
        return np.array([v[k] for k in self.eq.state_names])

    def check_matrices(self, *, symbolic=True, points=6):
        """Our M, f, G, c equal SymPy's at random points (and symbolically)."""
        ours, theirs = self.ours, self.theirs
        for key in ("M", "f", "G", "c"):
            assert ours[key].shape == theirs[key].shape, key
        # SymPy's multipliers multiply -G^T: the same convention as ours, M q_ddot = f + G^T lambda
        assert sp.simplify(theirs["lambda_coefficients"] + theirs["G"].T) == sp.zeros(self.n, self.m)
        fns = {key: (numeric(ours[key]), numeric(theirs[key])) for key in ("M", "f", "G", "c")}
        nonzero = {key: 0.0 for key in fns}
        for _ in range(points):
            v = self.point()
            for key, (a, b) in fns.items():
                x, y = a(v), b(v)
                assert np.allclose(x, y, rtol=1e-10, atol=1e-10), (key, x, y)
                nonzero[key] = max(nonzero[key], float(np.max(np.abs(y))))
        assert all(value > 1e-3 for value in nonzero.values()), ("a part that vanishes tests little", nonzero)
        if symbolic:
            for key in ("M", "f", "G", "c"):
                bad = [i for i, (a, b) in enumerate(zip(ours[key], theirs[key])) if not is_zero(a - b)]
                assert not bad, f"{key} differs at {bad}: ours {ours[key]}, SymPy's {theirs[key]}"

    def check_solution(self, states=4):
        """At random consistent states: our (q_ddot, lambda), from the simulation's numeric solve,
        equal SymPy's; returns the states and our results for further checks."""
        eq = self.eq
        cm = constrained_model(eq, compile_equations(eq))
        th = self.theirs
        K = numeric(sp.Matrix(sp.BlockMatrix([[th["M"], th["lambda_coefficients"]], [th["G"], sp.zeros(self.m)]])))
        rhs = numeric(th["f"].col_join(th["c"]))
        out = []
        for _ in range(states):
            v = self.consistent(self.point())
            p = np.array([v[s.name] for s in eq.parameters])
            u = np.array([v[s.name] for s in eq.inputs])
            qdd, lam = cm.solve(v["t"], self.state(v), u, p)
            z = np.linalg.solve(K(v), rhs(v).ravel())
            assert np.allclose(qdd, z[:self.n], rtol=1e-9, atol=1e-9), (qdd, z[:self.n])
            assert np.allclose(lam, z[self.n:], rtol=1e-9, atol=1e-9), (lam, z[self.n:])
            assert np.max(np.abs(lam)) > 1e-3 and np.max(np.abs(qdd)) > 1e-3
            out.append((v, qdd, lam))
        return out


POSITIVE = (0.5, 2.0)


# --------------------------------------------------------------- spherical pendulum in 3D
def spherical_3d():
    m, g, l = sp.symbols("m g l")
    model = lg.Model("sph3", coordinates=["x", "y", "z"], parameters={"m": None, "g": None, "l": None})
    model.add_particle(m, ("x", "y", "z"), name="bob")
    model.add_gravity(g)  # -z in space
    model.add_constraint("l - sqrt(x**2 + y**2 + z**2)", name="rod")

    X, Y, Z = dynamicsymbols("x y z")
    N, O = pendulum_frame()
    P = moving_point("P", O, N, X * N.x + Y * N.y + Z * N.z)
    bob = Particle("bob", P, m)
    bob.potential_energy = m * g * P.pos_from(O).dot(N.z)
    hol = [l - P.pos_from(O).magnitude()]
    lm = LagrangesMethod(Lagrangian(N, bob), [X, Y, Z], hol_coneqs=hol)
    return System(lg.derive(model), lm, "x y z".split(), hol=hol, params={"m": POSITIVE, "g": (5, 12), "l": POSITIVE})


def test_spherical_pendulum_as_a_particle_in_space():
    s = spherical_3d()
    s.check_matrices()
    for v, qdd, lam in s.check_solution():
        # the rod's tension from the particle's radial balance: m |v|^2 / l = lambda + m g z / l
        speed2 = sum(v[k + "_dot"] ** 2 for k in "xyz")
        assert lam[0] == pytest.approx(v["m"] * (speed2 - v["g"] * v["z"]) / v["l"], rel=1e-10)


# --------------------------------------------------------- double pendulum in Cartesian coordinates
def double_pendulum_cartesian():
    m1, m2, l1, l2, g = sp.symbols("m1 m2 l1 l2 g")
    model = lg.Model("dpc", coordinates=["x1", "y1", "x2", "y2"], parameters={k: None for k in ("m1", "m2", "l1",
                                                                                              "l2", "g")})
    model.add_particle(m1, ("x1", "y1"), name="bob1")
    model.add_particle(m2, ("x2", "y2"), name="bob2")
    model.add_gravity(g)
    model.add_constraint("l1 - sqrt(x1**2 + y1**2)", name="rod1")
    model.add_constraint("l2 - sqrt((x2 - x1)**2 + (y2 - y1)**2)", name="rod2")

    X1, Y1, X2, Y2 = dynamicsymbols("x1 y1 x2 y2")
    N, O = pendulum_frame()
    P1 = moving_point("P1", O, N, X1 * N.x + Y1 * N.y)
    P2 = moving_point("P2", O, N, X2 * N.x + Y2 * N.y)
    a, b = Particle("a", P1, m1), Particle("b", P2, m2)
    a.potential_energy = m1 * g * P1.pos_from(O).dot(N.y)
    b.potential_energy = m2 * g * P2.pos_from(O).dot(N.y)
    hol = [l1 - P1.pos_from(O).magnitude(), l2 - P2.pos_from(P1).magnitude()]
    lm = LagrangesMethod(Lagrangian(N, a, b), [X1, Y1, X2, Y2], hol_coneqs=hol)
    return System(lg.derive(model), lm, "x1 y1 x2 y2".split(), hol=hol,
                  params={k: POSITIVE for k in ("m1", "m2", "l1", "l2")} | {"g": (5, 12)})


@pytest.mark.slow
def test_double_pendulum_in_cartesian_coordinates_with_two_rods():
    s = double_pendulum_cartesian()
    s.check_matrices()
    # a third derivation: the double pendulum in angles (no constraints), its accelerations mapped
    angles = lg.derive(lg.load("double-pendulum"))
    nm = compile_equations(angles)
    for v, qdd, lam in s.check_solution():
        x1, y1, x2, y2 = (v[k] for k in ("x1", "y1", "x2", "y2"))
        th1, th2 = np.arctan2(x1, -y1), np.arctan2(x2 - x1, -(y2 - y1))
        # x1 = l1 sin th1, y1 = -l1 cos th1: th1_dot = (x1_dot cos th1 + y1_dot sin th1) / l1
        d1 = (v["x1_dot"] * np.cos(th1) + v["y1_dot"] * np.sin(th1)) / v["l1"]
        d2 = ((v["x2_dot"] - v["x1_dot"]) * np.cos(th2) + (v["y2_dot"] - v["y1_dot"]) * np.sin(th2)) / v["l2"]
        p = np.array([v[s_.name] for s_ in angles.parameters])
        a1, a2 = nm.rhs(0.0, np.array([th1, th2, d1, d2]), np.zeros(0), p)[2:]
        x1dd = v["l1"] * (np.cos(th1) * a1 - np.sin(th1) * d1**2)
        y1dd = v["l1"] * (np.sin(th1) * a1 + np.cos(th1) * d1**2)
        x2dd = x1dd + v["l2"] * (np.cos(th2) * a2 - np.sin(th2) * d2**2)
        y2dd = y1dd + v["l2"] * (np.sin(th2) * a2 + np.cos(th2) * d2**2)
        assert np.allclose(qdd, [x1dd, y1dd, x2dd, y2dd], rtol=1e-9, atol=1e-9)


# -------------------------------------------- bead on a rotating hoop: a rheonomic constraint g(q, t)
def bead_on_rotating_hoop():
    m, g, R, Om = sp.symbols("m g R Omega")
    model = lg.Model("hoop", coordinates=["x", "y", "z"], parameters={"m": None, "g": None, "R": None,
                                                                     "Omega": None})
    model.add_particle(m, ("x", "y", "z"), name="bead")
    model.add_gravity(g)
    model.add_constraint("R - sqrt(x**2 + y**2 + z**2)", name="hoop")
    model.add_constraint("x*sin(Omega*t) - y*cos(Omega*t)", name="plane")  # the hoop's plane turns at Omega

    X, Y, Z = dynamicsymbols("x y z")
    N, O = pendulum_frame()
    H = N.orientnew("H", "Axis", (Om * T_, N.z))  # the hoop's frame: its plane is H.x, H.z
    P = moving_point("P", O, N, X * N.x + Y * N.y + Z * N.z)
    bead = Particle("bead", P, m)
    bead.potential_energy = m * g * P.pos_from(O).dot(N.z)
    hol = [R - P.pos_from(O).magnitude(), -P.pos_from(O).dot(H.y)]
    lm = LagrangesMethod(Lagrangian(N, bead), [X, Y, Z], hol_coneqs=hol)
    return System(lg.derive(model), lm, "x y z".split(), hol=hol,
                  params={"m": POSITIVE, "g": (5, 12), "R": POSITIVE, "Omega": (1.0, 5.0)})


def test_bead_on_a_rotating_hoop_written_with_a_time_dependent_constraint():
    s = bead_on_rotating_hoop()
    assert "t" in {x.name for x in s.ours["c"].free_symbols}  # rheonomic: c depends on t explicitly
    s.check_matrices()
    for v, qdd, lam in s.check_solution():
        # the textbook equation in the hoop's angle th from the bottom: th_ddot = (Omega^2 cos th - g/R) sin th
        x, y, z, Om, t = v["x"], v["y"], v["z"], v["Omega"], v["t"]
        rho = x * np.cos(Om * t) + y * np.sin(Om * t)  # the distance from the axis, signed in the hoop's plane
        th = np.arctan2(rho, -z)
        # th_ddot from the Cartesian accelerations: in the hoop's frame, rho_ddot - Omega^2 rho etc.
        xdd, ydd, zdd = qdd
        xd, yd = v["x_dot"], v["y_dot"]
        rho_dot = xd * np.cos(Om * t) + yd * np.sin(Om * t) + Om * (-x * np.sin(Om * t) + y * np.cos(Om * t))
        rho_ddot = (xdd * np.cos(Om * t) + ydd * np.sin(Om * t) + 2 * Om * (-xd * np.sin(Om * t) + yd * np.cos(Om * t))
                    - Om**2 * (x * np.cos(Om * t) + y * np.sin(Om * t)))
        th_dot = (rho_dot * np.cos(th) + v["z_dot"] * np.sin(th)) / v["R"]
        th_ddot = (rho_ddot * np.cos(th) + zdd * np.sin(th)) / v["R"]  # tangential component / R
        assert th_ddot == pytest.approx((Om**2 * np.cos(th) - v["g"] / v["R"]) * np.sin(th), rel=1e-9, abs=1e-9)
        assert np.isfinite(th_dot)


# ------------------------------------------------ Chaplygin sled: a velocity (nonholonomic) constraint
def chaplygin_sled():
    m, J, a, g, tau = sp.symbols("m J a g tau")
    model = lg.Model("sled", coordinates=["x", "y", "phi"], parameters={"m": None, "J": None, "a": None, "g": None},
                     inputs=["tau"])
    model.add_rigid_body(m, J, position=("x + a*cos(phi)", "y + a*sin(phi)"), angle="phi", name="sled")
    model.add_gravity(g)  # the plane tilted: g is the slope's component of gravity, along -y
    model.add_torque(tau, body="sled", name="steer")
    model.add_velocity_constraint("-x_dot*sin(phi) + y_dot*cos(phi)", name="blade")

    X, Y, PHI = dynamicsymbols("x y phi")
    N, O = pendulum_frame()
    B = N.orientnew("B", "Axis", (PHI, N.z))
    B.set_ang_vel(N, PHI.diff(T_) * N.z)
    contact = moving_point("contact", O, N, X * N.x + Y * N.y)  # the blade, along B.x
    C = moving_point("C", O, N, contact.pos_from(O) + a * B.x)
    sled = RigidBody("sled", C, B, m, (inertia(B, 0, 0, J), C))
    sled.potential_energy = m * g * C.pos_from(O).dot(N.y)
    nonhol = [contact.vel(N).dot(B.y)]
    lm = LagrangesMethod(Lagrangian(N, sled), [X, Y, PHI], nonhol_coneqs=nonhol, forcelist=[(B, tau * N.z)], frame=N)
    return System(lg.derive(model), lm, "x y phi".split(), nonhol=nonhol,
                  params={"m": POSITIVE, "J": POSITIVE, "a": (0.2, 1.0), "g": (5, 12)}, inputs={"tau": (-1, 1)},
                  coordinates={"phi": (-3.0, 3.0)})


def test_chaplygin_sled_with_a_knife_edge_velocity_constraint_a_slope_and_a_torque():
    s = chaplygin_sled()
    assert s.eq.model.constraints[0].kind == "velocity"
    s.check_matrices()
    for v, qdd, lam in s.check_solution():
        # the blade's force is the only force across it: m times the centre's acceleration across the
        # blade, minus gravity's component across it, is lambda (G's row is the unit normal (-sin, cos, 0))
        phi, a, pd = v["phi"], v["a"], v["phi_dot"]
        acc_c = np.array([qdd[0] - a * (np.sin(phi) * qdd[2] + np.cos(phi) * pd**2),
                          qdd[1] + a * (np.cos(phi) * qdd[2] - np.sin(phi) * pd**2)])
        normal = np.array([-np.sin(phi), np.cos(phi)])
        assert v["m"] * acc_c @ normal + v["m"] * v["g"] * normal[1] == pytest.approx(lam[0], rel=1e-9, abs=1e-9)


# -------------------------------------------- a planar rigid body pinned at a point by two constraints
def pinned_body():
    m, J, d, g, tau = sp.symbols("m J d g tau")
    model = lg.Model("pinned", coordinates=["x", "y", "theta"], parameters={"m": None, "J": None, "d": None,
                                                                           "g": None}, inputs=["tau"])
    model.add_rigid_body(m, J, position=("x", "y"), angle="theta", name="body")
    model.add_gravity(g)
    model.add_torque(tau, body="body", name="motor")
    model.add_constraint("x - d*sin(theta)", name="pin_x")  # the body's point (0, d) held at the origin
    model.add_constraint("y + d*cos(theta)", name="pin_y")

    X, Y, TH = dynamicsymbols("x y theta")
    N, O = pendulum_frame()
    B = N.orientnew("B", "Axis", (TH, N.z))
    B.set_ang_vel(N, TH.diff(T_) * N.z)
    C = moving_point("C", O, N, X * N.x + Y * N.y)
    pin = C.locatenew("pin", d * B.y)
    body = RigidBody("body", C, B, m, (inertia(B, 0, 0, J), C))
    body.potential_energy = m * g * C.pos_from(O).dot(N.y)
    hol = [pin.pos_from(O).dot(N.x), pin.pos_from(O).dot(N.y)]
    lm = LagrangesMethod(Lagrangian(N, body), [X, Y, TH], hol_coneqs=hol, forcelist=[(B, tau * N.z)], frame=N)
    return System(lg.derive(model), lm, "x y theta".split(), hol=hol,
                  params={"m": POSITIVE, "J": POSITIVE, "d": POSITIVE, "g": (5, 12)}, inputs={"tau": (-1, 1)},
                  coordinates={"theta": (-3.0, 3.0)})


def test_planar_body_pinned_at_a_point_by_two_constraints_is_a_compound_pendulum():
    s = pinned_body()
    s.check_matrices()
    for v, qdd, lam in s.check_solution():
        th, thd = v["theta"], v["theta_dot"]
        m, J, d, g = v["m"], v["J"], v["d"], v["g"]
        # (J + m d^2) theta_ddot = -m g d sin(theta) + tau
        assert qdd[2] == pytest.approx((-m * g * d * np.sin(th) + v["tau"]) / (J + m * d**2), rel=1e-10)
        # the pin's force (lambda: its components, G = dg/dq has the identity in x, y) moves the centre
        acc = np.array([d * (np.cos(th) * qdd[2] - np.sin(th) * thd**2),
                        d * (np.sin(th) * qdd[2] + np.cos(th) * thd**2)])
        assert np.allclose(lam, m * acc + np.array([0.0, m * g]), rtol=1e-10, atol=1e-10)


# ---------------------------------------------- heavy top: a body in space with its tip held by three constraints
def top_with_held_tip():
    m, A, C_, l, g = sp.symbols("m A C l g")
    names = ["x", "y", "z", "phi", "theta", "psi"]
    model = lg.Model("top6", coordinates=names, parameters={k: None for k in ("m", "A", "C", "l", "g")})
    model.add_frame("body", origin=("x", "y", "z"), rotation=[("z", "phi"), ("x", "theta"), ("z", "psi")])
    model.add_rigid_body(m, (A, A, C_), frame="body", name="top")  # centroidal inertia, centre at the origin
    model.add_gravity(g)
    # the tip, at -l along the body's z axis from the centre, held at the world's origin
    model.add_constraint("x - l*sin(phi)*sin(theta)", name="tip_x")
    model.add_constraint("y + l*cos(phi)*sin(theta)", name="tip_y")
    model.add_constraint("z - l*cos(theta)", name="tip_z")

    X, Y, Z, PHI, TH, PSI = dynamicsymbols(" ".join(names))
    N, O = pendulum_frame()
    B = N.orientnew("B", "Body", (PHI, TH, PSI), "ZXZ")
    C = moving_point("C", O, N, X * N.x + Y * N.y + Z * N.z)
    tip = C.locatenew("tip", -l * B.z)
    top = RigidBody("top", C, B, m, (inertia(B, A, A, C_), C))
    top.potential_energy = m * g * C.pos_from(O).dot(N.z)
    hol = [tip.pos_from(O).dot(N.x), tip.pos_from(O).dot(N.y), tip.pos_from(O).dot(N.z)]
    lm = LagrangesMethod(Lagrangian(N, top), [X, Y, Z, PHI, TH, PSI], hol_coneqs=hol)
    return System(lg.derive(model), lm, names, hol=hol,
                  params={"m": POSITIVE, "A": (0.5, 1.0), "C": (0.2, 0.5), "l": POSITIVE, "g": (5, 12)},
                  coordinates={"theta": (0.3, 1.3), "phi": (-3.0, 3.0), "psi": (-3.0, 3.0)})


@pytest.mark.slow
def test_heavy_top_as_a_free_body_with_its_tip_held_by_three_constraints():
    s = top_with_held_tip()
    s.check_matrices()
    # a third derivation: the heavy-top example (the same top in Euler angles about its tip)
    angles = lg.derive(lg.load("heavy-top"))
    nm = compile_equations(angles)
    order = [c.name for c in angles.coordinates]  # theta, phi, psi
    for v, qdd, lam in s.check_solution():
        values = {"m": v["m"], "l": v["l"], "g": v["g"], "I1": v["A"] + v["m"] * v["l"] ** 2, "I3": v["C"]}
        p = np.array([values[k.name] for k in angles.parameters])
        x = np.array([v[k] for k in order] + [v[k + "_dot"] for k in order])
        expected = nm.rhs(0.0, x, np.zeros(0), p)[3:]
        ours = qdd[[s.names.index(k) for k in order]]
        assert np.allclose(ours, expected, rtol=1e-9, atol=1e-9)


# ------------------------- a wheel rolling upright on a moving belt: holonomic and velocity constraints with b(q, t)
def wheel_on_a_belt():
    m, A1, A3, C_, R, g, V, w, tau = sp.symbols("m A1 A3 C R g V omega tau")
    names = ["x", "y", "z", "phi", "theta"]
    model = lg.Model("belt", coordinates=names, parameters={k: None for k in ("m", "A1", "A3", "C", "R", "g", "V",
                                                                              "omega")}, inputs=["tau"])
    # heading phi about the vertical, then the spin theta about the axle (the frame's y axis)
    model.add_frame("wheel", origin=("x", "y", "z"), rotation=[("z", "phi"), ("y", "theta")])
    model.add_rigid_body(m, (A1, C_, A3), frame="wheel", name="wheel")  # unequal transverse moments: M(theta)
    model.add_gravity(g)
    model.add_torque((0, tau, 0), body="wheel", name="drive")  # about the axle
    model.add_constraint("z - R", name="contact")
    # the rim's point at the contact moves with the belt, V*sin(omega*t) along x
    model.add_velocity_constraint("x_dot - R*theta_dot*cos(phi) - V*sin(omega*t)", name="roll_x")
    model.add_velocity_constraint("y_dot - R*theta_dot*sin(phi)", name="roll_y")

    X, Y, Z, PHI, TH = dynamicsymbols(" ".join(names))
    N, O = pendulum_frame()
    H = N.orientnew("H", "Axis", (PHI, N.z))
    B = H.orientnew("B", "Axis", (TH, H.y))
    C = moving_point("C", O, N, X * N.x + Y * N.y + Z * N.z)
    contact = C.locatenew("contact", -R * N.z)
    contact.v2pt_theory(C, N, B)  # the rim's material point at the contact
    wheel = RigidBody("wheel", C, B, m, (inertia(B, A1, C_, A3), C))
    wheel.potential_energy = m * g * C.pos_from(O).dot(N.z)
    hol = [C.pos_from(O).dot(N.z) - R]
    slip = contact.vel(N) - V * sp.sin(w * T_) * N.x
    nonhol = [slip.dot(N.x), slip.dot(N.y)]
    lm = LagrangesMethod(Lagrangian(N, wheel), [X, Y, Z, PHI, TH], hol_coneqs=hol, nonhol_coneqs=nonhol,
                         forcelist=[(B, tau * B.y)], frame=N)
    return System(lg.derive(model), lm, names, hol=hol, nonhol=nonhol,
                  params={"m": POSITIVE, "A1": (0.3, 0.5), "A3": (0.6, 0.8), "C": (0.5, 0.9), "R": POSITIVE,
                          "g": (5, 12), "V": POSITIVE, "omega": (1.0, 3.0)}, inputs={"tau": (-1, 1)},
                  coordinates={"phi": (-3.0, 3.0), "theta": (-3.0, 3.0)})


def test_wheel_rolling_upright_on_a_moving_belt_mixes_holonomic_and_time_dependent_velocity_constraints():
    s = wheel_on_a_belt()
    assert [c.kind for c in s.eq.model.constraints] == ["holonomic", "velocity", "velocity"]
    assert "t" in {x.name for x in s.ours["c"].free_symbols}  # the belt's acceleration
    s.check_matrices()
    for v, qdd, lam in s.check_solution():
        # the contact's normal force carries the weight (z stays at R): lambda_contact = m g
        assert qdd[2] == pytest.approx(0.0, abs=1e-12) and lam[0] == pytest.approx(v["m"] * v["g"], rel=1e-12)
        # the belt drives the wheel's centre:
        # x_ddot = R (theta_ddot cos phi - theta_dot phi_dot sin phi) + V omega cos(omega t)
        phi, pd, td = v["phi"], v["phi_dot"], v["theta_dot"]
        assert qdd[0] == pytest.approx(v["R"] * (qdd[4] * np.cos(phi) - td * pd * np.sin(phi))
                                       + v["V"] * v["omega"] * np.cos(v["omega"] * v["t"]), rel=1e-9, abs=1e-9)
