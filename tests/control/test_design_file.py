"""The saved state-feedback design (lagrangian.control._design): written by design_json, read back
by read_design for the same equations and parameter values only."""

from __future__ import annotations

import json

import numpy as np
import pytest
import sympy

import lagrangian as lg
from lagrangian.control._design import design_fingerprint, design_json, read_design
from lagrangian.errors import ModelError

PARAMS = {"M1": 1.0, "M2": 0.5, "L": 1.0, "g": 9.81}


@pytest.fixture(scope="module")
def cart():
    eqs = lg.derive(lg.load("cart-pendulum"))
    return eqs, lg.linearize(eqs, at={"q2": sympy.pi / 2})


@pytest.mark.parametrize("sample_time", [None, 0.05])
def test_lqr_design_round_trip_keeps_every_number_and_the_law(cart, tmp_path, sample_time):
    eqs, lin = cart
    fb = lin.lqr([1, 10, 1, 1], 0.5, sample_time=sample_time)
    path = tmp_path / "d.json"
    path.write_text(design_json(fb, eqs, PARAMS, ["q2"]))
    back, wrap = read_design(str(path), eqs, PARAMS)
    assert wrap == ("q2",)
    np.testing.assert_array_equal(back.K, fb.K)
    for name in ("Q", "R", "P", "eigenvalues", "open_loop"):
        np.testing.assert_array_equal(getattr(back, name), getattr(fb, name))
    assert back.sample_time == sample_time and back.stable and back.method == "lqr"
    assert dict(back.operating_point) == dict(fb.operating_point)
    # the same law, numbers to the bit (x0 written as a float, pi/2 as 1.5707963267948966)
    law = back.law(wrap)["F"]
    assert law.replace("1.5707963267948966", "pi/2") == fb.law(["q2"])["F"]
    assert back.to_dict(wrap)["K"] == fb.to_dict(["q2"])["K"]


def test_place_design_round_trip_and_the_closed_loop_eigenvalues(cart, tmp_path):
    eqs, lin = cart
    fb = lin.place([-1, -2, -1.5 + 1j, -1.5 - 1j])
    path = tmp_path / "p.json"
    path.write_text(design_json(fb, eqs, PARAMS))
    back, wrap = read_design(str(path), eqs, PARAMS)
    assert wrap == () and back.method == "place" and back.Q is None
    A, B = np.asarray(lin.A, float), np.asarray(lin.B, float)
    np.testing.assert_allclose(np.sort_complex(np.linalg.eigvals(A - B @ back.K)),
                               np.sort_complex(np.array([-2, -1.5 - 1j, -1.5 + 1j, -1])), atol=1e-8)


def test_the_fingerprint_sees_the_parameter_values_and_the_equations(cart):
    eqs, _ = cart
    base = design_fingerprint(eqs, PARAMS)
    assert base == design_fingerprint(lg.derive(lg.load("cart-pendulum")), dict(reversed(PARAMS.items())))
    assert base != design_fingerprint(eqs, {**PARAMS, "M2": 0.5000000001})
    assert base != design_fingerprint(lg.derive(lg.load("cart-pendulum-energy")), PARAMS)


def test_read_design_refuses_other_parameter_values(cart, tmp_path):
    eqs, lin = cart
    path = tmp_path / "d.json"
    path.write_text(design_json(lin.lqr(), eqs, PARAMS))
    with pytest.raises(ModelError, match=r"designed with other parameter values \(L = 1.0 in the design, 2.0 now\)"):
        read_design(str(path), eqs, {**PARAMS, "L": 2.0})
    d = json.loads(path.read_text())
    del d["parameters"]  # the fingerprint still sees them
    path.write_text(json.dumps(d))
    with pytest.raises(ModelError, match="its fingerprint differs from the equations of 'cart-pendulum'"):
        read_design(str(path), eqs, {**PARAMS, "L": 2.0})
