"""Kinematics and inverse dynamics of URDF robots against Pinocchio (issue 22): a 3-joint arm written here
(revolute, revolute, prismatic, a fixed tool frame; inertias off the joint axes, rotated origins) and the
public UR5 of example-robot-data. The frame's placement, its LOCAL_WORLD_ALIGNED Jacobian and velocity,
and the inverse dynamics (rnea) agree to 1e-12 at random states. The mass matrix and the importer itself
are tested with the URDF reader (tests/io)."""

from __future__ import annotations

import numpy as np
import pytest

import lagrangian as lg

pin = pytest.importorskip("pinocchio", reason="Pinocchio (pip install pin) is the independent rigid-body reference")
urdf = pytest.importorskip("lagrangian.io._urdf", reason="the URDF reader (issue 22) is not in this checkout")

ARM = """<robot name="arm3">
  <link name="base"/>
  <link name="link1">
    <inertial><origin xyz="0.01 0.02 0.15" rpy="0.1 0.2 0.3"/><mass value="2.0"/>
      <inertia ixx="0.03" ixy="0.001" ixz="-0.002" iyy="0.025" iyz="0.003" izz="0.01"/></inertial>
  </link>
  <link name="link2">
    <inertial><origin xyz="0.2 0.0 0.01" rpy="0 0 0"/><mass value="1.5"/>
      <inertia ixx="0.002" ixy="0" ixz="0" iyy="0.02" iyz="0" izz="0.021"/></inertial>
  </link>
  <link name="link3">
    <inertial><origin xyz="0.0 0.05 0.1" rpy="0.3 0 0.1"/><mass value="0.8"/>
      <inertia ixx="0.004" ixy="0.0002" ixz="0" iyy="0.005" iyz="0" izz="0.002"/></inertial>
  </link>
  <link name="tool"/>
  <joint name="shoulder" type="revolute">
    <parent link="base"/><child link="link1"/><origin xyz="0 0 0.1" rpy="0 0 0"/><axis xyz="0 0 1"/>
    <limit lower="-3" upper="3" effort="10" velocity="2"/>
  </joint>
  <joint name="elbow" type="revolute">
    <parent link="link1"/><child link="link2"/><origin xyz="0 0.05 0.3" rpy="1.5707963267948966 0 0"/>
    <axis xyz="0 0 1"/><limit lower="-3" upper="3" effort="10" velocity="2"/>
  </joint>
  <joint name="slide" type="prismatic">
    <parent link="link2"/><child link="link3"/><origin xyz="0.4 0 0" rpy="0 0.2 0"/><axis xyz="1 0 0"/>
    <limit lower="-0.2" upper="0.2" effort="10" velocity="2"/>
  </joint>
  <joint name="flange" type="fixed">
    <parent link="link3"/><child link="tool"/><origin xyz="0 0 0.12" rpy="0 0 0.5"/>
  </joint>
</robot>
"""


def check_frame(model, path, frame, states, tol=1e-12):
    """lg.kinematics(model, frame=...) against Pinocchio's frame placement, Jacobian and velocity."""
    pm = pin.buildModelFromUrdf(str(path))
    pd = pm.createData()
    fid = pm.getFrameId(frame)
    k = lg.kinematics(model, frame=frame)
    for q, v in states:
        pin.forwardKinematics(pm, pd, q, v)
        pin.updateFramePlacements(pm, pd)
        pin.computeJointJacobians(pm, pd, q)
        J = pin.getFrameJacobian(pm, pd, fid, pin.LOCAL_WORLD_ALIGNED)
        world = pin.getFrameVelocity(pm, pd, fid, pin.LOCAL_WORLD_ALIGNED)
        local = pin.getFrameVelocity(pm, pd, fid, pin.LOCAL)
        got = k.at(q, v)
        np.testing.assert_allclose(got.position, pd.oMf[fid].translation, rtol=0, atol=tol)
        np.testing.assert_allclose(got.rotation, pd.oMf[fid].rotation, rtol=0, atol=tol)
        np.testing.assert_allclose(got.jacobian, J[:3], rtol=0, atol=tol)
        np.testing.assert_allclose(got.angular_jacobian, J[3:], rtol=0, atol=tol)
        np.testing.assert_allclose(got.velocity, world.linear, rtol=0, atol=tol)
        np.testing.assert_allclose(got.angular_velocity, world.angular, rtol=0, atol=tol)
        np.testing.assert_allclose(got.angular_velocity_body, local.angular, rtol=0, atol=tol)
    return pm


def test_three_joint_arm_kinematics_and_inverse_dynamics_match_pinocchio(tmp_path):
    path = tmp_path / "arm3.urdf"
    path.write_text(ARM)
    model = urdf.load_urdf(path)
    assert [c.name for c in model.q] == ["shoulder", "elbow", "slide"]
    rng = np.random.default_rng(21)
    states = [(rng.uniform(-2, 2, 3), rng.uniform(-2, 2, 3)) for _ in range(4)]
    pm = check_frame(model, path, "tool", states)
    pd = pm.createData()
    Q, V, A = (rng.uniform(-2, 2, (8, 3)) for _ in range(3))
    result = lg.inverse_dynamics(lg.derive(model), Q, V, A)
    expected = np.array([pin.rnea(pm, pd, q, v, a) for q, v, a in zip(Q, V, A)])
    np.testing.assert_allclose(result.tau, expected, rtol=0, atol=1e-12)
    # at rest: the gravity torques (Pinocchio's computeGeneralizedGravity)
    rest = lg.inverse_dynamics(lg.derive(model), Q[0]).torques
    np.testing.assert_allclose(rest, pin.computeGeneralizedGravity(pm, pd, Q[0]), rtol=0, atol=1e-12)


def _ur5():
    from importlib import metadata

    try:
        dist = metadata.distribution("example-robot-data")
    except metadata.PackageNotFoundError:
        pytest.skip("example-robot-data (pip install example-robot-data) ships the UR5's URDF")
    found = [f for f in (dist.files or ()) if str(f).endswith("ur_description/urdf/ur5_robot.urdf")]
    if not found:
        pytest.skip("this example-robot-data has no ur_description/urdf/ur5_robot.urdf")
    return dist.locate_file(found[0])


def test_ur5_tool_frame_matches_pinocchio():
    path = _ur5()
    model = urdf.load_urdf(path)
    assert len(model.q) == 6
    rng = np.random.default_rng(5)
    check_frame(model, path, "tool0", [(rng.uniform(-3, 3, 6), rng.uniform(-3, 3, 6)) for _ in range(4)])
