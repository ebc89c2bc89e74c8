"""lg.fit's checks of its data and options: every bad input is one error that names the file, the
row and the column (or the option) and says the fix; nothing read from a table is evaluated."""

from __future__ import annotations

import math

import numpy as np
import pytest

import lagrangian as lg
from lagrangian.errors import ModelError
from lagrangian.identification import fit, read_measurements


@pytest.fixture(scope="module")
def pend():
    m = lg.Model("pendulum")
    th = m.coordinate("theta")
    mass, ll, g, c = m.parameter("m", 1.0), m.parameter("l", 0.5), m.parameter("g", 9.81), m.parameter("c", 0.1)
    m.add_particle(mass, (ll * lg.sin(th), -ll * lg.cos(th)), name="bob")
    m.add_gravity(g)
    m.add_energy(D=c * lg.dot(th) ** 2 / 2)
    return lg.derive(m)


def csv(tmp_path, text, name="data.csv"):
    p = tmp_path / name
    p.write_text(text)
    return str(p)


GOOD = "t,theta\n" + "".join(f"{0.1 * i:g},{math.cos(i / 3):.6f}\n" for i in range(20))


def test_reads_a_good_file(tmp_path):
    m = read_measurements(csv(tmp_path, GOOD))
    assert len(m) == 20 and m.names == ("theta",) and m.t[1] == pytest.approx(0.1)


@pytest.mark.parametrize("text, match", [
    ("t,theta\n0,1\n0.1,nan\n0.2,1\n", r"data\.csv: row 3, column 'theta': 'nan' is not a finite number"),
    ("t,theta\n0,1\n0.1,\n0.2,1\n", r"row 3, column 'theta': empty is not a finite number; .*fill the missing"),
    ("t,theta\n0,1\n0.1,abc\n0.2,1\n", r"row 3, column 'theta': 'abc' is not a finite number"),
    ("t,theta\n0,1\n0.2,1\n0.1,1\n", r"row 4, time 0.1 is earlier than the time 0.2 before it; .*sort the rows"),
    ("t,theta\n0,1\n0.1,1\n0.1,1\n", r"row 4, time 0.1 repeats .*remove repeated times"),
    ("t,theta\n0,1\n0.1,1\n", r"2 sample\(s\); a fit needs at least 3 per experiment"),
    ("t,theta\n0,1,2\n0.1,1\n0.2,1\n", r"row 2 has 3 cells but the header has 2"),
    ("t,theta,theta\n0,1,1\n", r"the column 'theta' appears twice"),
    ("t\n0\n1\n", r"only the time column 't'"),
    ("", r"the file is empty"),
])
def test_bad_files(tmp_path, pend, text, match):
    with pytest.raises(ModelError, match=match):
        fit(pend, csv(tmp_path, text), ["l"])


def test_unknown_column_did_you_mean(tmp_path, pend):
    with pytest.raises(ModelError, match=r"data\.csv: the column 'thetta' is not a coordinate, velocity, input, "
                                         r"output or point of the model \(did you mean 'theta'\?\)"):
        fit(pend, csv(tmp_path, GOOD.replace("theta", "thetta", 1)), ["l"])


def test_header_that_is_code_is_a_name(tmp_path, pend):
    marker = tmp_path / "pwned"
    code = f"__import__('os').system('touch {marker}')"
    text = f't,"{code}"\n0,1\n0.1,1\n0.2,1\n'
    with pytest.raises(ModelError, match=r"is not a coordinate, velocity, input, output or point"):
        fit(pend, csv(tmp_path, text), ["l"])
    assert not marker.exists()
    with pytest.raises(ModelError, match=r"control characters"):
        fit(pend, csv(tmp_path, 't,"the\nta"\n0,1\n0.1,1\n0.2,1\n'), ["l"])
    with pytest.raises(ModelError, match=r"column 'ball.x': 'ball' is not a point, particle or body: .*use one of bob"):
        fit(pend, csv(tmp_path, "t,ball.x\n0,1\n0.1,1\n0.2,1\n"), ["l"])


def test_huge_file_refused_by_the_row_limit(tmp_path, pend, monkeypatch):
    monkeypatch.setenv("LAGRANGIAN_MAX_ROWS", "10")
    with pytest.raises(ModelError, match=r"20 data rows; the limit on .* LAGRANGIAN_MAX_ROWS"):
        fit(pend, csv(tmp_path, GOOD), ["l"])


def test_not_utf8_and_missing(tmp_path, pend):
    p = tmp_path / "bin.csv"
    p.write_bytes(b"t,theta\n0,\xff\xfe\n")
    with pytest.raises(ModelError, match=r"not a text CSV file \(not UTF-8\)"):
        fit(pend, str(p), ["l"])
    with pytest.raises(ModelError, match=r"cannot read the measurements file .*nope\.csv.*check the path"):
        fit(pend, str(tmp_path / "nope.csv"), ["l"])


def test_arrays(pend):
    t = np.linspace(0, 1, 11)
    with pytest.raises(ModelError, match=r"experiment 1: sample 3, column 'theta': nan is not a finite number"):
        fit(pend, {"t": t, "theta": np.where(t > 0.25, np.nan, 1.0)}, ["l"])
    with pytest.raises(ModelError, match=r"experiment 1: no time column; give the sample times under 't'"):
        fit(pend, {"theta": t}, ["l"])
    with pytest.raises(ModelError, match=r"column 'theta' has 3 values but there are 11 times"):
        fit(pend, {"t": t, "theta": [1, 2, 3]}, ["l"])
    with pytest.raises(ModelError, match=r"column 'theta' is not an array of numbers"):
        fit(pend, {"t": t, "theta": ["a"] * 11}, ["l"])
    with pytest.raises(ModelError, match=r"data: expected a CSV path, a mapping"):
        fit(pend, 42, ["l"])


@pytest.mark.parametrize("kwargs, match", [
    (dict(params=["ll"]), r"params: 'll' is not a parameter of pendulum \(did you mean 'l'\?\); its parameters are"),
    (dict(params=["l", "l"]), r"params: 'l' is given twice"),
    (dict(params=[]), r"params: no parameter to fit"),
    (dict(params=["l"], bounds={"l": (0.6, 1.0)}), r"bounds: the guess 0.5 of 'l' is outside its bounds \[0.6, 1\]; "
                                                    r"give a guess inside them"),
    (dict(params=["l"], bounds={"l": (1.0, 0.6)}), r"must be two numbers with low < high"),
    (dict(params=["l"], bounds={"c": (0, 1)}), r"bounds: 'c' is not a fitted parameter"),
    (dict(params=["l"], guess={"l": float("nan")}), r"guess: the value of 'l' \(nan\) is not a finite number"),
    (dict(params=["l"], guess={"x": 1}), r"guess: 'x' is not a parameter"),
    (dict(params=["l"], noise=-1), r"noise: the level of 'theta' \(-1\) must be a positive number"),
    (dict(params=["l"], noise={"thta": 0.1}), r"noise: 'thta' is not a measured column \(did you mean 'theta'\?\)"),
    (dict(params=["l"], initial={"th": 1}), r"initial: 'th' is not a coordinate or velocity"),
    (dict(params=["l"], intervals=0), r"intervals: expected a whole number of shooting intervals"),
    (dict(params=["l"], confidence=1.5), r"confidence: 1.5 must be a level between 0 and 1"),
    (dict(params=["l"], inputs={"F": 1.0}), r"inputs: 'F' is not an input of pendulum"),
])
def test_bad_options(tmp_path, pend, kwargs, match):
    with pytest.raises(ModelError, match=match):
        fit(pend, csv(tmp_path, GOOD), **kwargs)


def test_missing_input_and_parameter_without_value(tmp_path):
    eqs = lg.derive(lg.Model("msd", coordinates=["x"], parameters={"m": 1.0, "k": None}, inputs=["F"],
                             T="m*x_dot**2/2", V="k*x**2/2", Q={"x": "F"}))
    data = csv(tmp_path, GOOD.replace("theta", "x", 1))
    with pytest.raises(ModelError, match=r"have no value in the model; give them in guess="):
        fit(eqs, data, ["m"])
    with pytest.raises(ModelError, match=r"the input 'F' is neither a column of the data nor given; add a column 'F'"):
        fit(eqs, data, ["m", "k"], guess={"k": 1.0})
    with pytest.raises(ModelError, match=r"no measured column to fit \(only inputs F\)"):
        fit(eqs, csv(tmp_path, GOOD.replace("theta", "F", 1)), ["m", "k"], guess={"k": 1.0})


def test_columns_selects_and_checks(tmp_path, pend):
    """columns= keeps only the named columns (a simulation's CSV has theta_dot and energy too); without
    it, every measurable column: the energy a simulation writes is left out, not refused."""
    run = lg.simulate(pend, 2.0, initial={"theta": 1.0}, dt=0.02)
    path = str(tmp_path / "sim.csv")
    run.to_csv(path)
    every = fit(pend, path, ["l"], guess={"l": 0.6})
    assert list(every.fitted[0]) == ["theta", "theta_dot"] and every["l"] == pytest.approx(0.5, abs=1e-5)
    bad = tmp_path / "other.csv"
    bad.write_text(open(path).read().replace("energy", "power"))
    with pytest.raises(ModelError, match=r"the column 'power' is not a coordinate, velocity, input, output or point"):
        fit(pend, str(bad), ["l"])
    r = fit(pend, path, ["l"], columns=["theta"], guess={"l": 0.6})
    assert list(r.fitted[0]) == ["theta"] and r["l"] == pytest.approx(0.5, abs=1e-5)
    with pytest.raises(ModelError, match=r"columns: .*sim\.csv has no column 'thta' \(did you mean 'theta'\?\); its "
                                         r"columns are theta, theta_dot, energy"):
        fit(pend, path, ["l"], columns=["thta"])
    with pytest.raises(ModelError, match=r"columns: expected a list of column names"):
        fit(pend, path, ["l"], columns=[1])


def test_jacobian_size_is_bounded(pend, monkeypatch):
    import lagrangian.identification._fit as fitmod

    monkeypatch.setattr(fitmod, "MAX_JACOBIAN", 1000)
    t = np.linspace(0, 1, 101)
    with pytest.raises(ModelError, match=r"the fit's Jacobian would have 1\d\d x \d+ entries .* more than 1,000; use "
                                         r"fewer samples \(every k-th row of the data\)"):
        fit(pend, {"t": t, "theta": np.cos(t)}, ["l"])


def test_equations_or_model(tmp_path, pend):
    with pytest.raises(ModelError, match=r"fit: equations must be the Equations of a model "
                                         r"\(lagrangian.derive\(model\)\) or a Model, not str"):
        fit("pendulum", csv(tmp_path, GOOD), ["l"])
    r = fit(pend.model, csv(tmp_path, GOOD), ["l"], max_iterations=3)
    assert r.parameters == ("l",)
