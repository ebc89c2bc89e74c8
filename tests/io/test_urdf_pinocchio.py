"""URDF import against Pinocchio (an independent rigid-body library): the mass matrix (CRBA) and the
inverse dynamics (RNEA) of public arms from example-robot-data, at random states, to 1e-10 relative."""

from __future__ import annotations

import xml.etree.ElementTree as ET
from pathlib import Path

import numpy as np
import pytest

import lagrangian as lg
from lagrangian.errors import ModelFileError
from lagrangian.io._urdf import load_urdf

pin = pytest.importorskip("pinocchio", reason="the Pinocchio cross-check needs pip install pin")


def _robots() -> Path:
    import site

    for folder in [*site.getsitepackages(), site.getusersitepackages()]:
        path = Path(folder) / "cmeel.prefix" / "share" / "example-robot-data" / "robots"
        if path.is_dir():
            return path
    pytest.skip("example-robot-data is not installed (pip install example-robot-data)")


def _check_against_pinocchio(path, states=4, seed=0):
    model = load_urdf(path)
    nm = lg.compile(lg.derive(model), backend="scipy")
    pm = pin.buildModelFromUrdf(str(path))
    data = pm.createData()
    names = [c.name for c in model.q]
    order = [names.index(pm.names[i]) for i in range(1, pm.njoints)]  # Pinocchio's joints in our order
    assert pm.nq == pm.nv == len(names) == len(order)
    damping = np.array([j.damping[0] if j.damping else 0.0 for j in model.joints.values() if j.coordinates])
    rng = np.random.default_rng(seed)
    for _ in range(states):
        q, qd, qdd = (rng.uniform(-2, 2, len(names)) for _ in range(3))
        x = np.concatenate([q, qd])
        M = nm.mass_matrix(0.0, x, [], nm.parameter_values)
        f = nm.forcing(0.0, x, [], nm.parameter_values)
        tau = M @ qdd - f  # the inverse dynamics of M q_ddot = f; f holds the joints' viscous damping
        Mp = pin.crba(pm, data, q[order])
        Mp = np.triu(Mp) + np.triu(Mp, 1).T  # crba fills the upper triangle
        taup = pin.rnea(pm, data, q[order], qd[order], qdd[order])
        assert np.abs(M[np.ix_(order, order)] - Mp).max() <= 1e-10 * np.abs(Mp).max()
        assert np.abs(tau[order] - damping[order] * qd[order] - taup).max() <= 1e-10 * np.abs(taup).max()
    return model


def test_ur5_mass_matrix_and_inverse_dynamics_match_pinocchio():
    model = _check_against_pinocchio(_robots() / "ur_description" / "urdf" / "ur5_robot.urdf")
    assert [c.name for c in model.q] == ["shoulder_pan_joint", "shoulder_lift_joint", "elbow_joint",
                                         "wrist_1_joint", "wrist_2_joint", "wrist_3_joint"]


def _panda_arm(tmp_path) -> Path:
    """Franka Emika Panda without its fingers (the second finger mimics the first: a closed loop)."""
    tree = ET.parse(_robots() / "panda_description" / "urdf" / "panda.urdf")
    root = tree.getroot()
    for tag in ("joint", "link"):
        for el in list(root.findall(tag)):
            if "finger" in el.get("name"):
                root.remove(el)
    path = tmp_path / "panda_arm.urdf"
    tree.write(path)
    return path


def test_panda_with_its_fingers_is_refused_for_the_mimic_joint():
    with pytest.raises(ModelFileError, match=r"\[joint 'panda_finger_joint2'\]: a <mimic> joint \(following "
                                             r"'panda_finger_joint1'\) closes a loop"):
        load_urdf(_robots() / "panda_description" / "urdf" / "panda.urdf")


@pytest.mark.slow
def test_panda_7_joint_arm_matches_pinocchio(tmp_path):
    model = _check_against_pinocchio(_panda_arm(tmp_path), states=3)
    assert len(model.q) == 7 and model.joints["panda_joint1"].damping is not None
