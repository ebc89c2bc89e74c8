"""Named outputs in the model (issue 21, Part 0): ``Model.add_output``, ``lg.Model(outputs=...)`` and
the model file's ``[outputs]`` table, each checked like every other key (clashes, unknown names,
malformed expressions, a point's component), and hostile names and expressions stopped before
anything is generated."""

from __future__ import annotations

import json

import pytest
import sympy

import lagrangian as lg
from lagrangian.errors import ModelError, ModelFileError
from lagrangian.io._modelfile import loads_model
from lagrangian.numeric._codegen import numba_source

DOUBLE = """
name = "dp"
coordinates = ["th1", "th2"]
inputs = ["F"]

[parameters]
m1 = 1.0
m2 = 0.8
l1 = 1.3
l2 = 0.7
g = 9.81

[[particles]]
name = "bob1"
mass = "m1"
position = ["l1*sin(th1)", "-l1*cos(th1)"]

[[particles]]
name = "bob2"
mass = "m2"
position = ["l1*sin(th1) + l2*sin(th2)", "-l1*cos(th1) - l2*cos(th2)"]

[gravity]
g = "g"

[forces]
th1 = "F"
"""

OUTPUTS = """
[outputs]
tip_x = "l1*sin(th1) + l2*sin(th2)"
tip_y = "bob2.y"
push = "2*F + th1"
"""


def double(outputs: str = OUTPUTS):
    return loads_model(DOUBLE + outputs, source="dp.toml")


def test_outputs_from_the_model_file_in_order_with_a_point_component():
    m = double()
    th1, th2, l1, l2, F = sympy.symbols("th1 th2 l1 l2 F")
    assert list(m.outputs) == ["tip_x", "tip_y", "push"]
    assert sympy.simplify(m.outputs["tip_x"] - (l1 * sympy.sin(th1) + l2 * sympy.sin(th2))) == 0
    assert sympy.simplify(m.outputs["tip_y"] + l1 * sympy.cos(th1) + l2 * sympy.cos(th2)) == 0
    assert m.outputs["push"] == 2 * F + th1


def test_python_api_add_output_and_constructor_agree_with_the_file():
    m = lg.Model("osc", coordinates=["x"], parameters={"k": 2.0}, inputs=["u"],
                 V="k*x**2/2", outputs={"spring_force": "-k*x", "y2": "x + 3*u"})
    x, k, u = sympy.symbols("x k u")
    assert m.outputs == {"spring_force": -k * x, "y2": x + 3 * u}
    m2 = lg.Model("osc", coordinates=["x"], parameters={"k": 2.0}, V="k*x**2/2")
    assert m2.add_output("sym", m2.symbol("x") ** 2) == x ** 2
    assert m2.outputs == {"sym": x ** 2}
    # a copy is independent; the snapshot of derive() keeps them
    c = m2.copy()
    c.add_output("more", "x_dot")
    assert list(m2.outputs) == ["sym"] and list(c.outputs) == ["sym", "more"]
    assert lg.derive(c).model.outputs == c.outputs


def test_the_notebook_table_lists_the_outputs():
    html = double()._repr_html_()
    assert "output tip_x" in html and "output push" in html and "2 F + th_{1}" in html


def test_an_element_position_component_in_python():
    m = lg.load("double-pendulum").copy()
    e = m.add_output("bx", "bob2.x")
    th1, th2, l1, l2 = sympy.symbols("theta1 theta2 l1 l2")
    assert sympy.simplify(e - (l1 * sympy.sin(th1) + l2 * sympy.sin(th2))) == 0


@pytest.mark.parametrize("name, what", [
    ("th1", "a coordinate, parameter, input or multiplier"),
    ("l1", "a coordinate, parameter, input or multiplier"),
    ("F", "a coordinate, parameter, input or multiplier"),
    ("energy", "an energy column"),
    ("jacobi_integral", "an energy column"),
])
def test_a_name_clash_is_refused_with_the_fix(name, what):
    with pytest.raises(ModelFileError) as exc:
        double(f'[outputs]\n{name} = "th1"\n')
    text = str(exc.value)
    assert "dp.toml" in text and f"[outputs.{name}]" in text
    assert f"output '{name}': the name is already {what}" in text
    assert "rename the output" in text


def test_clashes_in_python_between_outputs_and_with_later_declarations():
    m = lg.Model("osc", coordinates=["x"], outputs={"y": "x"})
    with pytest.raises(ModelError, match="output 'y': the name is already an output; .* rename the output"):
        m.add_output("y", "2*x")
    with pytest.raises(ModelError, match="'y' is declared twice"):
        m.parameter("y", 1.0)
    with pytest.raises(ModelError, match="'x_dot' ends in _dot or _ddot.*choose another output name"):
        m.add_output("x_dot", "x")
    with pytest.raises(ModelError, match="'t' is reserved"):
        m.add_output("t", "x")


def test_an_unknown_name_gets_did_you_mean_and_the_fix():
    with pytest.raises(ModelFileError) as exc:
        double('[outputs]\nz = "th1 + l3"\n')
    text = str(exc.value)
    assert "[outputs.z]" in text and "unknown name 'l3' (did you mean 'l2'?)" in text
    assert "declare it under [parameters] with a value (l3 = 1.0)" in text
    with pytest.raises(ModelError, match="unknown name 'kk'"):
        lg.Model("osc", coordinates=["x"], parameters={"k": 1.0}, outputs={"y": "kk*x"})


def test_a_malformed_expression_and_a_wrong_type():
    with pytest.raises(ModelFileError) as exc:
        double('[outputs]\nz = "th1 +"\nw = [1]\n')
    text = str(exc.value)
    assert "[outputs.z]: malformed expression at position 5: missing operand after '+'" in text
    assert "[outputs.w]: expected an expression (a string such as \"m*g\") or a number, got a list" in text
    with pytest.raises(ModelFileError, match=r"\[outputs\]: expected a table \[outputs\], got .*write a "
                                             r"\[outputs\] header followed by lines such as tip_x"):
        loads_model('outputs = 3\n' + DOUBLE)


def test_point_components_that_do_not_exist():
    with pytest.raises(ModelFileError) as exc:
        double('[outputs]\nz = "bob3.x"\nw = "bob1.z"\n')
    text = str(exc.value)
    assert ("[outputs.z]: 'bob3' is not a point, particle or body (did you mean 'bob2'?): \"<point>.x\" is a "
            "component of a located element's position; use one of bob1, bob2") in text
    assert "[outputs.w]: 'bob1' has a planar position (x, y): it has no z component; use bob1.x or bob1.y" in text


def test_an_acceleration_in_an_output_is_refused():
    with pytest.raises(ModelFileError, match=r"\[outputs.z\]: acceleration 'th1_ddot' may not appear"):
        double('[outputs]\nz = "th1_ddot"\n')


def test_unknown_top_level_key_suggests_outputs():
    with pytest.raises(ModelFileError, match="unknown top-level table 'output' \\(did you mean 'outputs'\\?\\)"):
        loads_model(DOUBLE.replace('[forces]', '[output]\nz = "th1"\n[forces]'))


HOSTILE_NAMES = ['x"""\nimport os', "a*/b", "__import__('os')", "y; rm -rf /", "nul\x00", "é", "",
                 "a.b", "class", "sin"]
HOSTILE_EXPRESSIONS = ["__import__('os').system('touch LG_PWNED')", "th1.__class__", "lambda: 0",
                       "open('/etc/passwd')", "exec('1')", "th1; th2", "[th1 for th1 in ()]", "9**9**9**9",
                       "'*/ system(\"x\") /*'", "bob1.__dict__"]


@pytest.mark.parametrize("name", HOSTILE_NAMES)
def test_hostile_output_names_are_refused(name):
    m = lg.Model("osc", coordinates=["x"])
    with pytest.raises(ModelError, match="output"):
        m.add_output(name, "x")
    assert m.outputs == {}


@pytest.mark.parametrize("text", HOSTILE_EXPRESSIONS)
def test_hostile_output_expressions_never_parse(text, tmp_path, monkeypatch):
    monkeypatch.chdir(tmp_path)
    with pytest.raises(ModelFileError, match=r"\[outputs.z\]"):
        double(f"[outputs]\nz = {json.dumps(text)}\n")  # a TOML basic string holds JSON's escapes
    assert not list(tmp_path.iterdir())


def test_outputs_never_reach_generated_code():
    """Outputs are evaluated by NumPy after a run: the compiled model's source is the same with them."""
    plain, with_outputs = lg.derive(double("")), lg.derive(double())
    assert numba_source(with_outputs) == numba_source(plain)
