"""Steady motions of constrained models (and equilibria with velocity constraints): the coin rolling
on a circle against Routh's closed form, kept steady by the simulation; the benchmark bicycle's
straight running against Table 2 and a steady turn kept by the simulation; a conical pendulum written
with a length constraint; a knife edge's set of steady motions; and every refusal by its text."""

import math

import numpy as np
import pytest

import lagrangian as lg
from lagrangian.analysis import steady_motions

from test_rolling import TABLE2, _roll_steer


@pytest.fixture(scope="module")
def disk():
    return lg.derive(lg.load("rolling-disk"))


@pytest.fixture(scope="module")
def bicycle():
    return lg.derive(lg.load("whipple-bicycle"))


@pytest.mark.parametrize("yaw_rate, spin", [(2.0, 20.0), (1.0, 15.0), (4.0, 12.0)])
def test_the_coin_rolls_steadily_on_a_circle_as_routh_says(disk, yaw_rate, spin):
    found = steady_motions(disk, {"psi_dot": yaw_rate, "theta_dot": spin})
    assert len(found) == 1  # the coin leaning into the turn; the one under the ground is left out
    assert found.notes[0].startswith("1 solution with a wheel's centre below the ground")
    s = found[0]
    a, g, m = 0.3, 9.81, 0.5
    alpha = math.pi / 2 - abs(s.coordinates["phi"])  # the coin's angle to the ground
    R = a * spin / yaw_rate  # the contact point's circle
    b = R - a * math.cos(alpha)  # the centre's circle
    # Routh (A Treatise on the Dynamics of a System of Rigid Bodies, art. 244), thin disk:
    # Omega**2 = 4 g cot(alpha) / (a cos(alpha) + 6 b)
    assert yaw_rate ** 2 == pytest.approx(4 * g / math.tan(alpha) / (a * math.cos(alpha) + 6 * b), rel=1e-8)
    # friction is the centripetal force of the centre, m b Omega**2, and does no work along the path
    friction = math.hypot(s.multipliers["lambda_contact_x"], s.multipliers["lambda_contact_y"])
    assert friction == pytest.approx(m * b * yaw_rate ** 2, rel=1e-8)
    assert s.velocities["x_dot"] == pytest.approx(a * spin) and s.velocities["y_dot"] == 0.0
    assert s.family == ("x", "y", "psi", "theta") and s.isolated
    assert s.stability == "marginally stable"


def test_the_steady_circle_stays_steady_in_the_simulation(disk):
    (s,) = steady_motions(disk, {"psi_dot": 2.0, "theta_dot": 20.0})
    tr = lg.simulate(disk, t_end=3.0, initial={**s.coordinates, **s.velocities})
    assert np.max(np.abs(tr["phi"] - s.coordinates["phi"])) < 1e-7
    # the rates wander by the integrator's error (rtol 1e-10) on the undamped lean mode, 29 rad/s
    assert np.max(np.abs(tr["psi_dot"] - 2.0)) < 1e-5 and np.max(np.abs(tr["theta_dot"] - 20.0)) < 1e-5
    assert tr["psi"][-1] == pytest.approx(6.0, rel=1e-6)  # the heading turns at the steady rate


@pytest.mark.parametrize("v, stability", [(0.5, "unstable"), (1.5, "marginally stable")])
def test_straight_rolling_is_a_steady_motion_whose_stability_changes_at_v_squared_g_r_over_3(disk, v, stability):
    (s,) = steady_motions(disk, {"theta_dot": v / 0.3})
    assert s.coordinates["phi"] == 0.0 and s.velocities["psi_dot"] == 0.0
    assert s.stability == stability
    lam = s.eigenvalues[np.abs(s.eigenvalues) > 1e-9]
    omega2 = (12 * v ** 2 / 0.3 ** 2 - 4 * 9.81 / 0.3) / 5
    assert np.allclose(np.sort(np.abs(lam)), [math.sqrt(abs(omega2))] * 2, rtol=1e-8)


@pytest.mark.slow
def test_the_bicycle_runs_straight_as_table_2_says_and_turns_steadily(bicycle):
    rR = 0.3
    found = steady_motions(bicycle, {"thetaR_dot": 5 / rR}, starts=16)
    straight = [s for s in found if s.coordinates["phi"] == 0 and s.coordinates["delta"] == 0
                and s.coordinates["theta"] == 0]
    assert len(straight) == 1
    s = straight[0]
    assert s.stability == "marginally stable"  # the roll and steer modes decay; the speed stays as it is
    assert np.allclose(_roll_steer(s.linear_model), np.sort_complex(np.array(TABLE2[5])), rtol=0, atol=1e-8)
    assert s.velocities["x_dot"] == pytest.approx(5.0) and s.multipliers["lambda_front_y"] == pytest.approx(0, abs=1e-9)
    (slow,) = [m for m in steady_motions(bicycle, {"thetaR_dot": 3 / rR}, starts=16)
               if m.coordinates["phi"] == 0 and m.coordinates["delta"] == 0 and m.coordinates["theta"] == 0]
    assert slow.stability == "unstable"  # below the weave speed 4.29 m/s
    # the bicycle is symmetric: each turn comes with its mirror image (phi, delta and the yaw rate of
    # opposite signs, the same stability), and no pose turned over under the wheels is listed
    assert any(s.coordinates["phi"] != 0 for s in found)
    for s in found:
        c = s.coordinates
        assert any(_angle(m.coordinates["phi"], -c["phi"]) < 1e-9 and _angle(m.coordinates["delta"], -c["delta"]) < 1e-9
                   and m.velocities["psi_dot"] == pytest.approx(-s.velocities["psi_dot"], abs=1e-9)
                   and m.stability == s.stability for m in found)
        assert abs(c["theta"]) < 0.1 and s.linear_model is not None
        if s.stability == "marginally stable":  # only where no eigenvalue grows
            assert max(z.real for z in s.eigenvalues) <= 1e-6 * max(1.0, np.abs(s.eigenvalues).max())
    assert ("2 solutions with the centres of mass of B and H below the ground (the mechanism turned over under its "
            "wheels: upside down, which the coordinates allow) are left out") in found.notes


def _angle(a, b):
    return abs(math.remainder(a - b, 2 * math.pi))


@pytest.mark.slow
def test_a_hands_free_steady_turn_of_the_bicycle_is_kept_by_the_simulation(bicycle):
    # at a given speed, steady turns without steer torque have isolated radii (Basu-Mandal, Chatterjee and
    # Papadopoulos 2007): the search finds one leaning 40 degrees, steering into the turn
    found = steady_motions(bicycle, {"thetaR_dot": 5 / 0.3}, starts=32)
    (turn,) = [s for s in found if 0 < s.coordinates["phi"] < 1 and 0 < s.coordinates["delta"] < 1]
    assert turn.coordinates["phi"] == pytest.approx(0.7097, abs=1e-4)
    assert abs(turn.velocities["psi_dot"]) == pytest.approx(2.3243, abs=1e-4)  # a 2.15 m radius
    tr = lg.simulate(bicycle, t_end=1.0, initial={**turn.coordinates, **turn.velocities})
    for name in ("phi", "delta", "theta"):
        assert np.max(np.abs(tr[name] - turn.coordinates[name])) < 1e-6
    assert np.max(np.abs(tr["psi_dot"] - turn.velocities["psi_dot"])) < 1e-6
    assert turn.stability == "unstable"


@pytest.mark.slow
def test_a_speed_and_a_yaw_rate_together_overdetermine_a_hands_free_turn_and_none_is_invented(bicycle):
    # steady turns without steer torque have isolated radii at each speed: 10 m at 5 m/s is not one of them
    found = steady_motions(bicycle, {"thetaR_dot": 5 / 0.3, "psi_dot": 0.5}, starts=16)
    assert not found
    assert found.notes[-1] == "the numerical search from 24 starting points found none"
    assert found.text("whipple-bicycle").startswith(
        "Steady motions of whipple-bicycle with thetaR_dot = 16.6667, psi_dot = 0.5: none.")


def test_a_conical_pendulum_written_with_a_length_constraint():
    m = lg.Model("rod", coordinates=["r", "theta", "phi"], parameters={"m": 2.0, "l": 1.5, "g": 9.81})
    m.add_energy(T="m*(r_dot**2 + r**2*theta_dot**2 + r**2*sin(theta)**2*phi_dot**2)/2", V="-m*g*r*cos(theta)")
    m.add_constraint("r - l", name="rod")
    eq = lg.derive(m)
    Omega = 4.0
    found = [s for s in steady_motions(eq, {"phi_dot": Omega}) if 0 < s.coordinates["theta"] < math.pi / 2]
    assert len(found) == 1
    s = found[0]
    assert s.coordinates["r"] == pytest.approx(1.5, rel=1e-12)
    assert math.cos(s.coordinates["theta"]) == pytest.approx(9.81 / (1.5 * Omega ** 2), rel=1e-9)
    # the tension m l Omega**2
    assert abs(s.multipliers["lambda_rod"]) == pytest.approx(2.0 * 1.5 * Omega ** 2, rel=1e-9)
    assert s.stability == "marginally stable"  # Routh's theorem is not applied with constraints


@pytest.mark.slow
def test_a_knife_edge_slides_steadily_at_any_heading_a_set_of_steady_motions():
    knife = lg.Model("knife", coordinates=["x", "y", "phi"], parameters={"m": 1.0})
    knife.add_energy(T="m*(x_dot**2 + y_dot**2 + phi_dot**2)/2")
    knife.add_velocity_constraint("x_dot*sin(phi) - y_dot*cos(phi)", name="blade")
    eq = lg.derive(knife)
    (s,) = steady_motions(eq, {"x_dot": 2.0})
    assert not s.isolated and s.dimension == 1 and s.family == ("x", "y")
    (rest,) = lg.equilibria(eq)
    assert not rest.isolated and rest.multipliers == {"lambda_blade": 0.0}


def test_the_coin_at_rest_is_an_unstable_equilibrium(disk):
    found = lg.equilibria(disk)
    assert [e.coordinates["phi"] for e in found] == [0.0]
    assert found[0].stability == "unstable" and found[0].family == ("x", "y", "psi", "theta")
    assert "found by a numerical search" in found.notes[-1]


# ----------------------------------------------------------------------------- refusals
def test_refusals_name_the_rate_and_say_what_can_be_given(disk):
    with pytest.raises(lg.ModelError, match=r"^\[phi_dot\]: phi is not ignorable \(the motion depends on its value, "
                                            r"or a holonomic constraint contains it\), so it cannot move at a constant "
                                            r"rate in a steady motion; the ignorable coordinates' velocities are "
                                            r"x_dot, y_dot, psi_dot, theta_dot$"):
        steady_motions(disk, {"phi_dot": 1.0})
    with pytest.raises(lg.ModelError, match=r"^\[p_psi\]: 'rolling-disk' has constraints, and steady motions of a "
                                            r"constrained model are found for given rates, not momenta \(velocity "
                                            r"constraints do not conserve momenta\): fix the rates instead "
                                            r"\(velocities=\{\.\.\.\}, --velocity\), e\.g\. psi_dot$"):
        steady_motions(disk, momenta={"p_psi": 1.0})


def test_rates_the_constraints_couple_without_fixing_them_are_refused():
    m = lg.Model("train", coordinates=["a", "b", "c"], parameters={"m": 1.0})
    m.add_energy(T="m*(a_dot**2 + b_dot**2 + c_dot**2)/2")
    m.add_velocity_constraint("a_dot - b_dot - c_dot", name="link")
    eq = lg.derive(m)
    with pytest.raises(lg.ModelError, match=r"^the constraints of 'train' couple the rates b_dot, c_dot without fixing "
                                            r"them, and the given rates move them: give the rate of one more of them "
                                            r"\(velocities=\{\.\.\.\}, --velocity\), so that the others follow$"):
        steady_motions(eq, {"a_dot": 1.0})
    (s,) = steady_motions(eq, {"a_dot": 1.0, "b_dot": 0.25})
    assert s.velocities == {"a_dot": 1.0, "b_dot": 0.25, "c_dot": 0.75}


def test_a_moving_constraint_has_no_steady_motion():
    lift = lg.Model("lift", coordinates=["x", "y"], parameters={"m": 1.0, "g": 9.81})
    lift.add_particle("m", ("x", "y"), name="bead")
    lift.add_gravity("g")
    lift.add_constraint("y - sin(t)", name="piston")
    with pytest.raises(lg.ModelError, match=r"^lift: constraint piston depends on the time t, so no motion of it stays "
                                            r"steady; linearize about a chosen state instead"):
        steady_motions(lg.derive(lift), {"x_dot": 1.0})


@pytest.mark.slow
@pytest.mark.subprocess
def test_the_cli_finds_the_coins_circle_with_its_friction_in_json(tmp_path):
    import json
    import subprocess
    import sys

    out = subprocess.run([sys.executable, "-m", "lagrangian", "steady", "rolling-disk", "--velocity",
                          "psi_dot=2,theta_dot=20", "--json"], capture_output=True, text=True, check=True).stdout
    data = json.loads(out)
    (s,) = data["steady_motions"] if "steady_motions" in data else data
    assert s["multipliers"]["lambda_contact_y"] == pytest.approx(5.4826, rel=1e-4)
    assert s["velocities"]["x_dot"] == pytest.approx(6.0) and s["stability"] == "marginally stable"
