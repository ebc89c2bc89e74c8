"""The [optimal_control] table and optimal_motion's arguments: one validator, clear messages, hostile input."""

from __future__ import annotations

import math

import pytest

import lagrangian as lg
from lagrangian.errors import ModelError, ModelFileError
from lagrangian.io import loads_model

HEAD = '''
name = "di"
coordinates = ["x"]
inputs = ["u"]
[parameters]
k = 1.0
[energy]
T = "x_dot**2/2"
[forces]
x = "u"
'''
GOOD = '''
[optimal_control]
duration = [0.5, 10.0]
minimum_time = true
initial = { x = 4.0, x_dot = 0.0 }
final = { x = 0.0, x_dot = 0.0 }
inputs = { u = [-1.0, 1.0] }
bounds = { x = [-1.0, 5.0] }
path = { speed = { expression = "x_dot", min = -3.0 } }
intervals = 12
tolerance = 1e-5
max_refinements = 2
'''


def read(table: str):
    return loads_model(HEAD + "[optimal_control]\n" + table, source="di.toml")


def problems(table: str) -> str:
    with pytest.raises(ModelFileError) as info:
        read(table)
    return str(info.value)


def test_good_table_read_and_solved():
    pytest.importorskip("casadi", reason="optimal motions need CasADi (the 'optimal' extra)")
    model = loads_model(HEAD + GOOD, source="di.toml")
    oc = model.optimal_control
    assert oc["duration"] == (0.5, 10.0) and oc["minimum_time"] is True
    assert oc["initial"] == {"x": 4.0, "x_dot": 0.0} and oc["inputs"] == {"u": (-1.0, 1.0)}
    assert oc["path"]["speed"][1:] == (-3.0, math.inf)
    motion = lg.optimal_motion(lg.derive(model))
    assert motion.duration == pytest.approx(4.0, rel=1e-3)
    # a keyword replaces the table's entry of that name
    faster = lg.optimal_motion(lg.derive(model), inputs={"u": (-4.0, 4.0)})
    assert faster.duration == pytest.approx(1.5 + 1.75 / 3, rel=1e-3)  # the speed limit 3 holds it


@pytest.mark.parametrize("table, needles", [
    ('duraton = 2.0\n', ["unknown key 'duraton' in [optimal_control] (did you mean 'duration'?)",
                         "needs the motion's duration"]),
    ("duration = 2.0\nobjectve = 'u**2'\n", ["did you mean 'objective'?"]),
    ('duration = "2"\n', ["optimal_control.duration", "expected a number, got the string '2'"]),
    ("duration = -1.0\n", ["expected a positive duration"]),
    ("duration = nan\n", ["expected a finite number, got nan"]),
    ("duration = [2.0, 1.0]\n", ["the lower bound 2 is above the upper bound 1"]),
    ("duration = [0.0, inf]\n", ["a free duration's bounds must be positive and finite"]),
    ("duration = 2.0\nminimum_time = true\n", ["minimum_time = true needs a free duration"]),
    ("duration = 2.0\nminimum_time = 'yes'\n", ["expected true or false"]),
    ("duration = 2.0\nobjective = \"__import__('os').system('ls')\"\n", ["optimal_control.objective"]),
    ('duration = 2.0\nobjective = "u**2 + zz"\n', ["optimal_control.objective", "zz"]),
    ('duration = 2.0\nobjective = "x_ddot**2"\n', ["optimal_control.objective", "x_ddot"]),
    ('duration = 2.0\nterminal_cost = "u*x"\n', ["the terminal cost uses the input(s) u"]),
    ("duration = 2.0\nfinal = { y = 1.0 }\n", ["'y' is not a coordinate or a velocity", "x, x_dot"]),
    ("duration = 2.0\nfinal = { x_dto = 1.0 }\n", ["did you mean 'x_dot'?"]),
    ("duration = 2.0\ninitial = { x = nan }\n", ["optimal_control.initial.x", "finite number"]),
    ("duration = 2.0\ninitial = [1.0]\n", ["optimal_control.initial", "expected a table"]),
    ("duration = 2.0\nbounds = { x = [1.0, -1.0] }\n", ["the lower bound 1 is above the upper bound -1"]),
    ("duration = 2.0\nbounds = { x = [nan, 1.0] }\n", ["optimal_control.bounds.x[0]", "not NaN"]),
    ("duration = 2.0\nbounds = { x = 1.0 }\n", ["expected a state's bounds as [lower, upper]"]),
    ("duration = 2.0\nbounds = { x = [-1.0, 1.0] }\nfinal = { x = 3.0 }\n",
     ["the final value x = 3 is outside its bounds [-1, 1]"]),
    ("duration = 2.0\ninputs = { F = [-1.0, 1.0] }\n", ["'F' is not an input", "the inputs are u"]),
    ("duration = 2.0\ninputs = { u = 'big' }\n", ["optimal_control.inputs.u", "expected a number"]),
    ("duration = 2.0\npath = { track = { expression = 'x' } }\n", ["needs min, max or both"]),
    ("duration = 2.0\npath = { track = { min = 1.0 } }\n", ["needs its expression"]),
    ("duration = 2.0\npath = { track = { expression = 'x', min = 2.0, max = 1.0 } }\n", ["min = 2 is above max = 1"]),
    ("duration = 2.0\npath = { track = { expression = 'x', mni = 2.0 } }\n", ["did you mean 'min'?"]),
    ("duration = 2.0\npath = { t = \"x\\nimport os\" }\n", ["optimal_control.path.t", "expected a table"]),
    ("duration = 2.0\nfinal = { \"__import__('os')\" = 1.0 }\n", ["'__import__('os')' is not a coordinate"]),
    ("duration = 2.0\ninputs = { \"u\\nimport os\" = 1.0 }\n", ["is not an input", "the inputs are u"]),
    ("duration = 2.0\nobjective = \"" + "u+" * 5000 + "u\"\n", ["optimal_control.objective"]),
    ("duration = 1e400\n", ["finite number"]),
    ("duration = 2.0\nintervals = 1e9\n", ["expected a whole number"]),
    ("duration = 2.0\nintervals = 100000000\n", ["expected intervals between 2 and 5000"]),
    ("duration = 2.0\ntolerance = -1.0\n", ["expected a positive tolerance"]),
    ("duration = 2.0\nmax_refinements = true\n", ["expected a whole number"]),
])
def test_hostile_tables(table, needles):
    text = problems(table)
    assert "di.toml" in text
    for needle in needles:
        assert needle in text, (needle, text)


def test_every_problem_at_once_with_lines():
    text = problems('duration = -1\nfinal = { y = 1 }\ninputs = { F = 1 }\n')
    assert text.count("optimal_control.") >= 3
    assert ":13" in text or ":14" in text  # the lines of the table's keys


def test_not_a_table():
    with pytest.raises(ModelFileError, match="optimal_control"):
        loads_model(HEAD.replace('name = "di"', 'name = "di"\noptimal_control = 3'), source="di.toml")


def test_keyword_arguments_share_the_rules():
    eqs = lg.derive(lg.Model(coordinates=["x"], T="x_dot**2/2", Q={"x": "u"}, inputs=["u"]))
    with pytest.raises(ModelError, match=r"'y' is not a coordinate or a velocity"):
        lg.optimal_motion(eqs, duration=1.0, final={"y": 1.0})
    with pytest.raises(ModelError, match=r"lower bound 1 is above the upper bound -1"):
        lg.optimal_motion(eqs, duration=1.0, inputs={"u": (1.0, -1.0)})
    with pytest.raises(ModelError, match="malformed expression"):
        lg.optimal_motion(eqs, duration=1.0, objective="__import__('os')")
    with pytest.raises(ModelError, match="not known here"):
        lg.optimal_motion(eqs, duration=1.0, objective=lg.Model("m").coordinate("zz") ** 2)
    with pytest.raises(ModelError, match="no optimal control problem for model"):
        lg.optimal_motion(eqs, objective="u**2")
    with pytest.raises(ModelError, match="minimum_time"):
        lg.optimal_motion(eqs, duration=1.0, minimum_time=True)
    with pytest.raises(ModelError, match="unknown input law 'spline'"):
        lg.optimal_motion(eqs, duration=1.0, law="spline")
    with pytest.raises(ModelError, match="'kk' is not a parameter"):
        lg.optimal_motion(eqs, duration=1.0, objective="u**2", params={"kk": 1.0})
    with pytest.raises(TypeError):
        lg.optimal_motion(eqs, duration=1.0, objectiv="u**2")


def test_constrained_ends_fix_only_the_degrees_of_freedom():
    eqs = lg.derive(lg.load("four-bar"))
    with pytest.raises(ModelError, match=r"at most 1 coordinate\(s\) .* give only the independent ones"):
        lg.optimal_motion(eqs, duration=1.0, objective="tau**2", initial={"th1": 1.2, "th2": 0.4})


def test_infeasible_problem_is_a_clear_error():
    pytest.importorskip("casadi", reason="optimal motions need CasADi (the 'optimal' extra)")
    eqs = lg.derive(lg.Model(coordinates=["x"], T="x_dot**2/2", Q={"x": "u"}, inputs=["u"]))
    # from x = 4 to 0 at rest in 1 s with |u| <= 1 needs 4 s
    with pytest.raises(lg.OptimalControlError, match=r"no optimal motion found: IPOPT stopped with "
                                                     r"'Infeasible_Problem_Detected'.*lengthen the duration") as info:
        lg.optimal_motion(eqs, duration=1.0, objective="u**2", initial={"x": 4.0, "x_dot": 0.0},
                          final={"x": 0.0, "x_dot": 0.0}, inputs={"u": (-1.0, 1.0)}, intervals=10)
    assert info.value.status == "Infeasible_Problem_Detected"
    assert isinstance(info.value, lg.LagrangianError)
