"""Frames and rigid bodies in space: the heavy top, a body with a full inertia tensor, a two-joint
arm with a motor torque and a body-fixed force, each cross-checked against
sympy.physics.mechanics' LagrangesMethod; conserved quantities in simulation; and every error a
user can hit."""

from __future__ import annotations

import math

import numpy as np
import pytest
import sympy as sp
from sympy.physics.mechanics import (LagrangesMethod, Lagrangian, Point, ReferenceFrame, RigidBody,
                                     dynamicsymbols, inertia)

import lagrangian as lg
from test_crosscheck_sympy import check

S = sp.Symbol


def _top_model(rotation=None):
    m = lg.Model("top3d")
    th, ph, ps = m.coordinate("theta", "phi", "psi")
    M, l, g, I1, I3 = (m.parameter(n, v) for n, v in [("m", 1.0), ("l", 0.1), ("g", 9.81), ("I1", 0.02),
                                                       ("I3", 0.01)])
    m.add_frame("body", rotation=rotation or [("z", ph), ("x", th), ("z", ps)])
    # I1 about the tip: the centroidal transverse moment is I1 - m l^2
    m.add_rigid_body(M, (I1 - M * l**2, I1 - M * l**2, I3), frame="body", center=(0, 0, l), name="top")
    m.add_gravity(g)
    return m


def test_heavy_top_from_a_body_in_space_equals_the_textbook_energies():
    ours = lg.derive(_top_model())
    textbook = lg.derive(lg.load("heavy-top"))
    for a, b in zip(ours.equations, textbook.equations):
        assert sp.simplify(a - b) == 0
    I1, I3, th = S("I1"), S("I3"), S("theta")
    assert ours.mass_matrix == sp.Matrix([[I1, 0, 0], [0, I1 * sp.sin(th) ** 2 + I3 * sp.cos(th) ** 2, I3 * sp.cos(th)],
                                          [0, I3 * sp.cos(th), I3]])


def test_heavy_top_against_lagranges_method():
    th, ph, ps = dynamicsymbols("theta phi psi")
    m, l, g, I1, I3 = sp.symbols("m l g I1 I3")
    N = ReferenceFrame("N")
    B = N.orientnew("B", "Body", (ph, th, ps), "ZXZ")
    O = Point("O")
    O.set_vel(N, 0)
    G = O.locatenew("G", l * B.z)
    G.v2pt_theory(O, N, B)
    top = RigidBody("top", G, B, m, (inertia(B, I1 - m * l**2, I1 - m * l**2, I3), G))
    top.potential_energy = m * g * l * sp.cos(th)
    lm = LagrangesMethod(Lagrangian(N, top), [th, ph, ps])
    check(lg.derive(_top_model()), lm, ["theta", "phi", "psi"], ranges={"theta": (0.3, 1.3)}, symbolic=False)


def _free_body_model(matrix=False):
    m = lg.Model("tumbling")
    yaw, pitch, roll = m.coordinate("yaw", "pitch", "roll")
    mass, g, a, b, c = (m.parameter(n, v) for n, v in [("m", 2.0), ("g", 9.81), ("a", 0.1), ("b", -0.2), ("c", 0.3)])
    Ixx, Iyy, Izz, Ixy, Iyz, Izx = (m.parameter(n, v) for n, v in
                                    [("Ixx", 0.5), ("Iyy", 0.6), ("Izz", 0.7), ("Ixy", 0.05), ("Iyz", -0.02),
                                     ("Izx", 0.03)])
    if matrix:  # the same rotation written as a matrix: Rz(yaw) Ry(pitch) Rx(roll)
        from lagrangian.model._frames import elementary

        R = elementary((0, 0, 1), yaw) * elementary((0, 1, 0), pitch) * elementary((1, 0, 0), roll)
        m.add_frame("body", rotation=R)
    else:
        m.add_frame("body", rotation=[("z", yaw), ("y", pitch), ("x", roll)])
    m.add_rigid_body(mass, (Ixx, Iyy, Izz, Ixy, Iyz, Izx), frame="body", center=(a, b, c), name="block")
    m.add_gravity(g)
    return m


def test_body_with_a_full_inertia_tensor_against_lagranges_method():
    yaw, pitch, roll = dynamicsymbols("yaw pitch roll")
    m, g, a, b, c = sp.symbols("m g a b c")
    Ixx, Iyy, Izz, Ixy, Iyz, Izx = sp.symbols("Ixx Iyy Izz Ixy Iyz Izx")
    N = ReferenceFrame("N")
    B = N.orientnew("B", "Body", (yaw, pitch, roll), "ZYX")
    O = Point("O")
    O.set_vel(N, 0)
    G = O.locatenew("G", a * B.x + b * B.y + c * B.z)
    G.v2pt_theory(O, N, B)
    body = RigidBody("block", G, B, m, (inertia(B, Ixx, Iyy, Izz, Ixy, Iyz, Izx), G))
    body.potential_energy = m * g * G.pos_from(O).dot(N.z)
    lm = LagrangesMethod(Lagrangian(N, body), [yaw, pitch, roll])
    check(lg.derive(_free_body_model()), lm, ["yaw", "pitch", "roll"], ranges={"pitch": (-1.2, 1.2)},
          symbolic=False)


def test_a_rotation_written_as_a_matrix_gives_the_same_equations():
    a, b = lg.derive(_free_body_model()), lg.derive(_free_body_model(matrix=True))
    f = sp.lambdify(sorted(a.mass_matrix.free_symbols | a.forcing.free_symbols | b.forcing.free_symbols, key=str),
                    [a.mass_matrix - b.mass_matrix, a.forcing - b.forcing], "numpy")
    rng = np.random.default_rng(1)
    for _ in range(5):
        dM, df = f(*rng.uniform(0.2, 1.2, len(f.__code__.co_varnames)))
        assert np.abs(np.array(dM, dtype=float)).max() < 1e-12 and np.abs(np.array(df, dtype=float)).max() < 1e-12


def _arm_model():
    m = lg.Model("arm")
    q1, q2 = m.coordinate("q1", "q2")
    m1, m2, h, L, g = (m.parameter(n, v) for n, v in [("m1", 2.0), ("m2", 1.0), ("h", 0.5), ("L", 0.8), ("g", 9.81)])
    J1, J2x, J2y, J2z = (m.parameter(n, v) for n, v in [("J1", 0.05), ("J2x", 0.06), ("J2y", 0.01), ("J2z", 0.06)])
    u, F = m.input("u"), m.input("F")
    m.add_frame("base", rotation=[("z", q1)])
    m.add_frame("link", parent="base", origin=(0, 0, h), rotation=[("x", q2)])
    m.add_rigid_body(m1, (J1, J1, J1), frame="base", center=(0, 0, h / 2), name="column")
    m.add_rigid_body(m2, (J2x, J2y, J2z), frame="link", center=(0, L / 2, 0), name="link")
    m.add_gravity(g)
    m.add_torque((u, 0, 0), body="link")  # a motor about the link's own x axis
    m.add_point("tip", (0, L, 0), frame="link")
    m.add_force((0, 0, F), at="tip", frame="link")  # a push along the link's z axis, at its tip
    return m


def test_two_joint_arm_with_a_motor_torque_and_a_body_fixed_force_against_lagranges_method():
    q1, q2 = dynamicsymbols("q1 q2")
    m1, m2, h, L, g, J1, J2x, J2y, J2z, u, F = sp.symbols("m1 m2 h L g J1 J2x J2y J2z u F")
    N = ReferenceFrame("N")
    A = N.orientnew("A", "Axis", (q1, N.z))
    B = A.orientnew("B", "Axis", (q2, A.x))
    O = Point("O")
    O.set_vel(N, 0)
    G1 = O.locatenew("G1", h / 2 * A.z)
    G1.v2pt_theory(O, N, A)
    P = O.locatenew("P", h * A.z)
    P.v2pt_theory(O, N, A)
    G2 = P.locatenew("G2", L / 2 * B.y)
    G2.v2pt_theory(P, N, B)
    tip = P.locatenew("tip", L * B.y)
    tip.v2pt_theory(P, N, B)
    column = RigidBody("column", G1, A, m1, (inertia(A, J1, J1, J1), G1))
    link = RigidBody("link", G2, B, m2, (inertia(B, J2x, J2y, J2z), G2))
    column.potential_energy = m1 * g * G1.pos_from(O).dot(N.z)
    link.potential_energy = m2 * g * G2.pos_from(O).dot(N.z)
    lm = LagrangesMethod(Lagrangian(N, column, link), [q1, q2], forcelist=[(B, u * B.x), (tip, F * B.z)], frame=N)
    eqs = lg.derive(_arm_model())
    check(eqs, lm, ["q1", "q2"], symbolic=False)
    # the motor acts on q2 alone; the push at the tip, normal to the link, on q2 with the arm L
    assert eqs.input_matrix == sp.Matrix([[0, 0], [1, L]])


def test_torque_free_body_conserves_energy_and_angular_momentum():
    eqs = lg.derive(_free_body_model())
    traj = lg.simulate(eqs, t_end=3.0, initial={"yaw_dot": 0.4, "pitch_dot": -0.7, "roll_dot": 1.1},
                       params={"g": 0.0}, rtol=1e-11, atol=1e-11)
    drift = traj.conserved_drift()
    assert drift["energy"] < 1e-9
    assert drift["p_yaw"] < 1e-9  # yaw turns about the vertical: its momentum, the vertical angular momentum
    assert np.ptp(traj["roll"]) > 0.5  # it does tumble


def test_heavy_top_precesses_steadily_as_the_closed_form_says():
    eqs = lg.derive(_top_model())
    found = [s for s in lg.steady_motions(eqs, {"phi_dot": 2.0, "psi_dot": 50.0}) if 0 < s.coordinates["theta"] < 3]
    (s,) = found
    theta, I1, I3 = s.coordinates["theta"], 0.02, 0.01
    omega3 = 50.0 + 2.0 * math.cos(theta)
    assert I1 * 4 * math.cos(theta) - I3 * omega3 * 2 + 0.981 == pytest.approx(0, abs=1e-12)


# ----------------------------------------------------------------------------- errors
def test_frame_and_body_errors_name_the_problem():
    m = lg.Model("bad")
    m.coordinate("q")
    with pytest.raises(lg.ModelError, match=r"frame 'arm'.parent: no frame is named 'bsae' \(did you mean 'base'\?\)"):
        m.add_frame("base")
        m.add_frame("arm", parent="bsae")
    with pytest.raises(lg.ModelError, match=r"frame 'base': the name is taken \(another frame\)"):
        m.add_frame("base")
    with pytest.raises(lg.ModelError, match=r"frame 'world': the name is taken \(the inertial frame\)"):
        m.add_frame("world")
    with pytest.raises(lg.ModelError, match=r"frame 'f'.rotation\[0\].axis: 'w' is not an axis; use \"x\", \"y\", \"z\""):
        m.add_frame("f", rotation=[("w", "q")])
    with pytest.raises(lg.ModelError, match=r"frame 'f'.rotation\[0\]: expected \(axis, angle\)"):
        m.add_frame("f", rotation=[("z",)])
    with pytest.raises(lg.ModelError, match=r"frame 'f'.rotation\[0\].axis: the zero vector is not an axis"):
        m.add_frame("f", rotation=[([0, 0, 0], "q")])
    with pytest.raises(lg.ModelError, match=r"body 'b'.frame: no frame is named 'bdoy' \(did you mean 'body'\?\)"):
        m.add_frame("body", rotation=[("z", "q")])
        m.add_rigid_body(1, (1, 1, 1), frame="bdoy", name="b")
    with pytest.raises(lg.ModelError, match=r"body 'b2': a body in space takes its orientation from its frame"):
        m.add_rigid_body(1, (1, 1, 1), (0, 0, 0), "q", frame="body", name="b2")
    with pytest.raises(lg.ModelError, match=r"body 'b3': a planar body needs a position and an angle"):
        m.add_rigid_body(1, 1, name="b3")
    with pytest.raises(lg.ModelError, match=r"body 'b4'.inertia: expected 3 principal moments"):
        m.add_rigid_body(1, (1, 1), frame="body", name="b4")
    with pytest.raises(lg.ModelError, match=r"body 'b5'.inertia: an inertia tensor is symmetric"):
        m.add_rigid_body(1, [[1, 0.1, 0], [0, 1, 0], [0, 0, 1]], frame="body", name="b5")
    with pytest.raises(lg.ModelError, match=r"particle 'p'.position: a position in the frame 'body' has 3 components"):
        m.add_particle(1, (0, 1), frame="body", name="p")


def test_inertia_and_rotation_checks_at_derive():
    m = lg.Model("bad")
    q = m.coordinate("q")
    m.add_frame("body", rotation=[("z", q)])
    m.add_rigid_body(1, (1, 1, -1), frame="body", name="neg")
    m.add_rigid_body(1, (1, 1, 3), frame="body", name="tri")
    m.add_frame("skew", rotation=[[1, 0, 0], [0, 1, 0], [0, 0, -1]])
    m.add_frame("stretch", rotation=[[2, 0, 0], [0, 1, 0], [0, 0, 1]])
    with pytest.raises(lg.ModelError) as info:
        lg.derive(m)
    text = str(info.value)
    assert "4 problems" in text
    assert ("[rigid body 'neg'.inertia]: the inertia tensor is not positive definite (principal moments -1, 1, 1): "
            "a moment of inertia is never negative") in text
    assert ("[rigid body 'tri'.inertia]: the principal moments of inertia 1, 1, 3 break the triangle inequality "
            "(1 + 1 < 3): no body has them") in text
    assert "[frame 'skew'.rotation]: the matrix is not a rotation: its determinant is -1, not 1 (a reflection)" in text
    assert ("[frame 'stretch'.rotation]: the matrix is not a rotation: its columns are not orthonormal "
            "(R^T R is not the identity)") in text


def test_torque_errors():
    m = _arm_model()
    with pytest.raises(lg.ModelError, match=r"torque 'bad'.torque: a torque on the body 'link' in space has 3 components"):
        m.add_torque((1, 0), body="link", name="bad")
    with pytest.raises(lg.ModelError, match=r"torque 'bad2'.frame: only a torque on a body in space has axes"):
        m.add_torque(1, angle="q1", frame="link", name="bad2")
