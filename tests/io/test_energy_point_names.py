"""[energy] and [forces] may use the elements' positions by name, "<point>.x" (.y, .z) (issue 22,
item 2): a potential between named balls is written without the angles. Checked against the same
potential written out in the angles from sympy.physics.mechanics' positions (an independent
derivation) and against a spring between the same points; the Python API takes the same names; an
unknown component is refused with the closest one; nothing is looked up on an object."""

from __future__ import annotations

import re

import pytest
import sympy as sp
from sympy.physics.mechanics import Point, ReferenceFrame, dynamicsymbols

import lagrangian as lg
from lagrangian.errors import ModelError
from lagrangian.io import loads_model

HEAD = """
coordinates = ["a1", "b1", "c1", "a2", "b2", "c2"]
[parameters]
m = 1.0
l = 1.0
k = 50.0
g = 9.81
[[frames]]
name = "link1"
rotation = [["z", "a1"], ["x", "b1"], ["y", "c1"]]
[[frames]]
name = "link2"
parent = "link1"
origin = ["0", "0", "-l"]
rotation = [["z", "a2"], ["x", "b2"], ["y", "c2"]]
[[particles]]
name = "ball1"
mass = "m"
frame = "link1"
position = ["0", "0", "-l"]
[[particles]]
name = "ball2"
mass = "m"
frame = "link2"
position = ["0", "0", "-l"]
[gravity]
g = "g"
"""

BY_NAME = HEAD + """
[energy]
V = "k/2*((ball2.x - ball1.x)**2 + (ball2.y - ball1.y)**2 + (ball2.z - ball1.z + l)**2)"
"""


def _by_hand():
    """The same V in the six angles, from sympy.physics.mechanics' positions of the two balls."""
    qs = dynamicsymbols("a1 b1 c1 a2 b2 c2")
    l, k = sp.symbols("l k")
    N = ReferenceFrame("N")
    A = N.orientnew("A", "Body", qs[:3], "ZXY")
    B = A.orientnew("B", "Body", qs[3:], "ZXY")
    O = Point("O")
    P1 = O.locatenew("P1", -l * A.z)
    P2 = P1.locatenew("P2", -l * B.z)
    d = P2.pos_from(P1).to_matrix(N) - sp.Matrix([0, 0, -l])  # the spring's stretch from its rest offset
    plain = {q: sp.Symbol(str(q.func)) for q in qs}
    return (k / 2 * (d.T * d)[0]).subs(plain)


def test_energy_with_point_names_equals_the_potential_written_in_the_angles():
    model = loads_model(BY_NAME)
    assert sp.simplify(model.V - _by_hand()) == 0
    assert len(BY_NAME) - len(HEAD) < 120  # the potential fits on one line


def test_energy_with_point_names_derives_as_the_hand_written_one():
    named = lg.derive(loads_model(BY_NAME))
    hand = loads_model(HEAD)
    hand.add_energy(V=_by_hand())
    assert sp.simplify(named.potential_gradient - lg.derive(hand).potential_gradient) == sp.zeros(6, 1)


def test_forces_and_the_python_api_take_point_names():
    model = loads_model(HEAD + '[forces]\na1 = "-k*ball1.x"\n')
    assert model.Q[sp.Symbol("a1")] == -sp.Symbol("k") * model.elements[0].position[0]
    m = lg.Model("api", coordinates=["x"], parameters={"k": 2.0})
    m.add_particle(1, ("x", "0"), name="cart")
    m.add_energy(V="k/2*cart.x**2")
    assert m.V == sp.Symbol("k") * sp.Symbol("x") ** 2 / 2


@pytest.mark.parametrize("text, message", [
    ('V = "ball3.x"', "unknown name 'ball3.x' (did you mean 'ball2.x'?): a dotted name is a component of a "
                      "point's, particle's or body's position"),
    ('V = "ball1.w"', "unknown name 'ball1.w'"),
    ('V = "ball1.x.y"', "unknown name 'ball1.x.y'"),
    ('V = "m.__class__"', "unknown name 'm.__class__'"),
    ('V = "ball1.__dict__"', "unknown name 'ball1.__dict__'"),
])
def test_unknown_point_components_are_refused(text, message):
    with pytest.raises(ModelError, match=re.escape(message)):
        loads_model(HEAD + "[energy]\n" + text + "\n")
