"""A rotational damper on a rigid body (issue 22, item 4): the torque -s omega, D = s |omega|^2 / 2,
against the dissipation function written by hand in Euler rates from sympy.physics.mechanics'
angular velocity (identical equations), a free spherical body's exponential spin-down, the model
file's [[dampers]] body = "...", and every error a user can hit."""

from __future__ import annotations

import re

import numpy as np
import pytest
import sympy as sp
from sympy.physics.mechanics import ReferenceFrame, dynamicsymbols

import lagrangian as lg
from lagrangian.errors import ModelError
from lagrangian.io import loads_model

ROTATION = [("z", "phi"), ("x", "theta"), ("z", "psi")]


def _body(damper: bool):
    m = lg.Model("damped-body")
    m.coordinate("phi", "theta", "psi")
    for name, value in (("m", 1.0), ("I1", 0.3), ("I2", 0.5), ("I3", 0.6), ("s", 0.2)):
        m.parameter(name, value)
    m.add_frame("body", rotation=ROTATION)
    m.add_rigid_body("m", ("I1", "I2", "I3"), frame="body", name="disk")
    if damper:
        m.add_damper("s", body="disk", name="air")
    return m


def _hand_D():
    """D = s |omega|^2 / 2 with omega from sympy.physics.mechanics (ZXZ body rotation), in plain symbols."""
    ph, th, ps = dynamicsymbols("phi theta psi")
    N = ReferenceFrame("N")
    B = N.orientnew("B", "Body", (ph, th, ps), "ZXZ")
    w = B.ang_vel_in(N)
    D = sp.Symbol("s") * w.dot(w) / 2
    t = dynamicsymbols._t
    plain = {q.diff(t): sp.Symbol(f"{n}_dot") for q, n in ((ph, "phi"), (th, "theta"), (ps, "psi"))}
    plain.update({q: sp.Symbol(n) for q, n in ((ph, "phi"), (th, "theta"), (ps, "psi"))})
    return sp.simplify(D.subs(plain))


def _at_random_points(exprs, symbols, count=5):
    rng = np.random.default_rng(22)
    f = sp.lambdify(symbols, list(exprs), modules="numpy")
    return [np.array(f(*rng.uniform(0.2, 1.3, len(symbols))), dtype=float) for _ in range(count)]


def test_rotational_damper_equals_the_hand_written_dissipation_in_euler_rates():
    ours = lg.derive(_body(True))
    hand = _body(False)
    hand.add_energy(D=_hand_D())
    theirs = lg.derive(hand)
    assert sp.simplify(ours.D - theirs.D) == 0
    symbols = sorted((ours.forcing.free_symbols | theirs.forcing.free_symbols), key=str)
    for a, b in zip(_at_random_points(ours.forcing, symbols), _at_random_points(theirs.forcing, symbols)):
        assert np.allclose(a, b, rtol=1e-13, atol=1e-13)
    # the damping forces are -dD/dq_dot: linear in the rates, zero at rest
    assert all(sp.simplify(e.subs({sp.Symbol(f"{n}_dot"): 0 for n in ("phi", "theta", "psi")})) == 0
               for e in ours.damping_forces)


def test_free_spherical_body_spins_down_exponentially():
    """I1 = I2 = I3 = I: I omega' = -s omega, so |omega| = |omega0| exp(-s t / I) (any axis)."""
    m = lg.Model("sphere")
    m.coordinate("phi", "theta", "psi")
    I, s = 0.4, 0.3
    m.parameter("I", I)
    m.parameter("s", s)
    m.add_frame("body", rotation=ROTATION)
    m.add_rigid_body(1.0, ("I", "I", "I"), frame="body", name="ball")
    m.add_damper("s", body="ball")
    x0 = {"theta": 1.0, "phi_dot": 0.7, "theta_dot": -0.4, "psi_dot": 1.1}
    traj = lg.simulate(lg.derive(m), 2.0, initial=x0, rtol=1e-11, atol=1e-12)

    def speed(th, dph, dth, dps):
        return np.sqrt(dph**2 + dth**2 + dps**2 + 2 * dph * dps * np.cos(th))

    w = speed(traj["theta"], traj["phi_dot"], traj["theta_dot"], traj["psi_dot"])
    w0 = speed(1.0, 0.7, -0.4, 1.1)
    assert np.allclose(w, w0 * np.exp(-s * traj.t / I), rtol=1e-8, atol=0)


def test_planar_body_rotational_damper_is_c_angle_rate_squared():
    m = lg.Model("planar")
    th = m.coordinate("th")
    m.parameter("c", 0.5)
    m.add_rigid_body(1, 2, (0, 0), th, name="wheel")
    m.add_damper("c", body="wheel")
    eqs = lg.derive(m)
    assert sp.simplify(eqs.D - sp.Symbol("c") * sp.Symbol("th_dot") ** 2 / 2) == 0


TOML = """
coordinates = ["phi", "theta", "psi"]
[parameters]
m = 1.0
I1 = 0.3
I2 = 0.5
I3 = 0.6
s = 0.2
[[frames]]
name = "body"
rotation = [["z", "phi"], ["x", "theta"], ["z", "psi"]]
[[bodies]]
name = "disk"
mass = "m"
inertia = ["I1", "I2", "I3"]
frame = "body"
[[dampers]]
name = "air"
coefficient = "s"
body = "disk"
"""


def test_model_file_rotational_damper_is_the_api_one():
    from_file = lg.derive(loads_model(TOML))
    assert sp.simplify(from_file.D - lg.derive(_body(True)).D) == 0


@pytest.mark.parametrize("extra, message", [
    ('length = "phi"', "has a body (a rotational damper, the torque -c omega on it): remove 'length'"),
    ('between = ["a", "b"]', "remove 'between'"),
])
def test_model_file_refuses_body_with_a_length(extra, message):
    with pytest.raises(ModelError, match=re.escape(message)):
        loads_model(TOML + extra + "\n")


@pytest.mark.parametrize("body, message", [
    ('"dsik"', "no rigid body is named 'dsik' (did you mean 'disk'?)"),
    ("3", "expected the name of a [[bodies]] element in quotes, got"),
    ('"__import__(\'os\')"', "no rigid body is named"),
])
def test_model_file_refuses_unknown_bodies(body, message):
    with pytest.raises(ModelError, match=re.escape(message)):
        loads_model(TOML.replace('body = "disk"', f"body = {body}"))


def test_api_errors():
    m = _body(False)
    with pytest.raises(ModelError, match=re.escape("no rigid body is named 'dsk'")):
        m.add_damper("s", body="dsk")
    with pytest.raises(ModelError, match=re.escape("give `body` (a rotational damper on a rigid body) or "
                                                   "`between`/`length`")):
        m.add_damper("s", body="disk", length="phi")


def test_negative_coefficient_is_reported():
    m = _body(True)
    m2 = m.copy()
    m2._parameters[sp.Symbol("s")] = -1.0
    assert any("coefficient is negative" in str(p) for p in m2.check())

