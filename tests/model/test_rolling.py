"""Wheels rolling without slipping, linearization about steady motions with velocity constraints,
and the benchmark bicycle.

Checked against closed forms (a rolling disk's no-slip conditions, its lean frequency and its critical
speed v**2 = g r / 3), the published eigenvalues of Meijaard, Papadopoulos, Ruina and Schwab (2007)
(Table 2 and its weave and capsize speeds, and the coefficient matrices M, C1, K0, K2 of their
eq. (A 1)-(A 4) values), the nonlinear simulation against the linearization, and conserved energy."""

from __future__ import annotations

import json
import math
import re

import numpy as np
import pytest
import sympy as sp
from scipy.linalg import expm
from scipy.optimize import brentq

import lagrangian as lg
from lagrangian.cli import main
from lagrangian.io import loads_model

# --------------------------------------------------------------------------- the rolling disk


@pytest.fixture(scope="module")
def disk():
    return lg.derive(lg.load("rolling-disk"))


@pytest.mark.slow
def test_a_disk_on_its_contact_point_gets_the_textbook_no_slip_conditions_and_no_contact_condition(disk):
    x_dot, y_dot, th_dot, psi, r = sp.symbols("x_dot y_dot theta_dot psi r")
    cons = {c.name: c for c in disk.model.constraints}
    assert set(cons) == {"contact_x", "contact_y"}  # C_z = r cos(phi): the coordinates keep it on the ground
    assert sp.simplify(cons["contact_x"].expression - (x_dot - r * th_dot * sp.cos(psi))) == 0
    assert sp.simplify(cons["contact_y"].expression - (y_dot - r * th_dot * sp.sin(psi))) == 0
    assert disk.model.wheels[0].constraint_names == ("contact_x", "contact_y")
    assert "energy" in disk.to_dict()["conserved_quantities"]


@pytest.mark.parametrize("v", [0.5, 0.9, 1.2, 1.5, 3.0])
def test_the_rolling_disk_leans_with_the_closed_form_frequency(disk, v):
    r, g = 0.3, 9.81
    lin = lg.linearize(disk, params={"v": v})
    assert lin.state_names == ("psi", "phi", "theta", "psi_dot", "phi_dot", "theta_dot")
    assert lin.constrained["ignorable"] == ["x", "y"] and lin.family == ("psi", "theta")
    assert lin.operating_point["theta_dot"] == pytest.approx(v / r)
    omega2 = (12 * (v / r) ** 2 - 4 * g / r) / 5  # (I3 (I3 + m r^2) Omega^2 / I1 - m g r) / (I1 + m r^2), thin disk
    lam = lin.eigenvalues[np.abs(lin.eigenvalues) > 1e-9]
    assert len(lam) == 2
    if omega2 > 0:
        assert np.allclose(np.sort(lam.imag), [-math.sqrt(omega2), math.sqrt(omega2)], rtol=1e-9)
        assert np.max(np.abs(lam.real)) < 1e-9 and lin.stability == "marginally stable"
    else:
        assert np.allclose(np.sort(lam.real), [-math.sqrt(-omega2), math.sqrt(-omega2)], rtol=1e-9)
        assert lin.stability == "unstable"


def test_upright_rolling_is_stable_above_v_squared_g_r_over_3(disk):
    def growth(v):
        lam = lg.linearize(disk, params={"v": v}).eigenvalues
        return float(np.max(lam.real)) - 1e-6  # 0 on the stable side, sqrt(...) on the other

    critical = brentq(growth, 0.5, 1.5, xtol=1e-12)
    assert critical == pytest.approx(math.sqrt(9.81 * 0.3 / 3), rel=1e-6)


def test_the_rolling_disk_stays_up_above_the_critical_speed_and_falls_below_it(disk):
    fast = lg.simulate(disk, t_end=5.0, initial={"phi": 0.02, "theta_dot": 1.5 / 0.3})
    slow = lg.simulate(disk, t_end=2.0, initial={"phi": 0.02, "theta_dot": 0.5 / 0.3})
    assert np.max(np.abs(fast["phi"])) < 0.1  # oscillates about a slightly tilted steady turn
    assert np.max(np.abs(slow["phi"])) > 0.5
    for tr in (fast, slow):
        assert abs(tr.energy[-1] - tr.energy[0]) < 1e-8 * abs(tr.energy[0])
        assert tr.stats["constraint_drift"]["velocity"] < 1e-10
        assert np.allclose(tr["x_dot"], 0.3 * tr["theta_dot"] * np.cos(tr["psi"]), atol=1e-10)  # no slip
        assert np.allclose(tr["y_dot"], 0.3 * tr["theta_dot"] * np.sin(tr["psi"]), atol=1e-10)


def test_a_wheel_whose_centre_is_free_gets_the_contact_condition_and_the_normal_force_is_its_weight():
    model = loads_model("""
coordinates = ["x", "y", "z", "psi", "phi", "theta"]
[parameters]
m = 2.0
r = 0.5
g = 9.81
[[frames]]
name = "disk"
origin = ["x", "y", "z"]
rotation = [["z", "psi"], ["x", "phi"], ["y", "theta"]]
[[bodies]]
mass = "m"
frame = "disk"
inertia = ["m*r**2/4", "m*r**2/2", "m*r**2/4"]
[[wheels]]
name = "w"
frame = "disk"
radius = "r"
[gravity]
g = "g"
""")
    eqs = lg.derive(model)
    z, phi, r = sp.symbols("z phi r")
    contact = {c.name: c for c in model.constraints}["w_contact"]
    assert contact.kind == "holonomic"
    for value in (0.0, 0.3, -1.1):  # z - r |cos(phi)|: the lowest point of the rim
        assert (float(contact.expression.subs({z: 0.7, phi: value, r: 0.5}))
                == pytest.approx(0.7 - 0.5 * abs(math.cos(value))))
    from lagrangian.numeric._compiled import compile_equations
    from lagrangian.numeric._constrained import constrained_model
    cm = constrained_model(eqs, compile_equations(eqs))
    x = np.zeros(12)
    x[2] = 0.5  # upright on the ground, at rest
    qdd, lam = cm.solve(0.0, x, np.zeros(0), np.array([2.0, 0.5, 9.81]))
    names = [mu.name for mu in eqs.multipliers]
    assert lam[names.index("lambda_w_contact")] == pytest.approx(-2.0 * 9.81) or \
        lam[names.index("lambda_w_contact")] == pytest.approx(2.0 * 9.81)
    assert np.allclose(qdd, 0, atol=1e-12)


# --------------------------------------------------------------------------- the benchmark bicycle

#: Meijaard et al. (2007), Table 2: the eigenvalues at v = 0, 1, ..., 10 m/s.
TABLE2 = {
    0: [-5.53094371765393, -3.13164324790656, 3.13164324790656, 5.53094371765393],
    1: [-7.11008014637442, -3.13423125066578, 3.52696170990070 - 0.80774027519930j,
        3.52696170990070 + 0.80774027519930j],
    2: [-8.67387984831735, -3.07158645641514, 2.68234517512745 - 1.68066296590675j,
        2.68234517512745 + 1.68066296590675j],
    3: [-10.35101467245920, -2.63366137253667, 1.70675605663975 - 2.31582447384325j,
        1.70675605663975 + 2.31582447384325j],
    4: [-12.15861426576450, -1.42944427361326, 0.41325331521125 - 3.07910818603206j,
        0.41325331521125 + 3.07910818603206j],
    5: [-14.07838969279820, -0.32286642900409, -0.77534188219585 - 4.46486771378823j,
        -0.77534188219585 + 4.46486771378823j],
    6: [-16.08537123098030, -0.00406690076970, -1.52644486584142 - 5.87673060598709j,
        -1.52644486584142 + 5.87673060598709j],
    7: [-18.15788466125262, 0.10268170574766, -2.13875644258362 - 7.19525913329805j,
        -2.13875644258362 + 7.19525913329805j],
    8: [-20.27940894394569, 0.14327879765713, -2.69348683581097 - 8.46037971396931j,
        -2.69348683581097 + 8.46037971396931j],
    9: [-22.43788559040858, 0.15790184030917, -3.21675402252485 - 9.69377351531791j,
        -3.21675402252485 + 9.69377351531791j],
    10: [-24.62459635017404, 0.16105338653172, -3.72016840437287 - 10.90681139476287j,
         -3.72016840437287 + 10.90681139476287j],
}


@pytest.fixture(scope="module")
def bicycle():
    return lg.derive(lg.load("whipple-bicycle"))


def _roll_steer(lin):
    """The four roll and steer eigenvalues (the two others are the speed's and the spin's zeros)."""
    lam = np.linalg.eigvals(lin.A)
    order = np.argsort(np.abs(lam))
    assert np.max(np.abs(lam[order[:2]])) < 1e-10
    return np.sort_complex(lam[order[2:]])


@pytest.mark.parametrize("v", sorted(TABLE2))
def test_the_bicycle_has_the_eigenvalues_of_table_2(bicycle, v):
    lin = lg.linearize(bicycle, params={"v": float(v)})
    assert np.max(np.abs(_roll_steer(lin) - np.sort_complex(np.array(TABLE2[v], complex)))) < 1e-8


def test_the_bicycle_weave_and_capsize_speeds_are_those_of_table_2a(bicycle):
    def weave(v):  # real part of the oscillatory pair
        lam = _roll_steer(lg.linearize(bicycle, params={"v": v}))
        return float(lam[np.abs(lam.imag) > 1e-6].real.max())

    def capsize(v):  # the real eigenvalue that crosses zero
        lam = _roll_steer(lg.linearize(bicycle, params={"v": v}))
        real = lam[np.abs(lam.imag) <= 1e-6].real
        return float(real[np.argmin(np.abs(real))])

    v_weave = brentq(weave, 4.0, 5.0, xtol=1e-13)
    v_capsize = brentq(capsize, 5.5, 6.5, xtol=1e-13)
    assert abs(v_weave - 4.29238253634111) < 1e-8
    assert abs(v_capsize - 6.02426201538837) < 1e-8
    lam = _roll_steer(lg.linearize(bicycle, params={"v": v_weave}))
    assert abs(np.abs(lam.imag).max() - 3.43503384866144) < 1e-8  # the weave frequency there


def test_the_bicycle_coefficient_matrices_are_the_papers(bicycle):
    """M q'' + v C1 q' + (g K0 + v^2 K2) q = 0 in q = (phi, delta) (Meijaard et al. 2007, eq. (A 1)-(A 4)
    values in their section 3)."""
    g = 9.81
    at = {v: lg.linearize(bicycle, params={"v": v}) for v in (0.0, 1.0, 2.0)}
    rows = [0, 2]  # (phi, thetaR, delta)
    pick = lambda a: np.asarray(a)[np.ix_(rows, rows)]  # noqa: E731
    M = pick(at[0.0].M)
    C1 = pick(at[1.0].C + at[1.0].G)
    K0 = pick(at[0.0].K) / g
    K2 = (pick(at[2.0].K) - pick(at[0.0].K)) / 4
    assert np.allclose(M, [[80.81722, 2.31941332208709], [2.31941332208709, 0.29784188199686]], rtol=0, atol=1e-11)
    assert np.allclose(C1, [[0, 33.86641391492494], [-0.85035641456978, 1.68540397397560]], rtol=0, atol=1e-10)
    assert np.allclose(K0, [[-80.95, -2.59951685249872], [-2.59951685249872, -0.80329488458618]], rtol=0, atol=1e-10)
    assert np.allclose(K2, [[0, 76.59734589573222], [0, 2.65431523794604]], rtol=0, atol=1e-9)


@pytest.mark.slow
def test_lagrangian_linearize_whipple_bicycle_at_5_m_s_from_the_cli(capsys):
    assert main(["linearize", "whipple-bicycle", "--param", "v=5", "--json"]) == 0
    data = json.loads(capsys.readouterr().out)
    assert data["state_names"] == ["phi", "thetaR", "delta", "phi_dot", "thetaR_dot", "delta_dot"]
    assert data["operating_point"]["thetaR_dot"] == pytest.approx(5 / 0.3)
    assert data["constrained"]["ignorable"] == ["x", "y", "psi", "thetaF"]
    assert data["constrained"]["rates"]["x_dot"] == pytest.approx(5.0)
    assert data["constrained"]["rates"]["thetaF_dot"] == pytest.approx(5 / 0.35)
    A = np.array(data["A"])
    lam = np.linalg.eigvals(A)
    lam = np.sort_complex(lam[np.abs(lam) > 1e-9])
    assert np.max(np.abs(lam - np.sort_complex(np.array(TABLE2[5], complex)))) < 1e-8
    assert main(["linearize", "whipple-bicycle", "--param", "v=5"]) == 0
    out = capsys.readouterr().out
    assert "-0.775342-4.46487j" in out and "-14.0784" in out


@pytest.mark.slow
def test_the_nonlinear_bicycle_follows_its_linearization_and_keeps_its_energy(bicycle):
    v, eps = 5.0, 1e-3
    tr = lg.simulate(bicycle, t_end=3.0, dt=0.01, initial={"phi_dot": eps, "thetaR_dot": v / 0.3},
                     params={"v": v}, rtol=1e-10, atol=1e-12)
    lin = lg.linearize(bicycle, params={"v": v})
    x0 = np.zeros(6)
    x0[3] = eps
    predicted = np.array([expm(lin.A * t) @ x0 for t in tr.t])
    for k, name in enumerate(("phi", "delta")):
        col = lin.state_names.index(name)
        assert np.max(np.abs(tr[name] - predicted[:, col])) < 1e-2 * np.max(np.abs(predicted[:, col]))
    assert abs(tr.energy[-1] - tr.energy[0]) < 1e-9 * abs(tr.energy[0])
    assert tr.stats["constraint_drift"]["position"] < 1e-10
    assert np.max(np.abs(tr["phi"][tr.t > 2.5])) < 0.3 * np.max(np.abs(tr["phi"]))  # weave decays at 5 m/s


# --------------------------------------------------------------------------- steady motions and errors


def test_the_steady_path_and_the_holonomic_path_agree_at_rest():
    from lagrangian.analysis._constrained_linear import linearize_steady
    from lagrangian.analysis._setting import collect_setting

    eqs = lg.derive(lg.load("cartesian-pendulum"))
    at = {"x": 0.0, "y": -1.0, "x_dot": 0.0, "y_dot": 0.0}
    lin = lg.linearize(eqs, {"x": 0.0, "y": -1.0})
    steady = linearize_steady(eqs, at, {"x", "y"}, collect_setting(eqs, None, None, 0.0, []))
    assert np.allclose(np.sort_complex(lin.eigenvalues), np.sort_complex(steady.eigenvalues), atol=1e-9)
    assert np.allclose(steady.eigenvalues.imag.max(), math.sqrt(9.81), rtol=1e-9)


def test_a_state_that_is_not_a_steady_motion_is_refused_with_what_changes(bicycle, disk):
    with pytest.raises(lg.ModelError, match=r"is not a steady motion: the independent speeds phi_dot, delta_dot change "
                                            r"there \(phi_ddot = 0.947, delta_ddot = 1.17\)"):
        lg.linearize(bicycle, {"phi": 0.1, "thetaR_dot": 10.0})
    eqs = lg.derive(lg.load("cartesian-pendulum"))
    with pytest.raises(lg.ModelError, match=r"the state y = -1, x_dot = 1 is not a steady motion: x changes there and "
                                            r"the motion depends on it; linearize about a motion in which only "
                                            r"ignorable coordinates move"):
        lg.linearize(eqs, {"x": 0.0, "y": -1.0, "x_dot": 1.0})


@pytest.mark.parametrize("text, key, message", [
    ('[[wheels]]\nradius = "r"\n', "wheels[0]", 'a wheel needs frame: frame = "wheel"'),
    ('[[wheels]]\nframe = "disk"\n', "wheels[0]", 'a wheel needs radius: radius = "r"'),
    ('[[wheels]]\nframe = "disk"\nradius = "r"\nspokes = 32\n', "wheels[0].spokes", "spokes"),
    ('[[wheels]]\nframe = "disk"\nradius = "r"\naxis = "w"\n', "wheels[0]", "'w' is not an axis of the frame"),
    ('[[wheels]]\nframe = "world"\nradius = "r"\n', "wheels[0]", "a wheel is carried by a frame that moves with it"),
    ('[[wheels]]\nframe = "disc"\nradius = "r"\n', "wheels[0]", "no frame is named 'disc' (did you mean 'disk'?)"),
    ('[[wheels]]\nframe = "disk"\nradius = "r*phi"\n', "wheels[0]", "a wheel's radius is a number or an expression "
                                                                    "of parameters"),
    ('[operating_point]\nphi_dott = 1\n', "operating_point.phi_dott", "'phi_dott' is not a coordinate or a velocity"),
    ('[operating_point]\ntheta_dot = "phi/r"\n', "operating_point.theta_dot",
     "an operating point's value is a number or an expression of the parameters"),
    ('[simulation]\nindependent_speeds = ["phi"]\n', "simulation.independent_speeds", "'phi' is not a velocity"),
    ('[simulation]\nindependent_speeds = "phi_dot"\n', "simulation.independent_speeds", "expected a list of velocity "
                                                                                         "names"),
])
def test_model_file_errors_of_wheels_and_operating_points(text, key, message):
    base = """
coordinates = ["x", "y", "psi", "phi", "theta"]
[parameters]
m = 1.0
r = 0.3
[[frames]]
name = "disk"
origin = ["x", "y", "r*cos(phi)"]
rotation = [["z", "psi"], ["x", "phi"], ["y", "theta"]]
[[bodies]]
mass = "m"
frame = "disk"
inertia = ["m*r**2/4", "m*r**2/2", "m*r**2/4"]
"""
    with pytest.raises(lg.ModelError) as info:
        loads_model(base + text)
    text_out = str(info.value)
    assert key in text_out and message in text_out


def test_two_wheels_with_one_name_and_a_clash_with_a_constraint_are_errors():
    m = lg.Model("w", coordinates=["x", "psi", "theta"])
    m.parameter("r", 0.3)
    m.add_frame("disk", origin=("x", 0, "r"), rotation=[("z", "psi"), ("y", "theta")])
    m.add_wheel("disk", "r", name="w")
    with pytest.raises(lg.ModelError, match="two wheels are named 'w': give each wheel its own name"):
        m.add_wheel("disk", "r", name="w")
    m.add_velocity_constraint("x_dot", name="v_x")
    with pytest.raises(lg.ModelError, match="its constraint 'v_x' is already the name of a constraint"):
        m.add_wheel("disk", "r", name="v")


def test_modes_of_a_gyroscopic_steady_motion_say_that_the_eigenvalues_decide(disk, capsys):
    modes = lg.modes(lg.linearize(disk, params={"v": 1.5}))
    assert modes.coupling == ("gyroscopic",)
    assert "unstable" in modes.kinds  # of M and K alone: the lean has no stiffness of its own
    omega = math.sqrt((12 * 5.0 ** 2 - 4 * 9.81 / 0.3) / 5)
    assert np.allclose(sorted(modes.eigenvalues.imag)[-1], omega, rtol=1e-9)
    assert main(["modes", "rolling-disk", "--param", "v=1.5"]) == 0
    out = capsys.readouterr().out
    assert (f"gyroscopic terms couple these modes, which are those of M and K alone: the motion's eigenvalues are "
            f"0-{omega:.6g}j, 0, 0, 0, 0, 0+{omega:.6g}j (they, not the kinds above, decide its stability)") in out
    assert lg.modes(lg.linearize(lg.derive(lg.load("double-pendulum")))).coupling == ()  # hanging at rest


# --------------------------------------------------------------------------- compiled constrained integration


@pytest.mark.parametrize("name, t_end", [("cartesian-pendulum", 20.0), ("four-bar", 5.0), ("slider-crank", 5.0),
                                         ("whipple-bicycle", 3.0), ("rolling-disk", 5.0)])
@pytest.mark.slow
def test_the_compiled_constrained_integration_takes_scipys_steps_and_holds_the_constraints(name, t_end):
    eqs = lg.derive(lg.load(name))
    fast = lg.simulate(eqs, t_end=t_end, rtol=1e-10, atol=1e-10)
    slow = lg.simulate(eqs, t_end=t_end, rtol=1e-10, atol=1e-10, backend="scipy")
    assert fast.stats["backend"] == "numba" and slow.stats["backend"] == "scipy"
    assert fast.stats["nstep"] == slow.stats["nstep"]  # the same DOP853 and the same projection
    for s in eqs.state_names:
        assert np.max(np.abs(fast[s] - slow[s])) < 1e-6 * (1 + np.max(np.abs(slow[s])))
    assert np.allclose(fast.multipliers, slow.multipliers, rtol=1e-5, atol=1e-6 * np.max(np.abs(slow.multipliers)))
    assert fast.stats["constraint_drift"]["position"] < 1e-10
    assert fast.stats["constraint_drift"]["velocity"] < 1e-12
    assert abs(fast.energy[-1] - fast.energy[0]) < 1e-7 * max(1.0, abs(fast.energy[0]))


def test_the_c_backend_takes_constraints():
    """It refused them until the saddle-point solve and the projection were generated for C from
    numba's template (numeric._codegen_constrained): a C model passed in, too."""
    from lagrangian.numeric._cbackend import c_compiler
    from lagrangian.numeric._compiled import compile_equations

    if c_compiler() is None:
        pytest.skip("no C compiler ($CC, cc or gcc) for the C backend")
    pytest.importorskip("cffi", reason="the C backend needs cffi")
    eqs = lg.derive(lg.load("cartesian-pendulum"))
    fast = lg.simulate(eqs, t_end=1.0, rtol=1e-10, atol=1e-10)
    for c in (lg.simulate(eqs, t_end=1.0, rtol=1e-10, atol=1e-10, backend="c"),
              lg.simulate(compile_equations(eqs, backend="c"), t_end=1.0, rtol=1e-10, atol=1e-10)):
        assert c.stats["backend"] == "c" and np.max(np.abs(c.x - fast.x)) < 1e-10


@pytest.mark.slow
def test_check_of_the_bicycle_finishes_and_names_the_gimbal_lock_of_its_angles(bicycle):
    report = lg.singularities(bicycle)  # M of 8 coordinates: searched numerically (it used to hang)
    assert report.singular
    c = report.configurations[0]
    assert abs(abs(float(c.where["phi"])) - math.pi / 2) < 1e-5  # lying flat: yaw and pitch about one axis
    assert {k for k, v in c.null_velocity.items() if v != 0} >= {"psi_dot", "theta_dot"}
    assert report.cause.startswith("the coordinates ") and "the gimbal lock of successive rotations" in report.cause


def test_independent_speeds_that_cannot_serve_are_refused_with_the_reason():
    disk = lg.load("rolling-disk")
    disk.simulation["independent_speeds"] = ["x_dot", "y_dot", "phi_dot"]  # x_dot, y_dot follow theta_dot
    with pytest.raises(lg.ModelError, match=re.escape(
            "the independent speeds x_dot, y_dot, phi_dot ([simulation] independent_speeds) do not determine the "
            "other rates at this state (5 velocities, 2 constraints: 3 independent speeds are needed, and the "
            "constraints must fix the rest); name other independent speeds")):
        lg.linearize(lg.derive(disk), {"x_dot": 1.5})
    sled = lg.Model("sled", coordinates=["x", "y", "phi"], parameters={"m": 1.0, "k": 2.0})
    sled.add_energy(T="m*(x_dot**2 + y_dot**2 + phi_dot**2)/2", V="k*x**2/2")  # a spring on x: x matters
    sled.add_velocity_constraint("x_dot*sin(phi) - y_dot*cos(phi)", name="blade")
    sled.simulation["independent_speeds"] = ["phi_dot", "y_dot"]
    with pytest.raises(lg.ModelError, match=re.escape(
            "the linearization keeps the coordinates x whose rates are not independent speeds, and the motion "
            "depends on them: choose independent speeds that include their rates ([simulation] "
            "independent_speeds), where the constraints allow it")):
        lg.linearize(lg.derive(sled), {"phi": 0.7})
    sled.simulation["independent_speeds"] = ["phi_dot", "x_dot"]  # with x's rate independent it linearizes
    lin = lg.linearize(lg.derive(sled), {"phi": 0.7})
    assert lin.state_names == ("x", "phi", "x_dot", "phi_dot") and lin.constrained["ignorable"] == ["y"]
