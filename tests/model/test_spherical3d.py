"""The zoo's spherical-pendulum-3d: a bob at (x, y, z) held at the rod's length l by one holonomic
constraint, its multiplier the rod's tension.

Checked against closed forms: two small-oscillation modes at sqrt(g/l) about the hanging
position; the conical pendulum (omega^2 = g/(l cos theta0), tension m g / cos theta0) staying on
its circle; the tension m (|v|^2 - g z)/l along any motion; the constraint's drift at round-off
over a long run; and its equations equal to sympy.physics.mechanics' (tests/equations/test_constraints_sympy.py).
"""

from __future__ import annotations

import json
import math

import numpy as np
import pytest

import lagrangian as lg
from lagrangian.cli import main
from lagrangian.examples import example_descriptions

from test_constraints_sympy import spherical_3d


@pytest.fixture(scope="module")
def pendulum():
    return lg.derive(lg.load("spherical-pendulum-3d"))


def test_the_example_is_listed_and_its_equations_are_sympys(pendulum):
    assert "spherical-pendulum-3d" in example_descriptions()
    assert pendulum.model.simulation["independent"] == ["x", "y"]
    assert [c.name for c in pendulum.coordinates] == ["x", "y", "z"] and pendulum.multipliers[0].name == "lambda_rod"
    reference = spherical_3d()  # the same pendulum in Python and in sympy.physics.mechanics
    for key, ours in (("M", pendulum.mass_matrix), ("f", pendulum.forcing), ("G", pendulum.constraint_jacobian),
                      ("c", pendulum.constraint_acceleration)):
        assert (ours - reference.theirs[key]).applyfunc(lambda e: e.simplify()).is_zero_matrix, key


@pytest.mark.parametrize("params", [{}, {"l": 0.5, "g": 3.7, "m": 2.0}])
def test_hanging_it_has_two_modes_at_sqrt_g_over_l(pendulum, params):
    values = {"l": 1.0, "g": 9.81, "m": 1.0} | params
    lin = lg.linearize(pendulum, {"x": 0.0, "y": 0.0}, params=params)
    assert lin.coordinate_names == ("x", "y")
    assert lin.constrained["dependent"]["z"] == pytest.approx(-values["l"], abs=1e-14)  # z found below the pivot
    assert lin.constrained["multipliers"]["lambda_rod"] == pytest.approx(values["m"] * values["g"], rel=1e-12)
    modes = lg.modes(lin)
    omega = math.sqrt(values["g"] / values["l"])
    assert modes.frequencies == pytest.approx([omega, omega], rel=1e-12)
    assert lin.stability == "stable"


def test_the_modes_command_gives_the_two_modes(capsys):
    assert main(["modes", "spherical-pendulum-3d", "--at", "x=0,y=0", "--json"]) == 0
    data = json.loads(capsys.readouterr().out)
    assert data["coordinates"] == ["x", "y"]
    assert data["frequencies_rad_s"] == pytest.approx([math.sqrt(9.81)] * 2, rel=1e-12)


@pytest.mark.parametrize("theta0", [0.3, 1.0])
def test_a_conical_motion_stays_on_its_circle_at_the_closed_form_rate_and_tension(pendulum, theta0):
    m, l, g = 1.5, 0.8, 9.81
    omega = math.sqrt(g / (l * math.cos(theta0)))  # omega^2 = g / (l cos theta0)
    radius = l * math.sin(theta0)
    initial = {"x": radius, "y": 0.0, "z": -l * math.cos(theta0), "x_dot": 0.0, "y_dot": omega * radius,
               "z_dot": 0.0}
    period = 2 * math.pi / omega
    tr = lg.simulate(pendulum, t_end=5 * period, initial=initial, params={"m": m, "l": l, "g": g},
                     dt=period / 50, rtol=1e-11, atol=1e-11)
    assert np.max(np.abs(tr["z"] + l * math.cos(theta0))) < 1e-10  # the height stays
    assert np.max(np.abs(np.hypot(tr["x"], tr["y"]) - radius)) < 1e-10  # on its circle
    angle = np.unwrap(np.arctan2(tr["y"], tr["x"]))
    assert np.max(np.abs(angle - omega * tr.t)) < 1e-9  # turning at omega
    assert np.max(np.abs(tr["lambda_rod"] - m * g / math.cos(theta0))) < 1e-8  # T cos(theta0) = m g


def test_the_rods_tension_is_m_v2_minus_g_z_over_l_along_any_motion(pendulum):
    tr = lg.simulate(pendulum, t_end=5.0, rtol=1e-11, atol=1e-11)  # the example's own launch
    m, l, g = 1.0, 1.0, 9.81
    v2 = tr["x_dot"] ** 2 + tr["y_dot"] ** 2 + tr["z_dot"] ** 2
    assert np.max(np.abs(tr["lambda_rod"] - m * (v2 - g * tr["z"]) / l)) < 1e-11
    assert np.ptp(tr["lambda_rod"]) > 1.0  # not a conical motion: the tension varies
    assert tr["x"][0] == 0.6 and tr["z"][0] == pytest.approx(-0.8, abs=1e-15) and tr["z_dot"][0] == 0.0


def test_the_drift_of_the_rod_stays_at_round_off_over_a_long_run(pendulum):
    tr = lg.simulate(pendulum, t_end=200.0, dt=0.05, rtol=1e-8, atol=1e-8)
    drift = tr.stats["constraint_drift"]
    assert drift["position"] < 1e-12 and drift["velocity"] < 1e-12
    r = np.sqrt(tr["x"] ** 2 + tr["y"] ** 2 + tr["z"] ** 2)
    assert np.max(np.abs(r - 1.0)) < 1e-12
    assert tr.energy_drift < 1e-4  # the integration error at rtol 1e-8, not the constraint's
