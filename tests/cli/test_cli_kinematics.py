"""`lagrangian kinematics` and `lagrangian inverse-dynamics` (issue 22): the printed and JSON forms
against the library and closed forms, --motion CSV files, -o, and every refusal's text."""

from __future__ import annotations

import json

import numpy as np
import pytest

import lagrangian as lg
from cli_support import run_cli


# ----------------------------------------------------------------------------------- kinematics
def test_kinematics_symbolic_then_numbers(capsys):
    rc, out, err = run_cli(capsys, "kinematics", "double-pendulum", "--point", "bob2")
    assert rc == 0, err
    assert "position = [l1*sin(theta1) + l2*sin(theta2), -l1*cos(theta1) - l2*cos(theta2)]" in out
    assert "[l1*cos(theta1), l2*cos(theta2)]" in out and "At " not in out
    rc, out, err = run_cli(capsys, "kinematics", "double-pendulum", "--point", "bob2", "--at",
                           "theta1=pi/2,theta2=0,theta1_dot=1", "--param", "l2=2", "--json")
    assert rc == 0, err
    d = json.loads(out)
    assert d["name"] == "bob2" and d["kind"] == "particle" and d["coordinates"] == ["theta1", "theta2"]
    assert d["state"]["theta1"] == pytest.approx(np.pi / 2) and d["state"]["theta2_dot"] == 0.0
    assert np.allclose(d["values"]["position"], [1.0, -2.0], atol=1e-15)  # l1 = 1, l2 = 2
    assert np.allclose(d["values"]["velocity"], [0.0, 1.0], atol=1e-15)
    assert np.allclose(d["values"]["jacobian"], [[0.0, 2.0], [1.0, 0.0]], atol=1e-15)


def test_kinematics_of_a_frame(capsys):
    rc, out, err = run_cli(capsys, "kinematics", "heavy-top", "--frame", "body", "--at", "theta=1,phi_dot=2,psi_dot=50",
                           "--json")
    assert rc == 0, err
    d = json.loads(out)
    expected = lg.kinematics(lg.load("heavy-top"), frame="body").at([1.0, 0.0, 0.0], [0.0, 2.0, 50.0])
    assert np.allclose(d["values"]["angular_velocity"], expected.angular_velocity, rtol=0, atol=0)
    assert np.allclose(d["values"]["rotation"], expected.rotation, rtol=0, atol=0)
    assert d["angular_velocity_body"][2] == "phi_dot*cos(theta) + psi_dot"
    rc, out, _ = run_cli(capsys, "kinematics", "heavy-top", "--frame", "body")
    assert rc == 0 and "angular_velocity (world axes)" in out and "rotation (the frame's axes" in out


def test_kinematics_refusals(capsys):
    rc, _, err = run_cli(capsys, "kinematics", "double-pendulum", "--point", "bbo2")
    assert rc == 2 and "point 'bbo2'" in err and "(did you mean 'bob2'?)" in err and "Traceback" not in err
    rc, _, err = run_cli(capsys, "kinematics", "double-pendulum", "--point", "bob2", "--at", "theta3=1")
    assert rc == 2 and "--at theta3: 'theta3' is not a coordinate or velocity of the model" in err
    assert "(did you mean 'theta2'?)" in err
    rc, _, err = run_cli(capsys, "kinematics", "double-pendulum", "--point", "bob2", "--at", "theta1=nan")
    assert rc == 2 and "--at theta1" in err
    rc, _, err = run_cli(capsys, "kinematics", "double-pendulum", "--point", "bob2", "--at", "theta1=__import__('os')")
    assert rc == 2 and "--at theta1" in err and "Traceback" not in err
    rc, _, err = run_cli(capsys, "kinematics", "double-pendulum")
    assert rc == 2 and "one of the arguments --point --frame is required" in err
    rc, _, err = run_cli(capsys, "kinematics", "double-pendulum", "--point", "bob2", "--param", "l9=1")
    assert rc == 2 and "'l9' is not a parameter of the model" in err
    rc, _, err = run_cli(capsys, "kinematics", "heavy-top", "--frame", "bodyy")
    assert rc == 2 and "(did you mean 'body'?)" in err


# ----------------------------------------------------------------------------- inverse dynamics
def test_inverse_dynamics_symbolic_and_at_a_pose(capsys):
    rc, out, err = run_cli(capsys, "inverse-dynamics", "double-pendulum")
    assert rc == 0, err
    assert "tau_theta2 = g*l2*m2*sin(theta2)" in out
    rc, out, err = run_cli(capsys, "inverse-dynamics", "double-pendulum", "--json")
    assert json.loads(out)["tau"][1].startswith("g*l2*m2*sin(theta2)")
    rc, out, err = run_cli(capsys, "inverse-dynamics", "double-pendulum", "--at", "theta1=0.5,theta2=0.2", "--json")
    assert rc == 0, err
    d = json.loads(out)
    g, m1, m2, l1, l2 = 9.81, 1.0, 1.0, 1.0, 1.0
    assert np.allclose(d["tau"], [[g * l1 * (m1 + m2) * np.sin(0.5), g * l2 * m2 * np.sin(0.2)]], rtol=0, atol=1e-13)
    assert d["q"] == [[0.5, 0.2]] and d["multiplier_names"] == []


def test_inverse_dynamics_cart_pendulum_with_input(capsys):
    rc, out, err = run_cli(capsys, "inverse-dynamics", "cart-pendulum", "--at", "q2=1,q2_dot=0.5,q1_ddot=2",
                           "--input", "F=0.25", "--json")
    assert rc == 0, err
    Mc, Mp, L, g = 1.0, 0.5, 1.0, 9.81
    s2, c2 = np.sin(1.0), np.cos(1.0)
    tau1 = (Mc + Mp) * 2 - Mp * L * c2 * 0.25 - 0.25
    tau2 = -Mp * L * s2 * 2 + Mp * g * L * c2
    assert np.allclose(json.loads(out)["tau"], [[tau1, tau2]], rtol=0, atol=1e-13)


def test_inverse_dynamics_four_bar_completed_by_the_constraints(capsys):
    """The torque that holds the four-bar at th1 = 1.2 (th2, th3 from the constraints) is dV/dth1 along
    the mechanism: virtual work, by central differences of V over the completed poses."""
    def pose(th1):
        rc, out, err = run_cli(capsys, "inverse-dynamics", "four-bar", "--at", f"th1={th1!r}", "--json")
        assert rc == 0, err
        d = json.loads(out)
        return np.array(d["q"][0]), d["tau"][0][0], d

    a, b, c, ma, mb, mc, g = 0.2, 0.6, 0.45, 0.4, 1.2, 0.9, 9.81

    def V(q):
        th1, th2, th3 = q
        return g * (ma * a / 2 * np.sin(th1) + mb * (a * np.sin(th1) + b / 2 * np.sin(th2)) + mc * c / 2 * np.sin(th3))

    q, tau, d = pose(1.2)
    h = 1e-5
    dV = (V(pose(1.2 + h)[0]) - V(pose(1.2 - h)[0])) / (2 * h)
    assert tau == pytest.approx(dV, abs=1e-7)
    assert d["actuated"] == ["th1"] and len(d["multipliers"][0]) == 2
    rc, out, _ = run_cli(capsys, "inverse-dynamics", "four-bar", "--at", "th1=1.2")
    assert rc == 0 and "The state, completed by the constraints" in out
    rc, _, err = run_cli(capsys, "inverse-dynamics", "four-bar", "--at", "th1=1.2", "--actuated", "th5")
    assert rc == 2 and "'th5' is not a coordinate" in err


def motion_csv(path, t, q, qd, qdd, names=("theta1", "theta2"), drop=()):
    header = ["t", *names, *(f"{c}_dot" for c in names), *(f"{c}_ddot" for c in names)]
    data = np.column_stack((t, q, qd, qdd))
    keep = [i for i, h in enumerate(header) if h not in drop]
    lines = [",".join(header[i] for i in keep)] + [",".join(repr(float(row[i])) for i in keep) for row in data]
    path.write_text("\n".join(lines) + "\n")
    return path


def test_inverse_dynamics_motion_csv_and_output(capsys, tmp_path):
    t = np.linspace(0, 1, 11)
    q = np.column_stack((np.sin(t), np.cos(t)))
    qd = np.column_stack((np.cos(t), -np.sin(t)))
    qdd = -q
    path = motion_csv(tmp_path / "motion.csv", t, q, qd, qdd)
    out_csv = tmp_path / "torques.csv"
    rc, out, err = run_cli(capsys, "inverse-dynamics", "double-pendulum", "--motion", path, "-o", out_csv)
    assert rc == 0, err
    assert "wrote 11 rows to" in out
    rows = np.loadtxt(out_csv, delimiter=",", skiprows=1)
    assert out_csv.read_text().splitlines()[0] == "t,tau_theta1,tau_theta2"
    expected = lg.inverse_dynamics(lg.derive(lg.load("double-pendulum")), q, qd, qdd, t=t).tau
    assert np.array_equal(rows[:, 0], t) and np.allclose(rows[:, 1:], expected, rtol=0, atol=0)
    rc, out, err = run_cli(capsys, "inverse-dynamics", "double-pendulum", "--motion", path, "-o", "-")
    assert rc == 0 and out.splitlines()[0] == "t,tau_theta1,tau_theta2" and len(out.splitlines()) == 12


def test_inverse_dynamics_motion_refusals(capsys, tmp_path):
    t = np.linspace(0, 1, 3)
    z = np.zeros((3, 2))
    missing = motion_csv(tmp_path / "m.csv", t, z, z, z, drop=("theta1_ddot", "theta2_ddot"))
    rc, _, err = run_cli(capsys, "inverse-dynamics", "double-pendulum", "--motion", missing)
    assert rc == 2 and "the columns theta1_ddot, theta2_ddot are missing" in err and "Traceback" not in err
    typo = tmp_path / "typo.csv"
    typo.write_text(missing.read_text().replace("theta2_dot", "theta2_dt", 1))
    rc, _, err = run_cli(capsys, "inverse-dynamics", "double-pendulum", "--motion", typo)
    assert rc == 2 and "Did you mean 'theta2_dt'?" in err
    bad = motion_csv(tmp_path / "bad.csv", t, z, z, z)
    bad.write_text(bad.read_text().replace("0.5,0.0", "0.5,nan", 1))
    rc, _, err = run_cli(capsys, "inverse-dynamics", "double-pendulum", "--motion", bad)
    assert rc == 2 and "row 3, column 'theta1': 'nan' is not a finite number" in err
    code = tmp_path / "code.csv"
    code.write_text("t,theta1,theta2,theta1_dot,theta2_dot,theta1_ddot,theta2_ddot\n"
                    "0,__import__('os'),0,0,0,0,0\n")
    rc, _, err = run_cli(capsys, "inverse-dynamics", "double-pendulum", "--motion", code)
    assert rc == 2 and "is not a finite number" in err
    empty = tmp_path / "empty.csv"
    empty.write_text("")
    rc, _, err = run_cli(capsys, "inverse-dynamics", "double-pendulum", "--motion", empty)
    assert rc == 2 and "the file is empty" in err
    header = tmp_path / "header.csv"
    header.write_text("t,theta1,theta2,theta1_dot,theta2_dot,theta1_ddot,theta2_ddot\n")
    rc, _, err = run_cli(capsys, "inverse-dynamics", "double-pendulum", "--motion", header)
    assert rc == 2 and "no data rows" in err
    binary = tmp_path / "binary.csv"
    binary.write_bytes(b"\xff\xfe\x00garbage")
    rc, _, err = run_cli(capsys, "inverse-dynamics", "double-pendulum", "--motion", binary)
    assert rc == 2 and "not a text CSV file" in err
    rc, _, err = run_cli(capsys, "inverse-dynamics", "double-pendulum", "--motion", tmp_path / "none.csv")
    assert rc == 2 and "cannot read the file" in err
    rc, _, err = run_cli(capsys, "inverse-dynamics", "double-pendulum", "--motion", missing, "--at", "theta1=1")
    assert rc == 2 and "give one state (--at) or a motion (--motion FILE.csv), not both" in err
    rc, _, err = run_cli(capsys, "inverse-dynamics", "double-pendulum", "-o", tmp_path / "t.csv")
    assert rc == 2 and "--output: the table needs numbers" in err
    rc, _, err = run_cli(capsys, "inverse-dynamics", "double-pendulum", "--at", "theta1_ddt=1")
    assert rc == 2 and "is not a coordinate, velocity or acceleration of the model (did you mean 'theta1_ddot'?)" in err
    rc, _, err = run_cli(capsys, "inverse-dynamics", "four-bar", "--at", "th1=1.2", "--input", "tauu=1")
    assert rc == 2 and "'tauu' is not an input of the model" in err


def test_inverse_dynamics_motion_row_limit(capsys, tmp_path, monkeypatch):
    monkeypatch.setenv("LAGRANGIAN_MAX_ROWS", "5")
    t = np.linspace(0, 1, 10)
    z = np.zeros((10, 2))
    path = motion_csv(tmp_path / "big.csv", t, z, z, z)
    rc, _, err = run_cli(capsys, "inverse-dynamics", "double-pendulum", "--motion", path)
    assert rc == 2 and "more than 5 rows" in err and "LAGRANGIAN_MAX_ROWS" in err
