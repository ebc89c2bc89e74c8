"""An ellipsoid rolling without slipping on the ground (issue 22, item 3): the rattleback. Its
contact point comes from the surface's support function; checked against the lowest point of the
surface found by numerical minimisation (an independent path), a ball (a = b = c) against the
textbook rolling ball, and in simulation: the spin reversal (a conservative rattleback spun the
"wrong" way turns round; its mirror image, skew angle -delta, turns round the other way), energy
and constraints held. Model-file keys and errors."""

from __future__ import annotations

import re

import numpy as np
import pytest
import sympy as sp
from scipy.optimize import minimize

import lagrangian as lg
from lagrangian.errors import ModelError
from lagrangian.io import loads_model

S = sp.Symbol
VALUES = dict(m=1.0, a=0.2, b=0.03, c=0.02, h=0.01, A=2e-4, B=1.6e-3, C=1.7e-3, g=9.81)


def rattleback(delta=0.1):
    """Semi-axes a, b, c; the centre of mass h below the centre; the inertia's principal axes turned by
    delta about z from the geometric ones (the skew that makes it reverse)."""
    m = lg.Model("rattleback")
    m.coordinate("x", "y", "z", "psi", "theta", "phi")
    for k, v in {**VALUES, "delta": delta}.items():
        m.parameter(k, v)
    m.add_frame("body", origin=("x", "y", "z"), rotation=[("z", "psi"), ("x", "theta"), ("y", "phi")])
    d = S("delta")
    turn = sp.Matrix([[sp.cos(d), -sp.sin(d), 0], [sp.sin(d), sp.cos(d), 0], [0, 0, 1]])
    inertia = turn * sp.diag(S("A"), S("B"), S("C")) * turn.T
    m.add_rigid_body("m", inertia.tolist(), frame="body", center=(0, 0, "-h"), name="shell")
    m.add_wheel("body", shape="ellipsoid", semi_axes=("a", "b", "c"), name="floor")
    m.add_gravity("g")
    return m


def _rotation(psi, theta, phi):
    def r(axis, a):
        c, s = np.cos(a), np.sin(a)
        return {"z": np.array([[c, -s, 0], [s, c, 0], [0, 0, 1]]), "x": np.array([[1, 0, 0], [0, c, -s], [0, s, c]]),
                "y": np.array([[c, 0, s], [0, 1, 0], [-s, 0, c]])}[axis]
    return r("z", psi) @ r("x", theta) @ r("y", phi)


def test_the_contact_condition_is_the_lowest_point_of_the_surface():
    m = rattleback()
    contact = {c.name: c for c in m.constraints}["floor_contact"].expression
    f = sp.lambdify(("z", "psi", "theta", "phi"), contact.subs({S(k): v for k, v in VALUES.items()}))
    a, b, c = VALUES["a"], VALUES["b"], VALUES["c"]
    rng = np.random.default_rng(22)
    for _ in range(10):
        z, psi, theta, phi = 0.1, *rng.uniform(-1.2, 1.2, 3)
        R = _rotation(psi, theta, phi)

        def height(uv):
            u, v = uv
            return z + (R @ np.array([a * np.cos(u) * np.cos(v), b * np.sin(u) * np.cos(v), c * np.sin(v)]))[2]

        best = min((minimize(height, x0, method="Nelder-Mead", options={"xatol": 1e-12, "fatol": 1e-14})
                    for x0 in rng.uniform(-3, 3, (6, 2))), key=lambda r: r.fun)
        assert f(z, psi, theta, phi) == pytest.approx(best.fun, abs=1e-9)


def test_a_ball_rolls_as_the_textbook_ball():
    """a = b = c = r: the no-slip conditions are v_C + omega x (-r e_z) = 0 horizontally, omega in world axes."""
    m = lg.Model("ball")
    m.coordinate("x", "y", "z", "psi", "theta", "phi")
    m.parameter("r", 0.3)
    m.add_frame("body", origin=("x", "y", "z"), rotation=[("z", "psi"), ("x", "theta"), ("y", "phi")])
    m.add_rigid_body(1, (0.036, 0.036, 0.036), frame="body", name="ball")
    m.add_wheel("body", shape="ellipsoid", semi_axes=("r", "r", "r"), name="floor")
    r = S("r", positive=True)
    cons = {c.name: c.expression.subs(S("r"), r) for c in m.constraints}
    assert sp.simplify(cons["floor_contact"] - (S("z") - r)) == 0
    from sympy.physics.mechanics import ReferenceFrame, dynamicsymbols
    q = dynamicsymbols("psi theta phi")
    N = ReferenceFrame("N")
    B = N.orientnew("B", "Body", q, "ZXY")
    w = B.ang_vel_in(N).to_matrix(N)
    t = dynamicsymbols._t
    plain = {qi.diff(t): S(f"{n}_dot") for qi, n in zip(q, ("psi", "theta", "phi"))}
    plain.update({qi: S(n) for qi, n in zip(q, ("psi", "theta", "phi"))})
    w = w.subs(plain)
    v = sp.Matrix([S("x_dot"), S("y_dot"), S("z_dot")]) + w.cross(sp.Matrix([0, 0, -r]))
    names = sp.symbols("x y z psi theta phi x_dot y_dot z_dot psi_dot theta_dot phi_dot")
    rng = np.random.default_rng(3)
    for ours, theirs in ((cons["floor_x"], v[0]), (cons["floor_y"], v[1])):
        f = sp.lambdify(names, (ours - theirs).subs(r, 0.3))
        assert all(abs(f(*rng.uniform(-2, 2, 12))) < 1e-12 for _ in range(20))


@pytest.mark.slow
def test_the_rattleback_reverses_its_spin_and_its_mirror_image_the_other_way():
    for delta, wrong in ((0.1, -2.0), (-0.1, 2.0)):
        eqs = lg.derive(rattleback(delta))
        traj = lg.simulate(eqs, 3.0, initial={"z": 0.02, "psi_dot": wrong, "phi_dot": 0.05}, rtol=1e-10, atol=1e-10)
        spin = traj["psi_dot"]
        # it turns round: the spin changes sign and comes to about the same speed the other way
        assert np.sign(spin[-1]) == -np.sign(wrong) and abs(spin[-1]) > 1.5
        assert np.ptp(traj.energy) < 1e-9 * abs(traj.energy).max()
        assert traj.stats["constraint_drift"]["position"] < 1e-10
        # spun the preferred way, it keeps its direction over the same time
        kept = lg.simulate(eqs, 3.0, initial={"z": 0.02, "psi_dot": -wrong, "phi_dot": 0.05}, rtol=1e-10,
                           atol=1e-10)["psi_dot"]
        assert np.all(np.sign(kept) == -np.sign(wrong))


TOML = """
coordinates = ["x", "y", "z", "psi", "theta", "phi"]
[parameters]
r = 0.3
[[frames]]
name = "body"
origin = ["x", "y", "z"]
rotation = [["z", "psi"], ["x", "theta"], ["y", "phi"]]
[[bodies]]
name = "ball"
mass = 1
inertia = [0.036, 0.036, 0.036]
frame = "body"
[[wheels]]
name = "floor"
frame = "body"
shape = "ellipsoid"
semi_axes = ["r", "r", "r"]
"""


def test_model_file_ellipsoid_is_the_api_one():
    m = loads_model(TOML)
    assert [c.name for c in m.constraints] == ["floor_contact", "floor_x", "floor_y"]
    assert m.wheels[0].shape == "ellipsoid" and m.wheels[0].semi_axes == (S("r"),) * 3


@pytest.mark.parametrize("extra, message", [
    ('radius = "r"', "an ellipsoid has semi_axes = [a, b, c], not a radius"),
    ("lateral = false", "an ellipsoid rolls without slipping in both directions; remove lateral"),
])
def test_model_file_ellipsoid_errors(extra, message):
    with pytest.raises(ModelError, match=re.escape(message)):
        loads_model(TOML + extra + "\n")


@pytest.mark.parametrize("old, new, message", [
    ('semi_axes = ["r", "r", "r"]', 'semi_axes = ["r", "r"]', "expected the 3 semi-axes"),
    ('semi_axes = ["r", "r", "r"]', 'semi_axes = ["r", "r", "-1"]', "a semi-axis is positive, got -1"),
    ('semi_axes = ["r", "r", "r"]', 'semi_axes = ["r", "r", "x"]', "a semi-axis is a number or an expression of "
                                                                   "parameters, got x"),
    ('shape = "ellipsoid"', 'shape = "elipsoid"', "unknown shape 'elipsoid' (did you mean 'ellipsoid'?)"),
    ('shape = "ellipsoid"', "shape = 3", "expected \"disk\" or \"ellipsoid\" in quotes"),
    ('shape = "ellipsoid"\n', "", "semi-axes belong to shape = \"ellipsoid\""),
])
def test_model_file_ellipsoid_value_errors(old, new, message):
    text = TOML.replace(old, new)
    if "radius" not in text and 'shape = "ellipsoid"' not in text:
        text += 'radius = "r"\n'
    with pytest.raises(ModelError, match=re.escape(message)):
        loads_model(text)
