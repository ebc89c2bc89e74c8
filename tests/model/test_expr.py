"""Tests of the safe expression parser `lagrangian.model._expr`."""

from __future__ import annotations

import ast
import inspect
import re

import pytest
import sympy

from lagrangian.errors import ExpressionError, ModelError, UnknownNameError
from lagrangian.model import _expr
from lagrangian.model._expr import (
    ALLOWED_FUNCTIONS,
    MAX_DEPTH,
    MAX_LENGTH,
    identifiers,
    parse_expression,
)

a, b, c, m, k, x, y, t, g, l = sympy.symbols("a b c m k x y t g l")
q1, q1_dot = sympy.symbols("q1 q1_dot")
NAMES = {
    "a": a, "b": b, "c": c, "m": m, "k": k, "x": x, "y": y, "t": t, "g": g, "l": l,
    "q1": q1, "q1_dot": q1_dot, "mass": m,
}


def parse(text: str, names=NAMES) -> sympy.Expr:
    return parse_expression(text, names)


def error(text: str, names=NAMES) -> ExpressionError:
    with pytest.raises(ExpressionError) as info:
        parse(text, names)
    return info.value


# ---------------------------------------------------------------------------
# Valid expressions
# ---------------------------------------------------------------------------

@pytest.mark.parametrize("text, expected", [
    ("a + b*c", a + b * c),
    ("(a + b)*c", (a + b) * c),
    ("a - b - c", a - b - c),
    ("a - (b - c)", a - b + c),
    ("a/b/c", a / (b * c)),
    ("a/(b/c)", a * c / b),
    ("a*b/c*x", a * b * x / c),
    ("a + b*c**2", a + b * c**2),
    ("a*b**c", a * b**c),
    ("2^3^2", sympy.Integer(2)**9),
    ("2**3**2", sympy.Integer(512)),
    ("(2**3)**2", sympy.Integer(64)),
    ("a^b^c", a**(b**c)),
    ("-x**2", -(x**2)),
    ("(-x)**2", x**2),
    ("-2**2", sympy.Integer(-4)),
    ("(-2)**2", sympy.Integer(4)),
    ("x**-1", 1 / x),
    ("2**-1", sympy.Rational(1, 2)),
    ("2^-x^2", 2**(-(x**2))),
    ("x**+2", x**2),
    ("--x", x),
    ("- - -x", -x),
    ("+x", x),
    ("a*-b", -a * b),
    ("a - -b", a + b),
    ("-a/b", -a / b),
    ("q1_dot*l", q1_dot * l),
    ("mass*g", m * g),
    ("1/2*m*(l*q1_dot)**2 - m*g*l*(1 - cos(q1))",
     sympy.Rational(1, 2) * m * (l * q1_dot)**2 - m * g * l * (1 - sympy.cos(q1))),
])
def test_precedence_and_associativity(text, expected):
    assert parse(text) == expected


@pytest.mark.parametrize("text, expected", [
    ("12", sympy.Integer(12)),
    ("007", sympy.Integer(7)),
    ("0.5", sympy.Rational(1, 2)),
    (".5", sympy.Rational(1, 2)),
    ("5.", sympy.Integer(5)),
    ("0.1", sympy.Rational(1, 10)),
    ("1e-3", sympy.Rational(1, 1000)),
    ("1E3", sympy.Integer(1000)),
    ("2.5E+4", sympy.Integer(25000)),
    ("1.25e-1", sympy.Rational(1, 8)),
    ("5.e2", sympy.Integer(500)),
    ("0e5", sympy.Integer(0)),
    ("9.81", sympy.Rational(981, 100)),
])
def test_numbers_are_exact(text, expected):
    result = parse(text)
    assert result == expected
    assert isinstance(result, sympy.Rational)


def test_no_floats_anywhere():
    assert parse("1/2*m") == m / 2
    assert parse("0.5*m*x**2") == m * x**2 / 2
    result = parse("0.1*x + 2.5e-1*y + 1/3")
    assert result == x / 10 + y / 4 + sympy.Rational(1, 3)
    assert not result.atoms(sympy.Float)


@pytest.mark.parametrize("name, function", [
    ("sin", sympy.sin), ("cos", sympy.cos), ("tan", sympy.tan),
    ("asin", sympy.asin), ("acos", sympy.acos), ("atan", sympy.atan),
    ("sinh", sympy.sinh), ("cosh", sympy.cosh), ("tanh", sympy.tanh),
    ("exp", sympy.exp), ("log", sympy.log), ("sqrt", sympy.sqrt),
    ("abs", sympy.Abs), ("sign", sympy.sign),
])
def test_functions(name, function):
    assert parse(f"{name}(x)") == function(x)
    assert parse(f"{name}(2*x + 1)") == function(2 * x + 1)


def test_atan2_and_function_values():
    assert parse("atan2(y, x)") == sympy.atan2(y, x)
    assert parse("atan2(1, 1)") == sympy.pi / 4
    assert parse("log(exp(x))") == sympy.log(sympy.exp(x))
    assert parse("sin(pi/6)") == sympy.Rational(1, 2)
    assert parse("sqrt(8)") == 2 * sympy.sqrt(2)
    assert parse("abs(-3)") == 3
    assert parse("sign(-2.5)") == -1


def test_allowed_functions_export():
    assert set(ALLOWED_FUNCTIONS) == {
        "sin", "cos", "tan", "asin", "acos", "atan", "atan2", "sinh", "cosh", "tanh",
        "exp", "log", "sqrt", "abs", "sign"}
    assert isinstance(ALLOWED_FUNCTIONS, tuple)


def test_pi_is_always_available_unless_redefined():
    assert parse("2*pi*l") == 2 * sympy.pi * l
    assert parse("pi", {}) == sympy.pi
    p = sympy.Symbol("p")
    assert parse("pi*x", {"pi": p, "x": x}) == p * x


def test_whitespace_is_ignored():
    assert parse(" \t a +\n b *\r\n c \n") == a + b * c
    assert parse("sin ( x )") == sympy.sin(x)
    assert parse("atan2(\n  y,\n  x\n)") == sympy.atan2(y, x)
    assert parse("2 ** 3") == 8


def test_names_can_be_any_sympy_object():
    f = sympy.Function("f")(t)
    assert parse("f*2", {"f": f}) == 2 * f
    assert parse("v + 1", {"v": sympy.Integer(3)}) == 4


def test_a_name_may_be_a_python_keyword_or_function_name_when_defined():
    lam = sympy.Symbol("lambda")
    assert parse("lambda*x", {"lambda": lam, "x": x}) == lam * x
    s = sympy.Symbol("sign")
    assert parse("sign*x", {"sign": s, "x": x}) == s * x
    assert parse("sign(x)", {"sign": s, "x": x}) == sympy.sign(x)


def test_result_is_not_a_python_number():
    assert isinstance(parse("1"), sympy.Basic)
    assert isinstance(parse("x"), sympy.Basic)


# ---------------------------------------------------------------------------
# Errors
# ---------------------------------------------------------------------------

@pytest.mark.parametrize("text", ["", "   ", "\n\t"])
def test_empty(text):
    err = error(text)
    assert err.reason.startswith("empty expression: write a formula such as")
    with pytest.raises(ExpressionError, match="empty expression: write a formula"):
        parse(text)


@pytest.mark.parametrize("text, position, pattern", [
    ("x $ y", 2, r"unexpected '\$': names may only contain letters, digits and '_'"),
    ("x; y", 1, r"unexpected ';': write a single expression"),
    ("'x'", 0, r"unexpected quote .*strings are not allowed"),
    ('"x"', 0, r"unexpected quote .*strings are not allowed"),
    ("`x`", 0, r"unexpected backquote .*strings are not allowed"),
    ("x[0]", 1, r"unexpected '\[': square brackets \(indexing, lists\) are not allowed"),
    ("x]", 1, r"unexpected '\]': square brackets"),
    ("{x}", 0, r"unexpected '\{': braces are not allowed"),
    ("x}", 1, r"unexpected '\}': braces are not allowed"),
    ("x < y", 2, r"unexpected '<': comparisons are not allowed"),
    ("x >= y", 2, r"unexpected '>': comparisons are not allowed"),
    ("x != y", 2, r"unexpected '!': comparisons and factorials are not allowed"),
    ("x == y", 2, r"unexpected '==': comparisons are not allowed"),
    ("x = y", 2, r"unexpected '=': an expression is a value, not an assignment"),
    ("atan2(y=1, x=2)", 7, r"functions take no keyword arguments"),
    ("x % 2", 2, r"unexpected '%': the modulo operator is not allowed"),
    ("x // 2", 2, r"unexpected '//': floor division is not allowed; use '/'"),
    ("x & y", 2, r"unexpected '&': logical and bitwise operators"),
    ("|x|", 0, r"unexpected '\|'.*write abs\(x\)"),
    ("~x", 0, r"unexpected '~': logical and bitwise operators"),
    ("x @ y", 2, r"unexpected '@': matrix multiplication is not allowed; use '\*'"),
    ("x # comment", 2, r"unexpected '#': comments are not allowed"),
    ("x \\\n + y", 2, r"unexpected '\\': line continuations"),
    ("x ? y", 2, r"unexpected '\?': conditional expressions are not allowed"),
    ("x: 1", 1, r"unexpected ':': an expression is a formula, not Python code"),
    ("\u03b8 + 1", 0, r"unexpected character '\u03b8' \(U\+03B8\): names may only use ASCII"),
    ("x\u00a0+ 1", 1, r"unexpected character .*U\+00A0"),
    ("x\x00", 1, r"unexpected character '\\x00': an expression may only contain numbers"),
    ("x + . + y", 4, r"unexpected '\.': a decimal point must belong to a number"),
    (".", 0, r"unexpected '\.': a decimal point must belong to a number"),
    ("x.y", 1, r"attribute access '\.y' is not allowed"),
    ("(x).y", 3, r"attribute access '\.y' is not allowed"),
    ("1.2.3", 0, r"malformed number '1\.2\.': a number has at most one decimal point"),
])
def test_unexpected_characters(text, position, pattern):
    with pytest.raises(ExpressionError, match=pattern) as info:
        parse(text)
    assert info.value.position == position


@pytest.mark.parametrize("text, pattern", [
    ("x and y", r"'and' is not allowed: logical operators, comparisons and conditions"),
    ("not x", r"'not' is not allowed: logical operators"),
    ("x if y else 1", r"'if' is not allowed: logical operators"),
    ("x in y", r"'in' is not allowed"),
    ("import os", r"'import' is a Python keyword and is not allowed: an expression is a "
                  r"formula, not Python code"),
    ("lambda: 1", r"'lambda' is a Python keyword"),
    ("True", r"'True' is not allowed: an expression stands for a number; write a number"),
    ("x*None", r"'None' is not allowed"),
])
def test_python_keywords(text, pattern):
    with pytest.raises(ExpressionError, match=pattern):
        parse(text)


@pytest.mark.parametrize("text, position, pattern", [
    ("(x + 1", 0, r"missing '\)': the '\(' here is never closed; add a '\)'"),
    ("((x + 1)", 0, r"missing '\)'"),
    ("x*(y + (1 - x)", 2, r"missing '\)'"),
    ("(", 0, r"missing '\)'"),
    ("sin(x", 3, r"missing '\)'"),
    ("sin(", 3, r"missing '\)'"),
    ("atan2(y,", 5, r"missing '\)'"),
    ("x + 1)", 5, r"unexpected '\)': it has no matching '\('; remove it or add the missing"),
    (")", 0, r"unexpected '\)': it has no matching '\('"),
    ("(x))", 3, r"unexpected '\)'"),
    ("()", 0, r"empty parentheses '\(\)': write an expression inside them"),
    ("x*()", 2, r"empty parentheses"),
])
def test_unbalanced_parentheses(text, position, pattern):
    with pytest.raises(ExpressionError, match=pattern) as info:
        parse(text)
    assert info.value.position == position


@pytest.mark.parametrize("text, position, pattern", [
    ("m*", 1, r"missing operand after '\*': write a number, a name or an expression in "
              r"parentheses after it"),
    ("m +", 2, r"missing operand after '\+'"),
    ("m - -", 4, r"missing operand after '-'"),
    ("m**", 1, r"missing operand after '\*\*'"),
    ("(m/)", 2, r"missing operand after '/'"),
    ("atan2(y+, x)", 7, r"missing operand after '\+'"),
    ("*m", 0, r"missing operand before '\*': write a number, a name or an expression in "
              r"parentheses before it"),
    ("/m", 0, r"missing operand before '/'"),
    ("^m", 0, r"missing operand before '\^'"),
    ("(*m)", 1, r"missing operand before '\*'"),
    ("m + * k", 4, r"missing operand between '\+' and '\*'"),
    ("m * / k", 4, r"missing operand between '\*' and '/'"),
    ("x***2", 3, r"missing operand between '\*\*' and '\*'"),
])
def test_missing_operand(text, position, pattern):
    with pytest.raises(ExpressionError, match=pattern) as info:
        parse(text)
    assert info.value.position == position


@pytest.mark.parametrize("text, position, pattern", [
    ("2x", 1, r"missing operator between '2' and 'x': write '2\*x' to multiply them"),
    ("2 x", 2, r"missing operator between '2' and 'x': write '2\*x'"),
    ("m k", 2, r"missing operator between 'm' and 'k': write 'm\*k'"),
    ("(m)(k)", 3, r"missing operator between '\)' and '\(': write '\)\*\('"),
    ("2(x + 1)", 1, r"missing operator between '2' and '\('"),
    ("x 2", 2, r"missing operator between 'x' and '2'"),
    ("2 sin(x)", 2, r"missing operator between '2' and 'sin'"),
    ("sin(x) cos(x)", 7, r"missing operator between '\)' and 'cos'"),
    ("x**2 y", 5, r"missing operator between '2' and 'y'"),
    ("1.5.", 0, r"malformed number"),
])
def test_missing_operator(text, position, pattern):
    with pytest.raises(ExpressionError, match=pattern) as info:
        parse(text)
    assert info.value.position == position


@pytest.mark.parametrize("text, pattern", [
    ("foo(x)", r"unknown function 'foo': the allowed functions are sin, cos, tan"),
    ("sinn(x)", r"unknown function 'sinn' \(did you mean 'sin'\?\): the allowed functions"),
    ("atan3(y, x)", r"unknown function 'atan3' \(did you mean 'atan"),
    ("Sin(x)", r"unknown function 'Sin' \(did you mean 'sin'\?\)"),
    ("ln(x)", r"unknown function 'ln' \(did you mean 'log'\?\)"),
    ("arctan(x)", r"unknown function 'arctan' \(did you mean 'atan'\?\)"),
    ("eval(x)", r"unknown function 'eval'"),
    ("getattr(x, y)", r"unknown function 'getattr'"),
])
def test_unknown_function(text, pattern):
    with pytest.raises(ExpressionError, match=pattern) as info:
        parse(text)
    assert info.value.position == 0
    assert not isinstance(info.value, UnknownNameError)


@pytest.mark.parametrize("text, position, pattern", [
    ("sin x", 0, r"'sin' is a function: write its argument in parentheses, as in sin\(x\)"),
    ("sin", 0, r"'sin' is a function"),
    ("2*sqrt", 2, r"'sqrt' is a function: write its argument in parentheses, as in sqrt"),
    ("atan2", 0, r"as in atan2\(y, x\)"),
])
def test_function_without_parentheses(text, position, pattern):
    with pytest.raises(ExpressionError, match=pattern) as info:
        parse(text)
    assert info.value.position == position


@pytest.mark.parametrize("text, position, pattern", [
    ("atan2(x)", 0, r"wrong number of arguments: atan2 takes 2 arguments, as in "
                    r"atan2\(y, x\), but got 1"),
    ("atan2(x, y, 1)", 0, r"atan2 takes 2 arguments.*but got 3"),
    ("sin(x, y)", 0, r"wrong number of arguments: sin takes 1 argument, as in sin\(x\), "
                     r"but got 2"),
    ("1 + exp(x, y)", 4, r"exp takes 1 argument"),
])
def test_wrong_number_of_arguments(text, position, pattern):
    with pytest.raises(ExpressionError, match=pattern) as info:
        parse(text)
    assert info.value.position == position


@pytest.mark.parametrize("text, position, pattern", [
    ("sin()", 4, r"empty argument: sin\(\) needs 1 argument, as in sin\(x\)"),
    ("atan2()", 6, r"empty argument: atan2\(\) needs 2 arguments, as in atan2\(y, x\)"),
    ("atan2(x,)", 7, r"empty argument after ',' in atan2\(\.\.\.\): write an expression "
                     r"there or remove the ','"),
    ("atan2(,x)", 6, r"empty argument before ',' in atan2\(\.\.\.\)"),
    ("atan2(x,,y)", 8, r"empty argument before ','"),
])
def test_empty_argument(text, position, pattern):
    with pytest.raises(ExpressionError, match=pattern) as info:
        parse(text)
    assert info.value.position == position


@pytest.mark.parametrize("text, position, pattern", [
    ("m(2)", 0, r"'m' is not a function and cannot be called: write 'm\*\(\.\.\.\)' to "
                r"multiply"),
    ("x + q1_dot(t)", 4, r"'q1_dot' is not a function"),
    ("pi(2)", 0, r"'pi' is not a function"),
])
def test_name_called_as_function(text, position, pattern):
    with pytest.raises(ExpressionError, match=pattern) as info:
        parse(text)
    assert info.value.position == position


@pytest.mark.parametrize("text, position", [("x, y", 1), ("(x, y)", 2), ("sin((x, y))", 6)])
def test_comma_outside_call(text, position):
    with pytest.raises(ExpressionError, match=r"unexpected ',': a comma may only separate "
                                              r"the arguments of a function call"):
        parse(text)
    assert error(text).position == position


# ---------------------------------------------------------------------------
# Unknown names
# ---------------------------------------------------------------------------

def test_unknown_names_are_all_reported_together():
    with pytest.raises(UnknownNameError, match=r"unknown names 'mas' \(did you mean "
                                               r"'mass'\?\), 'zeta', 'q1dot'") as info:
        parse("mas*g + zeta*x - q1dot*zeta")
    err = info.value
    assert err.unknown == (("mas", 0, "mass"), ("zeta", 8, None), ("q1dot", 17, "q1_dot"))
    assert err.position == 0
    assert isinstance(err, ExpressionError)


def test_one_unknown_name():
    with pytest.raises(UnknownNameError, match=r"unknown name 'z'") as info:
        parse("x + z")
    assert info.value.unknown == (("z", 4, None),)
    assert info.value.position == 4


def test_unknown_name_suggests_pi():
    with pytest.raises(UnknownNameError, match=r"did you mean 'pi'"):
        parse("2*pii*x")


def test_syntax_errors_take_precedence_over_unknown_names():
    with pytest.raises(ExpressionError, match="missing operand") as info:
        parse("zz + unknown *")
    assert not isinstance(info.value, UnknownNameError)
    with pytest.raises(ExpressionError, match="missing '\\)'") as info:
        parse("(zz")
    assert not isinstance(info.value, UnknownNameError)


def test_unknown_names_before_evaluation_errors():
    with pytest.raises(UnknownNameError):
        parse("zz/0")


# ---------------------------------------------------------------------------
# Evaluation errors and limits
# ---------------------------------------------------------------------------

@pytest.mark.parametrize("text, position, pattern", [
    ("1/0", 1, r"division by zero: the divisor here evaluates to 0"),
    ("x/(y - y)", 1, r"division by zero"),
    ("x/sin(pi)", 1, r"division by zero"),
    ("0**-1", 1, r"division by zero: 0 raised to a negative power"),
    ("log(0)", 0, r"undefined value: log\(\.\.\.\) has no finite value for this argument"),
    ("tan(pi/2)", 0, r"undefined value: tan"),
    ("atan2(0, 0)", 0, r"undefined value: atan2"),
])
def test_undefined_values(text, position, pattern):
    with pytest.raises(ExpressionError, match=pattern) as info:
        parse(text)
    assert info.value.position == position


@pytest.mark.parametrize("text", [
    "10**10**10", "2**100000", "2^(10^6)", "(2*x)**(10**10)", "sqrt(3)**(10**9)",
    "2**60000 * 2**60000", "(10**1000)**1000",
])
def test_huge_numbers_are_refused(text):
    # refused before SymPy would try to build the number (which would hang)
    with pytest.raises(ExpressionError, match=r"number too large: this would create a "
                                              r"number with more than \d+ binary digits"):
        parse(text)


def test_large_but_reasonable_numbers_and_symbolic_powers():
    assert parse("2**1000") == sympy.Integer(2)**1000
    assert parse("x**1000") == x**1000
    assert parse("(x + 1)**-1000") == (x + 1)**-1000


@pytest.mark.parametrize("text, pattern", [
    ("x**100000", r"exponent too large: 100000 \(in absolute value\); the limit on the exponent of a power of "
                  r"a variable is 1,000; to raise it, set the environment variable LAGRANGIAN_MAX_EXPONENT"),
    ("(x + 1)**-1001", r"exponent too large: -1001"),
    ("1**(10**1000)", r"number too large: this power is beyond the largest floating-point number"),
    ("2**1100", r"number too large: this power is beyond the largest floating-point number \(about 1.8e308\)"),
])
def test_powers_past_the_doubles_or_the_degree_limit(text, pattern):
    with pytest.raises(ExpressionError, match=pattern):
        parse(text)


def test_the_degree_limit_is_raised_by_its_environment_variable(monkeypatch):
    monkeypatch.setenv("LAGRANGIAN_MAX_EXPONENT", "200000")
    assert parse("x**100000") == x**100000
    monkeypatch.setenv("LAGRANGIAN_MAX_EXPONENT", "lots")
    with pytest.raises(ModelError, match=r"the environment variable LAGRANGIAN_MAX_EXPONENT='lots' must "
                                                     r"be a whole number >= 1"):
        parse("x**2")


@pytest.mark.parametrize("text, pattern", [
    ("1" * 1001, r"number too long: it has more than 1000 significant digits"),
    ("1e1001", r"number too large: its decimal exponent is out of range"),
    ("1e-1001", r"number too large: its decimal exponent is out of range"),
    ("1e99999999999999999999", r"number too large: its decimal exponent"),
])
def test_number_literal_limits(text, pattern):
    with pytest.raises(ExpressionError, match=pattern) as info:
        parse(text)
    assert info.value.position == 0


def test_too_long():
    text = "+".join(["x"] * (MAX_LENGTH // 2 + 1))
    with pytest.raises(ExpressionError, match=r"expression too long: it has \d+ characters "
                                              r"and at most 10000 are allowed"):
        parse(text)


def test_long_flat_expressions_do_not_recurse():
    assert parse("+".join(["x"] * 4000)) == 4000 * x
    assert parse("-" * 9000 + "x") == x
    assert parse("x" + "/x" * 3000) == x**-2999


def test_deep_nesting_is_an_expression_error_not_a_recursion_error():
    with pytest.raises(ExpressionError):
        parse("(" * 5000 + "x" + ")" * 5000)
    with pytest.raises(ExpressionError, match=r"expression nested too deeply: more than 100 "
                                              r"levels of parentheses, function calls or "
                                              r"powers") as info:
        parse("(" * 4000 + "x" + ")" * 4000)
    assert info.value.position == MAX_DEPTH
    with pytest.raises(ExpressionError, match="nested too deeply"):
        parse("sin(" * 1000 + "x" + ")" * 1000)
    with pytest.raises(ExpressionError, match="nested too deeply"):
        parse("x^" * 1000 + "x")
    with pytest.raises(ExpressionError, match="nested too deeply"):
        parse("(" * 4000)


def test_nesting_up_to_the_limit_is_fine():
    assert parse("(" * MAX_DEPTH + "x" + ")" * MAX_DEPTH) == x
    assert parse("sin(" * 50 + "x" + ")" * 50) is not None


def test_type_errors():
    with pytest.raises(TypeError, match="must be a str"):
        parse_expression(3, NAMES)  # type: ignore[arg-type]
    with pytest.raises(TypeError, match="must be a sympy object"):
        parse_expression("x", {"x": "__import__('os')"})  # type: ignore[dict-item]


# ---------------------------------------------------------------------------
# Safety
# ---------------------------------------------------------------------------

@pytest.mark.parametrize("text", [
    "__import__('os').system('echo hi')",
    "(lambda: 1)()",
    "x.__class__",
    "x.__class__.__bases__[0].__subclasses__()",
    "().__class__",
    "__import__",
    "__builtins__",
    "eval('1')",
    "exec('import os')",
    "compile('1', 'f', 'eval')",
    "getattr(x, 'y')",
    "open('/etc/passwd').read()",
    "sympy.sin(x)",
    "import os",
    "x; import os",
    "[x for x in y]",
    "{'a': 1}",
    "f'{x}'",
    "x if y else t",
    "globals()",
    "Symbol('x')",
    "S('x')",
])
def test_code_injection_is_rejected(text, capfd):
    with pytest.raises(ExpressionError):
        parse(text)
    assert capfd.readouterr().out == ""


def test_module_never_calls_dangerous_functions():
    source = inspect.getsource(_expr)
    forbidden = {"eval", "exec", "compile", "getattr", "__import__", "sympify",
                 "parse_expr", "S", "Symbol", "symbols"}
    for node in ast.walk(ast.parse(source)):
        if isinstance(node, ast.Call):
            func = node.func
            if (isinstance(func, ast.Attribute) and isinstance(func.value, ast.Name)
                    and func.value.id == "re"):
                continue  # re.compile builds the tokenizer's patterns
            name = func.attr if isinstance(func, ast.Attribute) else getattr(func, "id", "")
            assert name not in forbidden, f"_expr calls {name}()"


def test_error_message_shows_the_position():
    err = error("m + * k")
    assert err.position == 4
    lines = str(err).splitlines()
    assert lines[0].endswith("at position 5:")
    assert lines[1].strip() == "m + * k"
    assert lines[2].index("^") - lines[1].index("m") == 4


def test_every_error_is_a_value_error():
    with pytest.raises(ValueError):
        parse("2x")


# ---------------------------------------------------------------------------
# identifiers()
# ---------------------------------------------------------------------------

def test_identifiers():
    assert identifiers("sin(x)*m + k*q1_dot - pi + atan2(y, x)") == [
        ("x", 4), ("m", 7), ("k", 11), ("q1_dot", 13), ("pi", 22), ("y", 33), ("x", 36)]
    assert identifiers("2 + 3") == []
    assert identifiers("lambda*x") == [("lambda", 0), ("x", 7)]


def test_identifiers_rejects_bad_characters():
    with pytest.raises(ExpressionError, match=re.escape("unexpected '$'")):
        identifiers("x $ y")
