"""A model file's [simulation] inputs naming a CSV column ("@data.csv:acc", the CLI's --input syntax
parsed by the same function): read relative to the model file's folder, the same numbers as the API
with lagrangian.Signal.from_csv, and refused (absolute, '..', a symlink out, missing file, bad
column, a model not read from a file, the playground) with one message each."""

from __future__ import annotations

import io
import os

import numpy as np
import pytest

import lagrangian as lg
from lagrangian.cli import main
from lagrangian.errors import ModelError, ModelFileError
from lagrangian.io import loads_model

MODEL = ('name = "osc"\ncoordinates = ["x"]\nparameters = {{ m = 1.0, k = 4.0, c = 0.3 }}\ninputs = ["F"]\n'
         '[energy]\nT = "m*x_dot**2/2"\nV = "k*x**2/2"\nD = "c*x_dot**2/2"\n[forces]\nx = "F"\n'
         '[simulation]\nt_end = 2.0\ndt = 0.1\ninitial = {{ x = 0.1 }}\ninputs = {{ F = "{spec}" }}\n')


def write(folder, spec="@data.csv:acc", name="model.toml"):
    folder.mkdir(parents=True, exist_ok=True)
    t = np.linspace(0.0, 3.0, 31)
    rows = "".join(f"{float(a)!r},{float(np.sin(2 * a) + a * a / 3)!r}\n" for a in t)
    (folder / "data.csv").write_text("t,acc\n" + rows)
    path = folder / name
    path.write_text(MODEL.format(spec=spec))
    return path


def problem(path, key="simulation.inputs.F"):
    with pytest.raises(ModelFileError) as exc:
        lg.load(str(path))
    [p] = [p for p in exc.value.problems if p.key == key]
    return p.message


@pytest.mark.parametrize("spec, options", [("@data.csv:acc", {}), ("@data.csv:acc:cubic", {"interpolation": "cubic"})])
def test_a_model_file_s_csv_input_simulates_as_the_api_s_signal(tmp_path, spec, options, capsys):
    path = write(tmp_path / "m", spec)
    eqs = lg.derive(lg.load(str(path)))
    got = lg.simulate(eqs)
    signal = lg.Signal.from_csv(str(tmp_path / "m" / "data.csv"), "acc", **options)
    ref = lg.simulate(lg.derive(lg.load(str(path))), 2.0, {"x": 0.1}, dt=0.1, inputs={"F": signal})
    assert got.t.shape == (21,)
    np.testing.assert_allclose(got.x, ref.x, rtol=0, atol=1e-13)
    assert abs(got.x[-1, 0]) > 1e-3  # the forcing moved it
    cwd = os.getcwd()
    os.chdir(tmp_path)  # the path is the model file's folder's, not the working directory's
    try:
        assert main(["simulate", str(path)]) == 0
    finally:
        os.chdir(cwd)
    lines = [ln for ln in io.StringIO(capsys.readouterr().out).read().splitlines() if ln and not ln.startswith("#")]
    header = lines[0].split(",")
    table = np.array([[float(v) for v in ln.split(",")] for ln in lines[1:]])
    np.testing.assert_allclose(table[:, header.index("x")], ref.x[:, 0], rtol=1e-9, atol=1e-12)
    np.testing.assert_allclose(table[:, header.index("x_dot")], ref.x[:, 1], rtol=1e-9, atol=1e-12)


def test_the_api_s_inputs_replace_the_file_s_signal(tmp_path):
    eqs = lg.derive(lg.load(str(write(tmp_path))))
    got = lg.simulate(eqs, inputs={"F": "0"})
    free = lg.simulate(eqs, inputs={"F": 0.0})
    np.testing.assert_allclose(got.x, free.x, atol=1e-14)


def test_an_absolute_path_is_refused(tmp_path):
    csv = tmp_path / "m" / "data.csv"
    write(tmp_path / "m")
    message = problem(write(tmp_path / "m", f"@{csv}:acc"))
    assert message.startswith(f"'{csv}' is an absolute path; expected a path relative to the model file's folder; "
                              "put the CSV file in the model file's folder (or below it)")
    with pytest.raises(ModelFileError, match=r"model.toml.*simulation\.inputs\.F"):
        lg.load(str(tmp_path / "m" / "model.toml"))


def test_dot_dot_is_refused(tmp_path):
    write(tmp_path)
    message = problem(write(tmp_path / "m", "@../data.csv:acc"))
    assert message.startswith("'../data.csv' contains '..'; expected a path inside the model file's folder")
    message = problem(write(tmp_path / "m", "@sub/../data.csv:acc"))
    assert message.startswith("'sub/../data.csv' contains '..'")


def test_a_symlink_out_of_the_folder_is_refused(tmp_path):
    write(tmp_path / "outside")
    path = write(tmp_path / "m", "@link.csv:acc")
    (tmp_path / "m" / "link.csv").symlink_to(tmp_path / "outside" / "data.csv")
    message = problem(path)
    assert message.startswith("'link.csv' resolves (following symbolic links) to ")
    assert "outside the model file's folder" in message and str(tmp_path / "outside" / "data.csv") in message
    (tmp_path / "m" / "inside.csv").symlink_to(tmp_path / "m" / "data.csv")  # a link within the folder is fine
    lg.load(str(write(tmp_path / "m", "@inside.csv:acc")))


def test_a_missing_file_is_refused(tmp_path):
    message = problem(write(tmp_path, "@nope.csv:acc"))
    assert message.startswith(f"no such CSV file 'nope.csv' in the model file's folder {tmp_path.resolve()}; "
                              "expected a CSV file with a header row")


def test_a_missing_path_is_refused(tmp_path):
    assert problem(write(tmp_path, "@")) == ('expected a CSV file after \'@\', for example F = "@data.csv:F" '
                                             '(or "@data.csv:F:cubic", "@data.csv:F:hold")')


def test_a_bad_column_names_the_model_file_the_key_and_the_csv(tmp_path):
    path = write(tmp_path, "@data.csv:acx")
    eqs = lg.derive(lg.load(str(path)))
    with pytest.raises(ModelError) as exc:
        lg.simulate(eqs)
    assert str(exc.value).startswith(f"{path}: simulation.inputs.F: '@data.csv:acx': "
                                     f"{tmp_path.resolve() / 'data.csv'}: no column 'acx' (did you mean 'acc'?)")
    assert main(["simulate", str(path)]) != 0


def test_a_model_not_read_from_a_file_is_refused():
    with pytest.raises(ModelFileError) as exc:
        loads_model(MODEL.format(spec="@data.csv:acc"))
    [p] = exc.value.problems
    assert p.key == "simulation.inputs.F"
    assert p.message.startswith("'@data.csv:acc' names a CSV file, but this model was not read from a file, so "
                                "there is no folder to read it from; save the model as a .toml file")


def test_the_playground_s_reader_refuses_it():
    with pytest.raises(ModelFileError) as exc:
        loads_model(MODEL.format(spec="@data.csv:acc"), source="<playground>")
    [p] = exc.value.problems
    assert p.message.startswith("a model sent to the playground cannot read files on the server; '@data.csv:acc' "
                                "names a CSV file")
