"""The Python model-building API: every ModelError a user can hit, the one-pass model check,
the contribution of each element against hand results, Equations printing and singularities.

Errors are matched by their text (``pytest.raises(lg.ModelError, match=...)``); results are
compared with hand-derived expressions through ``sympy.simplify(difference) == 0``.
"""

from __future__ import annotations

import dataclasses
import json
import re

import pytest
import sympy as sp

import lagrangian as lg

S = sp.Symbol
sin, cos, sqrt = sp.sin, sp.cos, sp.sqrt


def esc(text: str) -> str:
    """A regex matching `text` literally."""
    return re.escape(text)


def assert_zero(expr, msg=""):
    diff = sp.simplify(sp.expand_trig(sp.sympify(expr)))
    assert diff == 0, f"{msg}: difference {diff}"


def assert_same(actual, expected, msg=""):
    a, e = sp.sympify(actual), sp.sympify(expected)
    if isinstance(a, sp.MatrixBase) or isinstance(e, sp.MatrixBase):
        a, e = sp.Matrix(a), sp.Matrix(e)
        assert a.shape == e.shape, f"{msg}: shapes {a.shape} != {e.shape}"
        for x, y in zip(a, e):
            assert_zero(x - y, msg)
    else:
        assert_zero(a - e, f"{msg}: {a} != {e}")


# ----------------------------------------------------------------------------- systems
def pendulum(*, with_values=True, strings=False):
    m = lg.Model("pendulum")
    th = m.coordinate("theta")
    vals = (1.0, 0.5, 9.81) if with_values else (None, None, None)
    mass, l, g = (m.parameter(n, v) for n, v in zip(("m", "l", "g"), vals))
    if strings:
        m.add_particle("m", ("l*sin(theta)", "-l*cos(theta)"), name="bob")
        m.add_gravity("g")
    else:
        m.add_particle(mass, (l * lg.sin(th), -l * lg.cos(th)), name="bob")
        m.add_gravity(g)
    return m


def double_pendulum():
    m = lg.Model("double-pendulum")
    q1, q2 = m.coordinate("q1", "q2")
    m1, m2, l1, l2, g = (m.parameter(n, 1.0) for n in ("m1", "m2", "l1", "l2", "g"))
    m.add_particle(m1, (l1 * lg.sin(q1), -l1 * lg.cos(q1)), name="bob1")
    m.add_particle(m2, (l1 * lg.sin(q1) + l2 * lg.sin(q2), -l1 * lg.cos(q1) - l2 * lg.cos(q2)),
                   name="bob2")
    m.add_gravity(g)
    return m


def mck():
    m = lg.Model("mck")
    x = m.coordinate("x")
    M, c, k = (m.parameter(n, v) for n, v in (("M", 1.0), ("c", 0.2), ("k", 4.0)))
    u = m.input("u")
    m.add_particle(M, (x, 0), name="mass")
    m.add_spring(k, length=x, name="spring")
    m.add_damper(c, length=x, name="damper")
    m.add_generalized_force(x, u)
    return m


# ============================================================ 1. ModelError from methods
class TestNames:
    @pytest.mark.parametrize("method", ["coordinate", "parameter", "input"])
    @pytest.mark.parametrize("name", ["1x", "a-b", "x y", "", "théta"])
    def test_invalid_name(self, method, name):
        m = lg.Model()
        with pytest.raises(lg.ModelError, match=esc(f"'{name}' is not a valid {method} name: use letters, "
                                                   "digits and underscores, starting with a letter")):
            getattr(m, method)(name)
        assert m.q == () and m.parameters == {} and m.inputs == ()

    @pytest.mark.parametrize("method", ["coordinate", "parameter", "input"])
    @pytest.mark.parametrize("name", ["t", "pi", "sin", "atan2", "sqrt", "abs", "sign"])
    def test_reserved_name(self, method, name):
        m = lg.Model()
        with pytest.raises(lg.ModelError, match=esc(f"'{name}' is reserved (time, pi or a function name) "
                                                   "and cannot name a")):
            getattr(m, method)(name)

    @pytest.mark.parametrize("method", ["coordinate", "parameter", "input"])
    @pytest.mark.parametrize("name", ["lambda", "if", "class", "None", "and"])
    def test_keyword_name(self, method, name):
        m = lg.Model()
        with pytest.raises(lg.ModelError, match=esc(f"'{name}' is a Python keyword and cannot name "
                                                   f"{'an' if method == 'input' else 'a'} {method}: "
                                                   "choose another name")):
            getattr(m, method)(name)

    @pytest.mark.parametrize("method", ["coordinate", "parameter", "input"])
    @pytest.mark.parametrize("name", ["x_dot", "theta_ddot", "a_dot"])
    def test_dot_suffix(self, method, name):
        m = lg.Model()
        with pytest.raises(lg.ModelError, match=esc(f"'{name}' ends in _dot or _ddot, which is kept for "
                                                   f"velocities and accelerations: choose another {method} name")):
            getattr(m, method)(name)

    @pytest.mark.parametrize("method", ["coordinate", "parameter", "input"])
    def test_non_string_name(self, method):
        article = "an" if method == "input" else "a"
        with pytest.raises(lg.ModelError, match=esc(f"{article} {method} name must be a string, got 3")):
            getattr(lg.Model(), method)(3)

    @pytest.mark.parametrize("first", ["coordinate", "parameter", "input"])
    @pytest.mark.parametrize("second", ["coordinate", "parameter", "input"])
    def test_duplicate_name_across_kinds(self, first, second):
        m = lg.Model()
        getattr(m, first)("x")
        with pytest.raises(lg.ModelError, match=esc("'x' is declared twice: each coordinate, parameter and "
                                                   "input needs its own name")):
            getattr(m, second)("x")

    def test_duplicate_in_constructor(self):
        with pytest.raises(lg.ModelError, match="'x' is declared twice"):
            lg.Model("c", coordinates=["x", "x"])

    def test_coordinate_without_name(self):
        with pytest.raises(lg.ModelError, match=esc("coordinate(): give at least one name, "
                                                   "e.g. m.coordinate('x')")):
            lg.Model().coordinate()

    def test_coordinate_returns_symbols(self):
        m = lg.Model()
        x = m.coordinate("x")
        a, b = m.coordinate("a", "b")
        assert (x, a, b) == (S("x"), S("a"), S("b"))
        assert m.q == (S("x"), S("a"), S("b"))
        assert m.q_dot == (S("x_dot"), S("a_dot"), S("b_dot"))
        assert m.q_ddot == (S("x_ddot"), S("a_ddot"), S("b_ddot"))

    @pytest.mark.parametrize("value", ["3", [1.0], 1 + 2j, None.__class__])
    def test_non_numeric_parameter_value(self, value):
        m = lg.Model()
        with pytest.raises(lg.ModelError, match=esc(f"parameter 'k': the value must be a finite real number, "
                                                   f"got {value!r}")):
            m.parameter("k", value)
        assert m.parameters == {}

    @pytest.mark.parametrize("value", [True, False])
    def test_bool_parameter_value(self, value):
        with pytest.raises(lg.ModelError, match=esc(f"parameter 'k': the value must be a finite real number, "
                                                   f"got {value!r}")):
            lg.Model().parameter("k", value)

    def test_parameter_values_become_floats(self):
        m = lg.Model()
        a, b, c = m.parameter("a", 2), m.parameter("b", sp.Integer(3)), m.parameter("c")
        assert m.parameters == {a: 2.0, b: 3.0, c: None}
        assert all(isinstance(v, float) for v in (m.parameters[a], m.parameters[b]))

    def test_symbol_lookup(self):
        m = lg.Model("p")
        th = m.coordinate("theta")
        k = m.parameter("k", 1.0)
        u = m.input("u")
        assert m.symbol("theta") == th and m.symbol("k") == k and m.symbol("u") == u
        assert m.symbol("theta_dot") == lg.dot(th) and m.symbol("t") == lg.t

    def test_symbol_unknown_with_did_you_mean(self):
        m = lg.Model("p")
        m.coordinate("theta")
        with pytest.raises(lg.ModelError, match=esc("model 'p' has no symbol 'thet' (did you mean 'theta'?)")):
            m.symbol("thet")

    def test_symbol_unknown_without_suggestion(self):
        m = lg.Model("p")
        m.coordinate("theta")
        with pytest.raises(lg.ModelError, match=esc("model 'p' has no symbol 'zzz'") + r"\Z"):
            m.symbol("zzz")


class TestExpr:
    def test_numbers_and_sympy(self):
        m = lg.Model()
        x = m.coordinate("x")
        assert m.expr(3) == sp.Integer(3) and isinstance(m.expr(3), sp.Integer)
        assert m.expr(0.5) == sp.Float(0.5)
        assert m.expr(x ** 2) == x ** 2
        assert m.expr("x**2 + x_dot") == x ** 2 + lg.dot(x)
        assert m.expr("x^2") == x ** 2

    @pytest.mark.parametrize("value", [True, False])
    def test_bool(self, value):
        with pytest.raises(lg.ModelError, match=esc(f"expression: expected an expression or a number, "
                                                   f"got {value!r}")):
            lg.Model().expr(value)

    def test_bool_with_where(self):
        with pytest.raises(lg.ModelError, match=esc("energy.T: expected an expression or a number, got True")):
            lg.Model().add_energy(T=True)

    @pytest.mark.parametrize("value, tname", [([1], "list"), ((1, 2), "tuple"), ({"a": 1}, "dict"),
                                              (None, "NoneType")])
    def test_wrong_type(self, value, tname):
        with pytest.raises(lg.ModelError, match=esc(f"expression: expected an expression, a number or a "
                                                   f"string, got {value!r} ({tname})")):
            lg.Model().expr(value)

    def test_malformed_string_has_position(self):
        m = lg.Model()
        m.coordinate("x")
        with pytest.raises(lg.ModelError) as info:
            m.expr("1 + * 2")
        text = str(info.value)
        assert text.startswith("[expression]: missing operand between '+' and '*'")
        assert "at position 5:\n    1 + * 2\n        ^" in text
        assert len(info.value.problems) == 1 and info.value.problems[0].key == "expression"

    def test_unclosed_parenthesis(self):
        m = lg.Model()
        m.coordinate("x")
        with pytest.raises(lg.ModelError, match=esc("[expression]: missing ')': the '(' here is never closed")
                           + ".*" + esc("at position 4:\n    sin(x\n       ^")):
            m.expr("sin(x")

    def test_unknown_name_in_string(self):
        m = lg.Model()
        m.coordinate("theta")
        with pytest.raises(lg.ModelError, match=esc("[particle 'bob'.mass]: unknown name 'thetta' "
                                                   "(did you mean 'theta'?) at position 1:")):
            m.add_particle("thetta", (0, 0), name="bob")

    def test_where_key_in_string_error(self):
        m = lg.Model()
        m.coordinate("x")
        with pytest.raises(lg.ModelError, match=esc("[energy.V]: missing operand after '+'")):
            m.add_energy(V="1 +")

    @pytest.mark.parametrize("text, fragment", [
        ("__import__('os')", "strings are not allowed in an expression"),
        ("x.__class__", "attribute access '.__class__' is not allowed"),
        ("lambda: 1", "'lambda' is a Python keyword and is not allowed"),
        ("[x]", "square brackets (indexing, lists) are not allowed"),
    ])
    def test_strings_are_never_executed(self, text, fragment):
        m = lg.Model()
        m.coordinate("x")
        with pytest.raises(lg.ModelError, match=esc(fragment)):
            m.expr(text)


class TestPositions:
    @pytest.mark.parametrize("position", [(1,), (1, 2, 3, 4), [], "nowhere", 5])
    def test_position_component_count(self, position):
        m = lg.Model()
        m.coordinate("x")
        with pytest.raises(lg.ModelError, match=esc(f"particle 'p'.position: expected a position with 2 or 3 "
                                                   f"components (x, y) or (x, y, z), or the name of a point, "
                                                   f"got {position!r}")):
            m.add_particle(1, position, name="p")
        assert m.elements == ()

    def test_matrix_position_accepted(self):
        m = lg.Model()
        x = m.coordinate("x")
        p = m.add_particle(1, sp.Matrix([x, 2 * x]), name="p")
        assert p.position == (x, 2 * x)

    def test_point_name_as_position(self):
        m = lg.Model()
        x = m.coordinate("x")
        m.add_point("A", (x, 1))
        p = m.add_particle(2, "A", name="p")
        assert p.position == (x, 1)

    @pytest.mark.parametrize("add", [
        lambda m: m.add_point("A", (1, 0)),
        lambda m: m.add_particle(1, (1, 0), name="A"),
        lambda m: m.add_rigid_body(1, 1, (1, 0), 0, name="A"),
        lambda m: m.add_spring(1, length=m.symbol("x"), name="A"),
        lambda m: m.add_damper(1, length=m.symbol("x"), name="A"),
        lambda m: m.add_force((1, 0), (0, 0), name="A"),
        lambda m: m.add_torque(1, angle=m.symbol("x"), name="A"),
    ])
    def test_duplicate_element_name(self, add):
        m = lg.Model()
        m.coordinate("x")
        m.add_point("A", (0, 0))
        with pytest.raises(lg.ModelError, match=esc("two elements are named 'A': give each element its own name")):
            add(m)
        assert len(m.elements) == 1

    @pytest.mark.parametrize("name", ["", 3])
    def test_bad_element_name(self, name):
        with pytest.raises(lg.ModelError, match=esc(f"an element name must be a non-empty string, got {name!r}")):
            lg.Model().add_particle(1, (0, 0), name=name)

    def test_automatic_element_names(self):
        m = lg.Model()
        x = m.coordinate("x")
        a = m.add_particle(1, (x, 0))
        b = m.add_particle(1, (2 * x, 0))
        s = m.add_spring(1, length=x)
        assert (a.name, b.name, s.name) == ("particle1", "particle2", "spring1")


class TestSpringsAndDampers:
    @pytest.mark.parametrize("kind", ["spring", "damper"])
    def test_neither_between_nor_length(self, kind):
        m = lg.Model()
        m.coordinate("x")
        with pytest.raises(lg.ModelError, match=esc(f"{kind} '{kind}1': give either `between` (two points) or "
                                                   "`length` (an expression), exactly one of them")):
            getattr(m, f"add_{kind}")(1)

    @pytest.mark.parametrize("kind", ["spring", "damper"])
    def test_both_between_and_length(self, kind):
        m = lg.Model()
        x = m.coordinate("x")
        with pytest.raises(lg.ModelError, match=esc(f"{kind} 'e': give either `between` (two points) or "
                                                   "`length` (an expression), exactly one of them")):
            getattr(m, f"add_{kind}")(1, between=((0, 0), (x, 0)), length=x, name="e")

    @pytest.mark.parametrize("kind", ["spring", "damper"])
    def test_between_different_dimensions(self, kind):
        m = lg.Model()
        x = m.coordinate("x")
        m.add_point("A", (0, 0))
        with pytest.raises(lg.ModelError, match=esc(f"{kind} 'e'.between: the two points have 2 and 3 "
                                                   "components; use points of the same dimension")):
            getattr(m, f"add_{kind}")(1, between=("A", (x, 0, 1)), name="e")

    @pytest.mark.parametrize("between", [("A",), ("A", "A", "A"), "A"])
    def test_between_not_two_points(self, between):
        m = lg.Model()
        m.coordinate("x")
        m.add_point("A", (0, 0))
        with pytest.raises(lg.ModelError, match=esc(f"spring 'e'.between: expected two points (names or "
                                                   f"positions), got {between!r}")):
            m.add_spring(1, between=between, name="e")

    def test_between_unknown_point_name(self):
        m = lg.Model()
        x = m.coordinate("x")
        m.add_point("Anchor", (0, 0))
        with pytest.raises(lg.ModelError, match=esc("spring 'e'.between[0]: expected a position with 2 or 3 "
                                                   "components (x, y) or (x, y, z), or the name of a point, "
                                                   "got 'Anchr'")):
            m.add_spring(1, between=("Anchr", (x, 0)), name="e")

    @pytest.mark.parametrize("between", [("A", "A"), ((1, 2), (1, 2)), ("A", (0, 0))])
    def test_damper_same_point_twice(self, between):
        m = lg.Model()
        m.coordinate("x")
        m.add_point("A", (0, 0))
        with pytest.raises(lg.ModelError, match=esc("damper 'd'.between: both ends are the same point, so the "
                                                   "damper has no length and no direction; attach it between "
                                                   "two different points")):
            m.add_damper(1, between=between, name="d")


class TestGravityForcesTorques:
    def test_gravity_twice(self):
        m = pendulum()
        with pytest.raises(lg.ModelError, match=esc("gravity is added twice: a model has at most one uniform "
                                                   "gravity field")):
            m.add_gravity(1.0)

    @pytest.mark.parametrize("direction", [
        (0, 0), (0, 0, 0), (sp.Integer(0), sp.Integer(0)),
        (0.0, 0.0),
    ])
    def test_gravity_zero_direction(self, direction):
        m = lg.Model()
        m.coordinate("x")
        with pytest.raises(lg.ModelError, match=esc("gravity.direction is the zero vector: give the direction "
                                                   "gravity pulls in, e.g. (0, -1) in a plane or (0, 0, -1) "
                                                   "in space")):
            m.add_gravity(9.81, direction)
        assert m.elements == ()

    def test_gravity_direction_bad_length(self):
        with pytest.raises(lg.ModelError, match=esc("gravity.direction: expected a position with 2 or 3 "
                                                   "components")):
            lg.Model().add_gravity(9.81, (0, 0, 0, -1))

    @pytest.mark.parametrize("force, at, nf, na", [((1, 0, 0), (0, 0), 3, 2), ((1, 0), (0, 0, 0), 2, 3)])
    def test_force_dimension(self, force, at, nf, na):
        m = lg.Model()
        m.coordinate("x")
        with pytest.raises(lg.ModelError, match=esc(f"force 'f': the force has {nf} components but the point "
                                                   f"has {na}; give them the same dimension")):
            m.add_force(force, at, name="f")

    def test_force_dimension_with_point_name(self):
        m = lg.Model()
        x = m.coordinate("x")
        m.add_particle(1, (x, 0, 0), name="p")
        with pytest.raises(lg.ModelError, match=esc("force 'force1': the force has 2 components but the "
                                                   "point has 3")):
            m.add_force((1, 0), "p")

    @pytest.mark.parametrize("kwargs", [{}, {"angle": S("x"), "body": "b"}])
    def test_torque_angle_xor_body(self, kwargs):
        m = lg.Model()
        x = m.coordinate("x")
        m.add_rigid_body(1, 1, (0, 0), x, name="b")
        with pytest.raises(lg.ModelError, match=esc("torque 'tq': give either `angle` (an expression) or "
                                                   "`body` (a rigid body's name), exactly one of them")):
            m.add_torque(1, name="tq", **kwargs)

    def test_torque_unknown_body_did_you_mean(self):
        m = lg.Model()
        x = m.coordinate("x")
        m.add_rigid_body(1, 1, (0, 0), x, name="wheel")
        with pytest.raises(lg.ModelError, match=esc("torque 'torque1'.body: no rigid body is named 'whel' "
                                                   "(did you mean 'wheel'?)")):
            m.add_torque(1, body="whel")

    def test_torque_on_particle_is_not_a_body(self):
        m = lg.Model()
        x = m.coordinate("x")
        m.add_particle(1, (x, 0), name="bob")
        with pytest.raises(lg.ModelError, match=esc("torque 'torque1'.body: no rigid body is named 'bob'") + r"\Z"):
            m.add_torque(1, body="bob")

    def test_generalized_force_on_non_coordinate(self):
        m = lg.Model()
        m.coordinate("theta")
        m.parameter("k", 1.0)
        with pytest.raises(lg.ModelError, match=esc("forces.thet: 'thet' is not a coordinate (did you mean "
                                                   "'theta'?); generalized forces are given by coordinate name")):
            m.add_generalized_force("thet", 1)
        with pytest.raises(lg.ModelError, match=esc("forces.k: 'k' is not a coordinate; generalized forces")):
            m.add_generalized_force(S("k"), 1)
        assert m.Q == {}

    def test_generalized_forces_accumulate(self):
        m = lg.Model()
        x = m.coordinate("x")
        u = m.input("u")
        m.add_generalized_force(x, u)
        m.add_generalized_force("x", "-x_dot")
        assert m.Q == {x: u - lg.dot(x)}


# ===================================================================== 2. check/validate
VELOCITY_FIX = ("move velocity-dependent terms to T (kinetic co-energy), D (dissipation) or the forces")


def bad_model():
    m = lg.Model("bad")
    x = m.coordinate("x")
    u = m.input("u")
    mass = m.parameter("mass", -2.0)
    k = m.parameter("k", -3.0)
    inertia = m.parameter("J", 1.0)
    xd, xdd = lg.dot(x), lg.ddot(x)
    m.add_energy(T=S("mas") * xd ** 2 / 2 + u * xd, V=xdd * x + xd ** 2 * x)
    m.add_particle(1, (x + xd, u), name="p")
    m.add_spring(xd + 1, length=x, name="s")
    m.add_spring(k, length=x, name="neg")
    m.add_rigid_body(mass, -inertia, (x, 0), x, name="b")
    return m


EXPECTED_BAD = [
    ("energy.T", "unknown symbol 'mas': it is not a coordinate, velocity, parameter, input or t. "
                 "Did you mean 'mass'? Declare it (m.parameter('mas', value), or under [parameters] in a model file)."),
    ("energy.T", "input u appears in T, whose time derivative the equations would need: inputs may appear in "
                 "V, D and forces; write a prescribed motion as a function of t instead"),
    ("energy.V", "acceleration 'x_ddot' may not appear in a model: the equations produce accelerations, write "
                 "energies and forces in terms of coordinates and velocities"),
    ("energy.V", "velocity x_dot appears here, but the potential energy V depends only on coordinates and time: "
                 + VELOCITY_FIX),
    ("particle 'p'.position[0]", "velocity x_dot appears here, but a position depends only on coordinates and "
                                 "time: " + VELOCITY_FIX),
    ("particle 'p'.position[1]", "input u appears in a position, whose velocity the equations would need: write "
                                 "a prescribed motion as a function of t instead"),
    ("spring 's'.stiffness", "velocity x_dot appears here, but a stiffness depends only on coordinates and "
                             "time: " + VELOCITY_FIX),
    ("spring 'neg'.stiffness", "stiffness is negative (-3): it must be zero or positive; check the sign or the "
                               "parameter values"),
    ("rigid body 'b'.mass", "mass is negative (-2): it must be zero or positive; check the sign or the "
                            "parameter values"),
    ("rigid body 'b'.inertia", "inertia is negative (-1): it must be zero or positive; check the sign or the "
                               "parameter values"),
]


class TestCheck:
    def test_every_problem_at_once(self):
        problems = bad_model().check()
        assert [(p.key, p.message) for p in problems] == EXPECTED_BAD

    def test_derive_raises_with_all_problems(self):
        with pytest.raises(lg.ModelError) as info:
            lg.derive(bad_model())
        err = info.value
        assert len(err.problems) == len(EXPECTED_BAD) == 10
        text = str(err)
        assert text.startswith("10 problems:\n")
        for key, message in EXPECTED_BAD:
            assert f"  - [{key}]: {message}" in text
        assert isinstance(err, ValueError) and isinstance(err, lg.LagrangianError)

    def test_validate_raises_same(self):
        with pytest.raises(lg.ModelError, match=r"\A10 problems:\n  - \[energy\.T\]: unknown symbol 'mas'"):
            bad_model().validate()

    def test_model_error_hierarchy(self):
        assert issubclass(lg.ModelError, ValueError)
        assert issubclass(lg.ModelError, lg.LagrangianError)
        with pytest.raises(ValueError, match="declared twice"):
            lg.Model(coordinates=["x"]).parameter("x")

    def test_unknown_symbol_without_suggestion(self):
        m = lg.Model()
        x = m.coordinate("x")
        m.add_energy(T=S("qqqq") * lg.dot(x) ** 2)
        [p] = m.check()
        assert p.key == "energy.T"
        assert p.message == ("unknown symbol 'qqqq': it is not a coordinate, velocity, parameter, input or t. "
                             "Declare it (m.parameter('qqqq', value), or under [parameters] in a model file).")

    def test_unknown_symbol_in_element(self):
        m = lg.Model()
        x = m.coordinate("x")
        m.parameter("mass", 1.0)
        m.add_particle(S("mas"), (x, 0), name="p")
        [p] = m.check()
        assert p.key == "particle 'p'.mass" and "unknown symbol 'mas'" in p.message
        assert "Did you mean 'mass'?" in p.message

    def test_no_coordinates(self):
        m = lg.Model("empty")
        m.add_energy(T=S("zz") ** 2)
        problems = m.check()
        assert [(p.key, p.message) for p in problems] == [
            ("coordinates", "the model has no coordinates: declare at least one (m.coordinate('x'), or "
                            "coordinates = [\"x\"] in a model file)"),
            ("energy.T", "unknown symbol 'zz': it is not a coordinate, velocity, parameter, input or t. "
                         "Declare it (m.parameter('zz', value), or under [parameters] in a model file)."),
        ]
        with pytest.raises(lg.ModelError, match=r"\A2 problems:\n  - \[coordinates\]: the model has no "
                                                r"coordinates"):
            lg.derive(m)

    def test_only_no_coordinates(self):
        with pytest.raises(lg.ModelError, match=r"\A\[coordinates\]: the model has no coordinates: declare "
                                                r"at least one"):
            lg.Model("empty").validate()

    def test_velocity_in_torque_angle_and_damper_coefficient(self):
        m = lg.Model()
        x = m.coordinate("x")
        m.add_torque(1, angle=x * lg.dot(x), name="tq")
        m.add_damper(lg.dot(x), length=x, name="d")
        assert [(p.key, p.message.split(":")[0]) for p in m.check()] == [
            ("torque 'tq'.angle", "velocity x_dot appears here, but a position depends only on coordinates "
                                  "and time"),
            ("damper 'd'.coefficient", "velocity x_dot appears here, but a coefficient depends only on "
                                       "coordinates and time"),
        ]

    def test_negative_only_after_values(self):
        m = lg.Model()
        x = m.coordinate("x")
        c = m.parameter("c")            # no value: cannot tell
        m.add_damper(-c, length=x, name="d")
        m.add_particle(1, (x, 0))
        assert m.check() == []
        m2 = lg.Model()
        x = m2.coordinate("x")
        c = m2.parameter("c", 0.5)
        m2.add_damper(-c, length=x, name="d")
        [p] = m2.check()
        assert p.key == "damper 'd'.coefficient"
        assert p.message.startswith("coefficient is negative (-0.5): it must be zero or positive")

    def test_allowed_uses(self):
        """Velocities and inputs where they belong raise no problem."""
        m = mck()
        x = m.symbol("x")
        m.add_force((m.symbol("u") * lg.dot(x), 0), (x, 0), name="f")
        m.add_energy(V=m.symbol("u") * x, D=lg.dot(x) ** 2)
        assert m.check() == []
        m.validate()


# ==================================================================== 3. contributions
class TestContributions:
    def test_particle_3d_time_dependent(self):
        m = lg.Model()
        z = m.coordinate("z")
        M, r, w = (m.parameter(n) for n in ("M", "r", "w"))
        tt = lg.t
        m.add_particle(M, (r * lg.cos(w * tt), r * lg.sin(w * tt) * z, z ** 2), name="p")
        eqs = lg.derive(m)
        zd = lg.dot(z)
        vx = -r * w * sin(w * tt)
        vy = r * w * cos(w * tt) * z + r * sin(w * tt) * zd
        vz = 2 * z * zd
        assert_same(eqs.T, M * (vx ** 2 + vy ** 2 + vz ** 2) / 2)
        assert eqs.V == 0 and eqs.D == 0

    def test_rigid_body(self):
        m = lg.Model()
        x, th = m.coordinate("x", "theta")
        M, J, a = m.parameter("M"), m.parameter("J"), m.parameter("a")
        m.add_rigid_body(M, J, (x + a * lg.cos(th), a * lg.sin(th)), 2 * th, name="body")
        eqs = lg.derive(m)
        xd, thd = lg.dot(x), lg.dot(th)
        v2 = (xd - a * sin(th) * thd) ** 2 + (a * cos(th) * thd) ** 2
        assert_same(eqs.T, M * v2 / 2 + J * (2 * thd) ** 2 / 2)

    def test_spring_between_named_points_with_rest_length(self):
        m = lg.Model()
        x, y = m.coordinate("x", "y")
        k, L0, M = m.parameter("k"), m.parameter("L0"), m.parameter("M")
        m.add_point("A", (1, 2))
        m.add_particle(M, (x, y), name="B")
        s = m.add_spring(k, between=("A", "B"), rest_length=L0, name="s")
        assert s.between == ("A", "B")
        eqs = lg.derive(m)
        assert_same(eqs.V, k * (sqrt((x - 1) ** 2 + (y - 2) ** 2) - L0) ** 2 / 2)

    def test_spring_between_points_rest_length_zero(self):
        m = lg.Model()
        x, y = m.coordinate("x", "y")
        k = m.parameter("k")
        m.add_particle(1, (x, y), name="A")
        m.add_particle(1, (2 * x, -y), name="B")
        m.add_spring(k, between=("A", "B"))
        eqs = lg.derive(m)
        assert_same(eqs.V, k * (x ** 2 + (2 * y) ** 2) / 2)
        # no square root: the potential is polynomial
        assert not eqs.V.has(sp.sqrt(x ** 2 + 4 * y ** 2)) and eqs.V.is_polynomial(x, y)

    def test_torsional_spring(self):
        m = lg.Model()
        th = m.coordinate("theta")
        kt, th0 = m.parameter("kt"), m.parameter("theta0")
        m.add_spring(kt, length=th, rest_length=th0, name="torsion")
        eqs = lg.derive(m)
        assert_same(eqs.V, kt * (th - th0) ** 2 / 2)
        assert_same(eqs.G, sp.Matrix([kt * (th - th0)]))

    def test_damper_between_points(self):
        m = lg.Model()
        x, y = m.coordinate("x", "y")
        c = m.parameter("c")
        m.add_point("A", (0, 1))
        m.add_particle(1, (x, y), name="B")
        m.add_damper(c, between=("A", "B"))
        eqs = lg.derive(m)
        r = sqrt(x ** 2 + (y - 1) ** 2)
        rdot = sp.diff(r, x) * lg.dot(x) + sp.diff(r, y) * lg.dot(y)
        assert_same(eqs.D, c * rdot ** 2 / 2)
        assert_same(eqs.damping_forces, sp.Matrix([-sp.diff(eqs.D, v) for v in eqs.velocities]))

    def test_damper_with_length_expression(self):
        m = lg.Model()
        x, th = m.coordinate("x", "theta")
        c, a = m.parameter("c"), m.parameter("a")
        m.add_damper(c, length=x + a * th ** 2, name="d")
        eqs = lg.derive(m)
        assert_same(eqs.D, c * (lg.dot(x) + 2 * a * th * lg.dot(th)) ** 2 / 2)

    def test_gravity_default_direction_2d(self):
        m = lg.Model()
        x, y = m.coordinate("x", "y")
        M, g = m.parameter("M"), m.parameter("g")
        m.add_particle(M, (x, y), name="p")
        m.add_gravity(g)
        assert_same(lg.derive(m).V, M * g * y)

    def test_gravity_default_direction_3d(self):
        m = lg.Model()
        x, y, z = m.coordinate("x", "y", "z")
        M, g = m.parameter("M"), m.parameter("g")
        m.add_particle(M, (x, y, z), name="p")
        m.add_rigid_body(2 * M, 1, (x, y, 3 * z), x, name="b")
        m.add_gravity(g)
        assert_same(lg.derive(m).V, M * g * z + 2 * M * g * 3 * z)

    def test_gravity_custom_direction_normalised(self):
        def V(direction):
            m = lg.Model()
            x, y = m.coordinate("x", "y")
            M, g = m.parameter("M"), m.parameter("g")
            m.add_particle(M, (x, y), name="p")
            m.add_gravity(g, direction)
            return lg.derive(m).V, (M, g, x, y)

        V1, (M, g, x, y) = V((0, -1))
        V2, _ = V((0, -2))
        assert_same(V1, M * g * y)
        assert_same(V2, V1)
        V3, _ = V((1, 1))
        assert_same(V3, -M * g * (x + y) / sqrt(2))

    def test_gravity_acts_on_every_massive_element_only(self):
        m = lg.Model()
        y = m.coordinate("y")
        g = m.parameter("g")
        m.add_point("P", (0, 5 * y))                   # massless: no weight
        m.add_particle(2, (0, y), name="a")
        m.add_rigid_body(3, 1, (0, -y), y, name="b")
        m.add_gravity(g)
        assert_same(lg.derive(m).V, 2 * g * y - 3 * g * y)

    def test_force_virtual_work_pendulum(self):
        m = pendulum(with_values=False)
        F = m.input("F")
        m.add_force((F, 0), "bob", name="push")
        eqs = lg.derive(m)
        th, l = m.symbol("theta"), m.symbol("l")
        assert_same(eqs.generalized_forces, sp.Matrix([F * l * cos(th)]))
        assert_same(eqs.input_matrix, sp.Matrix([[l * cos(th)]]))

    def test_force_3d_two_coordinates(self):
        m = lg.Model()
        x, z = m.coordinate("x", "z")
        F1, F3 = m.parameter("F1"), m.parameter("F3")
        m.add_particle(1, (x * z, 0, z ** 2), name="p")
        m.add_force((F1, 7, F3), "p")
        assert_same(lg.derive(m).Q, sp.Matrix([F1 * z, F1 * x + 2 * z * F3]))

    def test_torque_on_body(self):
        m = lg.Model()
        x, th = m.coordinate("x", "theta")
        tau = m.input("tau")
        m.add_rigid_body(1, 1, (x, 0), 3 * th + x ** 2, name="wheel")
        m.add_torque(tau, body="wheel", name="motor")
        assert_same(lg.derive(m).generalized_forces, sp.Matrix([2 * x * tau, 3 * tau]))

    def test_torque_on_angle_expression(self):
        m = lg.Model()
        q1, q2 = m.coordinate("q1", "q2")
        tau = m.parameter("tau")
        m.add_particle(1, (q1, q2))
        m.add_torque(tau, angle=q2 - q1, name="joint")
        assert_same(lg.derive(m).Q, sp.Matrix([-tau, tau]))

    def test_pendulum_equation(self):
        eqs = lg.derive(pendulum(with_values=False))
        th = S("theta")
        mass, l, g = S("m"), S("l"), S("g")
        assert_same(eqs.equations[0], mass * l ** 2 * lg.ddot(th) + mass * g * l * sin(th))
        assert_same(eqs.mass_matrix, sp.Matrix([[mass * l ** 2]]))


# ====================================================== 4. mixing, strings, snapshots
class TestMixingAndSnapshots:
    def test_elements_and_explicit_energies_add(self):
        m = lg.Model()
        x = m.coordinate("x")
        M, J, k, c = (m.parameter(n) for n in ("M", "J", "k", "c"))
        xd = lg.dot(x)
        m.add_particle(M, (x, 0), name="p")
        m.add_spring(k, length=x)
        m.add_damper(c, length=x)
        m.add_energy(T=J * xd ** 2 / 2, V=k * x ** 4, D=c * xd ** 4)
        m.add_generalized_force(x, 5)
        m.add_force((2, 0), "p")
        eqs = lg.derive(m)
        assert_same(eqs.T, (M + J) * xd ** 2 / 2)
        assert_same(eqs.V, k * x ** 2 / 2 + k * x ** 4)
        assert_same(eqs.D, c * xd ** 2 / 2 + c * xd ** 4)
        assert_same(eqs.Q, sp.Matrix([7]))
        # explicit parts stay on the model, without the elements
        assert_same(m.T, J * xd ** 2 / 2)

    def test_constructor_energies(self):
        m = lg.Model("c", coordinates=["x"], parameters={"k": 2.0}, inputs=["u"],
                     T="x_dot**2/2", V="k*x**2/2", D="x_dot**2", Q={"x": "u"})
        x, k, u = S("x"), S("k"), S("u")
        assert_same(lg.derive(m).equations[0], lg.ddot(x) + k * x + 2 * lg.dot(x) - u)

    def test_strings_give_same_equations(self):
        a = lg.derive(pendulum(strings=False))
        b = lg.derive(pendulum(strings=True))
        assert_same(sp.Matrix(a.equations), sp.Matrix(b.equations))
        assert_same(a.mass_matrix, b.mass_matrix)
        assert b.model.elements[0].position == (S("l") * sin(S("theta")), -S("l") * cos(S("theta")))

    def test_copy_is_independent(self):
        m = pendulum()
        c = m.copy()
        c.add_spring(1, length=c.symbol("theta"), name="extra")
        c.parameter("k2", 3.0)
        c.coordinate("phi")
        c.add_energy(T=c.symbol("phi_dot") ** 2)
        c.add_generalized_force("theta", 1)
        assert [e.name for e in m.elements] == ["bob", "gravity"]
        assert [e.name for e in c.elements] == ["bob", "gravity", "extra"]
        assert m.q == (S("theta"),) and S("k2") not in m.parameters
        assert m.T == 0 and m.Q == {}
        eqs = lg.derive(m)
        assert eqs.n == 1

    def test_derive_takes_a_snapshot(self):
        m = pendulum()
        eqs = lg.derive(m)
        before = eqs.model.elements
        V_before = eqs.V
        m.add_spring(1, length=m.symbol("theta"), name="later")
        m.parameter("extra", 1.0)
        assert eqs.model.elements == before
        assert [e.name for e in eqs.model.elements] == ["bob", "gravity"]
        assert S("extra") not in eqs.parameters
        assert eqs.V == V_before
        assert eqs.model is not m

    def test_equations_immutable(self):
        eqs = lg.derive(pendulum())
        with pytest.raises(dataclasses.FrozenInstanceError):
            eqs.model = lg.Model()
        with pytest.raises(dataclasses.FrozenInstanceError):
            eqs.foo = 1

    def test_derive_rejects_non_model(self):
        with pytest.raises(TypeError, match=esc("derive() expects a Model (lagrangian.load(...) or "
                                                "lagrangian.Model(...)), got str")):
            lg.derive("pendulum")


# ============================================================================ 5. printing
class TestPrinting:
    @staticmethod
    def locals_of(eqs):
        return {s.name: s for s in (*eqs.coordinates, *eqs.velocities, *eqs.accelerations,
                                    *eqs.parameters, *eqs.inputs)}

    def equation_lines(self, eqs):
        """The numbered equation lines of text(), parsed back: {coordinate name: expression}."""
        out = {}
        for line in eqs.text().splitlines():
            found = re.fullmatch(r"  \((\d+)\) \[(\w+)\]  (.*) = 0", line)
            if found:
                out[found.group(2)] = (int(found.group(1)), sp.sympify(found.group(3), locals=self.locals_of(eqs)))
        return out

    def test_text(self):
        eqs = lg.derive(double_pendulum())
        text = eqs.text()
        assert text.startswith("Lagrange's equations of double-pendulum (2 coordinates: q1, q2)")
        parsed = self.equation_lines(eqs)
        assert list(parsed) == ["q1", "q2"]
        for i, (q, expected) in enumerate(zip(eqs.coordinates, eqs.equations)):
            number, expr = parsed[q.name]
            assert number == i + 1
            assert_same(expr, expected)
        lines = text.splitlines()
        assert "Matrix form M(q) q_ddot = f(q, q_dot, t, u):" in text
        assert "  M =" in lines and "  f =" in lines
        assert "Linear:" not in text
        assert str(eqs) == text

    def test_text_linear(self):
        eqs = lg.derive(mck())
        x, M, c, k, u = (S(n) for n in ("x", "M", "c", "k", "u"))
        number, expr = self.equation_lines(eqs)["x"]
        assert number == 1
        assert_same(expr, M * lg.ddot(x) + c * lg.dot(x) + k * x - u)
        text = eqs.text()
        assert "Linear: M x'' + C x' + K x = f with" in text
        assert "  K = [[k]]" in text and "  f = [u]" in text

    def test_latex(self):
        eqs = lg.derive(double_pendulum())
        tex = eqs.latex()
        assert tex.startswith("\\begin{align}\n") and "\\end{align}" in tex
        assert "\\ddot{q_{1}}" in tex and "\\ddot{q_{2}}" in tex
        assert tex.count("&= 0") == 2
        assert "\\begin{equation}" in tex
        no_matrix = eqs.latex(matrix_form=False)
        assert "\\begin{equation}" not in no_matrix and no_matrix.endswith("\\end{align}")
        assert "\\ddot{\\theta}" in lg.derive(pendulum()).latex()

    def test_to_dict_and_json(self):
        eqs = lg.derive(double_pendulum())
        d = eqs.to_dict()
        for key in ("coordinates", "mass_matrix", "forcing", "equations", "linear"):
            assert key in d
        assert d["coordinates"] == ["q1", "q2"]
        assert d["velocities"] == ["q1_dot", "q2_dot"] and d["accelerations"] == ["q1_ddot", "q2_ddot"]
        assert d["linear"] is None
        assert json.loads(eqs.to_json()) == d
        names = {s.name: s for s in (*eqs.coordinates, *eqs.velocities, *eqs.accelerations,
                                      *eqs.parameters, *eqs.inputs)}
        for text, expected in zip(d["equations"], eqs.equations):
            assert_same(sp.sympify(text, locals=names), expected)
        M = sp.Matrix([[sp.sympify(x, locals=names) for x in row] for row in d["mass_matrix"]])
        assert_same(M, eqs.mass_matrix)
        f = sp.Matrix([sp.sympify(x, locals=names) for x in d["forcing"]])
        assert_same(f, eqs.forcing)

    def test_to_dict_with_sympy_like_names(self):
        """Parameter names that SymPy gives a meaning to (I, E, S, N) still round-trip with locals."""
        m = lg.Model("names")
        x = m.coordinate("x")
        I, E, N = (m.parameter(n, 1.0) for n in ("I", "E", "N"))
        m.add_energy(T=I * lg.dot(x) ** 2 / 2, V=E * x ** 2 / 2 + N * x)
        eqs = lg.derive(m)
        names = {s.name: s for s in (x, lg.dot(x), lg.ddot(x), I, E, N)}
        [text] = eqs.to_dict()["equations"]
        assert_same(sp.sympify(text, locals=names), eqs.equations[0])
        assert_same(eqs.equations[0], I * lg.ddot(x) + E * x + N)

    def test_to_dict_linear(self):
        eqs = lg.derive(mck())
        d = eqs.to_dict()
        assert d["linear"] == {"M": [["M"]], "C": [["c"]], "K": [["k"]], "f": ["u"]}
        assert d["inputs"] == ["u"] and d["parameters"] == {"M": 1.0, "c": 0.2, "k": 4.0}
        assert json.loads(eqs.to_json())["linear"] == d["linear"]


# ======================================================================= 6. singularities
class TestSingularities:
    def massless_coordinate(self):
        m = lg.Model("ghost")
        x, y = m.coordinate("x", "y")
        mass = m.parameter("m", 2.0)
        m.add_energy(T=mass * lg.dot(x) ** 2 / 2)
        return m

    def test_singular_everywhere(self):
        report = lg.singularities(lg.derive(self.massless_coordinate()))
        assert report.singular and report.everywhere
        assert report.det_mass_matrix == 0 and report.det_with_values == 0
        [c] = report.configurations
        assert c.where == {} and c.condition == ""
        assert {k: v for k, v in c.null_velocity.items() if v != 0} == {"y_dot": 1}
        assert c.velocity_text() == "y_dot alone (every other velocity zero)"
        assert "coordinate y carries no inertia" in report.cause
        assert "eliminate coordinate y from the model" in report.fix
        text = report.text()
        assert "det M vanishes at every configuration" in text
        assert "Everywhere, the velocity combination y_dot alone (every other velocity zero) has no inertia" in text
        assert f"Likely cause: {report.cause}" in text and f"Fix: {report.fix}" in text
        d = report.to_dict()
        assert d["singular"] is True and d["everywhere"] is True
        assert d["cause"] == report.cause and d["fix"] == report.fix and d["diagnosis"] == text
        assert d["configurations"][0]["null_velocity"] == {"x_dot": "0", "y_dot": "1"}
        json.dumps(d)

    def test_double_pendulum_regular(self):
        report = lg.singularities(lg.derive(double_pendulum()))
        assert not report.singular and not report.everywhere
        assert report.configurations == () and report.cause == "" and report.fix == ""
        assert "The mass matrix is regular" in report.text()
        l1, l2, m1, m2, q1, q2 = (S(n) for n in ("l1", "l2", "m1", "m2", "q1", "q2"))
        assert_same(report.det_mass_matrix, l1 ** 2 * l2 ** 2 * m2 * (m1 + m2 * sin(q1 - q2) ** 2))

    def test_massless_particle(self):
        m = lg.Model("cart")
        q1, q2 = m.coordinate("q1", "q2")
        M1, m2, L, g = (m.parameter(n, v) for n, v in (("M1", 0.0), ("m2", 1.0), ("L", 1.0), ("g", 9.81)))
        m.add_particle(M1, (q1, 0), name="cart")
        m.add_particle(m2, (q1 + L * lg.sin(q2), -L * lg.cos(q2)), name="bob")
        m.add_gravity(g)
        m.validate()                      # a zero mass is allowed, not negative
        report = lg.singularities(lg.derive(m))
        assert report.singular and not report.everywhere
        assert_same(report.det_with_values, sin(q2) ** 2)
        assert {tuple(c.where.items()) for c in report.configurations} == {(("q2", 0),), (("q2", sp.pi),)}
        c0 = report.configurations[0]
        assert c0.moving_massless == ("particle 'cart' (mass M1 = 0)",)
        assert c0.still == ("particle 'bob'",)
        assert "only massless parts move" in report.cause
        assert "particle 'cart'" in report.cause
        assert "give the massless part a positive mass" in report.fix
        assert "det M vanishes where q2 = 0 or q2 = pi." in report.text()

    def test_five_dof_numeric_path(self):
        eqs = lg.derive(lg.load("pendulum-chain-5"))
        assert eqs.n == 5
        report = lg.singularities(eqs)
        assert not report.singular and not report.everywhere
        assert isinstance(report.det_mass_matrix, sp.Determinant)  # numeric path: det not expanded
        assert "The mass matrix is regular" in report.text()


# ============================================================ bugs found (strict xfail)
def test_bug_reserved_input_grammar():
    with pytest.raises(lg.ModelError, match="cannot name an input"):
        lg.Model().input("pi")


@pytest.mark.parametrize("value", [float("nan"), float("inf")])
def test_bug_parameter_non_finite(value):
    with pytest.raises(lg.ModelError, match="parameter 'k'"):
        lg.Model().parameter("k", value)


def test_bug_coordinate_not_atomic():
    m = lg.Model()
    with pytest.raises(lg.ModelError, match="'1b' is not a valid coordinate name"):
        m.coordinate("a", "1b")
    assert m.q == ()


def test_bug_add_energy_not_atomic():
    m = lg.Model()
    x = m.coordinate("x")
    with pytest.raises(lg.ModelError, match=esc("[energy.V]")):
        m.add_energy(T=x ** 2, V="1 +")
    assert m.T == 0


def test_bug_gravity_name_collision():
    m = lg.Model()
    x = m.coordinate("x")
    m.add_particle(1, (x, 0), name="gravity")
    with pytest.raises(lg.ModelError, match="two elements are named 'gravity'"):
        m.add_gravity(9.81)


def test_bug_velocity_in_force_position_unreported():
    m = lg.Model()
    x = m.coordinate("x")
    m.add_particle(1, (x, 0))
    m.add_force((1, 0), (x + lg.dot(x), 0), name="f")
    assert [p.key for p in m.check()] == ["force 'f'.position[0]"]


@pytest.mark.parametrize("value", [sp.true, sp.Eq(S("x"), 1)])
def test_bug_sympy_non_expression_accepted(value):
    m = lg.Model()
    m.coordinate("x")
    with pytest.raises(lg.ModelError, match="expected an expression"):
        m.add_energy(T=value)


def test_bug_equations_model_snapshot_mutable():
    eqs = lg.derive(pendulum())
    with pytest.raises(lg.ModelError, match="is the snapshot held by an Equations object and cannot change"):
        eqs.model.coordinate("phi")
    with pytest.raises(lg.ModelError, match="snapshot"):
        eqs.model.add_energy(T=1)
    assert len(eqs.coordinates) == eqs.n
    changed = eqs.model.copy()
    changed.coordinate("phi")  # a copy can change
    assert len(changed.q) == 2 and eqs.n == 1


def test_derive_and_simulate_refuse_other_objects():
    with pytest.raises(TypeError, match="derive\\(\\) expects a Model"):
        lg.derive("cart-pendulum")
    with pytest.raises(TypeError, match="simulate\\(\\) expects a Model, Equations or NumericModel"):
        lg.simulate("cart-pendulum", 1.0)


def test_non_quadratic_kinetic_coenergy_has_no_matrix_form_parts():
    # a relativistic-like T: the equations exist, the split into C, gyroscopic, centrifugal does not
    m = lg.Model("nonquadratic", coordinates=["x"], parameters={"m": 1.0}, T="m*x_dot**4/4")
    eqs = lg.derive(m)
    assert sp.simplify(eqs.equations[0] - 3 * S("m") * S("x_dot") ** 2 * S("x_ddot")) == 0
    with pytest.raises(lg.LagrangianError, match="T\\* is not quadratic in the velocities"):
        eqs.coriolis_matrix


# ------------------------------------------------------------------ hostile constructor arguments (FUZZ)
@pytest.mark.parametrize("kwargs, text", [
    (dict(coordinates="xy"), r"coordinates must be a list of names, such as coordinates=\['x', 'theta'\], got str "
                             r"'xy'"),
    (dict(coordinates=None), r"coordinates must be a list of names, such as coordinates=\['x', 'theta'\], got "
                             r"NoneType None"),
    (dict(coordinates=3.0), r"coordinates must be a list of names, such as .*, got float 3\.0"),
    (dict(inputs="F"), r"inputs must be a list of names, such as inputs=\['F'\], got str 'F'"),
    (dict(inputs=1), r"inputs must be a list of names, such as inputs=\['F'\], got int 1"),
    (dict(parameters="m"), r"parameters must be a mapping of names to values, such as parameters=\{'m': 1\.0, "
                           r"'g': 9\.81\}, got str 'm'"),
    (dict(parameters=[("m", 1.0)]), r"parameters must be a mapping of names to values, .*got list \[\('m', 1\.0\)\]"),
])
def test_constructor_arguments_of_the_wrong_kind_are_one_error(kwargs, text):
    """Before: TypeError ('float' object is not iterable), ValueError (dictionary update sequence), or, for
    coordinates="xy", the coordinates x and y without a word."""
    with pytest.raises(lg.ModelError, match=text):
        lg.Model("m", **kwargs)


def test_constructor_takes_any_iterable_of_names():
    m = lg.Model("m", coordinates=(c for c in ("x", "y")), inputs={"F": None}.keys(), parameters={"k": 2.0})
    assert [c.name for c in m.coordinates] == ["x", "y"] and [u.name for u in m.inputs] == ["F"]
