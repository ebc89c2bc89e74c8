"""Constraints: holonomic and velocity constraints with Lagrange multipliers (M q_ddot = f + G^T lambda),
their simulation projected onto the constraints, and the linearization in independent coordinates.

Checked against closed forms (a pendulum's rod tension 3 m g at the bottom, a slider-crank's
kinematics, a knife edge's circle), conserved energy, the drift of the constraints, and sympy's
LagrangesMethod with holonomic constraints."""

from __future__ import annotations

import math
import re

import numpy as np
import pytest
import sympy as sp

import lagrangian as lg
from lagrangian.numeric._compiled import compile_equations
from lagrangian.numeric._constrained import constrained_model


@pytest.fixture(scope="module")
def cartesian():
    return lg.derive(lg.load("cartesian-pendulum"))


def test_cartesian_pendulum_equations_are_the_textbook_ones_with_the_rod_tension(cartesian):
    x, y, xdd, ydd, lam, m, g, l = sp.symbols("x y x_ddot y_ddot lambda_rod m g l")
    r = sp.sqrt(x**2 + y**2)
    assert sp.simplify(cartesian.equations[0] - (m * xdd + lam * x / r)) == 0
    assert sp.simplify(cartesian.equations[1] - (m * ydd + m * g + lam * y / r)) == 0
    assert cartesian.multipliers == (lam,)
    assert sp.simplify(cartesian.constraint_jacobian - sp.Matrix([[-x / r, -y / r]])) == sp.zeros(1, 2)
    data = cartesian.to_dict()
    assert data["multipliers"] == ["lambda_rod"]
    assert data["constraints"][0]["name"] == "rod" and data["constraints"][0]["kind"] == "holonomic"
    assert data["linear"] is None and "energy" in data["conserved_quantities"]
    assert "rod (holonomic): l - sqrt(x**2 + y**2) = 0" in cartesian.text()


def test_released_horizontally_the_rod_tension_is_3_m_g_at_the_bottom(cartesian):
    tr = lg.simulate(cartesian, t_end=3.0, initial={"x": 1.0, "y": 0.0}, dt=0.001, rtol=1e-10, atol=1e-10)
    m, g, l = 1.0, 9.81, 1.0
    # T = m v^2 / l + m g (-y / l) with v^2 = -2 g y: T = -3 m g y / l
    assert np.max(np.abs(tr["lambda_rod"] + 3 * m * g * tr["y"] / l)) < 1e-6
    i = np.argmin(tr["y"])
    assert tr["lambda_rod"][i] == pytest.approx(3 * m * g, rel=1e-5)
    assert tr.columns[-1] == "lambda_rod" and tr.energy_drift < 1e-8
    assert "lambda_rod" in tr.to_csv().splitlines()[0]


def test_the_drift_of_the_constraint_stays_at_round_off_over_a_long_run(cartesian):
    tr = lg.simulate(cartesian, t_end=200.0, initial={"x": 0.6}, dt=0.05, rtol=1e-8, atol=1e-8)
    drift = tr.stats["constraint_drift"]
    assert drift["position"] < 1e-11 and drift["velocity"] < 1e-11
    r = np.hypot(tr["x"], tr["y"])
    assert np.max(np.abs(r - 1.0)) < 1e-11 and tr.energy_drift < 1e-4  # the energy: the integration error (rtol 1e-8)
    assert abs(tr["y"][0]) == pytest.approx(0.8)  # y found on the rod (from y = 0, where the rod is flat, either way)


def test_four_bar_conserves_energy_and_keeps_its_loop_closed():
    eq = lg.derive(lg.load("four-bar"))
    tr = lg.simulate(eq, t_end=10.0, rtol=1e-10, atol=1e-10)
    assert tr["th1"][0] == 1.2 and tr["th1_dot"][0] == 4.0  # the independent coordinate as given
    assert np.ptp(tr.energy) < 1e-7 and np.ptp(tr["th1"]) > 6  # the crank turns round
    a, b, c, d = 0.2, 0.6, 0.45, 0.5
    th1, th2, th3 = tr["th1"], tr["th2"], tr["th3"]
    assert np.max(np.abs(a * np.cos(th1) + b * np.cos(th2) - d - c * np.cos(th3))) < 1e-11
    assert np.max(np.abs(a * np.sin(th1) + b * np.sin(th2) - c * np.sin(th3))) < 1e-11


def test_slider_crank_follows_its_closed_form_kinematics():
    tr = lg.simulate(lg.load("slider-crank"), t_end=1.0, rtol=1e-10, atol=1e-10)
    r, L = 0.1, 0.35
    th = tr["th"]
    s = r * np.cos(th) + np.sqrt(L**2 - (r * np.sin(th)) ** 2)
    assert np.max(np.abs(tr["s"] - s)) < 1e-11 and np.ptp(tr.energy) < 1e-7
    sd = -r * np.sin(th) * tr["th_dot"] * (1 + r * np.cos(th) / np.sqrt(L**2 - (r * np.sin(th)) ** 2))
    assert np.max(np.abs(tr["s_dot"] - sd)) < 1e-9


def _sympy_lagranges(eq, L_expr, coneqs):
    """q_ddot and lambda from sympy's LagrangesMethod with holonomic constraints, as functions of the state."""
    from sympy.physics.mechanics import LagrangesMethod, dynamicsymbols

    names = [c.name for c in eq.coordinates]
    q = dynamicsymbols(" ".join(names))
    q = q if isinstance(q, (list, tuple)) else [q]
    t = dynamicsymbols._t
    sub = {sp.Symbol(n): qi for n, qi in zip(names, q)}
    sub.update({sp.Symbol(n + "_dot"): qi.diff(t) for n, qi in zip(names, q)})
    lm = LagrangesMethod(L_expr.subs(sub), q, hol_coneqs=[c.subs(sub) for c in coneqs])
    lm.form_lagranges_equations()
    back = {qi.diff(t): sp.Symbol(n + "_dot") for n, qi in zip(names, q)}
    back.update({qi: sp.Symbol(n) for n, qi in zip(names, q)})
    Mf = lm.mass_matrix_full.subs(back)
    ff = lm.forcing_full.subs(back)
    return Mf, ff, len(names)


@pytest.mark.parametrize("name, state", [
    ("cartesian-pendulum", {"x": 0.6, "y": -0.8, "x_dot": 0.8, "y_dot": 0.6}),
    ("four-bar", None),
    ("slider-crank", None),
])
def test_accelerations_and_multipliers_equal_sympy_lagranges_method(name, state):
    eq = lg.derive(lg.load(name))
    cm = constrained_model(eq, compile_equations(eq))
    p = compile_equations(eq).parameter_values
    if state is None:  # a consistent state from the simulation's start
        tr = lg.simulate(eq, t_end=0.05, dt=0.05)
        x = tr.x[-1]
    else:
        x = np.array([state[s] for s in eq.state_names])
    u = np.zeros(len(eq.inputs))
    qdd, lam = cm.solve(0.0, x, u, p)
    values = {s: v for s, v in zip(eq.parameters, p)}
    values.update({sp.Symbol(s): v for s, v in zip(eq.state_names, x)})
    values.update({s: 0.0 for s in eq.inputs})
    Mf, ff, n = _sympy_lagranges(eq, eq.L, [c.expression for c in eq.model.constraints])  # inputs at 0: Q = 0
    z = np.linalg.solve(np.array(Mf.subs(values), float), np.array(ff.subs(values), float).ravel())
    assert np.allclose(z[n:2 * n], qdd, rtol=1e-9, atol=1e-9)
    # sympy's multipliers multiply the Jacobian of the same constraints: the same numbers up to its sign convention
    theirs = z[2 * n:]
    assert np.allclose(np.abs(theirs), np.abs(lam), rtol=1e-9, atol=1e-9)
    assert np.all(np.sign(theirs[np.abs(lam) > 1e-9]) == np.sign(theirs[0]) * np.sign(lam[np.abs(lam) > 1e-9])
                  * np.sign(lam[0]))


def test_linearized_in_the_independent_coordinate_the_cartesian_pendulum_has_omega_sqrt_g_over_l(cartesian):
    hanging = lg.linearize(cartesian, {"x": 0.0, "y": -1.0})
    assert hanging.coordinate_names == ("x",) and hanging.stability == "stable"
    assert sorted(abs(z.imag) for z in hanging.eigenvalues) == pytest.approx([math.sqrt(9.81)] * 2, rel=1e-12)
    assert hanging.constrained["multipliers"]["lambda_rod"] == pytest.approx(9.81)
    assert hanging.K[0, 0] == pytest.approx(9.81)  # all of it the rod's: tension/l (the Hessian term)
    top = lg.linearize(cartesian, {"x": 0.0, "y": 1.0})
    assert top.stability == "unstable" and max(z.real for z in top.eigenvalues) == pytest.approx(math.sqrt(9.81))
    modes = lg.modes(lg.linearize(cartesian, {"y": -1.0}))  # x found on the rod
    assert modes.frequencies[0] == pytest.approx(math.sqrt(9.81), rel=1e-7)


def test_a_spherical_pendulum_in_cartesian_coordinates_has_two_modes_at_sqrt_g_over_l():
    m = lg.Model("spherical-cartesian", coordinates=["x", "y", "z"], parameters={"m": 2.0, "l": 0.5, "g": 9.81})
    m.add_particle("m", ("x", "y", "z"), name="bob")
    m.add_gravity("g", direction=(0, 0, -1))
    m.add_constraint("sqrt(x**2 + y**2 + z**2) - l", name="rod")
    lin = lg.linearize(lg.derive(m), {"x": 0, "y": 0, "z": -0.5})
    assert set(lin.coordinate_names) == {"x", "y"}
    assert np.allclose(sorted(abs(z.imag) for z in lin.eigenvalues), [math.sqrt(9.81 / 0.5)] * 4, rtol=1e-12)
    assert lin.constrained["multipliers"]["lambda_rod"] == pytest.approx(-2.0 * 9.81)  # g = |r| - l: pulls inward


def test_knife_edge_velocity_constraint_moves_on_a_circle():
    m = lg.Model("knife-edge", coordinates=["x", "y", "phi"], parameters={"m": 1.0, "J": 0.1})
    m.add_energy(T="m*(x_dot**2 + y_dot**2)/2 + J*phi_dot**2/2")
    m.add_velocity_constraint("x_dot*sin(phi) - y_dot*cos(phi)", name="blade")
    eq = lg.derive(m)
    assert eq.constraint_jacobian == sp.Matrix([[sp.sin(sp.Symbol("phi")), -sp.cos(sp.Symbol("phi")), 0]])
    tr = lg.simulate(eq, t_end=10.0, initial={"x_dot": 2.0, "phi_dot": 0.5}, rtol=1e-10, atol=1e-10)
    # the blade allows only motion along (cos phi, sin phi): speed 2 kept, phi turning at 0.5: a circle of radius 4
    assert tr["y_dot"][0] == 0.0 and np.ptp(tr["phi_dot"]) < 1e-9
    assert np.max(np.abs(np.hypot(tr["x"] - 0.0, tr["y"] - 4.0) - 4.0)) < 1e-7
    assert tr.stats["constraint_drift"]["velocity"] < 1e-12 and tr.energy_drift < 1e-9


def test_dependent_constraints_are_diagnosed_where_the_jacobian_loses_rank():
    m = lg.Model("twice", coordinates=["x", "y"], parameters={"l": 1.0, "g": 9.81})
    m.add_particle(1, ("x", "y"), name="bob")
    m.add_gravity("g")
    m.add_constraint("l - sqrt(x**2 + y**2)", name="rod")
    m.add_constraint("x**2 + y**2 - l**2", name="rope")
    with pytest.raises(lg.SimulationError, match=r"the constraints' Jacobian G loses rank at t = 0 \(state x = 1, "
                                                 r"y = 0, .*\): the rows .*rod .*rope combine to zero, so the "
                                                 r"constraints are dependent there \(a dead point"):
        lg.simulate(lg.derive(m), t_end=1.0, initial={"x": 1.0, "y": 0.0})


def test_errors_of_constrained_models():
    cartesian = lg.derive(lg.load("cartesian-pendulum"))
    with pytest.raises(lg.ModelError, match=r"the configuration x = 1, y = 0 is not at rest: the constrained "
                                            r"accelerations there are .*y_ddot"):
        lg.linearize(cartesian, {"x": 1.0, "y": 0.0})
    # events are watched (tests/numeric/test_constrained_simulation.py): the bob crosses x = 0 every half period
    tr = lg.simulate(cartesian, t_end=3.0, initial={"x": 0.6}, events={"e": "x"}, rtol=1e-11, atol=1e-11)
    crossings = tr.events["e"]["t"]
    assert len(crossings) == 2 and np.allclose(tr.events["e"]["x"][:, 0], 0.0, atol=1e-12)
    assert crossings[1] - crossings[0] == pytest.approx(2 * crossings[0], rel=1e-8)  # from x = 0.6 at rest: T/4, 3T/4
    with pytest.raises(lg.ModelError, match=r"the initial coordinates do not meet constraint 'rod' .*give fewer "
                                            r"coordinates"):
        lg.simulate(cartesian, t_end=1.0, initial={"x": 2.0, "y": 0.0})
    model = lg.Model("m", coordinates=["x"])
    model.add_constraint("x - 1", name="c")
    with pytest.raises(lg.ModelError, match=r"two constraints are named 'c'"):
        model.add_constraint("x - 2", name="c")
    with pytest.raises(lg.ModelError, match=r"velocity x_dot appears in a holonomic constraint"):
        bad = lg.Model("v", coordinates=["x"])
        bad.add_constraint("x_dot - 1")
        bad.validate()


def test_model_file_constraint_errors_name_their_lines(tmp_path):
    path = tmp_path / "bad.toml"
    path.write_text('name = "bad"\ncoordinates = ["x", "y"]\n[[particles]]\nmass = 1.0\nposition = ["x", "y"]\n'
                    '[[constraints]]\nname = "rod"\nholonomic = "sqrt(x**2 + y**2) - L"\n[[constraints]]\n'
                    'velocity = "x + y"\n[[constraints]]\nname = "c3"\n[simulation]\nindependent = ["z"]\n')
    with pytest.raises(lg.ModelFileError) as info:
        lg.load(path)
    text = str(info.value)
    assert "bad.toml:8 [constraints[0].holonomic]: unknown name 'L'" in text
    assert ("bad.toml:10 [constraints[1].velocity]: a velocity constraint has no velocity in it: write a constraint "
            "on the coordinates as a holonomic one") in text
    assert ('bad.toml:11 [constraints[2]]: a constraint needs exactly one of holonomic = "g(q, t)"') in text
    assert "bad.toml:14 [simulation.independent]: 'z' is not a coordinate; the coordinates are x, y" in text


def test_every_refusal_of_a_constrained_model_says_what_to_do_instead(tmp_path):
    cartesian = lg.derive(lg.load("cartesian-pendulum"))
    says = r"does not handle constraints yet, and model 'cartesian-pendulum' has 1 \(rod\): "
    with pytest.raises(lg.ModelError, match=r"^\[x_dot\]: x is not ignorable \(the motion depends on its value, or a "
                                            r"holonomic constraint contains it\), so it cannot move at a constant rate "
                                            r"in a steady motion; cartesian-pendulum has no ignorable coordinate"):
        lg.steady_motions(cartesian, {"x_dot": 1.0})  # steady motions are searched; x cannot move steadily
    sweep = lg.continuation(cartesian, "g", [1.0, 2.0])  # no refusal: f + G^T lambda = 0 on g = 0 is continued
    assert sweep.critical_values == () and len(sweep.branches) == 2  # the bob below and above the pivot
    batch = lg.simulate_batch(cartesian, 1.0, params={"g": [9.0, 10.0]})  # no refusal: projected per run
    assert batch.ok.all() and np.max(np.abs(np.hypot(batch["x"], batch["y"]) - 1.0)) < 1e-12
    with pytest.raises(lg.ModelError, match=r"the exact \(symbolic\) linearization " + says + "its numeric"):
        lg.linearize(cartesian, {"x": 0.0, "y": -1.0}).symbolic()
    with pytest.raises(lg.ModelError, match=r"method 'variational' does not integrate constrained models: use "
                                            r"method='DOP853'"):
        lg.simulate(cartesian, t_end=1.0, method="variational")
    # sampled inputs are held (tests/numeric/test_constrained_simulation.py); this model has no input to sample
    with pytest.raises(lg.ModelError, match=r"sample_time is given but the model has no inputs to sample"):
        lg.simulate(cartesian, t_end=1.0, sample_time=0.1)


def test_initial_velocities_and_operating_points_that_the_constraints_refuse():
    cartesian = lg.derive(lg.load("cartesian-pendulum"))
    with pytest.raises(lg.ModelError, match=r"the initial velocities do not meet constraint 'rod' \(its velocity "
                                            r"residual is -1, not 0\), and changing the velocities that were not "
                                            r"given does not fix it"):
        lg.simulate(cartesian, t_end=1.0, initial={"x": 1.0, "y": 0.0, "x_dot": 1.0, "y_dot": 0.0})
    with pytest.raises(lg.ModelError, match=r"is not a steady motion: x changes there and the motion depends on it"):
        lg.linearize(cartesian, {"x": 0.0, "y": -1.0, "x_dot": 1.0})  # a swing, not a steady motion
    model = lg.load("cartesian-pendulum")
    model.simulation["independent"] = ["y"]
    with pytest.raises(lg.ModelError, match=r"the independent coordinates y \(\[simulation\] independent\) do not "
                                            r"determine the others at this configuration \(2 coordinates, 1 "
                                            r"constraints: 1 independent ones are needed"):
        lg.linearize(lg.derive(model), {"x": 0.0, "y": -1.0})
    knife = lg.Model("knife", coordinates=["x", "y", "phi"], parameters={"m": 1.0})
    knife.add_energy(T="m*(x_dot**2 + y_dot**2 + phi_dot**2)/2")
    knife.add_velocity_constraint("x_dot*sin(phi) - y_dot*cos(phi)", name="blade")
    straight = lg.linearize(lg.derive(knife), {"x_dot": 2.0})  # sliding straight on: a steady motion
    assert straight.state_names == ("x", "phi", "x_dot", "phi_dot") and straight.constrained["ignorable"] == ["y"]
    assert np.allclose(straight.A, np.block([[np.zeros((2, 2)), np.eye(2)], [np.zeros((2, 4))]]))
    assert straight.constrained["rates"] == {"x_dot": 2.0, "y_dot": 0.0, "phi_dot": 0.0}


def test_constraint_names_that_clash_and_tables_with_both_kinds(tmp_path):
    model = lg.Model("m", coordinates=["x", "lambda_c"])
    with pytest.raises(lg.ModelError, match=r"constraint 'c': its multiplier 'lambda_c' is already the name of a "
                                            r"coordinate, parameter or input; rename one of them"):
        model.add_constraint("x - 1", name="c")
    path = tmp_path / "both.toml"
    path.write_text('name = "both"\ncoordinates = ["x"]\n[energy]\nT = "x_dot**2/2"\n[[constraints]]\n'
                    'holonomic = "x"\nvelocity = "x_dot"\n[[constraints]]\nname = 3\nholonomic = "x - 1"\n')
    with pytest.raises(lg.ModelFileError) as info:
        lg.load(path)
    text = str(info.value)
    assert "both.toml:5 [constraints[0]]: a constraint needs exactly one of holonomic" in text and "got both" in text
    assert ("both.toml:9 [constraints[1].name]: a constraint's name is a string such as name = \"rod\", "
            "got the number 3") in text


@pytest.mark.parametrize("name", ["four-bar", "slider-crank"])
@pytest.mark.slow
def test_eliminated_to_an_ode_in_the_independent_coordinates_the_loop_moves_as_when_projected(name):
    eqs = lg.derive(lg.load(name))
    ode = lg.simulate(eqs, t_end=3.0, rtol=1e-11, atol=1e-11, constraints="eliminate")
    projected = lg.simulate(eqs, t_end=3.0, rtol=1e-11, atol=1e-11)
    assert "elimination" in ode.stats and "projection" not in ode.stats
    for s in eqs.state_names:
        assert np.max(np.abs(ode[s] - projected[s])) < 1e-7 * (1 + np.max(np.abs(projected[s])))
    assert np.allclose(ode.multipliers, projected.multipliers, rtol=1e-5, atol=1e-5)
    assert ode.stats["constraint_drift"]["position"] < 1e-12 * (1 + np.max(np.abs(ode[eqs.state_names[0]])))
    assert ode.stats["constraint_drift"]["velocity"] < 1e-12
    assert abs(ode.energy[-1] - ode.energy[0]) < 1e-8 * abs(ode.energy[0])


@pytest.mark.parametrize("model, message", [
    ("cartesian-pendulum", "constraints='eliminate' integrates the independent coordinates: name them under "
                           "[simulation] independent (e.g. independent = [\"x\"]), or use constraints='project'"),
    ("rolling-disk", "constraints='eliminate' reduces holonomic constraints to an ODE; velocity constraints cannot "
                     "be eliminated so: use constraints='project'"),
    ("double-pendulum", "constraints='eliminate' is for models with constraints; this one has none"),
])
def test_what_elimination_refuses_says_why(model, message, capsys):
    from lagrangian.cli import main

    with pytest.raises(lg.ModelError, match=re.escape(message)):
        lg.simulate(lg.derive(lg.load(model)), t_end=0.1, constraints="eliminate")
    assert main(["simulate", model, "--constraints", "eliminate", "--t-end", "0.1"]) == 2
    assert message in capsys.readouterr().err
    with pytest.raises(lg.ModelError, match=r"constraints must be 'project' or 'eliminate', got 'reduce'"):
        lg.simulate(lg.derive(lg.load(model)), t_end=0.1, constraints="reduce")
