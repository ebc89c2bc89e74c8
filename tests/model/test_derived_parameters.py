"""Parameters that are expressions of other parameters (issue 22, item 5): lA = "(l + r)/2".
Resolved in dependency order (any order in the file or the mapping), cycles refused with the cycle
named, self-references and hostile values refused; a derived parameter is not a free parameter
(not in Equations.parameters, nor in the JSON's "parameters": it is listed under
"derived_parameters"), and a new value of l at simulate time changes lA."""

from __future__ import annotations

import json
import re

import numpy as np
import pytest
import sympy as sp

import lagrangian as lg
from lagrangian.cli import main
from lagrangian.errors import ModelError
from lagrangian.io import loads_model

S = sp.Symbol

TOML = """
name = "derived"
coordinates = ["th"]
[parameters]
lA = "(l + r)/2"
m = 1.5
l = 1.0
r = 0.5
g = 9.81
[energy]
T = "m*lA**2*th_dot**2/2"
V = "-m*g*lA*cos(th)"
"""


def _hand(l=1.0, r=0.5):
    """The same pendulum with the length written as a number."""
    return lg.Model("hand", coordinates=["th"], parameters={"m": 1.5, "g": 9.81, "L": (l + r) / 2},
                    T="m*L**2*th_dot**2/2", V="-m*g*L*cos(th)")


def test_a_derived_parameter_is_its_expression_everywhere_and_not_a_free_parameter():
    model = loads_model(TOML)
    assert model.derived_parameters == {"lA": S("l") / 2 + S("r") / 2}
    assert [p.name for p in model.parameters] == ["m", "l", "r", "g"]
    eqs = lg.derive(model)
    assert [p.name for p in eqs.parameters] == ["m", "l", "r", "g"]
    assert sp.simplify(eqs.mass_matrix[0, 0] - S("m") * ((S("l") + S("r")) / 2) ** 2) == 0
    d = eqs.to_dict()
    assert "lA" not in d["parameters"] and d["derived_parameters"] == {"lA": "l/2 + r/2"}


def test_changing_l_at_simulate_time_changes_the_derived_parameter():
    eqs = lg.derive(loads_model(TOML))
    for l in (1.0, 3.0):
        ours = lg.simulate(eqs, 2.0, initial={"th": 0.4}, params={"l": l}, rtol=1e-11, atol=1e-11)
        hand = lg.simulate(lg.derive(_hand(l)), 2.0, initial={"th": 0.4}, rtol=1e-11, atol=1e-11)
        assert np.allclose(ours["th"], hand["th"], atol=1e-9)


def test_python_api_any_order_and_the_returned_expression():
    m = lg.Model("api", coordinates=["x"], parameters={"c": "a*b", "b": "2*a", "a": 3.0})
    assert m.derived_parameters == {"b": 2 * S("a"), "c": 2 * S("a") ** 2}
    d = m.parameter("d", "c + 1")
    assert d == 2 * S("a") ** 2 + 1
    assert m.parameter("e", S("a") ** 2) == S("a") ** 2  # a SymPy expression of the symbols
    assert m.derived_parameters["e"] == S("a") ** 2
    m.add_energy(T="x_dot**2/2", V="d*x**2/2 + e")
    assert lg.derive(m).parameters == {S("a"): 3.0}


@pytest.mark.parametrize("table, message", [
    ('lA = "lB + 1"\nlB = "2*lA"\n', "the parameters lA -> lB -> lA are defined by each other in a cycle"),
    ('lA = "lB"\nlB = "lC"\nlC = "lA"\n', "lA -> lB -> lC -> lA"),
    ('lA = "lA + 1"\n', "the parameter 'lA' = 'lA + 1' refers to itself"),
    ('lA = "__import__(\'os\')"\n', "parameters.lA"),
    ('lA = "l**100000"\n', "exponent too large"),
    ('lA = "10**10**10"\n', "parameters.lA"),
    ('lA = "th + l"\n', "a derived parameter is an expression of other parameters, but 'lA' uses th"),
    ('lA = "sqrt(l - 5)"\n', "is not a finite real number"),
    ('lA = "nan"\n', "the value must be a finite real number, got 'nan'"),
    ('lA = "2*m"\n', "uses m, which is not a parameter: a derived parameter is an expression of the other "
                     "parameters: declare m under [parameters] with a value, or give 'lA' a number"),
    ('lA = "1/0"\n', "parameters.lA"),
    ('lA = "1.5"\n', "write lA = 1.5 (a number, without quotes)"),
])
def test_hostile_derived_parameters_are_refused(table, message):
    text = 'coordinates = ["th"]\n[parameters]\nl = 1.0\n' + table + '[energy]\nT = "th_dot**2/2"\n'
    with pytest.raises(ModelError, match=re.escape(message)):
        loads_model(text)


def test_api_errors():
    with pytest.raises(ModelError, match=re.escape("lA -> lB -> lA")):
        lg.Model("c", coordinates=["x"], parameters={"lA": "lB", "lB": "lA"})
    m = lg.Model("m", coordinates=["x"], parameters={"l": 1.0})
    with pytest.raises(ModelError, match=re.escape("refers to itself")):
        m.parameter("q", "q*2")
    with pytest.raises(ModelError, match=re.escape("uses x (not a parameter")):
        m.parameter("q", "x*l")
    with pytest.raises(ModelError, match=re.escape("'l' is declared twice")):
        m.parameter("l", "2")


def test_the_cli_json_and_options_may_use_derived_parameters(tmp_path, capsys):
    path = tmp_path / "derived.toml"
    path.write_text(TOML + "[operating_point]\nth = \"lA/10\"\n")
    assert main(["derive", str(path), "--json"]) == 0
    d = json.loads(capsys.readouterr().out)
    assert d["derived_parameters"] == {"lA": "l/2 + r/2"} and "lA" not in d["parameters"]
    assert main(["linearize", str(path), "--at", "th=lA/5", "--param", "l=2", "--json"]) == 0
    d = json.loads(capsys.readouterr().out)
    assert d["operating_point"]["th"] == pytest.approx((2 + 0.5) / 2 / 5)
    assert "lA" not in d["parameters"]


def test_the_notebook_table_lists_derived_parameters():
    html = loads_model(TOML)._repr_html_()
    assert "derived parameters" in html and "lA = $\\frac{l}{2} + \\frac{r}{2}$" in html


def test_a_derived_parameter_given_a_value_is_refused_with_what_it_is():
    eqs = lg.derive(loads_model(TOML))
    message = ("'lA' is a derived parameter, lA = l/2 + r/2: it follows the parameters it uses (l, r); "
               "give those instead")
    with pytest.raises(ModelError, match=re.escape(message)):
        lg.simulate(eqs, 1.0, params={"lA": 2.0})
    with pytest.raises(ModelError, match=re.escape(message)):
        lg.linearize(eqs, {"th": 0.0}, params={"lA": 2.0})


@pytest.mark.parametrize("table, message", [
    ('lA = "l**400*1e300"\n', "the parameter 'lA' = "),
    ('lA = "lB + 1"\nlB = "2*lA"\n', "the parameters lA -> lB -> lA are defined by each other in a cycle"),
    ('lA = "l**100000"\n', "exponent too large"),
])
def test_a_failed_derived_parameter_is_one_problem_not_one_per_use(table, message):
    """The energy that uses a derived parameter whose expression failed is not reported as using an
    unknown name: the one problem is at the parameter's own key."""
    text = ('coordinates = ["th"]\n[parameters]\nl = 10.0\n' + table
            + '[energy]\nT = "th_dot**2/2"\nV = "lA*th**2"\n')
    with pytest.raises(ModelError) as exc:
        loads_model(text)
    assert message in str(exc.value)
    assert "unknown name" not in str(exc.value) and "energy.V" not in str(exc.value), str(exc.value)
