"""`linearize --at` merges with the model's [operating_point] by name (as --initial does with
[simulation] initial): the names --at does not give keep the model file's values, not 0."""

from __future__ import annotations

import json

import pytest

from lagrangian.cli import main

MODEL = """
name = "two-springs"
coordinates = ["x", "y"]
[parameters]
m = 2.0
k = 8.0
a = 0.25
[energy]
T = "m/2*(x_dot**2 + y_dot**2)"
V = "k/2*(x**2 + y**2) + k*x**2*y**2"
[operating_point]
x = "2*a"
y_dot = "a"
"""


def _op(capsys, *args):
    rc = main([str(a) for a in args])
    out, err = capsys.readouterr()
    assert rc == 0, err
    return json.loads(out)


@pytest.fixture
def model(tmp_path):
    path = tmp_path / "two-springs.toml"
    path.write_text(MODEL)
    return path


def test_at_merges_with_the_model_operating_point(capsys, model):
    d = _op(capsys, "linearize", model, "--at", "y=0.1", "--json")
    # x and y_dot keep the model's values (2a = 0.5, a = 0.25), y is --at's, x_dot is 0
    assert d["operating_point"] == {"x": 0.5, "y": 0.1, "x_dot": 0.0, "y_dot": 0.25}
    # the stiffness at (x, y) = (0.5, 0.1): K = [[k + 2k y^2, 4k x y], [4k x y, k + 2k x^2]]
    K = d["K"]
    assert K[0][0] == pytest.approx(8 + 16 * 0.01) and K[0][1] == pytest.approx(32 * 0.05)
    assert K[1][1] == pytest.approx(8 + 16 * 0.25)


def test_at_overrides_by_name_and_params_apply(capsys, model):
    d = _op(capsys, "linearize", model, "--at", "x=0,y_dot=0", "--param", "a=1", "--json")
    assert d["operating_point"] == {"x": 0.0, "y": 0.0, "x_dot": 0.0, "y_dot": 0.0}
    d = _op(capsys, "linearize", model, "--at", "y=a", "--param", "a=1", "--json")
    assert d["operating_point"] == {"x": 2.0, "y": 1.0, "x_dot": 0.0, "y_dot": 1.0}


def test_without_at_the_model_operating_point(capsys, model):
    d = _op(capsys, "linearize", model, "--json")
    assert d["operating_point"] == {"x": 0.5, "y": 0.0, "x_dot": 0.0, "y_dot": 0.25}


def test_rolling_disk_keeps_its_speed(capsys):
    """The built-in rolling disk's [operating_point] is theta_dot = v/r: --at phi=0 keeps it."""
    merged = _op(capsys, "linearize", "rolling-disk", "--at", "phi=0", "--json")["operating_point"]
    plain = _op(capsys, "linearize", "rolling-disk", "--json")["operating_point"]
    assert merged["theta_dot"] == plain["theta_dot"] != 0.0
