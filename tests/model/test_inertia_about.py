"""A body's inertia about a point other than its centre of mass (issue 22, item 1): the library
applies the parallel-axis theorem. Checked against sympy.physics.mechanics' RigidBody.parallel_axis
(sympy's test_parallel_axis: an independent derivation) and against the central-inertia version of
the same model (identical M), planar and in space, in the Python API and the model file, with every
error a user can hit."""

from __future__ import annotations

import re

import pytest
import sympy as sp
from sympy.physics.mechanics import Point, ReferenceFrame, RigidBody, inertia

import lagrangian as lg
from lagrangian.errors import ModelError
from lagrangian.io import loads_model

S = sp.Symbol
NAMES = ("m", "Ixx", "Iyy", "Izz", "Ixy", "Iyz", "Izx", "a", "b", "h")
VALUES = (2.0, 0.5, 0.6, 0.7, 0.01, -0.02, 0.03, 0.1, -0.2, 0.3)


def _central():
    m, Ixx, Iyy, Izz, Ixy, Iyz, Izx = (S(n) for n in NAMES[:7])
    return sp.Matrix([[Ixx, Ixy, Izx], [Ixy, Iyy, Iyz], [Izx, Iyz, Izz]])


def _about_origin_by_sympy():
    """sympy.physics.mechanics: the inertia about the frame's origin O of a body whose centre is
    G = O + a x + b y + h z (body axes), from its central inertia (RigidBody.parallel_axis)."""
    m, Ixx, Iyy, Izz, Ixy, Iyz, Izx, a, b, h = (S(n) for n in NAMES)
    B = ReferenceFrame("B")
    O = Point("O")
    G = O.locatenew("G", a * B.x + b * B.y + h * B.z)
    body = RigidBody("R", G, B, m, (inertia(B, Ixx, Iyy, Izz, Ixy, Iyz, Izx), G))
    return body.parallel_axis(O).to_matrix(B)


def _spatial(about=None, tensor=None):
    m = lg.Model("body")
    m.coordinate("phi", "theta", "psi", "x", "y", "z")
    for n, v in zip(NAMES, VALUES):
        m.parameter(n, v)
    m.add_frame("body", origin=("x", "y", "z"), rotation=[("z", "phi"), ("x", "theta"), ("z", "psi")])
    m.add_point("O", (0, 0, 0), frame="body")
    I = _central() if tensor is None else tensor
    m.add_rigid_body("m", I.tolist(), frame="body", center=("a", "b", "h"), inertia_about=about, name="R")
    return m


def test_the_parallel_axis_inertia_equals_sympy_mechanics_and_gives_the_central_body():
    Ip = _about_origin_by_sympy()
    # by hand as well: I_O = I_G + m (|r|^2 E - r r^T)
    m, a, b, h = S("m"), S("a"), S("b"), S("h")
    r = sp.Matrix([a, b, h])
    assert sp.simplify(Ip - (_central() + m * ((r.T * r)[0] * sp.eye(3) - r * r.T))) == sp.zeros(3)
    for about in ([0, 0, 0], "O"):
        body = _spatial(about, Ip).elements[-1]
        assert sp.simplify(sp.Matrix(body.inertia) - _central()) == sp.zeros(3), about


@pytest.mark.slow
def test_the_same_body_given_about_its_frame_origin_has_the_same_mass_matrix():
    central = lg.derive(_spatial())
    about = lg.derive(_spatial([0, 0, 0], _about_origin_by_sympy()))
    assert sp.simplify(central.mass_matrix - about.mass_matrix) == sp.zeros(6)


def test_about_a_point_given_in_the_world_and_a_centre_given_in_the_world():
    """The general path: r = R^T (G - P) from world positions (checked constant), the centre given in world axes."""
    m = lg.Model("pendulum3d")
    th = m.coordinate("th")
    m.parameter("m", 1.5)
    m.parameter("l", 0.4)
    m.add_frame("link", rotation=[("x", th)])
    # the centre at -l along the link's z, given in world axes; the inertia about the pivot (world origin)
    center = (0, "l*sin(th)", "-l*cos(th)")
    Ip = (0.1 + 1.5 * 0.16, 0.2 + 1.5 * 0.16, 0.3)
    m.add_rigid_body("m", Ip, frame="link", center=center, center_frame="world", inertia_about=(0, 0, 0))
    I = m.elements[-1].inertia
    assert [float(sp.sympify(x).subs({S("m"): 1.5, S("l"): 0.4})) for row in I for x in row] == pytest.approx(
        [0.1, 0, 0, 0, 0.2, 0, 0, 0, 0.3], abs=1e-14)
    # a pendulum about x: M = I_xx(pivot) = 0.1 + m l^2
    eqs = lg.derive(m)
    assert float(eqs.mass_matrix[0, 0].subs({S("m"): 1.5, S("l"): 0.4})) == pytest.approx(0.1 + 1.5 * 0.16)


def _planar(about=None, inertia="I"):
    m = lg.Model("compound-pendulum")
    th = m.coordinate("th")
    for n, v in (("m", 2.0), ("l", 0.5), ("I", 0.1), ("g", 9.81)):
        m.parameter(n, v)
    m.add_rigid_body("m", inertia, ("l*sin(th)", "-l*cos(th)"), th, inertia_about=about, name="rod")
    m.add_gravity("g")
    return m


def test_planar_body_about_its_pivot_is_the_central_one():
    central = lg.derive(_planar())
    about = lg.derive(_planar((0, 0), "I + m*l**2"))
    assert sp.simplify(about.model.elements[0].inertia - S("I")) == 0
    assert sp.simplify(central.mass_matrix - about.mass_matrix) == sp.zeros(1)
    assert sp.simplify(about.mass_matrix[0, 0] - (S("I") + S("m") * S("l") ** 2)) == 0


def test_a_point_not_fixed_on_the_body_is_refused():
    with pytest.raises(ModelError, match=re.escape("the point is not fixed on the body (its distance from the "
                                                   "centre of mass changes with the coordinates)")):
        _planar((1, 0))
    m = _spatial()
    m.add_point("ground", (1, 0, 0))
    with pytest.raises(ModelError, match=re.escape("the point is not fixed on the body")):
        m.add_rigid_body("m", (1, 1, 1), frame="body", inertia_about="ground", name="R2")


def test_too_small_an_inertia_about_the_point_is_reported_by_check():
    m = _planar((0, 0), "0.2")  # I_G = 0.2 - 2 * 0.25 < 0
    assert any("inertia is negative" in str(p) for p in m.check())


TOML = """
coordinates = ["th"]
[parameters]
m = 2.0
l = 0.5
I = 0.1
g = 9.81
[[points]]
name = "pivot"
position = ["0", "0"]
[[bodies]]
name = "rod"
mass = "m"
inertia = "I + m*l**2"
position = ["l*sin(th)", "-l*cos(th)"]
angle = "th"
inertia_about = "pivot"
[gravity]
g = "g"
"""


def test_model_file_inertia_about():
    eqs = lg.derive(loads_model(TOML))
    assert sp.simplify(eqs.mass_matrix[0, 0] - (S("I") + S("m") * S("l") ** 2)) == 0
    assert sp.simplify(eqs.model.elements[1].inertia - S("I")) == 0
    listed = lg.derive(loads_model(TOML.replace('inertia_about = "pivot"', 'inertia_about = ["0", "0"]')))
    assert sp.simplify(listed.mass_matrix - eqs.mass_matrix) == sp.zeros(1)


@pytest.mark.parametrize("value, message", [
    ('"pivto"', "no point is named 'pivto' (did you mean 'pivot'?)"),
    ('"__import__(\'os\')"', "no point is named '__import__('os')'"),
    ("3", "expected a point's name or a position in world coordinates"),
    ('["0", "0", "0"]', "expected a point's name or a position in world coordinates [\"x\", \"y\"] (2 expressions)"),
    ('["nan", "0"]', "bodies[0].inertia_about[0]"),
    ('["1", "0"]', "the point is not fixed on the body"),
])
def test_model_file_inertia_about_errors(value, message):
    with pytest.raises(ModelError, match=re.escape(message)):
        loads_model(TOML.replace('"pivot"\n[gravity]', f"{value}\n[gravity]"))


SPATIAL = """
coordinates = ["th"]
[parameters]
m = 1.0
[[frames]]
name = "link"
rotation = [["x", "th"]]
[[bodies]]
name = "arm"
mass = "m"
inertia = ["0.1 + m*0.25", "0.2 + m*0.25", "0.3"]
frame = "link"
center = ["0", "0", "-0.5"]
inertia_about = ["0", "0", "0"]
"""


def test_model_file_spatial_inertia_about_and_its_errors():
    body = loads_model(SPATIAL).elements[-1]
    assert [float(sp.sympify(x).subs(S("m"), 1.0)) for row in body.inertia for x in row] == pytest.approx(
        [0.1, 0, 0, 0, 0.2, 0, 0, 0, 0.3], abs=1e-15)
    with pytest.raises(ModelError, match=re.escape("in the body frame's axes [x, y, z] (3 expressions)")):
        loads_model(SPATIAL.replace('inertia_about = ["0", "0", "0"]', 'inertia_about = ["0", "0"]'))
