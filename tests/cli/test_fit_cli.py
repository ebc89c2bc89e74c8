"""lagrangian fit MODEL DATA.csv ... --params: the table, --json, --plot, and one clear error (exit 2)
for bad data and options."""

from __future__ import annotations

import json

import numpy as np
import pytest

import lagrangian as lg
from lagrangian.cli import main

PENDULUM = """
name = "pend"
coordinates = ["theta"]
[parameters]
m = 1.0
l = 0.5
g = 9.81
c = 0.1
[[particles]]
name = "bob"
mass = "m"
position = ["l*sin(theta)", "-l*cos(theta)"]
[gravity]
g = "g"
[[dampers]]
coefficient = "c"
length = "theta"
"""


@pytest.fixture(scope="module")
def files(tmp_path_factory):
    d = tmp_path_factory.mktemp("fit")
    model = d / "pend.toml"
    model.write_text(PENDULUM)
    eqs = lg.derive(lg.load(str(model)))
    paths = []
    for i, a in enumerate((1.0, 0.5)):
        tr = lg.simulate(eqs, 4.0, initial={"theta": a}, dt=0.02, rtol=1e-11, atol=1e-11)
        rng = np.random.default_rng(10 + i)
        y = tr["theta"] + 0.01 * rng.standard_normal(len(tr.t))
        p = d / f"run{i + 1}.csv"
        p.write_text("t,theta\n" + "".join(f"{t:.6g},{v:.8g}\n" for t, v in zip(tr.t, y)))
        paths.append(str(p))
    return str(model), paths, d


def test_table(files, capsys):
    model, (run1, _), _ = files
    assert main(["fit", model, run1, "--params", "l,c", "--guess", "l=0.8,c=0.3"]) == 0
    out = capsys.readouterr().out
    assert "fit of pend: 1 experiment(s), 201 samples" in out and "95 % interval" in out
    row = next(line for line in out.splitlines() if line.strip().startswith("l "))
    assert abs(float(row.split()[1]) - 0.5) < 0.005


def test_json_two_experiments_noise_bounds(files, capsys):
    model, runs, _ = files
    assert main(["fit", model, *runs, "--params", "l,c", "--guess", "l=0.8,c=0.3", "--noise", "0.01",
                 "--bounds", "c=0:1", "--confidence", "0.99", "--json"]) == 0
    d = json.loads(capsys.readouterr().out)
    assert d["confidence"] == 0.99 and d["noise"] == {"theta": 0.01} and not d["noise_estimated"]
    for p, true in (("l", 0.5), ("c", 0.1)):
        lo, hi = d["parameters"][p]["interval"]
        assert lo <= true <= hi
    assert len(d["initial_states"]) == 2 and abs(d["initial_states"][1]["theta"] - 0.5) < 0.02
    assert d["experiments"] == runs


def test_not_identifiable_in_json(files, capsys):
    model, (run1, _), _ = files
    assert main(["fit", model, run1, "--params", "m,l,c", "--json"]) == 0
    d = json.loads(capsys.readouterr().out)
    assert list(d["not_identifiable"]) == ["m"] and "m" not in d["parameters"]
    assert d["combinations"]["c/m"]["value"] == pytest.approx(0.1, abs=0.005)


def test_plot(files, capsys):
    pytest.importorskip("matplotlib", reason="the figure needs Matplotlib")
    model, (run1, _), d = files
    png = d / "fit.png"
    assert main(["fit", model, run1, "--params", "l,c", "--plot", str(png)]) == 0
    assert png.read_bytes()[:8] == b"\x89PNG\r\n\x1a\n"
    assert f"wrote the figure to {png}" in capsys.readouterr().out


@pytest.mark.parametrize("extra, match", [
    (["--params", "ll"], r"params: 'll' is not a parameter of pend \(did you mean 'l'\?\)"),
    (["--params", "l", "--bounds", "l=2"], r"--bounds l=2: expected NAME=LOW:HIGH"),
    (["--params", "l", "--bounds", "l=0.6:1"], r"the guess 0.5 of 'l' is outside its bounds"),
    (["--params", "l", "--noise", "0.1", "--noise", "theta=0.1"], r"--noise: give one number for every column"),
    (["--params", "l", "--intervals", "0"], r"--intervals"),
    (["--params", "l", "--guess", "l=__import__('os')"], r"--guess l"),
])
def test_errors(files, capsys, extra, match):
    model, (run1, _), _ = files
    assert main(["fit", model, run1, *extra]) == 2
    err = capsys.readouterr().err
    assert err.startswith("lagrangian fit: error: ") and "Traceback" not in err
    import re
    assert re.search(match, err), err


def test_bad_csv(files, capsys, tmp_path):
    model, _, _ = files
    bad = tmp_path / "bad.csv"
    bad.write_text("t,thetta\n0,1\n0.1,1\n0.2,1\n")
    assert main(["fit", model, str(bad), "--params", "l"]) == 2
    err = capsys.readouterr().err
    assert "bad.csv: the column 'thetta' is not a coordinate" in err and "did you mean 'theta'" in err
    assert main(["fit", model, str(tmp_path / "none.csv"), "--params", "l"]) == 2
    assert "cannot read the measurements file" in capsys.readouterr().err


def test_columns_of_a_simulation(files, capsys, tmp_path):
    model, _, _ = files
    out = tmp_path / "sim.csv"
    assert main(["simulate", model, "--t-end", "3", "--initial", "theta=1", "-o", str(out)]) == 0
    capsys.readouterr()
    assert main(["fit", model, str(out), "--columns", "theta", "--params", "l,c", "--guess", "l=0.7,c=0.2",
                 "--json"]) == 0
    d = json.loads(capsys.readouterr().out)
    assert d["parameters"]["l"]["estimate"] == pytest.approx(0.5, abs=1e-5)
    assert d["parameters"]["c"]["estimate"] == pytest.approx(0.1, abs=1e-4)


def test_simulates_own_csv_fits_as_it_is_and_a_measured_input_stays_an_input(capsys, tmp_path):
    """The CSV `lagrangian simulate` writes (with its energy column, and a forced model's input column)
    fits without --columns; with --columns naming only some coordinates, the input column still
    drives the model (it is not a fitted column)."""
    out = tmp_path / "mck.csv"
    assert main(["simulate", "mck", "--t-end", "4", "--input", "f=sin(2*t)", "-o", str(out)]) == 0
    capsys.readouterr()
    for columns in ([], ["--columns", "x1,x2"]):
        assert main(["fit", "mck", str(out), *columns, "--params", "c1,k1", "--guess", "c1=0.2,k1=80",
                     "--json"]) == 0, capsys.readouterr().err
        d = json.loads(capsys.readouterr().out)
        assert d["parameters"]["k1"]["estimate"] == pytest.approx(100.0, rel=1e-4)
        assert d["parameters"]["c1"]["estimate"] == pytest.approx(0.4, rel=1e-3)
    lines = out.read_text().splitlines()
    header = lines[0].split(",")
    (tmp_path / "noinput.csv").write_text("\n".join(",".join(r.split(",")[:3]) for r in lines) + "\n")
    assert header[:3] == ["t", "x1", "x2"]
    assert main(["fit", "mck", str(tmp_path / "noinput.csv"), "--params", "k1"]) == 2
    assert ("the input 'f' is neither a column of the data nor given; add a column 'f' (the measured signal) or "
            "give it: inputs={'f': 0.0} (a number, a function of t or a lagrangian.Signal; --input f=0 on the "
            "command line)") in capsys.readouterr().err
