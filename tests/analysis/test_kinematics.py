"""Kinematics of points and frames, and inverse dynamics (issue 22): closed forms, finite differences,
a simulation driven by the computed torques that reproduces the motion, and every error's text."""

from __future__ import annotations

import numpy as np
import pytest
import sympy

import lagrangian as lg
from lagrangian.errors import ModelError

M1, M2, L1, L2, G = 1.3, 0.7, 0.9, 0.6, 9.81


def planar_arm(inputs: bool = False) -> lg.Model:
    """Two uniform rods with relative joint angles q1, q2 (from the x axis), gravity along -y, a tip point."""
    m = lg.Model("arm2", inputs=("tau1", "tau2") if inputs else ())
    q1, q2 = m.coordinate("q1", "q2")
    m1, m2, l1, l2, g = (m.parameter(k, v) for k, v in (("m1", M1), ("m2", M2), ("l1", L1), ("l2", L2), ("g", G)))
    c1, s1, c12, s12 = lg.cos(q1), lg.sin(q1), lg.cos(q1 + q2), lg.sin(q1 + q2)
    m.add_rigid_body(m1, m1 * l1**2 / 12, (l1 / 2 * c1, l1 / 2 * s1), q1, name="link1")
    m.add_rigid_body(m2, m2 * l2**2 / 12, (l1 * c1 + l2 / 2 * c12, l1 * s1 + l2 / 2 * s12), q1 + q2, name="link2")
    m.add_point("tip", (l1 * c1 + l2 * c12, l1 * s1 + l2 * s12))
    m.add_gravity(g)
    if inputs:
        m.add_generalized_force("q1", "tau1")
        m.add_generalized_force("q2", "tau2")
    return m


def gravity_torques(q1, q2):
    return np.array([G * ((M1 / 2 + M2) * L1 * np.cos(q1) + M2 * L2 / 2 * np.cos(q1 + q2)),
                     G * M2 * L2 / 2 * np.cos(q1 + q2)])


# --------------------------------------------------------------------------------------- kinematics
def test_planar_arm_tip_position_and_jacobian_closed_form():
    k = lg.kinematics(planar_arm(), "tip")
    q1, q2, l1, l2 = sympy.symbols("q1 q2 l1 l2")
    expected = sympy.Matrix([[-l1 * sympy.sin(q1) - l2 * sympy.sin(q1 + q2), -l2 * sympy.sin(q1 + q2)],
                             [l1 * sympy.cos(q1) + l2 * sympy.cos(q1 + q2), l2 * sympy.cos(q1 + q2)]])
    assert sympy.simplify(k.jacobian - expected) == sympy.zeros(2, 2)
    assert sympy.simplify(k.position[0] - l1 * sympy.cos(q1) - l2 * sympy.cos(q1 + q2)) == 0
    assert k.kind == "point" and k.rotation is None and k.angular_velocity is None
    rng = np.random.default_rng(1)
    for _ in range(5):
        q, qd = rng.uniform(-3, 3, 2), rng.uniform(-2, 2, 2)
        v = k.at(q, qd)
        a, b = q[0], q[0] + q[1]
        assert np.allclose(v.position, [L1 * np.cos(a) + L2 * np.cos(b), L1 * np.sin(a) + L2 * np.sin(b)],
                           rtol=0, atol=1e-14)
        J = np.array([[-L1 * np.sin(a) - L2 * np.sin(b), -L2 * np.sin(b)], [L1 * np.cos(a) + L2 * np.cos(b),
                                                                           L2 * np.cos(b)]])
        assert np.allclose(v.jacobian, J, rtol=0, atol=1e-14)
        assert np.allclose(v.velocity, J @ qd, rtol=0, atol=1e-14)


def test_planar_body_angle_and_vectorised_rows():
    k = lg.kinematics(planar_arm(), "link2")
    assert k.kind == "body" and k.angle == sympy.Symbol("q1") + sympy.Symbol("q2")
    assert k.angular_jacobian.tolist() == [[1, 1]]
    q = np.array([[0.1, 0.2], [0.3, -0.4], [1.0, 2.0]])
    qd = np.array([[1.0, 2.0], [0.0, 1.0], [-1.0, 0.5]])
    v = k.at(q, qd)
    assert v.position.shape == (3, 2) and v.jacobian.shape == (3, 2, 2) and v.angle.shape == (3,)
    assert np.allclose(v.angle, q.sum(axis=1), rtol=0, atol=1e-15)
    assert np.allclose(v.angular_velocity[:, 0], qd.sum(axis=1), rtol=0, atol=1e-15)
    for i in range(3):  # each row as a single state
        assert np.allclose(k.at(q[i], qd[i]).jacobian, v.jacobian[i], rtol=0, atol=0)


def test_jacobian_against_finite_differences_in_space():
    """The heavy top's centre and frame: the Jacobian against central differences of the position, and
    the angular velocity against vee(R^T dR/dt) by central differences of R along q_dot."""
    model = lg.load("heavy-top")
    centre, frame = lg.kinematics(model, "top"), lg.kinematics(model, frame="body")
    rng = np.random.default_rng(7)
    h = 1e-6
    for _ in range(3):
        q, qd = rng.uniform(0.2, 1.2, 3), rng.uniform(-2, 2, 3)
        v = centre.at(q, qd)
        fd = np.column_stack([(centre.at(q + h * e).position - centre.at(q - h * e).position) / (2 * h)
                              for e in np.eye(3)])
        assert np.allclose(v.jacobian, fd, rtol=0, atol=1e-8)
        assert np.allclose(v.velocity, v.jacobian @ qd, rtol=0, atol=1e-14)
        f = frame.at(q, qd)
        R = f.rotation
        assert np.allclose(R.T @ R, np.eye(3), atol=1e-14)
        dR = (frame.at(q + h * qd).rotation - frame.at(q - h * qd).rotation) / (2 * h)
        W = R.T @ dR
        assert np.allclose([W[2, 1], W[0, 2], W[1, 0]], f.angular_velocity_body, rtol=0, atol=1e-7)
        assert np.allclose(R @ f.angular_velocity_body, f.angular_velocity, rtol=0, atol=1e-13)
        assert np.allclose(f.angular_jacobian @ qd, f.angular_velocity, rtol=0, atol=1e-13)


def test_frame_kinematics_symbolic_and_the_world():
    k = lg.kinematics(lg.load("heavy-top"), frame="body")
    theta, phi, psi = sympy.symbols("theta phi psi")
    # the symmetry axis (the frame's z, the third column of R) in world axes
    axis = sympy.Matrix([sympy.sin(phi) * sympy.sin(theta), -sympy.cos(phi) * sympy.sin(theta), sympy.cos(theta)])
    assert sympy.simplify(k.rotation[:, 2] - axis) == sympy.zeros(3, 1)
    assert sympy.simplify(k.angular_velocity_body[2] - (sympy.Symbol("phi_dot") * sympy.cos(theta)
                                                        + sympy.Symbol("psi_dot"))) == 0
    w = lg.kinematics(lg.load("heavy-top"), frame="world").at([0.1, 0.2, 0.3], [1, 2, 3])
    assert np.array_equal(w.rotation, np.eye(3)) and not w.angular_velocity.any()


def test_kinematics_from_equations_params_and_output():
    eqs = lg.derive(lg.load("double-pendulum"))
    k = lg.kinematics(eqs, "bob2")
    assert np.allclose(k.at([0.0, 0.0], params={"l2": 3.0}).position, [0.0, -4.0], rtol=0, atol=1e-15)
    assert np.allclose(k.at({"theta1": np.pi / 2}).position, [1.0, -1.0], rtol=0, atol=1e-15)
    d = k.to_dict()
    assert d["jacobian"] == [["l1*cos(theta1)", "l2*cos(theta2)"], ["l1*sin(theta1)", "l2*sin(theta2)"]]
    assert "jacobian =" in k.text() and "bob2" in repr(k)
    values = k.at([0.3, 0.5], [1.0, 2.0]).to_dict()
    assert set(values) == {"name", "coordinates", "position", "velocity", "jacobian"}


def test_kinematics_errors_name_what_is_wrong():
    model = lg.load("double-pendulum")
    with pytest.raises(ModelError, match=r"point 'bob3': model 'double-pendulum' has no point, particle or body of "
                                         r"that name \(did you mean 'bob2'\?\); the choices are pivot, bob1, bob2"):
        lg.kinematics(model, "bob3")
    with pytest.raises(ModelError, match=r"frame 'bdy': .* \(did you mean 'body'\?\); the frames are body"):
        lg.kinematics(lg.load("heavy-top"), frame="bdy")
    with pytest.raises(ModelError, match="give a point .* or a frame .*, exactly one of them"):
        lg.kinematics(model)
    with pytest.raises(ModelError, match="exactly one of them"):
        lg.kinematics(lg.load("heavy-top"), "tip", frame="body")
    with pytest.raises(TypeError, match="expects a Model or Equations"):
        lg.kinematics("double-pendulum", "bob2")
    with pytest.raises(ModelError, match=r"point '__import__\('os'\)'"):
        lg.kinematics(model, "__import__('os')")
    k = lg.kinematics(model, "bob2")
    with pytest.raises(ModelError, match=r"q: expected shape \(2,\) or \(N, 2\) .* got shape \(3,\)"):
        k.at([1, 2, 3])
    with pytest.raises(ModelError, match="q: every value must be a finite number"):
        k.at([np.nan, 0])
    with pytest.raises(ModelError, match="q: expected numbers"):
        k.at(["a", "b"])
    with pytest.raises(ModelError, match=r"'l3' is not a parameter of the model \(did you mean 'l2'\?\)"):
        k.at([0, 0], params={"l3": 1.0})
    with pytest.raises(ModelError, match="'thet1' is not a name of q"):
        k.at({"thet1": 1.0})
    with pytest.raises(ModelError, match="q_dot has shape"):
        k.at([0, 0], [[1, 2], [3, 4]])


# --------------------------------------------------------------------------------- inverse dynamics
def test_torques_that_hold_a_pose_are_the_gravity_torques():
    eqs = lg.derive(planar_arm())
    rng = np.random.default_rng(3)
    Q = rng.uniform(-3, 3, (20, 2))
    result = lg.inverse_dynamics(eqs, Q)
    assert result.tau.shape == (20, 2)
    assert np.allclose(result.tau, gravity_torques(Q[:, 0], Q[:, 1]).T, rtol=0, atol=1e-12)
    one = lg.inverse_dynamics(eqs, Q[0])
    assert one.torques.shape == (2,) and np.allclose(one.torques, result.tau[0], rtol=0, atol=0)
    assert np.allclose(result["q2"], result.tau[:, 1], rtol=0, atol=0)


def test_symbolic_inverse_dynamics_is_the_closed_form():
    eqs = lg.derive(planar_arm())
    q1, q2, m1, m2, l1, l2, g = sympy.symbols("q1 q2 m1 m2 l1 l2 g")
    rest = {s: 0 for s in (*eqs.velocities, *eqs.accelerations)}
    G1 = g * ((m1 / 2 + m2) * l1 * sympy.cos(q1) + m2 * l2 / 2 * sympy.cos(q1 + q2))
    G2 = g * m2 * l2 / 2 * sympy.cos(q1 + q2)
    tau = eqs.inverse_dynamics.subs(rest)
    assert sympy.simplify(tau[0] - G1) == 0 and sympy.simplify(tau[1] - G2) == 0


def test_cart_pendulum_torques_closed_form_and_the_input():
    eqs = lg.derive(lg.load("cart-pendulum"))
    Mc, Mp, L, g = 1.0, 0.5, 1.0, 9.81
    rng = np.random.default_rng(5)
    q, qd, qdd = (rng.uniform(-2, 2, (10, 2)) for _ in range(3))
    s2, c2 = np.sin(q[:, 1]), np.cos(q[:, 1])
    tau1 = (Mc + Mp) * qdd[:, 0] - Mp * L * s2 * qdd[:, 1] - Mp * L * c2 * qd[:, 1] ** 2
    tau2 = Mp * L**2 * qdd[:, 1] - Mp * L * s2 * qdd[:, 0] + Mp * g * L * c2
    r = lg.inverse_dynamics(eqs, q, qd, qdd)
    assert np.allclose(r.tau, np.column_stack((tau1, tau2)), rtol=0, atol=1e-12)
    F = rng.uniform(-1, 1, 10)  # the input's force is part of the model's: tau is what is needed beyond it
    r2 = lg.inverse_dynamics(eqs, q, qd, qdd, inputs={"F": F})
    assert np.allclose(r2.tau[:, 0], tau1 - F, rtol=0, atol=1e-12)
    assert np.allclose(lg.inverse_dynamics(eqs, q, qd, qdd, inputs={"F": 2.0}).tau[:, 0], tau1 - 2.0, atol=1e-12)


def test_torques_along_a_motion_reproduce_it_in_simulation():
    """The independent check: tau(t) of a prescribed motion, given to the model as measured signals
    (cubic), drives the simulation along that motion."""
    eqs = lg.derive(planar_arm(inputs=True))
    t = np.linspace(0.0, 2.0, 4001)
    q = np.column_stack((0.3 * np.sin(2 * t) - 0.5, 0.5 * np.cos(1.5 * t)))
    qd = np.column_stack((0.6 * np.cos(2 * t), -0.75 * np.sin(1.5 * t)))
    qdd = np.column_stack((-1.2 * np.sin(2 * t), -1.125 * np.cos(1.5 * t)))
    tau = lg.inverse_dynamics(eqs, q, qd, qdd, t=t).tau
    signals = {f"tau{i + 1}": lg.Signal(t, tau[:, i], interpolation="cubic") for i in range(2)}
    traj = lg.simulate(eqs, 2.0, {"q1": q[0, 0], "q2": q[0, 1], "q1_dot": qd[0, 0], "q2_dot": qd[0, 1]},
                       inputs=signals, dt=0.01, rtol=1e-11, atol=1e-11)
    expected = np.column_stack((0.3 * np.sin(2 * traj.t) - 0.5, 0.5 * np.cos(1.5 * traj.t)))
    assert np.abs(np.column_stack((traj["q1"], traj["q2"])) - expected).max() < 1e-8
    # and without the torques the arm falls: the check has teeth
    free = lg.simulate(eqs, 2.0, {"q1": q[0, 0], "q2": q[0, 1]}, dt=0.01)
    assert np.abs(free["q1"] - expected[:, 0]).max() > 0.1


def test_constrained_four_bar_motor_torque_and_multipliers():
    """A simulated run with the motor torque tau = 0.3: inverse dynamics along it gives 0.3 on th1 (the
    independent coordinate, actuated by default) and the simulation's multipliers."""
    eqs = lg.derive(lg.load("four-bar"))
    traj = lg.simulate(eqs, 0.5, inputs={"tau": "0.3"}, dt=0.01, rtol=1e-11, atol=1e-11)
    nm = lg.compile(eqs, "scipy")
    qdd = np.array([nm.accelerations(t, x, [0.3], nm.parameter_values) for t, x in zip(traj.t, traj.x)])
    r = lg.inverse_dynamics(eqs, traj.x[:, :3], traj.x[:, 3:], qdd, t=traj.t)
    assert r.actuated == ("th1",) and r.multiplier_names == ("lambda_loop_x", "lambda_loop_y")
    assert np.abs(r.tau[:, 0] - 0.3).max() < 1e-9 and not r.tau[:, 1:].any()
    assert np.abs(r.multipliers - traj.multipliers).max() < 1e-7 * (1 + np.abs(traj.multipliers).max())
    assert np.allclose(r.total, r.tau + np.einsum("kij,ki->kj", _G(eqs, traj), r.multipliers), atol=1e-9)
    # with the input given, nothing more is needed
    again = lg.inverse_dynamics(eqs, traj.x[:, :3], traj.x[:, 3:], qdd, t=traj.t, inputs={"tau": 0.3})
    assert np.abs(again.tau).max() < 1e-9


def _G(eqs, traj):
    nm = lg.compile(eqs, "scipy")
    return np.array([nm.constraint_parts(t, x, [0.3], nm.parameter_values)[0] for t, x in zip(traj.t, traj.x)])


def test_inverse_dynamics_output_forms(tmp_path):
    eqs = lg.derive(lg.load("double-pendulum"))
    r = lg.inverse_dynamics(eqs, [[0.5, 0.0], [0.0, 0.0]], t=[0.0, 0.1])
    assert r.columns == ("t", "tau_theta1", "tau_theta2")
    text = r.to_csv(tmp_path / "tau.csv")
    assert (tmp_path / "tau.csv").read_text() == text and text.splitlines()[0] == "t,tau_theta1,tau_theta2"
    assert float(text.splitlines()[1].split(",")[1]) == pytest.approx(2 * 9.81 * np.sin(0.5), abs=1e-12)
    d = r.to_dict()
    assert d["coordinates"] == ["theta1", "theta2"] and len(d["tau"]) == 2 and d["multipliers"] == [[], []]
    assert "tau_theta1" in r.text() and "2 states" in r.text()
    with pytest.raises(KeyError, match="'theta3' is not a coordinate or a multiplier"):
        r["theta3"]


def test_inverse_dynamics_errors_name_what_is_wrong():
    eqs = lg.derive(lg.load("cart-pendulum"))
    with pytest.raises(TypeError, match=r"expects Equations \(lagrangian.derive\(model\)\)"):
        lg.inverse_dynamics(lg.load("cart-pendulum"), [0, 0])
    with pytest.raises(ModelError, match=r"q: expected shape \(2,\) or \(N, 2\)"):
        lg.inverse_dynamics(eqs, [0, 0, 0])
    with pytest.raises(ModelError, match="q_ddot: every value must be a finite number"):
        lg.inverse_dynamics(eqs, [0, 0], [0, 0], [np.inf, 0])
    with pytest.raises(ModelError, match="q_dot: 3 rows, q has 2"):
        lg.inverse_dynamics(eqs, np.zeros((2, 2)), np.zeros((3, 2)))
    with pytest.raises(ModelError, match=r"'Fx' is not an input of the model \(did you mean 'F'\?\)"):
        lg.inverse_dynamics(eqs, [0, 0], inputs={"Fx": 1.0})
    with pytest.raises(ModelError, match=r"inputs.F: expected one value or 2"):
        lg.inverse_dynamics(eqs, np.zeros((2, 2)), inputs={"F": [1.0, 2.0, 3.0]})
    with pytest.raises(ModelError, match=r"'M3' is not a parameter of the model"):
        lg.inverse_dynamics(eqs, [0, 0], params={"M3": 1.0})
    with pytest.raises(ModelError, match="t: expected one time or 2"):
        lg.inverse_dynamics(eqs, np.zeros((2, 2)), t=[0.0, 1.0, 2.0])
    with pytest.raises(ModelError, match=r"'q1_ddt' is not a name of q_ddot \(did you mean 'q1_ddot'\?\)"):
        lg.inverse_dynamics(eqs, [0, 0], q_ddot={"q1_ddt": 1.0})
    four = lg.derive(lg.load("four-bar"))
    with pytest.raises(ModelError, match=r"'th4' is not a coordinate \(did you mean 'th3'\?\)"):
        lg.inverse_dynamics(four, [1.2, 0.2, 1.4], actuated=["th4"])
    with pytest.raises(ModelError, match="does not meet the constraint 'loop_x' at the level of the coordinates"):
        lg.inverse_dynamics(four, [0.0, 0.0, 0.0])
    free = lg.load("four-bar")
    free.simulation = {k: v for k, v in free.simulation.items() if k != "independent"}
    with pytest.raises(ModelError, match=r"say which coordinates the actuators act on, e.g. actuated=\['th1'\]"):
        lg.inverse_dynamics(lg.derive(free), [1.2, 0.2, 1.4])
