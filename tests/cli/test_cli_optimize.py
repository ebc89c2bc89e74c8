"""lagrangian optimize: the [optimal_control] problem from the command line."""

from __future__ import annotations

import csv
import json
import math

import pytest

from cli_support import run_cli

pytest.importorskip("casadi", reason="optimal motions need CasADi (the 'optimal' extra)")

MODEL = '''
name = "di"
coordinates = ["x"]
inputs = ["u"]
[parameters]
k = 0.0
[energy]
T = "x_dot**2/2"
V = "k*x**2/2"
[forces]
x = "u"
[optimal_control]
duration = 1.0
objective = "u**2"
initial = { x = 0.0, x_dot = 0.0 }
final = { x = 1.0, x_dot = 0.0 }
inputs = { u = [-10.0, 10.0] }
intervals = 8
'''


@pytest.fixture
def model_file(tmp_path):
    path = tmp_path / "di.toml"
    path.write_text(MODEL)
    return path


def test_optimize_prints_the_answer_and_its_checks(capsys, model_file):
    rc, out, err = run_cli(capsys, "optimize", model_file)
    assert rc == 0, err
    assert "optimal motion of di: Solve_Succeeded" in out
    assert "cost 12" in out  # min int u^2 from rest to rest over 1 in 1 s: 12
    assert "replay by simulate: largest deviation" in out


def test_optimize_json_and_files(capsys, model_file, tmp_path):
    motion, law = tmp_path / "motion.csv", tmp_path / "law.csv"
    rc, out, err = run_cli(capsys, "optimize", model_file, "--json", "-o", motion, "--input-law", law)
    assert rc == 0, err
    d = json.loads(out)
    assert d["cost"] == pytest.approx(12.0, rel=1e-9) and d["status"] == "Solve_Succeeded"
    assert d["converged"] is True and max(d["replay_deviation"].values()) < 1e-8
    rows = list(csv.reader(motion.open()))
    assert rows[0] == ["t", "x", "x_dot", "u"] and float(rows[-1][1]) == pytest.approx(1.0)
    # the law replayed by simulate --input reaches x = 1 at rest
    out_csv = tmp_path / "replay.csv"
    rc, out, err = run_cli(capsys, "simulate", model_file, "--input", f"u=@{law}:u", "--t-end", "1",
                           "-o", out_csv)
    assert rc == 0, err
    last = list(csv.reader(out_csv.open()))[-1]
    assert float(last[1]) == pytest.approx(1.0, abs=1e-6) and abs(float(last[2])) < 1e-5


def test_optimize_param_and_options(capsys, model_file):
    rc, out, err = run_cli(capsys, "optimize", model_file, "--param", "k=1", "--intervals", "4", "--tolerance",
                           "1e-9", "--json")
    assert rc == 0, err
    # x'' + x = u from rest at 0 to rest at 1 in T = 1: cost d' W^-1 d with the controllability Gramian W
    T = 1.0
    w11, w12, w22 = T / 2 - math.sin(2 * T) / 4, math.sin(T) ** 2 / 2, T / 2 + math.sin(2 * T) / 4
    assert json.loads(out)["cost"] == pytest.approx(w22 / (w11 * w22 - w12**2), rel=1e-8)


def test_optimize_without_a_table(capsys, tmp_path):
    path = tmp_path / "plain.toml"
    path.write_text(MODEL.split("[optimal_control]")[0])
    rc, out, err = run_cli(capsys, "optimize", path)
    assert rc == 2 and out == ""
    assert "has no [optimal_control] table" in err and "duration = 2.0" in err
    assert "Traceback" not in err


def test_optimize_bad_table_and_options(capsys, tmp_path, model_file):
    path = tmp_path / "bad.toml"
    path.write_text(MODEL.replace("duration = 1.0", "duration = 1.0\nobjectiv = 'u'"))
    rc, out, err = run_cli(capsys, "optimize", path)
    assert rc == 2 and "did you mean 'objective'?" in err
    rc, out, err = run_cli(capsys, "optimize", model_file, "--intervals", "1")
    assert rc == 2 and "--intervals" in err
    rc, out, err = run_cli(capsys, "optimize", model_file, "--param", "kk=1")
    assert rc == 2 and "'kk' is not a parameter" in err


def test_optimize_infeasible_is_exit_1_with_the_fix(capsys, tmp_path):
    path = tmp_path / "far.toml"
    path.write_text(MODEL.replace("x = 1.0, x_dot = 0.0 }", "x = 100.0, x_dot = 0.0 }"))
    rc, out, err = run_cli(capsys, "optimize", path)
    assert rc == 1, (out, err)
    assert "no optimal motion found" in err and "Traceback" not in err
