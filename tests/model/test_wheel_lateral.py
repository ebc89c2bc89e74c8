"""Wheels without their lateral no-slip condition (issue 22, item 3): two wheels on one rigid axle
(a differential-drive cart) are rank-deficient with both lateral conditions, and the diagnosis names
the key that fixes it; with lateral = false on one wheel the constraints are independent and are the
textbook differential-drive kinematics (rolling of each wheel, no sideways motion of the axle)."""

from __future__ import annotations

import re

import numpy as np
import pytest
import sympy as sp

import lagrangian as lg
from lagrangian.errors import ModelError
from lagrangian.io import loads_model

TOML = """
name = "diff-drive"
coordinates = ["x", "y", "psi", "thA", "thB"]
[parameters]
m = 2.0
r = 0.1
b = 0.2
I = 0.01
J = 0.002
[[frames]]
name = "axle"
origin = ["x", "y", "r"]
rotation = [["z", "psi"]]
[[frames]]
name = "wA"
parent = "axle"
origin = ["0", "b", "0"]
rotation = [["y", "thA"]]
[[frames]]
name = "wB"
parent = "axle"
origin = ["0", "-b", "0"]
rotation = [["y", "thB"]]
[[bodies]]
name = "cart"
mass = "m"
inertia = ["I", "I", "I"]
frame = "axle"
[[bodies]]
name = "A"
mass = "m/10"
inertia = ["J", "2*J", "J"]
frame = "wA"
[[bodies]]
name = "B"
mass = "m/10"
inertia = ["J", "2*J", "J"]
frame = "wB"
[[wheels]]
name = "wA"
frame = "wA"
radius = "r"
[[wheels]]
name = "wB"
frame = "wB"
radius = "r"
"""

LATERAL_FALSE = TOML + "lateral = false\n"


def _G(eqs, q):
    names = [c.name for c in eqs.coordinates]
    G = eqs.constraint_jacobian
    values = {sp.Symbol(k): v for k, v in zip(names, q)}
    values.update({p: v for p, v in eqs.parameters.items()})
    return np.array(G.subs(values), dtype=float)


def test_two_wheels_on_one_axle_with_lateral_false_are_the_differential_drive():
    eqs = lg.derive(loads_model(LATERAL_FALSE))
    assert [c.name for c in eqs.model.constraints] == ["wA_x", "wA_y", "wB_longitudinal"]
    assert eqs.model.wheels[1].constraint_names == ("wB_longitudinal",)
    r, b = 0.1, 0.2
    for psi in (0.0, 0.4, 2.1, -1.3):
        G = _G(eqs, [0.3, -0.2, psi, 0.5, 1.7])
        c, s = np.cos(psi), np.sin(psi)
        # by hand: each wheel's centre moves along the heading at r theta_dot, the axle not sideways
        hand = np.array([[c, s, -b, -r, 0], [c, s, b, 0, -r], [-s, c, 0, 0, 0]])
        assert np.linalg.matrix_rank(G) == 3
        assert np.linalg.matrix_rank(np.vstack([G, hand]), tol=1e-10) == 3


def test_both_lateral_conditions_are_rank_deficient_and_the_diagnosis_names_lateral_false():
    eqs = lg.derive(loads_model(TOML))
    assert np.linalg.matrix_rank(_G(eqs, [0.3, -0.2, 0.4, 0.5, 1.7]), tol=1e-10) == 3  # 4 rows, rank 3
    report = lg.constraint_singularities(eqs)
    assert "lateral = false in the [[wheels]] table of 'wB'" in report.fix
    assert "Model.add_wheel(..., lateral=False)" in report.fix and "wB_longitudinal" in report.fix


def test_lateral_false_cart_rolls_and_turns_with_energy_conserved():
    eqs = lg.derive(loads_model(LATERAL_FALSE))
    r, b = 0.1, 0.2
    # consistent initial velocities: forward speed v and turn rate w
    v, w = 0.5, 0.8
    init = {"x_dot": v, "psi_dot": w, "thA_dot": (v - b * w) / r, "thB_dot": (v + b * w) / r}
    traj = lg.simulate(eqs, 3.0, initial=init, rtol=1e-10, atol=1e-10)
    # no torque, symmetric cart: it goes round a circle of radius v / w at constant speed
    speed = np.hypot(traj["x_dot"], traj["y_dot"])
    assert np.allclose(speed, v, atol=1e-7)
    assert np.allclose(traj["psi_dot"], w, atol=1e-7)
    assert np.allclose(np.hypot(traj["x"], traj["y"] - v / w), v / w, atol=1e-7)
    assert traj.energy is not None and np.ptp(traj.energy) < 1e-8 * abs(traj.energy[0])


def test_lateral_must_be_a_boolean():
    with pytest.raises(ModelError, match=re.escape("wheels[1].lateral") + ".*" + re.escape("expected true or false")):
        loads_model(TOML + 'lateral = "no"\n')
    m = loads_model(TOML)
    m2 = m.copy()
    with pytest.raises(ModelError, match=re.escape("expected true or false (whether the wheel cannot slide")):
        m2.add_wheel("wA", "r", name="w3", lateral="no")
