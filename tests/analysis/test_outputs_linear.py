"""Named outputs in the linearization (issue 21, Part 0): y = C x + D u about the point, the states
first (C = I, D = 0 as before) and then one row per named output; ``to_control()`` keeps the names
(a Bode plot from F to tip_x); ``lagrangian linearize --json`` gains "outputs"."""

from __future__ import annotations

import json
from pathlib import Path

import numpy as np
import pytest
from scipy.optimize import fsolve

import lagrangian as lg
from lagrangian.cli import main
from lagrangian.errors import ModelError
from lagrangian.io._modelfile import loads_model

MODEL = Path(__file__).parent.parent / "models" / "double-pendulum-outputs.toml"
L1, L2 = 1.3, 0.7


@pytest.fixture(scope="module")
def hanging():
    eqs = lg.derive(loads_model(MODEL.read_text(), source=str(MODEL)))
    return lg.linearize(eqs, {"th1": 0.0, "th2": 0.0}, inputs={"F": 0.0})


def test_tip_x_row_at_the_hanging_equilibrium_is_exact(hanging):
    assert hanging.output_names == ("th1", "th2", "th1_dot", "th2_dot", "tip_x", "tip_y", "push")
    C, D = hanging.output_matrix, hanging.feedthrough
    assert C.shape == (7, 4) and D.shape == (7, 1)
    np.testing.assert_array_equal(C[:4], np.eye(4))
    np.testing.assert_array_equal(D[:4], np.zeros((4, 1)))
    assert C[4].tolist() == [L1, L2, 0.0, 0.0]
    assert C[5].tolist() == [0.0, 0.0, 0.0, 0.0]  # the height is flat at the bottom
    # push = 2*F + th1: its D is the input's coefficient
    assert C[6].tolist() == [1.0, 0.0, 0.0, 0.0] and D[6].tolist() == [2.0] and D[4:6].tolist() == [[0.0], [0.0]]


def test_rows_away_from_equilibrium_are_the_gradient():
    eqs = lg.derive(loads_model(MODEL.read_text()))
    lin = lg.linearize(eqs, {"th1": 0.3, "th2": -0.4, "th1_dot": 0.5}, inputs={"F": 1.5})
    np.testing.assert_allclose(lin.output_matrix[4], [L1 * np.cos(0.3), L2 * np.cos(-0.4), 0, 0], rtol=0, atol=1e-15)
    np.testing.assert_allclose(lin.output_matrix[5], [L1 * np.sin(0.3), L2 * np.sin(-0.4), 0, 0], rtol=0, atol=1e-15)


def test_without_outputs_c_is_the_identity_and_d_zero():
    lin = lg.linearize(lg.derive(lg.load("cart-pendulum")), {"q1": 0.0, "q2": 0.0}, inputs={"F": 0.0})
    assert lin.output_names == lin.state_names
    np.testing.assert_array_equal(lin.output_matrix, np.eye(4))
    np.testing.assert_array_equal(lin.feedthrough, np.zeros((4, 1)))
    assert "outputs" not in lin.to_dict()


def test_to_control_bode_from_F_to_tip_x(hanging):
    control = pytest.importorskip("control")
    sys = hanging.to_control()
    assert list(sys.output_labels) == list(hanging.output_names) and list(sys.input_labels) == ["F"]
    w = np.array([0.1, 1.0, 7.0])
    tip = np.array([complex(np.squeeze(sys[["tip_x"], ["F"]](1j * s))) for s in w])
    states = np.array([np.squeeze(sys[["th1", "th2"], ["F"]](1j * s)) for s in w]).T
    np.testing.assert_allclose(tip, L1 * states[0] + L2 * states[1], rtol=1e-12, atol=0)  # an independent path
    # the static gain: K dq = B0 F, tip_x = l1 th1 + l2 th2
    static = np.linalg.solve(hanging.K, hanging.input_matrix).ravel()
    assert control.dcgain(sys[["tip_x"], ["F"]]) == pytest.approx(L1 * static[0] + L2 * static[1], rel=1e-12)
    assert control.dcgain(sys[["push"], ["F"]]) == pytest.approx(static[0] + 2.0, rel=1e-12)


def test_four_bar_rows_in_the_independent_coordinate_against_the_loop_closure():
    a, b, c, d = 0.2, 0.6, 0.45, 0.5
    m = lg.load("four-bar").copy()
    m.add_output("rocker", "th3")
    m.add_output("Bx", "B.x")
    eqs = lg.derive(m)
    eq = lg.equilibria(eqs)[0]
    lin = lg.linearize(eqs, dict(eq.coordinates))
    assert lin.state_names == ("th1", "th1_dot")

    def closed(th1, guess):
        return fsolve(lambda z: [a * np.cos(th1) + b * np.cos(z[0]) - d - c * np.cos(z[1]),
                                 a * np.sin(th1) + b * np.sin(z[0]) - c * np.sin(z[1])], guess, xtol=1e-12)

    th1 = eq.coordinates["th1"]
    guess = [eq.coordinates["th2"], eq.coordinates["th3"]]
    h = 1e-6
    dth3 = (closed(th1 + h, guess)[1] - closed(th1 - h, guess)[1]) / (2 * h)
    rows = lin.output_matrix[2:]
    np.testing.assert_allclose(rows[0], [dth3, 0.0], rtol=0, atol=1e-8)
    np.testing.assert_allclose(rows[1], [-c * np.sin(eq.coordinates["th3"]) * dth3, 0.0], rtol=0, atol=1e-8)


def test_a_rolling_model_refuses_output_rows_with_the_reason():
    m = lg.load("rolling-disk").copy()
    m.add_output("height", m.coordinates[0])
    eqs = lg.derive(m)
    lin = lg.linearize(eqs)
    with pytest.raises(ModelError, match="the named outputs of a constrained model are linearized only at rest with "
                                         "holonomic constraints .*velocity constraints or a steady motion: read the "
                                         "outputs' derivatives from a simulation, or linearize at rest"):
        lin.output_matrix
    np.testing.assert_array_equal(lin.A, lg.linearize(lg.derive(lg.load("rolling-disk"))).A)


def test_cli_linearize_json_gains_the_outputs(capsys):
    rc = main(["linearize", str(MODEL), "--at", "th1=0,th2=0", "--json"])
    out = capsys.readouterr().out
    assert rc == 0
    data = json.loads(out)
    assert data["outputs"] == {"names": ["tip_x", "tip_y", "push"],
                               "C": [[L1, L2, 0.0, 0.0], [0.0, 0.0, 0.0, 0.0], [1.0, 0.0, 0.0, 0.0]],
                               "D": [[0.0], [0.0], [2.0]]}
    assert {"A", "B", "M", "C", "K", "state_names", "input_names"} <= set(data)
