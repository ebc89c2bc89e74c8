"""URDF import (io._urdf): a small arm from published numbers against its hand derivation, fixed joints
merged, names, lg.load and the CLI, and one clear error for each hostile or unsupported file."""

from __future__ import annotations

import math
import re

import numpy as np
import pytest
import sympy as sp

import lagrangian as lg
from lagrangian.cli import main
from lagrangian.errors import ModelFileError
from lagrangian.io import _urdf
from lagrangian.io._urdf import coordinate_name, load_urdf, loads_urdf

# Spong's Acrobot ("The swing up control problem for the Acrobot", IEEE Control Systems 1995): m1 = m2 = 1 kg,
# l1 = 1 m, lc1 = 0.5 m, lc2 = 1 m, I1 = 0.083, I2 = 0.33 kg m^2 about the centres of mass; here the links hang
# along -z from joints about +y, in the vertical x-z plane, gravity along -z.
ACROBOT = """<?xml version="1.0"?>
<robot name="acrobot">
  <link name="base"/>
  <link name="link1">
    <inertial>
      <origin xyz="0 0 -0.5" rpy="0 0 0"/>
      <mass value="1"/>
      <inertia ixx="0.083" ixy="0" ixz="0" iyy="0.083" iyz="0" izz="0.001"/>
    </inertial>
    <visual><origin xyz="0 0 -0.5"/><geometry><cylinder radius="0.02" length="1"/></geometry></visual>
  </link>
  <link name="link2">
    <inertial>
      <origin xyz="0 0 -1" rpy="0 0 0"/>
      <mass value="1"/>
      <inertia ixx="0.33" ixy="0" ixz="0" iyy="0.33" iyz="0" izz="0.001"/>
    </inertial>
    <visual><geometry><box size="0.05 0.05 2"/></geometry></visual>
    <visual><geometry><mesh filename="package://acrobot/meshes/link2.stl"/></geometry></visual>
  </link>
  <joint name="shoulder" type="continuous">
    <parent link="base"/><child link="link1"/>
    <origin xyz="0 0 2" rpy="0 0 0"/>
    <axis xyz="0 1 0"/>
  </joint>
  <joint name="elbow" type="revolute">
    <parent link="link1"/><child link="link2"/>
    <origin xyz="0 0 -1" rpy="0 0 0"/>
    <axis xyz="0 1 0"/>
    <limit lower="-2.5" upper="2.5" effort="10" velocity="5"/>
    <dynamics damping="0.05" friction="0"/>
  </joint>
  <transmission name="t1"><type>transmission_interface/SimpleTransmission</type></transmission>
</robot>
"""


def _acrobot_by_hand(q1, q2, qd1, qd2, g=9.81):
    """M, and the forcing f = -C q_dot - G - damping, of Spong's acrobot (hanging, q from the downward vertical)."""
    m1 = m2 = 1.0
    l1, lc1, lc2, I1, I2 = 1.0, 0.5, 1.0, 0.083, 0.33
    c2, s2 = math.cos(q2), math.sin(q2)
    M = np.array([[I1 + I2 + m1 * lc1 ** 2 + m2 * (l1 ** 2 + lc2 ** 2 + 2 * l1 * lc2 * c2),
                   I2 + m2 * (lc2 ** 2 + l1 * lc2 * c2)],
                  [I2 + m2 * (lc2 ** 2 + l1 * lc2 * c2), I2 + m2 * lc2 ** 2]])
    h = m2 * l1 * lc2 * s2
    coriolis = np.array([-2 * h * qd1 * qd2 - h * qd2 ** 2, h * qd1 ** 2])
    G = np.array([(m1 * lc1 + m2 * l1) * g * math.sin(q1) + m2 * lc2 * g * math.sin(q1 + q2),
                  m2 * lc2 * g * math.sin(q1 + q2)])
    return M, -coriolis - G - np.array([0.0, 0.05 * qd2])


def test_acrobot_from_published_numbers_matches_the_hand_derivation():
    model = loads_urdf(ACROBOT)
    assert [c.name for c in model.q] == ["shoulder", "elbow"]
    assert [s.name for s in model.q_dot] == ["shoulder_dot", "elbow_dot"]
    assert model.parameters == {sp.Symbol("g"): 9.81}
    assert model.joints["elbow"].limits == ((-2.5, 2.5),)
    assert "transmission" in model.description
    nm = lg.compile(lg.derive(model), backend="scipy")
    rng = np.random.default_rng(1)
    for _ in range(5):
        q, qd = rng.uniform(-3, 3, 2), rng.uniform(-3, 3, 2)
        x = np.concatenate([q, qd])
        M, f = _acrobot_by_hand(*q, *qd)
        np.testing.assert_allclose(nm.mass_matrix(0.0, x, [], nm.parameter_values), M, rtol=1e-12, atol=1e-12)
        np.testing.assert_allclose(nm.forcing(0.0, x, [], nm.parameter_values), f, rtol=1e-12, atol=1e-12)


def test_acrobot_conserves_energy_without_damping():
    model = loads_urdf(ACROBOT.replace('damping="0.05"', 'damping="0"'))
    traj = lg.simulate(lg.derive(model), t_end=2.0, initial={"shoulder": 1.0, "elbow": -0.5}, rtol=1e-10,
                       atol=1e-10)
    q1, q2, qd1, qd2 = (traj[n] for n in ("shoulder", "elbow", "shoulder_dot", "elbow_dot"))
    energy = []
    for k in range(len(traj.t)):
        M, _ = _acrobot_by_hand(q1[k], q2[k], qd1[k], qd2[k])
        qd = np.array([qd1[k], qd2[k]])
        V = -9.81 * (1.5 * math.cos(q1[k]) + math.cos(q1[k] + q2[k]))
        energy.append(qd @ M @ qd / 2 + V)
    assert np.ptp(energy) < 1e-7


def test_visuals_are_kept_and_meshes_are_markers():
    model = loads_urdf(ACROBOT)
    kinds = [(v.frame, v.kind) for v in model.visuals]
    assert kinds == [("link1", "cylinder"), ("link2", "box"), ("link2", "marker")]
    assert model.visuals[0].size == (0.02, 1.0) and model.visuals[2].mesh.startswith("package://")


FIXED = """<robot name="r">
  <link name="base"/>
  <link name="arm"><inertial><origin xyz="0.2 0 0"/><mass value="2"/>
    <inertia ixx="0.01" ixy="0" ixz="0" iyy="0.03" iyz="0" izz="0.03"/></inertial></link>
  <link name="tool"><inertial><origin xyz="0.05 0.01 0" rpy="0.3 0 0.2"/><mass value="0.5"/>
    <inertia ixx="0.002" ixy="0.0001" ixz="0" iyy="0.001" iyz="0" izz="0.0015"/></inertial></link>
  <joint name="j1" type="revolute"><parent link="base"/><child link="arm"/><axis xyz="0 0 1"/>
    <origin xyz="0 0 0.1" rpy="0.1 0.2 0"/></joint>
  <joint name="mount" type="fixed"><parent link="arm"/><child link="tool"/>
    <origin xyz="0.4 0 0" rpy="0 1.5707963267948966 0"/></joint>
</robot>"""


def test_a_fixed_joint_is_merged_into_its_parent_link():
    """One body per moving link, with the same M and f as the two bodies written with a fixed joint."""
    model = loads_urdf(FIXED)
    bodies = [e for e in model.elements if isinstance(e, lg.model.RigidBody3D)]
    assert [b.name for b in bodies] == ["arm"] and float(bodies[0].mass) == 2.5
    assert "tool" in model.frames  # the fixed frame is still there (kinematics, drawing)
    by_hand = lg.Model("r")
    by_hand.parameter("g", 9.81)
    by_hand.add_frame("base")
    by_hand.add_joint("j1", "revolute", parent="base", child="arm", origin=(0, 0, 0.1),
                      rotation=[("y", 0.2), ("x", 0.1)])
    by_hand.add_joint("mount", "fixed", parent="arm", child="tool", origin=(0.4, 0, 0), rotation=[("y", "pi/2")])
    by_hand.add_frame("tool_inertial", parent="tool", origin=(0.05, 0.01, 0), rotation=[("z", 0.2), ("x", 0.3)])
    by_hand.add_rigid_body(2, [0.01, 0.03, 0.03], frame="arm", center=(0.2, 0, 0))
    by_hand.add_rigid_body(0.5, [[0.002, 0.0001, 0], [0.0001, 0.001, 0], [0, 0, 0.0015]], frame="tool_inertial")
    by_hand.add_gravity("g")
    a, b = (lg.compile(lg.derive(m), backend="scipy") for m in (model, by_hand))
    for x in ([0.3, 0.0], [-1.2, 2.0]):
        np.testing.assert_allclose(a.mass_matrix(0, x, [], a.parameter_values),
                                   b.mass_matrix(0, x, [], b.parameter_values), rtol=1e-12)
        np.testing.assert_allclose(a.forcing(0, x, [], a.parameter_values),
                                   b.forcing(0, x, [], b.parameter_values), rtol=1e-12, atol=1e-14)


def test_floating_base_gives_the_root_six_coordinates():
    base = ('<link name="base"><inertial><origin xyz="0.01 0.02 -0.03"/><mass value="3"/>'
            '<inertia ixx="0.05" ixy="0" ixz="0" iyy="0.04" iyz="0" izz="0.03"/></inertial></link>')
    model = loads_urdf(FIXED.replace('<link name="base"/>', base), floating_base=True)
    assert [c.name for c in model.q] == ["floating_base_x", "floating_base_y", "floating_base_z",
                                         "floating_base_1", "floating_base_2", "floating_base_3", "j1"]
    nm = lg.compile(lg.derive(model), backend="scipy")
    x = np.zeros(14)
    qdd = np.linalg.solve(nm.mass_matrix(0, x, [], nm.parameter_values), nm.forcing(0, x, [], nm.parameter_values))
    f = nm.forcing(0, x, [], nm.parameter_values)
    np.testing.assert_allclose(f[:3], [0, 0, -5.5 * 9.81], atol=1e-12)  # gravity on the whole robot's mass
    np.testing.assert_allclose(qdd, [0, 0, -9.81, 0, 0, 0, 0], atol=1e-9)  # free fall: no rotation, no bending


def test_no_gravity_and_another_value():
    assert loads_urdf(FIXED, gravity=None).parameters == {}
    assert loads_urdf(FIXED, gravity=1.62).parameters == {sp.Symbol("g"): 1.62}


@pytest.mark.parametrize("name, expected", [
    ("shoulder_pan_joint", "shoulder_pan_joint"), ("arm/joint-1", "arm_joint_1"), ("1st.joint", "q_1st_joint"),
    ("a:b", "a_b"),
])
def test_names_renamed(name, expected):
    assert coordinate_name(name) == (expected, None)


@pytest.mark.parametrize("name, why", [
    ("__import__('os')", r"has the characters \"'\" '\(' '\)': a name may have letters, digits and _ - \. / : only"),
    ("a b", r"has the characters ' '"), ("x\ny", r"has the characters '\\n'"), ("__class__", r"starts with '__'"),
    ("t", r"'t' is reserved"), ("lambda", r"Python keyword"), ("q_dot", r"ends in _dot"),
    ("x" * 201, r"201 characters long"),
])
def test_names_refused(name, why):
    out, message = coordinate_name(name)
    assert out is None and re.search(why, message)


def _error(text, **kwargs):
    with pytest.raises(ModelFileError) as info:
        loads_urdf(text, **kwargs)
    return str(info.value)


def _robot(body):
    return f'<robot name="r">\n<link name="base"/>\n{body}\n</robot>'


ARM = ('<link name="a"><inertial><mass value="1"/><inertia ixx="1" ixy="0" ixz="0" iyy="1" iyz="0" izz="1"/>'
       '</inertial></link>')


def _joint(name="j", type="revolute", parent="base", child="a", extra=""):
    return (f'<joint name="{name}" type="{type}"><parent link="{parent}"/><child link="{child}"/>'
            f'<axis xyz="0 0 1"/>{extra}</joint>')


BOMB = ('<?xml version="1.0"?>\n<!DOCTYPE lolz [\n <!ENTITY lol "lol">\n <!ENTITY lol2 "&lol;&lol;&lol;&lol;&lol;">\n'
        ' <!ENTITY lol3 "&lol2;&lol2;&lol2;&lol2;&lol2;">\n]>\n<robot name="&lol3;"><link name="base"/></robot>')


@pytest.mark.parametrize("text, match", [
    (BOMB, r":2: the URDF has a DOCTYPE declaration: document types and entities are refused"),
    ('<robot name="r"><!ENTITY x "y"><link name="base"/></robot>', r"the URDF has a ENTITY declaration"),
    ('<robot name="r"><link name="base"></robot>', r"the URDF is not well-formed XML: mismatched tag"),
    ('<html/>', r"the root element is <html>, expected <robot>"),
    ('<robot name="r"/>', r"the URDF has no <link>"),
    (_robot('<link name="a"><inertial><inertia ixx="1" ixy="0" ixz="0" iyy="1" iyz="0" izz="1"/></inertial></link>'
            + _joint()), r"\[link 'a'\]: its <inertial> has no <mass value"),
    (_robot(ARM.replace('value="1"', 'value="-2"') + _joint()),
     r"\[link 'a'.mass\]: the mass is -2: a mass is at least 0"),
    (_robot(ARM.replace('value="1"', 'value="nan"') + _joint()), r"every number must be finite"),
    (_robot(ARM.replace('ixx="1"', 'ixx="-1"') + _joint()), r"the inertia tensor has the principal moment -1 < 0"),
    (_robot(ARM.replace('ixx="1"', 'ixx="5"') + _joint()), r"break the triangle inequality"),
    (_robot(ARM.replace('ixy="0"', 'ixy="2"') + _joint()), r"principal moment -1 < 0"),
    (_robot(ARM.replace(' iyz="0"', '') + _joint()), r"missing attribute iyz="),
    (_robot(ARM + ARM.replace('"a"', '"b"') + _joint() + _joint("k", parent="a", child="b")
            + _joint("m", parent="b", child="a")), r"the link 'a' is the child of the joints 'j' and 'm'"),
    (_robot(ARM + ARM.replace('"a"', '"b"') + _joint("k", parent="a", child="b") + _joint("m", parent="b", child="a")),
     r"the joints form a cycle through the links"),
    (_robot(ARM + ARM.replace('"a"', '"b"') + _joint()),
     r"the links base, b have no parent joint: a URDF has one root"),
    (_robot(ARM + _joint(name="__import__('os')")), r"\[joint '__import__\('os'\)'\]: the joint name .* has the "
                                                     r"characters"),
    (_robot(ARM + _joint(name="a-b") + ARM.replace('"a"', '"b"') + _joint(name="a_b", child="b")),
     r"the joint names 'a-b' and 'a_b' both become 'a_b'"),
    (_robot(ARM + _joint(extra='<mimic joint="other"/>')), r"a <mimic> joint \(following 'other'\) closes a loop"),
    (_robot(ARM + _joint(type="spherical")), r"unknown joint type 'spherical': the URDF types read are"),
    (_robot(ARM + _joint(type="planar").replace('0 0 1', '1 1 0')), r"a planar joint is read with its normal"),
    (_robot(ARM + _joint(child="nowhere")), r"\[joint 'j'.child\]: no link is named 'nowhere'"),
    (_robot(ARM + _joint().replace('<axis xyz="0 0 1"/>', '<axis xyz="0 0 0"/>')), r"the axis is the zero vector"),
    (_robot(ARM + _joint(extra='<origin xyz="0 0 inf"/>')), r"every number must be finite"),
    (_robot(ARM + _joint(extra='<origin xyz="0 0"/>')), r"expected 3 numbers, got 2"),
    (_robot(ARM + _joint(extra='<limit lower="1" upper="-1"/>')), r"lower = 1 is above upper = -1: swap them"),
    (_robot(ARM + _joint(extra='<dynamics damping="-1"/>')), r"damping = -1: it is at least 0"),
    (_robot(ARM.replace("</link>", '<visual><geometry><mesh filename="../../etc/passwd"/></geometry></visual>'
                        '</link>') + _joint()), r"the mesh '\.\./\.\./etc/passwd' is outside the URDF's folder"),
    (_robot(ARM.replace("</link>", '<visual><geometry><mesh filename="/etc/passwd"/></geometry></visual>'
                        '</link>') + _joint()), r"the mesh '/etc/passwd' is outside"),
    (_robot(ARM.replace("</link>", '<visual><geometry><mesh filename="file:///etc/passwd"/></geometry>'
                        '</visual></link>') + _joint()), r"the mesh 'file:///etc/passwd' is outside"),
    (_robot(ARM.replace("</link>", '<visual><geometry><box size="1 -1 1"/></geometry></visual></link>')
            + _joint()), r"a box's sizes are positive"),
])
def test_hostile_and_unsupported_urdfs(text, match):
    assert re.search(match, _error(text))


def test_a_link_with_a_problem_gives_one_error_not_a_second_for_its_joint():
    message = _error(_robot(ARM.replace('value="1"', 'value="nan"') + _joint()))
    assert "every number must be finite" in message and "no link is named" not in message


def test_problems_carry_the_line_of_their_link_or_joint():
    text = _robot(ARM.replace('value="1"', 'value="-2"') + "\n\n" + _joint(extra='<mimic joint="x"/>'))
    message = _error(text)
    assert "<string>:3 [link 'a'.mass]" in message and "<string>:5 [joint 'j']" in message


def test_a_file_larger_than_the_bound_is_not_read(tmp_path, monkeypatch):
    path = tmp_path / "big.urdf"
    path.write_text(_robot(ARM + _joint()) + " " * 2000)
    monkeypatch.setattr(_urdf, "MAX_BYTES", 1000)
    with pytest.raises(ModelFileError, match=r"the URDF file has \d+ bytes, more than the 1000 read"):
        load_urdf(path)
    with pytest.raises(ModelFileError, match=r"more than the 1000 read"):
        loads_urdf(path.read_text())


def test_load_routes_urdf_by_suffix_and_the_cli_reads_it(tmp_path, capsys):
    path = tmp_path / "acrobot.urdf"
    path.write_text(ACROBOT)
    model = lg.load(str(path))
    assert model.name == "acrobot" and [c.name for c in model.q] == ["shoulder", "elbow"]
    assert main(["check", str(path)]) == 0
    assert main(["derive", str(path)]) == 0
    out = capsys.readouterr().out
    assert "shoulder_ddot" in out or "shoulder" in out
    with pytest.raises(ModelFileError, match=r"no such URDF file"):
        lg.load(str(tmp_path / "missing.urdf"))
    assert main(["check", str(tmp_path / "missing.urdf")]) == 2
    with pytest.raises(ModelFileError, match=r"is a xacro file, a template that expands to a URDF: expand it first"):
        lg.load(str(tmp_path / "robot.urdf.xacro"))


def test_loads_urdf_takes_text_only():
    with pytest.raises(TypeError, match=r"expects the text of a URDF file"):
        loads_urdf(3)


def test_floating_and_planar_urdf_joints():
    floating = loads_urdf(_robot(ARM + _joint(type="floating")))
    assert [c.name for c in floating.q] == ["j_x", "j_y", "j_z", "j_1", "j_2", "j_3"]
    M0 = lg.derive(floating).mass_matrix.subs({c: 0 for c in floating.q})
    assert M0 == sp.diag(1, 1, 1, 1, 1, 1)
    planar = loads_urdf(_robot(ARM + _joint(type="planar")))
    assert [c.name for c in planar.q] == ["j_x", "j_y", "j_angle"]
    assert lg.derive(planar).mass_matrix == sp.eye(3)


def test_coordinates_of_two_joints_that_collide_are_refused():
    text = _robot(ARM + _joint(type="planar") + ARM.replace('"a"', '"b"') + _joint(name="j_x", parent="a", child="b"))
    assert "two joints' coordinates are both named 'j_x'" in _error(text)
    assert "floating_base_x" in _error(_robot(ARM + _joint(name="floating_base_x")), floating_base=True)


def test_visual_shapes_are_drawn_in_their_link_frames():
    """A box 0.2 x 0.1 x 0.4 at xyz 0 0 -0.2 of a link turned by q about y: its outline's corners are where the
    frame puts them (plot._geometry.scene_of, Scene.visual_outlines)."""
    from lagrangian.plot._geometry import outline_of, scene_of

    text = _robot(ARM.replace("</link>", '<visual><origin xyz="0 0 -0.2"/><geometry><box size="0.2 0.1 0.4"/>'
                              '</geometry></visual></link>') + _joint().replace('0 0 1', '0 1 0'))
    model = loads_urdf(text)
    scene = scene_of(model)
    assert scene.visuals == ("a box",)
    q = 0.7
    (outline,) = scene.visual_outlines(np.array([0.0]), np.array([[q]]))
    corners = outline[0][~np.isnan(outline[0][:, 0])]
    R = np.array([[math.cos(q), 0, math.sin(q)], [0, 1, 0], [-math.sin(q), 0, math.cos(q)]])
    local = outline_of("box", (0.2, 0.1, 0.4), (0, 0, -0.2))
    expected = local[~np.isnan(local[:, 0])] @ R.T
    np.testing.assert_allclose(corners, expected, atol=1e-12)
    assert {tuple(np.round(p, 12)) for p in local[~np.isnan(local[:, 0])]} == {
        (x, y, z) for x in (-0.1, 0.1) for y in (-0.05, 0.05) for z in (-0.4, 0.0)}
