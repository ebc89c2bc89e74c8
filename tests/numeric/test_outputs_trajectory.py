"""Named outputs along a simulation (issue 21, Part 0): ``traj["tip_x"]``, ``traj.outputs``, the CSV
columns after the existing ones (the CLI's CSV is only extended), evaluated vectorised by the one
numeric model after the run, on the compiled and the SciPy paths, and for a constrained model."""

from __future__ import annotations

import csv
import io
from pathlib import Path

import numpy as np
import pytest

import lagrangian as lg
from lagrangian.cli import main
from lagrangian.io._modelfile import loads_model
from lagrangian.numeric._compiled import compile_equations

MODEL = Path(__file__).parent.parent / "models" / "double-pendulum-outputs.toml"
DOUBLE, OUTPUTS = MODEL.read_text().split("[outputs]")
OUTPUTS = "[outputs]" + OUTPUTS

L1, L2 = 1.3, 0.7


@pytest.fixture(scope="module")
def equations():
    return lg.derive(loads_model(DOUBLE + OUTPUTS, source="dp.toml"))


@pytest.mark.parametrize("backend", ["auto", "scipy"])
def test_tip_position_against_the_closed_form_along_a_chaotic_run(equations, backend):
    tr = lg.simulate(equations, t_end=5.0, dt=0.01, initial={"th1": 2.0, "th2": -2.5}, inputs={"F": 0.3},
                     backend=backend, rtol=1e-9, atol=1e-9)
    th1, th2 = tr["th1"], tr["th2"]
    assert len(tr.t) == 501 and np.ptp(th2) > 1.0
    np.testing.assert_allclose(tr["tip_x"], L1 * np.sin(th1) + L2 * np.sin(th2), rtol=0, atol=1e-12)
    np.testing.assert_allclose(tr["tip_y"], -L1 * np.cos(th1) - L2 * np.cos(th2), rtol=0, atol=1e-12)
    np.testing.assert_allclose(tr["push"], 2 * 0.3 + th1, rtol=0, atol=1e-12)
    assert list(tr.outputs) == ["tip_x", "tip_y", "push"]
    assert tr.outputs["tip_x"] is tr["tip_x"] and not tr["tip_x"].flags.writeable


def test_csv_columns_come_after_the_existing_ones(equations):
    tr = lg.simulate(equations, t_end=0.5, dt=0.1, initial={"th1": 0.4}, inputs={"F": -1.0})
    base = ("t", "th1", "th2", "th1_dot", "th2_dot", "F", "energy")
    assert tr.columns == (*base, "tip_x", "tip_y", "push")
    rows = list(csv.reader(io.StringIO(tr.to_csv())))
    assert tuple(rows[0]) == tr.columns
    table = np.array(rows[1:], dtype=float)
    assert table.shape == (6, 10)
    np.testing.assert_array_equal(table[:, 7], tr["tip_x"])
    np.testing.assert_array_equal(table[:, 9], -2.0 + tr["th1"])
    # without outputs, the columns are what they were
    plain = lg.simulate(lg.derive(loads_model(DOUBLE)), t_end=0.5, dt=0.1, initial={"th1": 0.4}, inputs={"F": -1.0})
    assert plain.columns == base and plain.outputs == {}
    np.testing.assert_array_equal(plain.table(), tr.table()[:, :7])


def test_cli_csv_has_the_output_columns(tmp_path, capsys):
    path = tmp_path / "dp.toml"
    path.write_text(DOUBLE + OUTPUTS)
    out = tmp_path / "out.csv"
    rc = main(["simulate", str(path), "--t-end", "0.2", "--dt", "0.1", "--initial", "th1=0.3", "--output", str(out)])
    assert rc == 0, capsys.readouterr()
    rows = list(csv.reader(out.open()))
    assert rows[0] == ["t", "th1", "th2", "th1_dot", "th2_dot", "F", "energy", "tip_x", "tip_y", "push"]
    assert float(rows[1][7]) == pytest.approx(L1 * np.sin(0.3), abs=1e-15)


def test_the_vectorised_function_equals_the_pointwise_one(equations):
    nm = compile_equations(equations, "scipy")
    f = nm.function("test rows", lambda: list(equations.model.outputs.values()))
    rng = np.random.default_rng(1)
    t, x, u = rng.normal(size=7), rng.normal(size=(7, 4)), rng.normal(size=(7, 1))
    rows = f(t, x, u, nm.parameter_values)
    assert rows.shape == (7, 3)
    for i in range(7):
        np.testing.assert_array_equal(rows[i], f(t[i], x[i], u[i], nm.parameter_values))
    assert f(t[:0], x[:0], u[:0], nm.parameter_values).shape == (0, 3)


def test_a_constrained_model_outputs_follow_its_coordinates():
    m = lg.load("four-bar").copy()
    m.add_output("Bx", "B.x")
    m.add_output("gap", "a*cos(th1) + b*cos(th2) - d - c*cos(th3)")  # the loop closure: zero on the motion
    eqs = lg.derive(m)
    tr = lg.simulate(eqs, t_end=1.0, dt=0.05)
    c, d = 0.45, 0.5
    np.testing.assert_allclose(tr["Bx"], d + c * np.cos(tr["th3"]), rtol=0, atol=1e-12)
    assert np.max(np.abs(tr["gap"])) < 1e-8
    assert tr.columns[-2:] == ("Bx", "gap") and tr.columns.index("Bx") > tr.columns.index("lambda_loop_x")


def test_a_batch_has_the_outputs_of_each_run_as_simulate_gives_them(equations):
    """simulate_batch's outputs (issue 21, Part 0): batch["tip_x"] is (B, N), each row the output of
    that run alone (its own parameters and input), and trajectory(i) carries them."""
    starts = np.array([0.3, 1.0, 2.0])
    batch = lg.simulate_batch(equations, 2.0, initial={"th1": starts}, inputs={"F": "0.3*sin(t)"}, dt=0.05)
    assert batch.output_names == ("tip_x", "tip_y", "push")
    tip = batch["tip_x"]
    assert tip.shape == (3, len(batch.t)) and not tip.flags.writeable
    for i, th1 in enumerate(starts):
        alone = lg.simulate(equations, 2.0, {"th1": th1}, inputs={"F": "0.3*sin(t)"}, dt=0.05)
        for name in batch.output_names:
            np.testing.assert_allclose(batch[name][i], alone[name], rtol=0, atol=1e-9)
        np.testing.assert_allclose(batch.trajectory(i)["push"], 2 * 0.3 * np.sin(batch.t) + batch["th1"][i],
                                   rtol=0, atol=1e-12)
    with pytest.raises(KeyError, match="its columns are t, th1, th2, th1_dot, th2_dot, tip_x, tip_y, push"):
        batch["tip_z"]


def test_an_unpickled_trajectory_is_as_frozen_as_the_original():
    """pickle makes fresh, writable arrays: the unpickled Trajectory freezes them again."""
    import copy
    import pickle

    import lagrangian as lg

    eqs = lg.derive(lg.load("double-pendulum"))
    traj = lg.simulate(eqs, t_end=0.5, backend="scipy")
    for back in (pickle.loads(pickle.dumps(traj)), copy.deepcopy(traj)):
        np.testing.assert_array_equal(back.x, traj.x)
        np.testing.assert_array_equal(back.energy, traj.energy)
        assert back.columns == traj.columns
        for name in ("t", "x", "u", "energy"):
            array = getattr(back, name)
            assert not array.flags.writeable, name
            with pytest.raises(ValueError, match="read-only"):
                array[0] = 1.0
