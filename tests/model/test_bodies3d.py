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
    textbook = lg.derive(lg.load("heavy-top-energy"))
    for a, b in zip(ours.equations, textbook.equations):
        assert sp.simplify(a - b) == 0
    I1, I3, th = S("I1"), S("I3"), S("theta")
    assert ours.mass_matrix == sp.Matrix([[I1, 0, 0], [0, I1 * sp.sin(th) ** 2 + I3 * sp.cos(th) ** 2, I3 * sp.cos(th)],
                                          [0, I3 * sp.cos(th), I3]])


@pytest.mark.slow
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


@pytest.mark.slow
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


@pytest.mark.slow
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


@pytest.mark.slow
def test_heavy_top_precesses_steadily_as_the_closed_form_says():
    eqs = lg.derive(_top_model())
    found = [s for s in lg.steady_motions(eqs, {"phi_dot": 2.0, "psi_dot": 50.0}) if 0 < s.coordinates["theta"] < 3]
    (s,) = found
    theta, I1, I3 = s.coordinates["theta"], 0.02, 0.01
    omega3 = 50.0 + 2.0 * math.cos(theta)
    assert I1 * 4 * math.cos(theta) - I3 * omega3 * 2 + 0.981 == pytest.approx(0, abs=1e-12)


@pytest.mark.slow
def test_robot_arm_with_motor_torques_against_lagranges_method():
    import sys
    from pathlib import Path

    sys.path.insert(0, str(Path(__file__).resolve().parents[2] / "benchmarks"))
    from derive_arm import sympy_arm  # the arm the benchmark times, built with SymPy's mechanics

    q, bodies, loads, N, _, _ = sympy_arm(3, "lagrange")
    lm = LagrangesMethod(Lagrangian(N, *bodies), q, forcelist=loads, frame=N)
    eqs = lg.derive(lg.load("robot-arm-3"))
    check(eqs, lm, ["q1", "q2", "q3"], symbolic=False)
    assert eqs.input_matrix == sp.eye(3)  # each motor drives its own joint (its reaction cancels on the others)


def test_robot_arm_conserves_energy_without_torques():
    eqs = lg.derive(lg.load("robot-arm-4"))
    traj = lg.simulate(eqs, t_end=2.0, initial={"q1": 0.2, "q2": 0.4, "q3": -0.3, "q4": 0.1, "q1_dot": 1.0,
                                                 "q4_dot": 2.0}, rtol=1e-11, atol=1e-11)
    assert traj.energy_name == "energy" and np.ptp(traj["tau1"]) == 0  # the motors' torques default to 0
    assert traj.energy_drift < 1e-8 and np.ptp(traj["q2"]) > 0.1


@pytest.mark.slow
def test_gyroscope_precesses_with_its_axle_level_at_m_g_l_over_its_spin_momentum():
    eqs = lg.derive(lg.load("gyroscope"))
    m, R, l, g, p = 0.5, 0.05, 0.2, 9.81, 2.0
    Omega = m * g * l / p
    (level, *_) = [s for s in lg.steady_motions(eqs, {"phi_dot": Omega}, momenta={"p_psi": p})
                   if 0 < s.coordinates["theta"] < 3]
    assert level.coordinates["theta"] == pytest.approx(math.pi / 2, abs=1e-9)
    assert level.stability == "stable"
    # the fast nutation: about I3 omega3 / I1 (I1 about the pivot), the precession's correction small
    I1 = m * R**2 / 4 + m * l**2
    assert max(abs(z.imag) for z in level.eigenvalues) == pytest.approx(p / I1, rel=1e-3)


# ----------------------------------------------------------------------------- model files
TOP_FILE = """\
name = "top-file"
coordinates = ["theta", "phi", "psi"]
inputs = ["tau", "F"]

[parameters]
m = 1.0
l = 0.1
g = 9.81
I1 = 0.02
I3 = 0.01

[[frames]]
name = "spin"
parent = "tilt"
rotation = [["z", "psi"]]

[[frames]]
name = "tilt"
rotation = [["z", "phi"], ["x", "theta"]]

[[bodies]]
name = "top"
mass = "m"
frame = "spin"
inertia = {xx = "I1 - m*l**2", yy = "I1 - m*l**2", zz = "I3"}
center = ["0", "0", "l"]

[[points]]
name = "rim"
frame = "spin"
position = ["l", "0", "l"]

[gravity]
g = "g"

[[loads]]
torque = ["0", "0", "tau"]
body = "top"

[[loads]]
force = ["0", "F", "0"]
at = "rim"
frame = "spin"
"""


def test_model_file_with_frames_equals_the_python_model(tmp_path):
    path = tmp_path / "top.toml"
    path.write_text(TOP_FILE)
    from_file = lg.derive(lg.load(str(path)))
    m = _top_model([("z", "phi"), ("x", "theta")])  # the frame of the tilt; the spin frame below it
    m2 = lg.Model("top-api")
    th, ph, ps = m2.coordinate("theta", "phi", "psi")
    for k, v in m.parameters.items():
        m2.parameter(k.name, v)
    tau, F = m2.input("tau"), m2.input("F")
    m2.add_frame("tilt", rotation=[("z", ph), ("x", th)])
    m2.add_frame("spin", parent="tilt", rotation=[("z", ps)])
    M, l, I1, I3 = (S(n) for n in ("m", "l", "I1", "I3"))
    m2.add_rigid_body(M, (I1 - M * l**2, I1 - M * l**2, I3), frame="spin", center=(0, 0, l), name="top")
    m2.add_point("rim", (l, 0, l), frame="spin")
    m2.add_gravity(S("g"))
    m2.add_torque((0, 0, tau), body="top")
    m2.add_force((0, F, 0), at="rim", frame="spin")
    from_api = lg.derive(m2)
    for a, b in zip(from_file.equations, from_api.equations):
        assert sp.expand(a - b) == 0
    # the torque about the symmetry axis: Q = tau d(omega_z)/d(q_dot), omega_z = phi_dot cos(theta) + psi_dot
    assert from_file.input_matrix[:, 0] == sp.Matrix([0, sp.cos(S("theta")), 1])
    # the push along the body's y axis at the rim, at the distance l from the axis: a spin torque F l
    assert from_file.input_matrix[2, 1] == S("l")


def test_the_zoo_top_from_elements_equals_the_one_from_energies():
    a, b = lg.derive(lg.load("heavy-top")), lg.derive(lg.load("heavy-top-energy"))
    assert all(sp.expand(x - y) == 0 for x, y in zip(a.equations, b.equations))


def test_the_top_of_the_model_files_page_is_a_model_file():
    import re
    from pathlib import Path

    page = (Path(__file__).resolve().parents[2] / "docs" / "model-files.md").read_text()
    (block,) = [b for b in re.findall(r"```toml\n(.*?)```", page, re.S) if re.search(r"^\[\[frames\]\]", b, re.M)]
    eqs = lg.derive(lg.io.loads_model(block))
    assert eqs.input_matrix[:, 0] == sp.Matrix([0, sp.cos(S("theta")), 1])
    top = lg.derive(lg.load("heavy-top"))
    assert sp.expand(eqs.mass_matrix - top.mass_matrix) == sp.zeros(3, 3)


BAD_FILE = """\
coordinates = ["q"]
[parameters]
m = 1.0
[[frames]]
name = "a"
parent = "b"
[[frames]]
name = "b"
parent = "a"
[[frames]]
name = "c"
parent = "wrold"
[[frames]]
name = "d"
rotation = [["w", "q"]]
[[frames]]
name = "e"
matrix = [["1", "0", "0"], ["0", "1", "0"], ["0", "0", "-1"]]
[[frames]]
name = "f"
rotation = [["z", "q"]]
[[bodies]]
name = "x"
mass = "m"
frame = "ff"
inertia = ["1", "1", "1"]
[[bodies]]
name = "y"
mass = "m"
frame = "f"
inertia = ["1", "1", "5"]
position = ["0", "0", "0"]
[[bodies]]
name = "z"
mass = "m"
frame = "f"
inertia = ["1", "2", "-1"]
[[particles]]
name = "p"
mass = "m"
frame = "f"
position = ["0", "1"]
[[loads]]
torque = "3"
body = "z"
[[bodies]]
name = "w"
mass = "m"
frame = "a"
inertia = ["1", "1", "1"]
"""


def test_model_file_frame_errors_all_at_once_with_their_lines(tmp_path):
    path = tmp_path / "bad.toml"
    path.write_text(BAD_FILE)
    with pytest.raises(lg.ModelFileError) as info:
        lg.load(str(path))
    lines = str(info.value).splitlines()
    assert lines[0].endswith("10 problems in " + str(path) + ":")
    expected = [
        ':6 [frames[0].parent]: the frames a, b form a cycle of parents (a -> b -> a): every frame must hang, '
        'through its parents, from "world"',
        ":12 [frames[2].parent]: no frame is named 'wrold' (did you mean 'world'?); use \"world\" (the inertial "
        "frame) or the name of a [[frames]] table",
        ":15 [frames[3].rotation[0][0]]: 'w' is not an axis: use \"x\", \"y\", \"z\" or a list of 3 numbers such as "
        "[1, 1, 0]",
        ":18 [frames[4].matrix]: the matrix is not a rotation: its determinant is -1, not 1 (a reflection)",
        ":25 [bodies[0].frame]: no frame is named 'ff' (did you mean 'f'?); the frames are world, a, b, c, d, e, f",
        ":32 [bodies[1].position]: a body in space (it has a frame) takes its orientation from its frame",
        ":31 [bodies[1].inertia]: the principal moments of inertia 1, 1, 5 break the triangle inequality",
        ":37 [bodies[2].inertia]: the inertia tensor is not positive definite (principal moments -1, 1, 2)",
        ":42 [particles[0].position]: a position in the frame 'f' has 3 components (x, y, z), got 2",
        ':44 [loads[0].torque]: the body \'z\' is in space: its torque is a list of 3 expressions, torque = '
        '["0", "0", "tau"]',
    ]
    text = str(info.value)
    for item in expected:
        assert item.replace('\\"', '"') in text, item
    # the body in the frame caught in the cycle is not reported again: its frame's problem says it all
    assert "bodies[3]" not in text and "[bodies[3].frame]" not in text


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
    with pytest.raises(lg.ModelError,
                       match=r"frame 'f'.rotation\[0\].axis: 'w' is not an axis; use \"x\", \"y\", \"z\""):
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
    with pytest.raises(lg.ModelError,
                       match=r"torque 'bad'.torque: a torque on the body 'link' in space has 3 components"):
        m.add_torque((1, 0), body="link", name="bad")
    with pytest.raises(lg.ModelError, match=r"torque 'bad2'.frame: only a torque on a body in space has axes"):
        m.add_torque(1, angle="q1", frame="link", name="bad2")
