"""lagrangian.constraint_singularities and `lagrangian check` on mechanisms: the rank of the
constraints' Jacobian G, where it drops (dependent constraints: change points), and the dead points of
the coordinates that drive a mechanism.

Checked against what happens physically: a slider-crank's piston stands still at the crank's dead
centres (ds/dth = 0 in the closed-form kinematics) and a force on it gives the crank no acceleration
there; a four-bar whose input link rocks reaches its dead points where coupler and rocker line up
(cos th1 = (a^2 + d^2 - (b +- c)^2) / (2 a d)) and cannot be assembled beyond them; a parallelogram
four-bar's change points, where both branches (parallelogram and antiparallelogram) pass; a rod
written twice; a pendulum (G = (x, y)/l) regular everywhere.
"""

from __future__ import annotations

import json
import math

import numpy as np
import pytest
import sympy as sp

import lagrangian as lg
from lagrangian.cli import main
from lagrangian.examples import example_source
from lagrangian.io import loads_model
from lagrangian.numeric._compiled import compile_equations
from lagrangian.numeric._constrained import constrained_model


def four_bar(a, b, c, d, initial="th1 = 1.0, th2 = 0.2, th3 = 1.4"):
    """The four-bar example with other link lengths (a crank, b coupler, c rocker, d ground)."""
    text = example_source("four-bar")
    for old, new in (("a = 0.2", f"a = {a}"), ("b = 0.6", f"b = {b}"), ("c = 0.45", f"c = {c}"),
                     ("d = 0.5", f"d = {d}")):
        assert old in text
        text = text.replace(old, new)
    text = text.replace("initial = { th1 = 1.2, th2 = 0.2, th3 = 1.4, th1_dot = 4.0 }", f"initial = {{ {initial} }}")
    return lg.derive(loads_model(text))


def run(capsys, *args):
    rc = main([str(a) for a in args])
    out, err = capsys.readouterr()
    return rc, out, err


# ---------------------------------------------------------------------------------- regular
def test_a_pendulum_in_cartesian_coordinates_has_full_rank_everywhere():
    report = lg.constraint_singularities(lg.derive(lg.load("cartesian-pendulum")))
    assert report.gram_determinant == 1  # G = -(x, y)/sqrt(x**2 + y**2): a unit vector
    assert report.initial == {"x": 1.0, "y": 0.0} and report.initial_rank == 1
    assert not report.singular and not report.everywhere and report.configurations == ()
    assert report.dead_points == ()  # no independent coordinate, no input: nothing drives it
    assert "G has full rank at every configuration: det(G G^T) does not vanish." in report.text()
    assert report.cause == "" and report.fix == ""


def test_the_four_bar_crank_rocker_has_no_change_point_and_its_crank_no_dead_point():
    eq = lg.derive(lg.load("four-bar"))
    report = lg.constraint_singularities(eq)
    a, b, c, th1, th2, th3 = sp.symbols("a b c th1 th2 th3")
    gram = a**2 * b**2 * sp.sin(th1 - th2) ** 2 + a**2 * c**2 * sp.sin(th1 - th3) ** 2 \
        + b**2 * c**2 * sp.sin(th2 - th3) ** 2  # the three links' 2x2 minors: 0 only with all three parallel
    assert sp.simplify(report.gram_determinant - gram) == 0
    assert report.initial_rank == 2 and report.initial["th1"] == 1.2 and not report.singular
    assert [d.drivers for d in report.dead_points] == [("th1",)]  # [simulation] independent (and tau's)
    crank = report.dead_points[0]
    assert crank.reason == "[simulation] independent" and crank.configurations == ()
    assert sp.simplify(crank.determinant - b * c * sp.sin(th2 - th3)) == 0
    # a + d = 0.7 <= b + c = 1.05 and the shortest link turns (Grashof): the crank turns round, as simulated
    assert np.ptp(lg.simulate(eq, t_end=2.0)["th1"]) > 2 * math.pi


# ------------------------------------------------------------------------------- dead points
@pytest.mark.slow
def test_slider_crank_dead_centres_lock_the_piston_and_a_force_on_it_does_not_turn_the_crank():
    eq = lg.derive(lg.load("slider-crank"))
    report = lg.constraint_singularities(eq)
    r, L = 0.1, 0.35
    crank, piston = report.dead_points
    assert crank.drivers == ("th",) and crank.configurations == ()  # driven from the crank: no dead point
    assert piston.drivers == ("s",) and piston.reason == "driven by input P"
    th, ph = sp.symbols("th ph")
    assert sp.simplify(piston.determinant - sp.Symbol("L") * sp.Symbol("r") * sp.sin(ph - th)) == 0
    found = {(c.where["th"], c.where["ph"], c.where["s"]) for c in piston.configurations}
    assert found == {(0, 0, sp.Rational(9, 20)), (sp.pi, 0, sp.Rational(1, 4)),  # top and bottom dead centre
                     (0, sp.pi, -sp.Rational(1, 4)), (sp.pi, sp.pi, -sp.Rational(9, 20))}  # the mirrored assembly
    top, bottom = piston.configurations[:2]  # nearest the initial configuration first: the example's assembly
    assert top.condition == "th = 0, ph = 0, s = 9/20" and bottom.condition == "th = pi, ph = 0, s = 1/4"
    for c in (top, bottom):
        assert c.exact and c.rank == 1 and c.locked == {"s_dot": 1.0} and c.dependent == {"pin_x": 1.0}
        free = c.free[0]  # the crank turns with the piston held: r th_dot + L cos(ph)/cos(th) ph_dot = 0 there
        assert free["s_dot"] == 0.0 and free["ph_dot"] / free["th_dot"] == pytest.approx(
            -r / L * float(sp.cos(c.where["th"])), rel=1e-9)
    # what happens there: s(th) = r cos th + sqrt(L^2 - r^2 sin^2 th) has ds/dth = 0 at th = 0 and pi
    for th0 in (0.0, math.pi):
        h = 1e-6
        s = [r * math.cos(t) + math.sqrt(L**2 - (r * math.sin(t)) ** 2) for t in (th0 - h, th0 + h)]
        assert abs(s[1] - s[0]) / (2 * h) < 1e-9
    # and a force P on the piston, at rest there, gives the crank no acceleration (elsewhere it does)
    cm = constrained_model(eq, compile_equations(eq))
    p = compile_equations(eq).parameter_values
    u = np.array([0.0, 100.0])  # tau, P
    for th0, expected_zero in ((0.0, True), (math.pi, True), (0.5, False)):
        ph0 = -math.asin(r * math.sin(th0) / L)
        x = np.array([th0, ph0, r * math.cos(th0) + L * math.cos(ph0), 0.0, 0.0, 0.0])
        qdd, lam = cm.solve(0.0, x, u, p)
        assert (abs(qdd[0]) < 1e-9) == expected_zero, (th0, qdd)
    assert "Dead points of s (driven by input P): at th = 0, ph = 0, s = 9/20 or th = pi, ph = 0, s = 1/4" \
        in report.text()
    assert ("At th = 0, ph = 0, s = 9/20: every motion the constraints allow keeps s_dot = 0 (s at the end of its "
            "travel), and th_dot = -7/2*ph_dot (s_dot = 0) is free with s held; a force on s there is carried by "
            "constraint pin_x alone and does no work: it cannot drive the mechanism.") in report.text()
    assert report.cause.startswith("s reaches the end of its travel at the dead points")


def test_a_four_bar_whose_input_rocks_has_dead_points_where_coupler_and_rocker_line_up():
    a, b, c, d = 0.45, 0.6, 0.2, 0.5  # the rocker c is the shortest link: th1 cannot turn round
    eq = four_bar(a, b, c, d)
    (dead,) = lg.constraint_singularities(eq).dead_points
    assert dead.drivers == ("th1",) and len(dead.configurations) == 4 and dead.more == 0
    # |A - D| = b + c or b - c: cos th1 = (a^2 + d^2 - (b +- c)^2) / (2 a d)
    expected = sorted(s * math.acos((a**2 + d**2 - (b + k * c) ** 2) / (2 * a * d)) for k in (1, -1) for s in (1, -1))
    assert sorted(float(x.where["th1"]) for x in dead.configurations) == pytest.approx(expected, abs=1e-7)
    for x in dead.configurations:
        th1, th2, th3 = (float(x.where[k]) for k in ("th1", "th2", "th3"))
        assert abs(math.sin(th2 - th3)) < 1e-7  # coupler and rocker in line
        assert abs(a * math.cos(th1) + b * math.cos(th2) - d - c * math.cos(th3)) < 1e-9
        assert x.locked == {"th1_dot": 1.0} and x.free[0]["th1_dot"] == 0.0 and not x.exact
    # th1 at the end of its travel: just beyond a dead point the loop does not close, just before it does
    th1_dead = math.acos((a**2 + d**2 - (b - c) ** 2) / (2 * a * d))
    with pytest.raises(lg.ModelError, match=r"the initial coordinates do not meet constraint 'loop_x'"):
        lg.simulate(eq, t_end=0.1, initial={"th1": th1_dead - 1e-3})
    assert lg.simulate(eq, t_end=0.1, initial={"th1": th1_dead + 1e-3})["th1"][0] == th1_dead + 1e-3


# ------------------------------------------------------------------------ singular configurations
def test_a_parallelogram_four_bar_has_change_points_where_the_constraints_become_dependent():
    eq = four_bar(0.3, 0.5, 0.3, 0.5, "th1 = 1.0, th2 = 0.0, th3 = 1.0")  # a = c, b = d
    report = lg.constraint_singularities(eq)
    assert report.singular and not report.everywhere and report.initial_rank == 2
    assert [c.condition for c in report.configurations] == ["th1 = 0, th2 = 0, th3 = 0", "th1 = pi, th2 = 0, th3 = pi"]
    G = sp.Matrix(eq.constraint_jacobian)
    values = {sp.Symbol(k): v for k, v in (("a", 0.3), ("b", 0.5), ("c", 0.3), ("d", 0.5))}
    for c in report.configurations:
        assert c.exact and c.rank == 1 and c.dependent == {"loop_x": 1.0}  # all pivots on the x axis: no x force
        at = np.array(G.subs(values).subs({sp.Symbol(k): v for k, v in c.where.items()}), float)
        free = np.array([[m[k] for k in ("th1_dot", "th2_dot", "th3_dot")] for m in c.free])
        assert free.shape == (2, 3) and np.allclose(at @ free.T, 0, atol=1e-12)  # two motions: one more than 1 dof
        # both branches pass here: the parallelogram (th1 = th3, th2 still) and the antiparallelogram
        parallelogram = np.array([1.0, 0.0, 1.0])
        assert np.linalg.matrix_rank(np.vstack((free, parallelogram)), tol=1e-9) == 2
    assert "G loses rank where th1 = 0, th2 = 0, th3 = 0 or th1 = pi, th2 = 0, th3 = pi." in report.text()
    assert ("At th1 = 0, th2 = 0, th3 = 0: G has rank 1 of 2; constraint loop_x has no gradient, so the constraints "
            "are dependent; G q_dot = 0 allows 2 independent motions") in report.text()
    assert "a change point" in report.cause and "a + d != b + c" in report.fix
    # the simulation steps across th1 = 0 (and on) on the parallelogram branch: th2 stays 0
    tr = lg.simulate(eq, t_end=3.0, initial={"th1": 1.0, "th1_dot": 3.0})
    assert tr["th1"].max() >= 1.0 and tr["th1"].min() < -math.pi and np.max(np.abs(tr["th2"])) < 1e-12


def test_a_constraint_written_twice_makes_g_lose_rank_everywhere():
    m = lg.Model("twice", coordinates=["x", "y"], parameters={"l": 1.0, "g": 9.81})
    m.add_particle(1, ("x", "y"), name="bob")
    m.add_gravity("g")
    m.add_constraint("l - sqrt(x**2 + y**2)", name="rod")
    m.add_constraint("x**2 + y**2 - l**2", name="rope")
    report = lg.constraint_singularities(lg.derive(m))
    assert report.gram_determinant == 0 and report.everywhere and report.singular and report.initial_rank == 1
    (c,) = report.configurations
    assert c.where == {} and set(c.dependent) == {"rod", "rope"} and len(c.free) == 1
    # their gradients -(x, y)/l and 2 (x, y) on the circle: rod + rope/(2 l) has none
    assert c.dependent["rod"] / c.dependent["rope"] == pytest.approx(2.0)
    assert "G loses rank at every configuration on the constraints: they are dependent everywhere." in report.text()
    assert "Everywhere: G has rank 1 of 2; the combination rod + 1/2*rope has no gradient" in report.text()
    assert report.fix.startswith("remove one of rod, rope from the model")


def test_the_dead_points_of_independent_x_y_on_a_sphere_are_its_equator():
    report = lg.constraint_singularities(lg.derive(lg.load("spherical-pendulum-3d")))
    assert report.gram_determinant == 1 and not report.singular and report.degrees_of_freedom == 2
    (dead,) = report.dead_points
    assert dead.drivers == ("x", "y") and dead.others == ("z",)
    (curve,) = dead.configurations
    assert curve.dimension == 1 and curve.condition == "z = 0" and curve.exact
    assert curve.where == {"x": 1, "y": 0, "z": 0}  # the point of it nearest the initial configuration
    assert curve.locked == {"x_dot": 1.0, "y_dot": 0.0} and curve.free == ({"x_dot": 0.0, "y_dot": 0.0, "z_dot": 1.0},)
    assert "Dead points of x, y ([simulation] independent): at z = 0 (a curve of them)" in report.text()
    assert "At x = 1, y = 0, z = 0 (on the curve z = 0): every motion" in report.text()


def test_velocity_constraints_are_rows_of_g_too():
    report = lg.constraint_singularities(lg.derive(lg.load("rolling-disk")))
    assert report.holonomic == () and len(report.constraints) == 2 and report.initial_rank == 2
    assert not report.singular and report.dead_points == ()


# ------------------------------------------------------------------------------------ the CLI
@pytest.mark.slow
def test_check_json_adds_constraint_singularities_and_keeps_the_mass_matrix_keys(capsys):
    rc, out, err = run(capsys, "check", "slider-crank", "--json")
    assert rc == 0 and err == ""
    data = json.loads(out)
    assert {"model", "coordinates", "singular", "everywhere", "det_mass_matrix", "det_with_values", "configurations",
            "cause", "fix", "diagnosis"} <= set(data)
    assert data["singular"] is False and data["configurations"] == []  # M's diagnosis, as before
    cs = data["constraint_singularities"]
    assert cs["constraints"] == ["pin_x", "pin_y"] and cs["initial_rank"] == 2 and cs["singular"] is False
    piston = cs["dead_points"][1]
    assert piston["drivers"] == ["s"] and piston["determinant"] == "L*r*sin(ph - th)"
    assert piston["configurations"][0]["where"] == {"th": "0", "ph": "0", "s": "9/20"}
    assert piston["configurations"][0]["locked"] == {"s_dot": 1.0}
    rc, out, _ = run(capsys, "check", "cart-pendulum", "--json")
    assert rc == 0 and json.loads(out)["constraint_singularities"] is None


@pytest.mark.slow
def test_check_text_and_the_driver_option(capsys):
    rc, out, _ = run(capsys, "check", "four-bar")
    assert rc == 0
    assert "The mass matrix is regular" in out
    assert "At the initial configuration th1 = 1.2, th2 = 0.425322, th3 = 1.30313: G has rank 2 of 2 (full)." in out
    assert "Dead points of th1 ([simulation] independent): none found on the constraints; det dg/d(th2, th3) = " \
           "b*c*sin(th2 - th3)." in out
    rc, out, _ = run(capsys, "check", "four-bar", "--driver", "th3")
    assert rc == 0 and "Dead points of th3 (given): at th1 = " in out  # the rocker's ends: crank and coupler in line
    rc, out, _ = run(capsys, "check", "slider-crank", "--driver", "th", "--driver", "ph")
    assert "Dead points of th (given): none found" in out and "Dead points of ph (given): at th = 1.5708" in out


# ---------------------------------------------------------------------------- errors and notes
def test_errors_name_what_is_wrong():
    with pytest.raises(lg.ModelError, match=r"model 'cart-pendulum' has no constraints, so there is no constraint "
                                            r"Jacobian to diagnose; lagrangian.singularities \(lagrangian check\) "
                                            r"diagnoses its mass matrix"):
        lg.constraint_singularities(lg.derive(lg.load("cart-pendulum")))
    with pytest.raises(TypeError, match=r"constraint_singularities\(\) expects the Equations of a model "
                                        r"\(lagrangian.derive\(model\)\), got Model"):
        lg.constraint_singularities(lg.load("four-bar"))
    eq = lg.derive(lg.load("slider-crank"))
    with pytest.raises(lg.ModelError, match=r"driver 'z' is not a coordinate of model 'slider-crank'; its coordinates "
                                            r"are th, ph, s; the drivers th, ph leave 1 coordinates to the 2 holonomic "
                                            r"constraints to fix: name at most 1 drivers in a set"):
        lg.constraint_singularities(eq, drivers=["z", ["th", "ph"]])
    with pytest.raises(lg.ModelError, match=r"a set of drivers names no coordinate; name one or more of th, ph, s"):
        lg.constraint_singularities(eq, drivers=[[]])
    with pytest.raises(lg.ModelError, match=r"a driver has dead points only through holonomic constraints, and model "
                                            r"'rolling-disk' has none"):
        lg.constraint_singularities(lg.derive(lg.load("rolling-disk")), drivers="x")


def test_cli_errors(capsys):
    rc, out, err = run(capsys, "check", "cart-pendulum", "--driver", "q1")
    assert rc == 2 and out == ""
    assert err == ("lagrangian check: error: --driver: model 'cart-pendulum' has no constraints, so no coordinate "
                   "drives it through dead points; --driver is for mechanisms (models with [[constraints]])\n")
    rc, out, err = run(capsys, "check", "four-bar", "--driver", "th9")
    assert rc == 2 and "driver 'th9' is not a coordinate of model 'four-bar'; its coordinates are th1, th2, th3" in err
    rc, out, err = run(capsys, "check", "four-bar", "--driver", ",")
    assert rc == 2 and "a set of drivers names no coordinate; name one or more of th1, th2, th3" in err
    assert "Traceback" not in err


def test_notes_say_what_was_not_searched_and_why():
    free = lg.Model("free", coordinates=["x", "y"], parameters={"l": None})
    free.add_particle(1, ("x", "y"), name="bob")
    free.add_constraint("l - sqrt(x**2 + y**2)", name="rod")
    report = lg.constraint_singularities(lg.derive(free))
    assert report.notes == ("Not searched: parameter l has no value; give it a value in the model to have the "
                            "configurations found.",)
    assert report.gram_determinant == 1 and "At the initial configuration" not in report.text()
    hoop = lg.Model("hoop", coordinates=["x", "y"], parameters={"R": 1.0, "w": 2.0})
    hoop.add_particle(1, ("x", "y"), name="bead")
    hoop.add_constraint("x*sin(w*t) - y*cos(w*t)", name="wire")
    assert "The constraints depend on t: they are diagnosed at t = 0." in lg.constraint_singularities(
        lg.derive(hoop)).notes
    beyond = four_bar(0.45, 0.6, 0.2, 0.5, "th1 = 0.5, th2 = 0.2, th3 = 1.4")  # th1 = 0.5: past the dead point
    report = lg.constraint_singularities(beyond)
    assert report.notes == ("The initial configuration cannot be assembled with th1 held at the model's values "
                            "([simulation] independent); it was assembled with them free.",)
    nowhere = lg.Model("nowhere", coordinates=["x", "y"])
    nowhere.add_particle(1, ("x", "y"), name="p")
    nowhere.add_constraint("x**2 + y**2 + 1", name="impossible")
    report = lg.constraint_singularities(lg.derive(nowhere))
    assert report.notes == ("The model's initial values do not meet the constraints and could not be moved onto "
                            "them: G's rank is given at those values.",)
    assert not report.singular and report.initial_rank == 0  # G = (2x, 2y) = 0 at x = y = 0


def test_the_searchs_point_call_is_the_lambdify_call_bit_for_bit():
    """_constraint_singular._point_call: SymEngine's unsafe_eval into a new array at one point, the numbers of
    fn(x) bit for bit (not finite ones too); anything but a vector of the arguments goes to fn(x) itself (which
    refuses a wrong length)."""
    import symengine as se

    from lagrangian.equations._constraint_singular import _point_call
    from lagrangian.equations._lambdify import lambdify

    a, b = se.symbols("a b")
    fn = lambdify([a, b], [se.sin(a) * b, a / b, se.sqrt(a) + b ** 3])
    call = _point_call(fn, 2, 3)
    rng = np.random.default_rng(1)
    for x in [*rng.uniform(-2, 2, (20, 2)), np.array([1.0, 0.0]), np.array([np.nan, 1.0]), [0.5, 2]]:
        want = np.asarray(fn(np.asarray(x, float)), float).ravel()
        assert call(x).tobytes() == want.tobytes()
    with pytest.raises((ValueError, TypeError)):
        call(np.zeros(3))
