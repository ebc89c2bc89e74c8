"""What docs/model-files.md says of [[particles]] frame, [[loads]] at = "<body>" and a frame's
matrix (written row by row, its columns the frame's axes in the parent's), checked (issue 22, item 6)."""

from __future__ import annotations

import sympy as sp

import lagrangian as lg
from lagrangian.io import loads_model

S = sp.Symbol

FRAME = """
coordinates = ["phi"]
[parameters]
m = 2.0
[[frames]]
name = "arm"
origin = ["1", "2", "3"]
{rotation}
[[particles]]
name = "bob"
mass = "m"
frame = "arm"
position = ["1", "0", "0"]
"""


def test_particles_take_a_frame_and_a_matrix_is_given_by_columns():
    # the columns of this constant matrix are the frame's axes: x' = (0, 1, 0), y' = (0, 0, 1), z' = (1, 0, 0)
    rows = 'matrix = [["0", "0", "1"], ["1", "0", "0"], ["0", "1", "0"]]'
    bob = loads_model(FRAME.format(rotation=rows)).elements[0]
    assert bob.position == (1, 3, 3)  # origin + first column
    turned = loads_model(FRAME.format(rotation='matrix = [["cos(phi)", "-sin(phi)", "0"], ["sin(phi)", "cos(phi)", '
                                               '"0"], ["0", "0", "1"]]'))
    steps = loads_model(FRAME.format(rotation='rotation = [["z", "phi"]]'))
    phi = S("phi")
    assert turned.elements[0].position == (1 + sp.cos(phi), 2 + sp.sin(phi), 3)
    assert sp.simplify(sp.Matrix(turned.elements[0].position) - sp.Matrix(steps.elements[0].position)) == sp.zeros(3, 1)
    assert sp.simplify(lg.derive(turned).mass_matrix - lg.derive(steps).mass_matrix) == sp.zeros(1)


LOAD = """
coordinates = ["x", "th"]
inputs = ["F"]
[parameters]
m = 1.0
l = 0.5
[[bodies]]
name = "rod"
mass = "m"
inertia = "m*l**2/12"
position = ["x + l*sin(th)", "-l*cos(th)"]
angle = "th"
[[loads]]
force = ["F", "0"]
at = "{at}"
"""


def test_a_load_at_a_body_name_acts_at_its_centre_of_mass():
    by_name = lg.derive(loads_model(LOAD.format(at="rod")))
    by_position = lg.derive(loads_model(LOAD.replace('at = "{at}"', 'at = ["x + l*sin(th)", "-l*cos(th)"]')))
    assert sp.simplify(by_name.generalized_forces - by_position.generalized_forces) == sp.zeros(2, 1)
    assert sp.simplify(by_name.generalized_forces - sp.Matrix([S("F"), S("F") * S("l") * sp.cos(S("th"))])) \
        == sp.zeros(2, 1)
