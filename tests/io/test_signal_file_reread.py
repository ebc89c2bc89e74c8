"""A model file's CSV input is read once per version of the file: simulating again does not read it
again, and a changed file is read again (its new values are used)."""

from __future__ import annotations

import os

import numpy as np

import lagrangian as lg
from lagrangian.numeric import _inputs

MODEL = """
name = "driven"
coordinates = ["x"]
inputs = ["F"]

[energy]
T = "x_dot**2/2"
V = "2*x**2"

[forces]
x = "F"

[simulation]
t_end = 1.0
inputs = { F = "@force.csv:f" }
"""


def _write(folder, scale):
    t = np.linspace(0.0, 1.0, 101)
    np.savetxt(folder / "force.csv", np.column_stack((t, scale * np.sin(3 * t))), delimiter=",", header="t,f",
               comments="")


def test_the_csv_is_read_once_per_version_of_the_file(tmp_path, monkeypatch):
    (tmp_path / "driven.toml").write_text(MODEL)
    _write(tmp_path, 1.0)
    reads = []
    original = _inputs.Signal.from_csv.__func__

    def counted(cls, *args, **kwargs):
        reads.append(args)
        return original(cls, *args, **kwargs)

    monkeypatch.setattr(_inputs.Signal, "from_csv", classmethod(counted))
    eqs = lg.derive(lg.load(str(tmp_path / "driven.toml")))
    first = lg.simulate(eqs)
    again = lg.simulate(eqs)
    assert len(reads) == 1 and np.array_equal(first.x, again.x)
    _write(tmp_path, 2.0)
    st = os.stat(tmp_path / "force.csv")
    os.utime(tmp_path / "force.csv", ns=(st.st_atime_ns, st.st_mtime_ns + 10**9))  # a later version
    changed = lg.simulate(eqs)
    assert len(reads) == 2
    assert np.allclose(changed["F"], 2 * first["F"], rtol=1e-12, atol=1e-15)


def test_an_input_the_caller_replaces_is_never_read(tmp_path, monkeypatch, capsys):
    """The model file names a CSV column that the file lacks: an input given by the caller (API or
    --input) in its place means the column is not read; simulating with the model file's input names
    the file, the key and the column."""
    (tmp_path / "driven.toml").write_text(MODEL)
    (tmp_path / "force.csv").write_text("t,g\n0,1\n1,2\n")  # no column f
    eqs = lg.derive(lg.load(str(tmp_path / "driven.toml")))
    traj = lg.simulate(eqs, inputs={"F": "sin(3*t)"}, dt=0.5)
    assert np.allclose(traj["F"], np.sin(3 * traj.t))
    batch = lg.simulate_batch(eqs, inputs={"F": 0.0}, initial={"x": np.array([1.0, 2.0])}, dt=0.5)
    assert np.allclose(batch["x"][:, -1], [np.cos(2.0), 2 * np.cos(2.0)], atol=1e-8)  # x'' = -4 x
    from lagrangian.cli import main

    assert main(["simulate", str(tmp_path / "driven.toml"), "--input", "F=0", "--dt", "0.5",
                 "-o", str(tmp_path / "out.csv")]) == 0
    try:
        lg.simulate(eqs)
    except lg.ModelError as exc:
        assert "force.csv" in str(exc) and "simulation.inputs.F" in str(exc) and "'f'" in str(exc), exc
    else:
        raise AssertionError("a missing CSV column was not reported")
