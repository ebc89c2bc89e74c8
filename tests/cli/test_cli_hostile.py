"""Hostile option values on the command line (found by fuzzing every command): one error line naming the option,
exit status 2, never a traceback."""

from __future__ import annotations

import os

import pytest

from cli_support import run_cli


@pytest.mark.parametrize("args, text", [
    (["sweep", "double-pendulum", "--param", "g", "--from", "1", "--to", "2", "--steps", "2", "--coordinate",
      "theta3"],
     "lagrangian sweep: error: --coordinate theta3: not a coordinate of double-pendulum (did you mean 'theta2'?); "
     "the coordinates are theta1, theta2"),
    (["lqr", "cart-pendulum", "--at", "q2=pi/2", "--Q", "1e308"],
     "Q has a weight of 1e+308, too large: at most 1e+150 in magnitude"),
    (["lqr", "cart-pendulum", "--at", "q2=pi/2", "--sample-time", "1e308"],
     "sample_time 1e+308 s is too long for cart-pendulum"),
    (["simulate", "cart-pendulum", "--t-end", "0.1", "--input", "F=1e308"],
     "the input is 1e+308, too large: at most 1e+150 in magnitude"),
    (["inverse-dynamics", "double-pendulum", "--at", "theta1=0.5", "--actuated", "theta1"],
     "actuated: model 'double-pendulum' has no constraints, so every coordinate is actuated"),
    (["derive", "y" * 300 + ".toml"], "File name too long; check the path"),
])
def test_a_hostile_option_value_is_one_error_line(capsys, args, text):
    """Before: LinAlgError, ZeroDivisionError, OSError with a traceback, or the value ignored without a word."""
    rc, out, err = run_cli(capsys, *args)
    assert rc == 2, (rc, err)
    assert text in err
    assert "Traceback" not in err and len(err.strip().splitlines()) == 1


@pytest.mark.skipif(not os.path.exists("/dev/null"), reason="needs /dev/null")
def test_a_device_as_the_model_file(capsys):
    rc, out, err = run_cli(capsys, "check", "/dev/null")
    assert rc == 2
    assert "'/dev/null' is not a regular file (a device, a pipe or a socket)" in err
