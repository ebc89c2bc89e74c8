"""The model-file reader: valid files build the right Model, invalid ones report every problem.

Every error is matched by its text, with the file name and the line of the key in
``str(exc)``, and several problems of one file are reported together.
"""

from __future__ import annotations

import random
import re
import textwrap
from pathlib import Path

import pytest
import sympy

import lagrangian as lg
from lagrangian.errors import ModelFileError, Problem
from lagrangian.io._modelfile import load_model_file, loads_model

# ----------------------------------------------------------------------------- fixtures

CART_PENDULUM = """\
name = "cart-pendulum"
description = "A cart carrying an inverted pendulum (Bona)"
coordinates = ["q1", "q2"]
inputs = ["F"]

[parameters]
M1 = 1.0
M2 = 0.5
L = 0.8
G = 9.81

[[particles]]
name = "cart"
mass = "M1"
position = ["q1", "0"]

[[particles]]
name = "bob"
mass = "M2"
position = ["q1 + L*cos(q2)", "L*sin(q2)"]

[gravity]
g = "G"

[forces]
q1 = "F"

[simulation]
t_end = 10.0
dt = 0.01
rtol = 1e-9
atol = 1e-9
initial = { q2 = 0.5, q2_dot = 0.0 }
inputs = { F = "0.5*sin(3*t)" }
"""

# The same system written with energies and generalized forces only.
CART_PENDULUM_ENERGIES = """\
coordinates = ["q1", "q2"]
inputs = ["F"]

[parameters]
M1 = 1.0
M2 = 0.5
L = 0.8
G = 9.81

[energy]
T = "1/2*M1*q1_dot**2 + 1/2*M2*(q1_dot**2 + L**2*q2_dot**2 - 2*L*sin(q2)*q1_dot*q2_dot)"
V = "M2*G*L*sin(q2)"

[forces]
q1 = "F"
"""

EVERY_ELEMENT = """\
name = "zoo"
coordinates = ["x", "theta"]
inputs = ["F", "tau"]

[parameters]
m = 1.0
M = 2
l = 0.5
k = 100.0
c = 0.3
g = 9.81

[energy]
T = "0"
V = "0"
D = "c/10*x_dot**2"

[forces]
theta = "-c*theta_dot"

[[points]]
name = "pivot"
position = ["x", "0"]

[[points]]
name = "wall"
position = [-1, 0]

[[particles]]
name = "bob"
mass = "m"
position = ["x + l*sin(theta)", "-l*cos(theta)"]

[[bodies]]
name = "rod"
mass = "M"
inertia = "M*l**2/12"
position = ["x + l/2*sin(theta)", "-l/2*cos(theta)"]
angle = "theta"

[[springs]]
name = "wall_spring"
stiffness = "k"
between = ["wall", "pivot"]
rest_length = 1

[[springs]]
stiffness = "k/10"
between = [["0", "0"], ["x", "0"]]

[[springs]]
name = "torsion"
stiffness = 2.5
length = "theta"

[[dampers]]
coefficient = "c"
between = ["wall", "pivot"]

[[dampers]]
coefficient = "c"
length = "theta"

[gravity]
g = "g"
direction = ["0", "-1"]

[[loads]]
name = "push"
force = ["F", "0"]
at = "pivot"

[[loads]]
force = ["0", "-F/10"]
at = ["x + l*sin(theta)", "-l*cos(theta)"]

[[loads]]
torque = "tau"
body = "rod"

[[loads]]
torque = "-tau/10"
angle = "theta"
"""


def write(tmp_path: Path, text: str, name: str = "model.toml") -> Path:
    path = tmp_path / name
    path.write_text(textwrap.dedent(text), encoding="utf-8")
    return path


def problems_of(tmp_path: Path, text: str, name: str = "model.toml") -> tuple[ModelFileError, Path]:
    path = write(tmp_path, text, name)
    with pytest.raises(ModelFileError) as info:
        load_model_file(path)
    return info.value, path


def by_key(exc: ModelFileError) -> dict[str | None, Problem]:
    return {p.key: p for p in exc.problems}


def line_of(text: str, fragment: str) -> int:
    """1-based line of the first line of `text` containing `fragment`."""
    for number, line in enumerate(textwrap.dedent(text).splitlines(), start=1):
        if fragment in line:
            return number
    raise AssertionError(f"{fragment!r} not in the text")


MINIMAL = """\
coordinates = ["q1", "q2"]
inputs = ["F"]

[parameters]
m = 1.0
k = 2.0
"""

# ----------------------------------------------------------------------------- valid files


def test_cart_pendulum_loads_and_derives(tmp_path):
    model = load_model_file(write(tmp_path, CART_PENDULUM))
    assert model.name == "cart-pendulum"
    assert model.description.startswith("A cart")
    assert [c.name for c in model.q] == ["q1", "q2"]
    assert [u.name for u in model.inputs] == ["F"]
    assert {p.name: v for p, v in model.parameters.items()} == {"M1": 1.0, "M2": 0.5, "L": 0.8,
                                                                 "G": 9.81}
    eqs = lg.derive(model)
    M1, M2, L, q2 = sympy.symbols("M1 M2 L q2")
    expected = sympy.Matrix([[M1 + M2, -M2 * L * sympy.sin(q2)],
                             [-M2 * L * sympy.sin(q2), M2 * L**2]])
    assert sympy.simplify(sympy.Matrix(eqs.mass_matrix) - expected) == sympy.zeros(2, 2)


def test_cart_pendulum_simulation_table(tmp_path):
    model = load_model_file(write(tmp_path, CART_PENDULUM))
    assert model.simulation == {"t_end": 10.0, "dt": 0.01, "rtol": 1e-9, "atol": 1e-9,
                                "initial": {"q2": 0.5, "q2_dot": 0.0},
                                "inputs": {"F": "0.5*sin(3*t)"}}
    assert all(isinstance(v, float) for v in model.simulation["initial"].values())


def test_energies_and_forces_only_give_the_same_equations(tmp_path):
    by_elements = lg.derive(load_model_file(write(tmp_path, CART_PENDULUM, "a.toml")))
    by_energies = lg.derive(load_model_file(write(tmp_path, CART_PENDULUM_ENERGIES, "b.toml")))
    for a, b in zip(by_elements.equations, by_energies.equations):
        assert sympy.simplify(a - b) == 0
    M2, L, G, q2 = sympy.symbols("M2 L G q2")
    # Bona: the gravity term of the second equation is M G L cos(q2)
    assert sympy.simplify(sympy.diff(by_energies.V, q2) - M2 * G * L * sympy.cos(q2)) == 0


def test_energy_only_example_of_the_issue():
    model = loads_model(textwrap.dedent("""\
        coordinates = ["x"]
        inputs = ["F"]
        [parameters]
        m = 2.0
        k = 50.0
        c = 0.4
        [energy]
        T = "1/2*m*x_dot**2"
        V = "1/2*k*x**2"
        D = "1/2*c*x_dot**2"
        [forces]
        x = "F"
        """))
    eqs = lg.derive(model)
    m, k, c, x, xd, xdd, F = sympy.symbols("m k c x x_dot x_ddot F")
    assert sympy.simplify(eqs.equations[0] - (m * xdd + c * xd + k * x - F)) == 0
    assert model.name == "model"


def test_every_element_kind_loads_and_derives(tmp_path):
    model = load_model_file(write(tmp_path, EVERY_ELEMENT))
    kinds = sorted(e.kind for e in model.elements)
    assert kinds == sorted(["point", "point", "particle", "rigid body", "spring", "spring", "spring",
                            "damper", "damper", "gravity", "force", "force", "torque", "torque"])
    names = {e.name for e in model.elements}
    assert {"pivot", "wall", "bob", "rod", "wall_spring", "spring1", "torsion", "damper1",
            "damper2", "push", "force1", "torque1", "torque2"} <= names
    eqs = lg.derive(model)
    m, M, l, theta = sympy.symbols("m M l theta")
    # the angular inertia: m l^2 + M l^2/4 + M l^2/12
    assert sympy.simplify(eqs.mass_matrix[1, 1] - (m * l**2 + M * l**2 / 3)) == 0
    assert sympy.simplify(eqs.mass_matrix[0, 0] - (m + M)) == 0


def test_name_defaults_to_the_file_stem(tmp_path):
    model = load_model_file(write(tmp_path, 'coordinates = ["x"]\n', "my-system.toml"))
    assert model.name == "my-system"
    assert loads_model('coordinates = ["x"]\n', source="other.toml").name == "other"


def test_numbers_are_accepted_where_expressions_are_expected():
    model = loads_model(textwrap.dedent("""\
        coordinates = ["x"]
        [[particles]]
        mass = 1.5
        position = ["x", 0]
        [energy]
        V = 3
        """))
    (particle,) = model.elements
    assert particle.mass == sympy.Rational(3, 2)
    assert particle.position == (sympy.Symbol("x"), 0)
    assert model.V == 3


def test_inline_tables_and_dotted_keys_are_ordinary_toml():
    model = loads_model(textwrap.dedent("""\
        coordinates = ["x"]
        parameters = { k = 3 }
        energy.T = "x_dot**2/2"
        energy.V = "k*x**2/2"
        particles = [{ mass = 1, position = ["x", "0"] }]
        """))
    assert model.V == sympy.Symbol("k") * sympy.Symbol("x") ** 2 / 2
    assert len(model.elements) == 1


# ----------------------------------------------------------------------------- errors, one by one

# (snippet appended to MINIMAL or a whole file, the key, the line fragment, a regex of the message)
CASES = [
    pytest.param('nmae = "x"\n' + MINIMAL, "nmae", 'nmae =',
                 r"unknown top-level key 'nmae' \(did you mean 'name'\?\)", id="unknown-top-level-key"),
    pytest.param(MINIMAL + "[gravty]\ng = 9.81\n", "gravty", "[gravty]",
                 r"unknown top-level table 'gravty' \(did you mean 'gravity'\?\)", id="unknown-table"),
    pytest.param('coordinates = ["x"]\nT = "x_dot**2"\n', "T", "T =",
                 r"unknown top-level key 'T'; put T under an \[energy\] table", id="energy-at-top"),
    pytest.param(MINIMAL + '[[particles]]\nmas = "m"\nposition = ["q1", "0"]\n', "particles[0].mas",
                 'mas =', r"unknown key 'mas' in \[\[particles\]\] \(did you mean 'mass'\?\)",
                 id="unknown-element-key"),
    pytest.param(MINIMAL + '[[particles]]\nposition = ["q1", "0"]\n', "particles[0].mass",
                 "[[particles]]", r"missing required key 'mass' in this \[\[particles\]\] table.*"
                 r"add mass = \"m\"", id="missing-mass"),
    pytest.param(MINIMAL + '[[points]]\nname = "p"\n', "points[0].position", "[[points]]",
                 r"missing required key 'position'", id="missing-position"),
    pytest.param(MINIMAL + '[[springs]]\nlength = "q1"\n', "springs[0].stiffness", "[[springs]]",
                 r"missing required key 'stiffness'", id="missing-stiffness"),
    pytest.param(MINIMAL + '[[bodies]]\nmass = "m"\nposition = ["q1", "0"]\nangle = "q2"\n',
                 "bodies[0].inertia", "[[bodies]]", r"missing required key 'inertia'",
                 id="missing-inertia"),
    pytest.param('coordinates = "q1"\n', "coordinates", "coordinates =",
                 r"expected a list of names, got the string 'q1'; write coordinates = \[\"q1\"\]",
                 id="coordinates-not-a-list"),
    pytest.param('coordinates = ["q1", 2]\n', "coordinates[1]", "coordinates =",
                 r"expected a name in quotes, got the number 2", id="coordinate-not-a-string"),
    pytest.param('coordinates = []\n', "coordinates", "coordinates =",
                 r"the list of coordinates is empty", id="coordinates-empty"),
    pytest.param('inputs = ["F"]\n', "coordinates", None,
                 r"missing required key 'coordinates'", id="coordinates-missing"),
    pytest.param('coordinates = ["x"]\n[parameters]\nk = "2"\n', "parameters.k", 'k = "2"',
                 r"expected a number, got the string '2'; write k = 2", id="parameter-string"),
    pytest.param('coordinates = ["x"]\n[parameters]\nk = "2*m"\n', "parameters.k", 'k = "2*m"',
                 r"the parameter 'k' = '2\*m' uses m, which is not a parameter: a derived parameter is an "
                 r"expression of the other parameters: declare m under \[parameters\] with a value",
                 id="parameter-expression"),
    pytest.param('coordinates = ["x"]\n[parameters]\nk = true\n', "parameters.k", "k = true",
                 r"expected a number, got the boolean true", id="parameter-bool"),
    pytest.param('coordinates = ["x"]\n[parameters]\nk = nan\n', "parameters.k", "k = nan",
                 r"expected a finite number, got nan", id="parameter-nan"),
    pytest.param('[parameters]\nk = 1\ncoordinates = ["x"]\n', "parameters.coordinates",
                 "coordinates =", r"'coordinates' is a top-level key, not a parameter.*move it before "
                 r"the first \[table\] header", id="top-level-key-in-table"),
    pytest.param(MINIMAL + '[[particles]]\nmass = "m"\nposition = ["q1"]\n', "particles[0].position",
                 "position =", r"expected a position with 2 components \(x, y\) or 3 \(x, y, z\), got 1",
                 id="position-1-component"),
    pytest.param(MINIMAL + '[[particles]]\nmass = "m"\nposition = ["q1", "0", "0", "0"]\n',
                 "particles[0].position", "position =", r"got 4; write it as", id="position-4-components"),
    pytest.param(MINIMAL + '[[particles]]\nmass = "m"\nposition = "q1"\n', "particles[0].position",
                 "position =", r"expected a position: a list of 2 or 3 expressions.*got the string 'q1'",
                 id="position-not-a-list"),
    pytest.param(MINIMAL + '[[particles]]\nmass = "m"\nposition = ["q1", "0"]\n'
                 '[gravity]\ng = 9.81\ndirection = ["0", "0", "-1"]\n', "gravity.direction",
                 "direction =", r"the direction has 3 components but particles\[0\].*has a position "
                 r"with 2", id="direction-length"),
    pytest.param(MINIMAL + '[gravity]\ng = 9.81\ndirection = ["0", "0"]\n', "gravity.direction",
                 "direction =", r"the direction is the zero vector", id="direction-zero"),
    pytest.param(MINIMAL + '[gravity]\ndirection = ["0", "-1"]\n', "gravity.g", "[gravity]",
                 r"missing required key 'g' in \[gravity\]", id="gravity-without-g"),
    pytest.param(MINIMAL + '[[springs]]\nstiffness = "k"\nbetween = ["a"]\n', "springs[0].between",
                 "between =", r"expected two points, got 1 items", id="between-1"),
    pytest.param(MINIMAL + '[[springs]]\nstiffness = "k"\n', "springs[0].between", "[[springs]]",
                 r"needs its ends or its length: add between = ", id="spring-without-span"),
    pytest.param(MINIMAL + '[[dampers]]\ncoefficient = "k"\nlength = "q1"\nbetween = ["a", "b"]\n',
                 "dampers[0].length", "length =", r"give either between or length.*not both",
                 id="damper-both-spans"),
    pytest.param(MINIMAL + '[[points]]\nname = "pivot"\nposition = ["0", "0"]\n[[springs]]\n'
                 'stiffness = "k"\nbetween = ["pivt", ["q1", "0"]]\n', "springs[0].between[0]",
                 "between =", r"no point, particle or body is named 'pivt' \(did you mean 'pivot'\?\)",
                 id="unknown-point-in-between"),
    pytest.param(MINIMAL + '[[points]]\nname = "a"\nposition = ["0", "0"]\n[[points]]\nname = "b"\n'
                 'position = ["0", "0", "q1"]\n[[springs]]\nstiffness = "k"\nbetween = ["a", "b"]\n',
                 "springs[0].between", "between =", r"the two ends have 2 and 3 components",
                 id="between-dimensions"),
    pytest.param(MINIMAL + '[[points]]\nname = "cart"\nposition = ["q1", "0"]\n[[loads]]\n'
                 'force = ["F", "0"]\nat = "crt"\n', "loads[0].at", "at =",
                 r"no point, particle or body is named 'crt' \(did you mean 'cart'\?\)",
                 id="unknown-point-in-at"),
    pytest.param(MINIMAL + '[[loads]]\nforce = ["F", "0"]\n', "loads[0].at", "[[loads]]",
                 r"missing required key 'at'", id="force-without-at"),
    pytest.param(MINIMAL + '[[loads]]\nforce = ["F", "0"]\nat = ["q1", "0", "0"]\n', "loads[0].force",
                 "force =", r"the force has 2 components but the point it acts at has 3",
                 id="force-dimension"),
    pytest.param(MINIMAL + '[[loads]]\nforce = ["F", "0"]\ntorque = "F"\nat = ["q1", "0"]\n',
                 "loads[0].torque", "torque =", r"either a force or a torque, not both",
                 id="force-and-torque"),
    pytest.param(MINIMAL + '[[loads]]\nname = "nothing"\n', "loads[0].force", "[[loads]]",
                 r"neither force nor torque", id="load-without-force-or-torque"),
    pytest.param(MINIMAL + '[[loads]]\ntorque = "F"\n', "loads[0].angle", "[[loads]]",
                 r"say what the torque turns: add angle = ", id="torque-without-angle"),
    pytest.param(MINIMAL + '[[loads]]\ntorque = "F"\nbody = "rod"\n', "loads[0].body", "body =",
                 r"no rigid body is named 'rod'", id="torque-unknown-body"),
    pytest.param(MINIMAL + '[[loads]]\nforce = ["F", "0"]\nat = ["q1", "0"]\nangle = "q2"\n',
                 "loads[0].angle", "angle =", r"'angle' belongs to a torque", id="angle-on-a-force"),
    pytest.param(MINIMAL + '[[particles]]\nname = "bob"\nmass = "m"\nposition = ["q1", "0"]\n'
                 '[[points]]\nname = "bob"\nposition = ["0", "0"]\n', "particles[0].name",
                 'name = "bob"', r"the name 'bob' is already used by points\[0\]: give each element "
                 "its own name", id="duplicate-element-name"),
    pytest.param(MINIMAL + '[[particles]]\nname = ""\nmass = "m"\nposition = ["q1", "0"]\n',
                 "particles[0].name", 'name = ""', r"expected a non-empty string, got the string ''",
                 id="empty-element-name"),
    pytest.param('coordinates = ["x", "x"]\n', "coordinates[1]", "coordinates =",
                 r"'x' is declared twice", id="duplicate-coordinate"),
    pytest.param('coordinates = ["x"]\n[parameters]\nx = 1\n', "parameters.x", "x = 1",
                 r"'x' is declared twice", id="parameter-named-like-a-coordinate"),
    pytest.param('coordinates = ["x_dot"]\n', "coordinates[0]", "coordinates =",
                 r"'x_dot' ends in _dot or _ddot", id="bad-coordinate-name"),
    pytest.param('coordinates = ["x"]\ninputs = ["sin"]\n', "inputs[0]", "inputs =",
                 r"'sin' is reserved", id="reserved-input-name"),
    pytest.param('coordinates = ["2x"]\n', "coordinates[0]", "coordinates =",
                 r"'2x' is not a valid coordinate name", id="invalid-coordinate-name"),
    pytest.param(MINIMAL + '[energy]\nV = "1/2*k*q3**2"\n', "energy.V", "V =",
                 r"unknown name 'q3' \(did you mean 'q2'\?\) in the expression at position 7; .*"
                 r"declare it under \[parameters\] with a value \(q3 = 1\.0\), or in coordinates",
                 id="unknown-symbol"),
    pytest.param(MINIMAL + '[[particles]]\nmass = "mm"\nposition = ["q1", "0"]\n', "particles[0].mass",
                 "mass =", r"unknown name 'mm' \(did you mean 'm'\?\)", id="unknown-symbol-in-element"),
    pytest.param(MINIMAL + '[energy]\nT = "1/2*m*(q1_dot**2"\n', "energy.T", "T =",
                 r"malformed expression at position 7: missing '\)'", id="malformed-expression"),
    pytest.param(MINIMAL + '[energy]\nT = ""\n', "energy.T", "T =", r"malformed expression: empty "
                 "expression", id="empty-expression"),
    pytest.param(MINIMAL + '[energy]\nT = ["q1"]\n', "energy.T", "T =",
                 r"expected an expression \(a string such as \"m\*g\"\) or a number, got a list",
                 id="expression-wrong-type"),
    pytest.param(MINIMAL + '[energy]\nL = "0"\n', "energy.L", "L =",
                 r"unknown key 'L' in \[energy\]; the keys of \[energy\] are: T, V, D",
                 id="unknown-energy-key"),
    pytest.param(MINIMAL + '[energy]\nV = "k*q1**2 + m*q1_dot"\n', "energy.V", "V =",
                 r"velocity q1_dot appears here, but the potential energy V depends only on "
                 "coordinates and time", id="velocity-in-V"),
    pytest.param(MINIMAL + '[energy]\nT = "m*q1_ddot"\n', "energy.T", "T =",
                 r"acceleration 'q1_ddot' may not appear", id="acceleration-in-T"),
    pytest.param(MINIMAL + '[[particles]]\nmass = "m"\nposition = ["q1_dot", "0"]\n',
                 "particles[0].position[0]", "position =",
                 r"velocity q1_dot appears here, but a position depends only on coordinates",
                 id="velocity-in-position"),
    pytest.param(MINIMAL + '[[springs]]\nstiffness = "k"\nbetween = [["0", "0"], ["q1", "q2_dot"]]\n',
                 "springs[0].between", "between =", r"velocity q2_dot appears here",
                 id="velocity-in-spring-end"),
    pytest.param(MINIMAL + '[[points]]\nname = "a"\nposition = ["0", "0"]\n[[dampers]]\ncoefficient = "k"\n'
                 'between = ["a", "a"]\n', "dampers[0].between", "between =",
                 r"both ends of the damper 'damper1' are the same point", id="between-same-point"),
    pytest.param(MINIMAL + '[[particles]]\nmass = "m"\nposition = ["q1 + F", "0"]\n',
                 "particles[0].position[0]", "position =", r"input F appears in a position",
                 id="input-in-position"),
    pytest.param(MINIMAL + '[[loads]]\ntorque = "F"\nangle = "q1 + q2_dot"\n', "loads[0].angle",
                 "angle =", r"velocity q2_dot appears here", id="velocity-in-torque-angle"),
    pytest.param(MINIMAL + '[energy]\nT = "F*q1_dot**2"\n', "energy.T", "T =",
                 r"input F appears in T", id="input-in-T"),
    pytest.param(MINIMAL + '[[particles]]\nmass = -1\nposition = ["q1", "0"]\n', "particles[0].mass",
                 "mass =", r"the mass is negative \(-1\): a mass must be zero or positive",
                 id="negative-mass-number"),
    pytest.param('coordinates = ["x"]\n[parameters]\nk = -3.0\n[[springs]]\nstiffness = "k"\n'
                 'length = "x"\n', "springs[0].stiffness", "stiffness =",
                 r"stiffness is negative \(-3\).*check the sign or the parameter values",
                 id="negative-stiffness-by-parameter"),
    pytest.param('coordinates = ["x"]\n[[dampers]]\ncoefficient = -0.5\nlength = "x"\n',
                 "dampers[0].coefficient", "coefficient =", r"the coefficient is negative \(-0\.5\)",
                 id="negative-coefficient"),
    pytest.param('coordinates = ["x"]\n[parameters]\nm = 1\n[[bodies]]\nmass = "m"\ninertia = "-m"\n'
                 'position = ["x", "0"]\nangle = "x"\n', "bodies[0].inertia", "inertia =",
                 r"inertia is negative \(-1\)", id="negative-inertia-by-parameter"),
    pytest.param(MINIMAL + '[forces]\nq3 = "F"\n', "forces.q3", 'q3 = "F"',
                 r"'q3' is not a coordinate \(did you mean 'q2'\?\): \[forces\] gives generalized forces "
                 "by coordinate name", id="force-on-a-non-coordinate"),
    pytest.param(MINIMAL + '[simulation]\ninitial = { q3 = 0.5 }\n', "simulation.initial.q3",
                 "initial =", r"'q3' is not a coordinate or a velocity \(did you mean 'q2'\?\)",
                 id="initial-not-a-coordinate"),
    pytest.param(MINIMAL + '[simulation]\ninitial = { q1 = "0.5" }\n', "simulation.initial.q1",
                 "initial =", r"expected a number, got the string '0.5'; write q1 = 0.5",
                 id="initial-string"),
    pytest.param(MINIMAL + '[simulation]\ninputs = { G = "sin(t)" }\n', "simulation.inputs.G",
                 "inputs = {", r"'G' is not an input: the inputs are F; declare it",
                 id="signal-not-an-input"),
    pytest.param(MINIMAL + '[simulation]\ninputs = { F = "sin(q1_ddot)" }\n', "simulation.inputs.F",
                 "inputs = {", r"unknown name 'q1_ddot'.*an input may use t, the coordinates, velocities "
                 r"\(<coordinate>_dot\) and parameters", id="signal-uses-an-acceleration"),
    pytest.param(MINIMAL + '[simulation]\ninputs = { F = "10*(q1 > 0)" }\n', "simulation.inputs.F",
                 "inputs = {", r"the condition 'q1 > 0' is true or false, not a number: use it as the condition "
                 r"of where\(q1 > 0, a, b\)", id="signal-comparison-outside-where"),
    pytest.param(MINIMAL + '[simulation]\nsample_time = 0\n', "simulation.sample_time", "sample_time =",
                 r"sample_time = 0, but it must be greater than 0", id="sample-time-zero"),
    pytest.param(MINIMAL + '[simulation]\nsample_time = { G = 0.1 }\n', "simulation.sample_time.G",
                 "sample_time =", r"'G' is not an input: the inputs are F; sample_time names the inputs",
                 id="sample-time-not-an-input"),
    pytest.param(MINIMAL + '[simulation]\nt_end = 0\n', "simulation.t_end", "t_end =",
                 r"t_end = 0, but it must be greater than 0", id="t_end-zero"),
    pytest.param(MINIMAL + '[simulation]\ndt = -0.1\n', "simulation.dt", "dt =",
                 r"dt = -0.1, but it must be greater than 0", id="dt-negative"),
    pytest.param(MINIMAL + '[simulation]\nrtol = "1e-9"\n', "simulation.rtol", "rtol =",
                 r"expected a number, got the string '1e-9'; write rtol = 1e-9", id="rtol-string"),
    pytest.param(MINIMAL + '[simulation]\nsteps = 3\n', "simulation.steps", "steps =",
                 r"unknown key 'steps' in \[simulation\]", id="unknown-simulation-key"),
    pytest.param('energy = "T"\n' + MINIMAL, "energy", "energy =",
                 r"expected a table \[energy\], got the string 'T'", id="energy-not-a-table"),
    pytest.param(MINIMAL + '[particles]\nmass = "m"\n', "particles", "[particles]",
                 r"expected \[\[particles\]\] tables \(an array of tables, with double brackets\)",
                 id="single-brackets-for-elements"),
    pytest.param('name = 3\ncoordinates = ["x"]\n', "name", "name =",
                 r"expected the model's name, a non-empty string, got the number 3", id="bad-model-name"),
]


@pytest.mark.parametrize("text, key, fragment, pattern", CASES)
def test_each_problem_is_reported_with_file_key_and_line(tmp_path, text, key, fragment, pattern):
    exc, path = problems_of(tmp_path, text)
    found = by_key(exc)
    assert key in found, f"no problem at {key!r}; got:\n{exc}"
    problem = found[key]
    assert re.search(pattern, problem.message), problem.message
    line = line_of(text, fragment) if fragment is not None else None
    assert problem.line == line
    where = f"{path}:{line}" if line is not None else f"{path}"
    assert re.search(re.escape(f"{where} [{key}]: ") + ".*" + pattern, str(exc)), str(exc)
    assert exc.file == str(path)


def test_every_problem_of_a_file_is_reported_at_once(tmp_path):
    text = """\
        nme = "x"
        coordinates = ["q1", "q2"]
        inputs = ["F"]

        [parameters]
        m = 1.0
        k = "2"

        [energy]
        V = "1/2*k*q3**2"
        D = "m*(q1_dot"

        [forces]
        x = "F"

        [[particles]]
        name = "bob"
        mas = "m"
        position = ["q1"]

        [[springs]]
        stiffness = -1
        between = ["bob", "pivt"]

        [simulation]
        t_end = 0
        initial = { q3 = 0.5 }
        inputs = { G = "sin(t)" }
        """
    exc, path = problems_of(tmp_path, text)
    keys = [p.key for p in exc.problems]
    assert keys == ["nme", "parameters.k", "energy.V", "energy.D", "forces.x",
                    "particles[0].mass", "particles[0].mas", "particles[0].position",
                    "springs[0].stiffness", "springs[0].between[1]", "simulation.t_end",
                    "simulation.initial.q3", "simulation.inputs.G"]
    lines = [p.line for p in exc.problems]
    assert lines == sorted(lines)
    message = str(exc)
    assert message.startswith(f"{len(keys)} problems in {path}:")
    assert f"{path}:1 [nme]" in message
    assert f"{path}:7 [parameters.k]" in message
    assert f"{path}:27 [simulation.initial.q3]" in message


def test_model_check_problems_of_an_unbuilt_element_do_not_cascade(tmp_path):
    # the particle cannot be built: the spring referring to it says nothing more
    exc, _ = problems_of(tmp_path, MINIMAL + '[[particles]]\nname = "bob"\nmass = "mm"\n'
                         'position = ["q1", "0"]\n[[springs]]\nstiffness = "k"\n'
                         'between = ["bob", ["0", "0"]]\n')
    assert [p.key for p in exc.problems] == ["particles[0].mass"]


def test_a_torque_on_a_particle_is_not_a_torque_on_a_body(tmp_path):
    exc, _ = problems_of(tmp_path, MINIMAL + '[[particles]]\nname = "bob"\nmass = "m"\n'
                         'position = ["q1", "0"]\n[[loads]]\ntorque = "F"\nbody = "bob"\n')
    assert "no rigid body is named 'bob' ('bob' is a particle)" in str(exc)


def test_a_spring_cannot_end_at_a_spring(tmp_path):
    exc, _ = problems_of(tmp_path, MINIMAL + '[[springs]]\nname = "s"\nstiffness = "k"\nlength = "q1"\n'
                         '[[dampers]]\ncoefficient = "k"\nbetween = ["s", ["0", "0"]]\n')
    assert "'s' is a spring (springs[0]), not a point" in str(exc)


def test_toml_syntax_error_has_its_line(tmp_path):
    exc, path = problems_of(tmp_path, 'coordinates = ["x"]\n[energy]\nT = 1/2*m*x_dot**2\n')
    (problem,) = exc.problems
    assert problem.line == 3
    assert re.search(r"invalid TOML at column \d+: .*expressions are strings in quotes", problem.message)
    assert str(exc).startswith(f"{path}:3: invalid TOML")


def test_toml_error_at_the_end_of_the_document():
    with pytest.raises(ModelFileError, match=r"<string>:2: invalid TOML at the end of the file"):
        loads_model('coordinates = ["x"]\ninputs = ["F",\n')


def test_missing_file(tmp_path):
    path = tmp_path / "nothere.toml"
    with pytest.raises(ModelFileError, match=r"no such model file '.*nothere\.toml': check the path"):
        load_model_file(path)


def test_missing_file_suggests_a_close_name(tmp_path):
    write(tmp_path, 'coordinates = ["x"]\n', "pendulum.toml")
    with pytest.raises(ModelFileError, match=r"did you mean '.*pendulum\.toml'\?"):
        load_model_file(tmp_path / "pendulumm.toml")


def test_directory_is_not_a_model_file(tmp_path):
    with pytest.raises(ModelFileError, match=r"no such model file '.*': it is a directory"):
        load_model_file(tmp_path)


def test_non_utf8_file(tmp_path):
    path = tmp_path / "latin1.toml"
    path.write_bytes('coordinates = ["x"]\n# \u00e9t\u00e9\n'.encode("latin-1"))
    with pytest.raises(ModelFileError, match=r"latin1\.toml:2: the model file is not UTF-8 text"):
        load_model_file(path)


def test_loads_model_rejects_bytes():
    with pytest.raises(TypeError, match="expects the text of a model file"):
        loads_model(b'coordinates = ["x"]')  # type: ignore[arg-type]


def test_errors_are_model_errors_and_value_errors():
    with pytest.raises(ValueError):
        loads_model("coordinates = 1")
    with pytest.raises(lg.ModelError):
        loads_model("coordinates = 1")


# ----------------------------------------------------------------------------- lines


def test_lines_in_multiline_arrays_inline_tables_and_subtables():
    text = textwrap.dedent("""\
        coordinates = [
            "q1",
            "q2",
        ]  # [not a header]
        [parameters]
        m = 1
        [[particles]]
        mass = "m"
        position = ["q1", "0"]
        [[particles]]
        mass = "m"
        position = [
            "q1",
            "q3",
        ]
        [simulation.initial]
        q1 = 0.0
        q9 = 1.0
        """)
    with pytest.raises(ModelFileError) as info:
        loads_model(text)
    found = by_key(info.value)
    assert found["particles[1].position[1]"].line == 12
    assert found["simulation.initial.q9"].line == 18


# ----------------------------------------------------------------------------- safety


def test_code_injection_is_rejected_and_nothing_runs(tmp_path):
    marker = tmp_path / "pwned"
    text = ('coordinates = ["x"]\n[energy]\n'
            f"T = \"__import__('os').system('touch {marker}')\"\n")
    exc, path = problems_of(tmp_path, text)
    assert not marker.exists()
    (problem,) = exc.problems
    assert problem.key == "energy.T"
    assert problem.line == 3
    assert "malformed expression" in problem.message


@pytest.mark.parametrize("payload", [
    "x.__class__", "(lambda: 1)()", "[c for c in ()]", "exec('1')", "x if x else 1",
    "open('/etc/passwd')", "sympify('1')", "'a'*3",
])
def test_python_syntax_never_reaches_an_evaluator(payload):
    text = 'coordinates = ["x"]\n[energy]\nV = ' + _toml_string(payload) + "\n"
    with pytest.raises(ModelFileError) as info:
        loads_model(text)
    assert [p.key for p in info.value.problems] == ["energy.V"]


def _toml_string(s: str) -> str:
    return '"' + s.replace("\\", "\\\\").replace('"', '\\"') + '"'


def test_random_garbage_only_raises_model_file_errors():
    rng = random.Random(20240521)
    alphabet = list('abcxyzq12_.=[]{}"\', \n#-+*/()') + ["\n[[particles]]\n", "\n[energy]\n",
                                                        'coordinates = ["x"]\n', "mass", "position",
                                                        "between", "\n[simulation]\n", "inf", "nan"]
    for _ in range(300):
        text = "".join(rng.choice(alphabet) for _ in range(rng.randint(0, 80)))
        _load_or_model_file_error(text)


def test_mutated_valid_files_only_raise_model_file_errors():
    rng = random.Random(7)
    for base in (CART_PENDULUM, EVERY_ELEMENT):
        for _ in range(150):
            chars = list(base)
            for _ in range(rng.randint(1, 4)):
                i = rng.randrange(len(chars))
                op = rng.random()
                if op < 0.4:
                    del chars[i]
                elif op < 0.8:
                    chars[i] = rng.choice('"[]{}=,.#\n-0123456789abqxl_*')
                else:
                    chars.insert(i, rng.choice('"[]{}=, -9eq'))
            _load_or_model_file_error("".join(chars))


def _load_or_model_file_error(text: str) -> None:
    try:
        model = loads_model(text)
    except ModelFileError as exc:
        assert exc.problems and all(isinstance(p.message, str) and p.message for p in exc.problems)
        str(exc)
    else:
        assert isinstance(model, lg.Model)


@pytest.mark.parametrize("text", [
    "", "\n\n", "[[particles]]\n", "coordinates = [[]]\n", 'coordinates = ["x"]\nparticles = [1, 2]\n',
    'coordinates = ["x"]\n[[loads]]\nforce = "F"\nat = 3\n', 'coordinates = ["x"]\n[gravity]\ng = {}\n',
    'coordinates = ["x"]\n[forces]\nx = 1979-05-27\n', 'coordinates = ["x"]\n[simulation]\ninitial = 3\n',
    'coordinates = ["x"]\n[energy]\nT = "' + "(" * 500 + 'x' + ")" * 500 + '"\n',
    'coordinates = ["x"]\n[energy]\nT = "10**10**10"\n',
])
def test_odd_files_only_raise_model_file_errors(text):
    with pytest.raises(ModelFileError):
        loads_model(text)
