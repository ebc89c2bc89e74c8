"""Equilibria of models with holonomic constraints: f + G^T lambda = 0 on g = 0, solved for q and the
multipliers, with the stability from the linearization in independent coordinates.

Checked against closed forms (a pendulum in Cartesian coordinates, in the plane and in space: the
rod's tension m g hanging, -m g upright; a slider-crank's dead centres under a force on the slider,
its multiplier the force itself), and a four-bar under gravity against its reduced potential V(th1)
along each assembly mode (closed-form loop closure): the equilibria are V's critical points, the
stable ones its minima, the reduced stiffness V''."""

from __future__ import annotations

import json
import math

import numpy as np
import pytest
import sympy as sp

import lagrangian as lg
from lagrangian.cli import main


@pytest.fixture(scope="module")
def cartesian():
    return lg.derive(lg.load("cartesian-pendulum"))


def spherical_cartesian():
    m = lg.Model("spherical-cartesian", coordinates=["x", "y", "z"], parameters={"m": 2.0, "l": 0.5, "g": 9.81})
    m.add_particle("m", ("x", "y", "z"), name="bob")
    m.add_gravity("g", direction=(0, 0, -1))
    m.add_constraint("sqrt(x**2 + y**2 + z**2) - l", name="rod")
    return lg.derive(m)


# ----------------------------------------------------------------------------- pendulums, exact
def test_cartesian_pendulum_hangs_with_the_rod_in_tension_m_g_and_is_unstable_upright(cartesian):
    found = lg.equilibria(cartesian, params={"m": 2.0, "l": 0.5})
    assert len(found) == 2 and found.notes == ()  # SymPy solved for (x, y, lambda): complete
    bottom, top = found
    m, g, l = 2.0, 9.81, 0.5
    assert bottom.coordinates == {"x": 0.0, "y": -l} and top.coordinates == {"x": 0.0, "y": l}
    assert bottom.exact == {"x": 0, "y": -sp.Symbol("l")} and top.exact["y"] == sp.Symbol("l")
    # the rod written l - |r|: lambda_rod is its tension, m g hanging, -m g (a compression) upright
    assert bottom.multipliers == {"lambda_rod": pytest.approx(m * g, rel=1e-14)}
    assert top.multipliers == {"lambda_rod": pytest.approx(-m * g, rel=1e-14)}
    assert bottom.exact_multipliers == {"lambda_rod": sp.Symbol("g") * sp.Symbol("m")}
    assert bottom.dependent == {"y": -l} and bottom.linear_model.coordinate_names == ("x",)
    assert bottom.stability == "stable" and top.stability == "unstable"
    w = math.sqrt(g / l)
    assert sorted(z.imag for z in bottom.eigenvalues) == pytest.approx([-w, w], rel=1e-12)
    assert sorted(z.real for z in top.eigenvalues) == pytest.approx([-w, w], rel=1e-12)
    assert found.text("cartesian-pendulum") == (
        "Equilibria of cartesian-pendulum (2):\n"
        "  x = 0, y = -l = -0.5 (dependent: y); lambda_rod = g*m = 19.62: stable\n"
        "  x = 0, y = l = 0.5 (dependent: y); lambda_rod = -g*m = -19.62: unstable")


def test_the_json_of_an_equilibrium_gains_the_multipliers_and_the_dependent_coordinates(cartesian):
    bottom = lg.equilibria(cartesian)[0].to_dict()
    assert list(bottom) == ["coordinates", "stable", "stability", "eigenvalues", "exact", "conditions", "family",
                            "isolated", "dimension", "multipliers", "exact_multipliers", "dependent"]
    assert bottom["multipliers"] == {"lambda_rod": 9.81} and bottom["exact_multipliers"] == {"lambda_rod": "g*m"}
    assert bottom["dependent"] == {"y": -1.0} and bottom["exact"] == {"x": "0", "y": "-l"}
    json.dumps(bottom)
    # a model without constraints: the same keys, empty
    plain = lg.equilibria(lg.derive(lg.load("cart-pendulum")))[0].to_dict()
    assert plain["multipliers"] == {} and plain["exact_multipliers"] is None and plain["dependent"] == {}


def test_a_spherical_pendulum_in_cartesian_coordinates_hangs_with_two_modes_at_sqrt_g_over_l():
    found = lg.equilibria(spherical_cartesian())
    assert [e.coordinates for e in found] == [{"x": 0.0, "y": 0.0, "z": -0.5}, {"x": 0.0, "y": 0.0, "z": 0.5}]
    bottom, top = found
    assert found.notes == () and bottom.exact["z"] == -sp.Symbol("l")
    # written |r| - l, the rod's multiplier is minus its tension
    assert bottom.multipliers["lambda_rod"] == pytest.approx(-2.0 * 9.81, rel=1e-14)
    assert bottom.exact_multipliers == {"lambda_rod": -sp.Symbol("g") * sp.Symbol("m")}
    assert bottom.stable and bottom.stability == "stable" and set(bottom.linear_model.coordinate_names) == {"x", "y"}
    assert np.allclose(sorted(abs(z.imag) for z in bottom.eigenvalues), [math.sqrt(9.81 / 0.5)] * 4, rtol=1e-12)
    assert top.stability == "unstable" and bottom.dependent == {"z": -0.5}


# ----------------------------------------------------------------------------- four-bar under gravity
A, B, C, D = 0.2, 0.6, 0.45, 0.5
MA, MB, MC, GRAV = 0.4, 1.2, 0.9, 9.81


def closed_loop(th1, branch):
    """th2, th3 that close the loop at th1, on assembly mode `branch` (+1 or -1): circle intersection."""
    ax, ay = A * math.cos(th1), A * math.sin(th1)
    ex, ey = D - ax, -ay
    dist = math.hypot(ex, ey)
    along = (B**2 - C**2 + dist**2) / (2 * dist)
    h = math.sqrt(B**2 - along**2)
    bx = ax + (along * ex - branch * h * ey) / dist
    by = ay + (along * ey + branch * h * ex) / dist
    return math.atan2(by - ay, bx - ax), math.atan2(by, bx - D)


def reduced_potential(th1, branch):
    th2, th3 = closed_loop(th1, branch)
    return GRAV * (MA * A / 2 * math.sin(th1) + MB * (A * math.sin(th1) + B / 2 * math.sin(th2))
                   + MC * C / 2 * math.sin(th3))


def test_four_bar_rests_where_its_reduced_potential_is_stationary_on_each_assembly_mode():
    eq = lg.derive(lg.load("four-bar"))
    found = lg.equilibria(eq)
    # along each assembly mode V(th1) has one minimum and one maximum: four equilibria in all
    grid = np.linspace(-math.pi, math.pi, 4001)
    critical = sum(int(np.sum(np.diff(np.sign(np.diff([reduced_potential(t, s) for t in grid]))) != 0))
                   for s in (1, -1))
    assert critical == 4 and len(found) == 4
    assert [e.stable for e in found] == [True, True, False, False]
    assert "there may be others" in found.notes[0]  # found numerically: SymPy does not solve it
    th = [sp.Symbol(n) for n in ("th1", "th2", "th3")]
    lam = eq.multipliers
    at_rest = {v: 0 for v in eq.velocities} | {u: 0 for u in eq.inputs}
    balance = sp.lambdify([*th, *lam], (sp.Matrix(eq.forcing).subs(at_rest) + eq.constraint_forces)
                          .subs({p: v for p, v in eq.parameters.items()}))
    h = 1e-4
    for e in found:
        th1, th2, th3 = e.coordinates.values()
        branch = min((1, -1), key=lambda s: abs(math.remainder(closed_loop(th1, s)[0] - th2, 2 * math.pi)))
        assert np.allclose(closed_loop(th1, branch), (th2, th3), atol=1e-10)
        V = [reduced_potential(th1 + k * h, branch) for k in (-1, 0, 1)]
        assert abs(V[2] - V[0]) / (2 * h) < 1e-7  # dV/dth1 = 0: the forces balance along the mechanism
        stiffness = (V[2] - 2 * V[1] + V[0]) / h**2
        assert e.linear_model.K[0, 0] == pytest.approx(stiffness, rel=1e-5)  # K reduced to th1 is V''
        assert e.stable == (stiffness > 0) and e.dependent == {"th2": th2, "th3": th3}
        # the multipliers balance the forces: f + G^T lambda = 0
        assert np.abs(np.array(balance(th1, th2, th3, *e.multipliers.values()), float)).max() < 1e-9
    # mirrored in the x axis (the ground pivots on it) gravity turns over: stable and unstable swap
    for e, mirror in zip(found, reversed(found)):
        assert np.allclose(list(e.coordinates.values()), [-v for v in mirror.coordinates.values()], atol=1e-9)
        assert e.stable != mirror.stable


# ----------------------------------------------------------------------------- slider-crank
@pytest.mark.slow
def test_slider_crank_without_forces_rests_anywhere_on_its_two_assembly_modes():
    eq = lg.derive(lg.load("slider-crank"))
    found = lg.equilibria(eq)
    assert len(found) == 2 and all(not e.isolated and e.dimension == 1 for e in found)
    r, L = 0.1, 0.35
    slider = sorted(e.coordinates["s"] for e in found)
    for e in found:
        th, ph, s = e.coordinates.values()
        assert r * math.sin(th) + L * math.sin(ph) == pytest.approx(0.0, abs=1e-12)
        assert s == pytest.approx(r * math.cos(th) + L * math.cos(ph), abs=1e-12)
        assert e.multipliers == {"lambda_pin_x": 0.0, "lambda_pin_y": 0.0}
        assert e.stability == "marginally stable"  # nothing holds it along the set
    assert slider[0] < -0.2 and slider[1] > 0.2  # the slider left of the crank and right of it
    right = max(found, key=lambda e: e.coordinates["s"])  # stands for its set by the point nearest q = 0
    assert right.coordinates == {"th": 0.0, "ph": 0.0, "s": pytest.approx(r + L, abs=1e-15)}
    assert found.notes[0] == ("no force acts at rest (f = 0 with these inputs): every configuration that meets the "
                              "constraints is an equilibrium, with its multipliers 0, a set of dimension 1 (n - m) "
                              "for each assembly mode of the mechanism")
    assert "(non-isolated: on a curve of equilibria) (dependent: ph, s)" in found.text()


def test_slider_crank_pushed_rests_at_its_dead_centres_with_the_push_in_the_rod():
    found = lg.equilibria(lg.derive(lg.load("slider-crank")), inputs={"P": 3.0})
    r, L = 0.1, 0.35
    points = [(round(e.coordinates["th"], 12), round(e.coordinates["ph"], 12), e.coordinates["s"], e.stable)
              for e in found]
    pi = round(math.pi, 12)
    assert points == [(0.0, 0.0, pytest.approx(r + L), True), (0.0, pi, pytest.approx(r - L), True),
                      (pi, 0.0, pytest.approx(L - r), False), (pi, pi, pytest.approx(-r - L), False)]
    for e in found:  # the slider's force goes through the rod: lambda_pin_x = P, lambda_pin_y = 0
        assert e.multipliers["lambda_pin_x"] == pytest.approx(3.0, rel=1e-12)
        assert e.multipliers["lambda_pin_y"] == pytest.approx(0.0, abs=1e-12)


# ----------------------------------------------------------------------------- refusals and reasons
def test_velocity_constraints_and_moving_constraints_are_refused_with_the_reason():
    knife = lg.Model("knife", coordinates=["x", "y", "phi"], parameters={"m": 1.0})
    knife.add_energy(T="m*(x_dot**2 + y_dot**2 + phi_dot**2)/2")
    knife.add_velocity_constraint("x_dot*sin(phi) - y_dot*cos(phi)", name="blade")
    # handled now (tests/analysis/test_constrained_steady.py): at rest anywhere
    (rest,) = lg.equilibria(lg.derive(knife))
    assert rest.family == ("x", "y") and rest.dimension == 1
    lift = lg.Model("lift", coordinates=["x", "y"], parameters={"m": 1.0, "g": 9.81})
    lift.add_particle("m", ("x", "y"), name="bead")
    lift.add_gravity("g")
    lift.add_constraint("y - sin(t)", name="piston")
    with pytest.raises(lg.ModelError, match=r"^lift: constraint piston depends on the time t \(a constraint that "
                                            r"moves\), so no state stays at rest and there is no equilibrium; "
                                            r"linearize about a chosen state instead"):
        lg.equilibria(lg.derive(lift))


def test_no_equilibrium_says_why_a_constraint_or_the_forces_rule_it_out():
    ramp = lg.Model("ramp", coordinates=["x", "y"], parameters={"m": 1.0, "g": 9.81, "k": 2.0})
    ramp.add_particle("m", ("x", "y"), name="bead")
    ramp.add_gravity("g")
    ramp.add_constraint("y - x/2", name="wire")  # a frictionless incline: the bead slides down
    found = lg.equilibria(lg.derive(ramp))
    assert found == () and found.notes[0] == ("SymPy finds no solution of -lambda_wire/2 = 0, -g*m + lambda_wire = 0, "
                                              "-(x - 2*y)/2 = 0")
    ramp.add_constraint("k - 1", name="never")
    found = lg.equilibria(lg.derive(ramp))
    assert found.notes == ("constraint 'never', k - 1 = 0, never holds (1 with these values)",)


# ----------------------------------------------------------------------------- the commands
@pytest.mark.slow
def test_equilibria_modes_and_linearize_commands_on_constrained_models(capsys):
    assert main(["equilibria", "cartesian-pendulum"]) == 0
    out = capsys.readouterr().out
    assert out.splitlines()[1] == "  x = 0, y = -l = -1 (dependent: y); lambda_rod = g*m = 9.81: stable"
    assert main(["equilibria", "cartesian-pendulum", "--json", "--param", "m=3"]) == 0
    items = json.loads(capsys.readouterr().out)
    assert [e["multipliers"]["lambda_rod"] for e in items] == pytest.approx([3 * 9.81, -3 * 9.81])
    assert main(["modes", "cartesian-pendulum"]) == 0  # about the stable equilibrium, as without constraints
    out = capsys.readouterr().out
    assert out.startswith("Modes of cartesian-pendulum about the stable equilibrium x = 0, y = -1:")
    assert f"{math.sqrt(9.81) / (2 * math.pi):.6g}" in out
    assert main(["linearize", "four-bar", "--json"]) == 0
    lin = json.loads(capsys.readouterr().out)
    assert lin["state_names"] == ["th1", "th1_dot"] and lin["stable"]
    assert lin["operating_point"]["th1"] == pytest.approx(-1.65824, abs=1e-5)  # the stable one nearest q = 0
    assert lin["constrained"]["dependent"]["th2"] == pytest.approx(-0.429576, abs=1e-6)


def test_a_particle_on_a_slope_has_no_equilibrium_and_the_search_claims_no_fading_force():
    m = lg.Model("incline", coordinates=["x", "y"], parameters={"m": 1.0, "g": 9.81, "a": 0.3})
    m.add_particle("m", ("x", "y"))
    m.add_gravity("g")
    m.add_constraint("y - x*tan(a)", name="slope")
    found = lg.equilibria(lg.derive(m))
    assert list(found) == []
    text = found.text()
    assert "SymPy finds no solution of -lambda_slope*tan(a) = 0, -g*m + lambda_slope = 0" in text
    assert "where the forces tend to 0" not in text  # the slope's pull never fades
    kepler = lg.equilibria(lg.derive(lg.load("kepler"))).text()
    assert "ran away towards r = +-infinity, where the forces tend to 0" in kepler  # -m mu / r**2 does
