"""A safe parser for the mathematical expressions of model files.

An expression in a model file is *data*, never code: it is read by a hand-written
tokenizer and a recursive-descent parser, and turned into a sympy expression from a
fixed set of building blocks. Nothing is ever passed to ``eval``, ``exec``,
``compile``, ``sympy.sympify`` or ``sympy.parse_expr``, and no attribute is looked up
from user text.

Grammar
-------
Whitespace (spaces, tabs, newlines) between tokens is ignored::

    expression := sum
    sum        := product (("+" | "-") product)*
    product    := unary (("*" | "/") unary)*
    unary      := ("+" | "-")* power
    power      := atom (("**" | "^") unary)?
    atom       := NUMBER | NAME | FUNCTION "(" arguments ")" | "(" expression ")"
    arguments  := expression ("," expression)*

* ``**`` and ``^`` both mean "to the power of". A power is right-associative and binds
  tighter than a unary sign: ``2^3^2`` is ``2**9``, ``-x**2`` is ``-(x**2)``, and the
  exponent may carry a sign: ``x**-1``.
* ``NUMBER``: an integer (``12``), a decimal (``0.5``, ``.5``, ``5.``) or a number in
  scientific notation (``1e-3``, ``2.5E+4``). Numbers are exact: an integer becomes a
  ``sympy.Integer`` and a decimal the ``sympy.Rational`` it denotes (``0.5`` is 1/2).
* ``NAME``: ``[A-Za-z_][A-Za-z0-9_]*``, one of the names given to
  :func:`parse_expression`, or ``pi``; or ``NAME.NAME`` when that dotted name is one of the
  names given (a model gives ``<point>.x``, ``.y``, ``.z``: a component of a point's, particle's or
  body's position). Nothing is looked up on an object: a dotted name is a key of the names given.
* ``FUNCTION``: one of :data:`ALLOWED_FUNCTIONS`: ``sin cos tan asin acos atan``
  ``atan2(y, x) sinh cosh tanh exp log sqrt abs sign`` (``log`` is the natural
  logarithm, ``abs`` is ``sympy.Abs``).

Feedback laws
-------------
With ``feedback=True`` (inputs and events: expressions that a simulation evaluates, never
differentiates) the language also has the functions of :data:`FEEDBACK_FUNCTIONS`,
``min(a, b, ...)``, ``max(a, b, ...)``, ``clip(x, lo, hi)`` and ``where(condition, a, b)``,
and conditions::

    condition  := conjunction ("or" conjunction)*
    conjunction:= negation ("and" negation)*
    negation   := "not" negation | comparison
    comparison := sum (("<" | "<=" | ">" | ">=") sum)*

A condition is true or false, not a number: it may only be the first argument of ``where``
(``where(abs(q2 - pi/2) < 0.3, -K*x, 0)``), and a comparison anywhere else is an error that
says so. Chained comparisons read as in mathematics (``-1 < x < 1``). ``==`` and ``!=`` are
refused: a simulated value meets an exact equality almost never. ``where`` is
``sympy.Piecewise``, ``min``/``max`` are ``sympy.Min``/``Max`` and ``clip(x, lo, hi)`` is
``Min(Max(x, lo), hi)``.

Anything else (strings, ``==``, ``lambda``, attribute access, indexing, keyword arguments,
and, outside feedback laws, comparisons and ``and``) is rejected with an
:class:`~lagrangian.errors.ExpressionError` that says what is wrong, where, and how to
fix it. Names that are not defined are all reported together in one
:class:`~lagrangian.errors.UnknownNameError`, once the syntax is known to be correct.

Limits
------
An expression has at most :data:`MAX_LENGTH` characters and at most :data:`MAX_DEPTH`
levels of nested parentheses, function calls and powers. A number may not have more
than :data:`MAX_LITERAL_DIGITS` digits, and no computation may create a number with
more than :data:`MAX_BITS` binary digits (``10**10**10`` is an error), so that parsing
always finishes quickly. Every constant part is evaluated in floating point first: one that no
double holds (``exp(exp(exp(100)))``, ``10**400``) or that has no real value (``sqrt(-1)``,
``acos(2)``) is an error, and so is a power of a variable with an exponent larger than
``lagrangian._limits.MAX_EXPONENT`` (1000 unless ``LAGRANGIAN_MAX_EXPONENT`` says otherwise).
"""

from __future__ import annotations

import keyword
import math
import re
from dataclasses import dataclass
from typing import Callable, Mapping, NoReturn, Union

import sympy

from lagrangian._limits import MAX_EXPONENT
from lagrangian._util import closest
from lagrangian.errors import ExpressionError, ModelError, UnknownNameError

__all__ = [
    "ALLOWED_FUNCTIONS",
    "FEEDBACK_FUNCTIONS",
    "MAX_BITS",
    "MAX_DEPTH",
    "MAX_LENGTH",
    "MAX_LITERAL_DIGITS",
    "constant_value",
    "identifiers",
    "parse_expression",
]

#: Longest accepted expression, in characters.
MAX_LENGTH = 10_000
#: Deepest accepted nesting of parentheses, function calls and powers.
MAX_DEPTH = 100
#: Most significant digits a number literal may have (and largest decimal exponent).
MAX_LITERAL_DIGITS = 1_000
#: Largest number, in binary digits, that evaluating an expression may create.
MAX_BITS = 100_000

# name -> (sympy function, number of arguments, example of a call)
_FUNCTIONS: dict[str, tuple[Callable[..., sympy.Expr], int, str]] = {
    "sin": (sympy.sin, 1, "sin(x)"),
    "cos": (sympy.cos, 1, "cos(x)"),
    "tan": (sympy.tan, 1, "tan(x)"),
    "asin": (sympy.asin, 1, "asin(x)"),
    "acos": (sympy.acos, 1, "acos(x)"),
    "atan": (sympy.atan, 1, "atan(x)"),
    "atan2": (sympy.atan2, 2, "atan2(y, x)"),
    "sinh": (sympy.sinh, 1, "sinh(x)"),
    "cosh": (sympy.cosh, 1, "cosh(x)"),
    "tanh": (sympy.tanh, 1, "tanh(x)"),
    "exp": (sympy.exp, 1, "exp(x)"),
    "log": (sympy.log, 1, "log(x)"),
    "sqrt": (sympy.sqrt, 1, "sqrt(x)"),
    "abs": (sympy.Abs, 1, "abs(x)"),
    "sign": (sympy.sign, 1, "sign(x)"),
}

#: The functions an expression may call, in the order they are documented.
ALLOWED_FUNCTIONS: tuple[str, ...] = tuple(_FUNCTIONS)


def _clip(x, lo, hi):
    return sympy.Min(sympy.Max(x, lo), hi)


def _where(condition, a, b):
    return sympy.Piecewise((a, condition), (b, True))


# The functions of feedback laws (inputs and events): name -> (sympy function, number of
# arguments (-2: two or more), example of a call).
_FEEDBACK_FUNCTIONS: dict[str, tuple[Callable[..., sympy.Expr], int, str]] = {
    "min": (sympy.Min, -2, "min(x, 10)"),
    "max": (sympy.Max, -2, "max(x, -10)"),
    "clip": (_clip, 3, "clip(x, -10, 10)"),
    "where": (_where, 3, "where(q1 > 0, -1, 1)"),
}

#: The functions that only inputs and events (``feedback=True``) may call.
FEEDBACK_FUNCTIONS: tuple[str, ...] = tuple(_FEEDBACK_FUNCTIONS)

_COMPARISONS = {"<": sympy.StrictLessThan, "<=": sympy.LessThan, ">": sympy.StrictGreaterThan,
                ">=": sympy.GreaterThan}
_LOGIC_WORDS = ("and", "or", "not")

# Common spellings of the allowed functions in other languages and libraries.
_FUNCTION_ALIASES = {
    "ln": "log",
    "arcsin": "asin",
    "arccos": "acos",
    "arctan": "atan",
    "arctan2": "atan2",
    "fabs": "abs",
    "Abs": "abs",
    "sgn": "sign",
    "signum": "sign",
}

_CONSTANTS: dict[str, sympy.Basic] = {"pi": sympy.pi}

_ALLOWED_SUMMARY = (
    "numbers, names, the operators + - * / ** ^, parentheses and the functions "
    + ", ".join(ALLOWED_FUNCTIONS)
)

# ---------------------------------------------------------------------------
# Tokens
# ---------------------------------------------------------------------------

_NUM = "number"
_NAME = "name"
_OP = "operator"
_LPAREN = "("
_RPAREN = ")"
_COMMA = ","
_CMP = "comparison"
_LOGIC = "logic"
_EOF = "end"

_WHITESPACE = frozenset(" \t\n\r\f\v")
_DIGITS = frozenset("0123456789")
_NAME_START = frozenset("abcdefghijklmnopqrstuvwxyzABCDEFGHIJKLMNOPQRSTUVWXYZ_")
_NUMBER_RE = re.compile(r"([0-9]*)(?:\.([0-9]*))?(?:[eE]([+-]?[0-9]+))?", re.ASCII)
_NAME_RE = re.compile(r"[A-Za-z_][A-Za-z0-9_]*", re.ASCII)

# Characters that are never part of an expression, with the reason given for each.
_BAD_CHARACTERS = {
    ";": "unexpected ';': write a single expression, without ';'",
    ":": "unexpected ':': an expression is a formula, not Python code "
         "(no lambdas, slices or annotations)",
    "'": "unexpected quote \"'\": strings are not allowed in an expression",
    '"': "unexpected quote '\"': strings are not allowed in an expression",
    "`": "unexpected backquote '`': strings are not allowed in an expression",
    "[": "unexpected '[': square brackets (indexing, lists) are not allowed; "
         "use parentheses ( ) for grouping",
    "]": "unexpected ']': square brackets (indexing, lists) are not allowed; "
         "use parentheses ( ) for grouping",
    "{": "unexpected '{': braces are not allowed; use parentheses ( ) for grouping",
    "}": "unexpected '}': braces are not allowed; use parentheses ( ) for grouping",
    "<": "unexpected '<': comparisons are not allowed, an expression must be a single value "
         "(a switch, where(condition, a, b), belongs in an input or an event)",
    ">": "unexpected '>': comparisons are not allowed, an expression must be a single value "
         "(a switch, where(condition, a, b), belongs in an input or an event)",
    "!": "unexpected '!': comparisons and factorials are not allowed",
    "%": "unexpected '%': the modulo operator is not allowed",
    "&": "unexpected '&': logical and bitwise operators are not allowed",
    "|": "unexpected '|': logical and bitwise operators are not allowed; "
         "write abs(x) for an absolute value",
    "~": "unexpected '~': logical and bitwise operators are not allowed",
    "@": "unexpected '@': matrix multiplication is not allowed; use '*' to multiply",
    "#": "unexpected '#': comments are not allowed inside an expression",
    "\\": "unexpected '\\': line continuations and escapes are not allowed; "
          "an expression may span several lines as it is",
    "$": "unexpected '$': names may only contain letters, digits and '_'",
    "?": "unexpected '?': conditional expressions are not allowed",
}


@dataclass(frozen=True, slots=True)
class _Token:
    kind: str
    text: str
    pos: int
    value: sympy.Rational | None = None


def _fail(text: str, reason: str, position: int | None) -> NoReturn:
    raise ExpressionError(text, reason, position)


def _check_length(text: str) -> None:
    if not isinstance(text, str):
        raise TypeError(f"an expression must be a str, not {type(text).__name__}")
    if len(text) > MAX_LENGTH:
        _fail(text, f"expression too long: it has {len(text)} characters and at most "
                    f"{MAX_LENGTH} are allowed; split it into shorter expressions or "
                    "introduce parameters", None)


def _tokenize(text: str, known: Mapping[str, object] | None = None,
              feedback: bool = False) -> list[_Token]:
    """Split `text` into tokens, ending with an end-of-text token.

    Parameters
    ----------
    text : str
        The expression.
    known : mapping or None
        The defined names. Python keywords that are not among them are rejected;
        ``None`` accepts every keyword as a plain name.
    feedback : bool
        Read the comparisons ``< <= > >=`` and the words ``and or not`` of feedback laws.

    Raises
    ------
    ExpressionError
        At the first character that cannot start a token.
    """
    tokens: list[_Token] = []
    i, n = 0, len(text)
    while i < n:
        c = text[i]
        if c in _WHITESPACE:
            i += 1
        elif c in _DIGITS or (c == "." and i + 1 < n and text[i + 1] in _DIGITS):
            match = _NUMBER_RE.match(text, i)
            assert match is not None and match.end() > i
            end = match.end()
            if end < n and text[end] == ".":
                _fail(text, f"malformed number '{text[i:end + 1]}': a number has at most "
                            "one decimal point, as in 0.5", i)
            value = _number_value(text, i, match.group(1), match.group(2) or "",
                                  match.group(3))
            tokens.append(_Token(_NUM, text[i:end], i, value))
            i = end
        elif c in _NAME_START:
            match = _NAME_RE.match(text, i)
            assert match is not None
            name = match.group()
            if feedback and name in _LOGIC_WORDS and (known is None or name not in known):
                tokens.append(_Token(_LOGIC, name, i))
                i = match.end()
                continue
            if known is not None and keyword.iskeyword(name) and name not in known:
                _fail(text, _keyword_reason(name, feedback), i)
            end = match.end()
            if known is not None and text.startswith(".", end):  # a point's component, "bob.x": a known name
                member = _NAME_RE.match(text, end + 1)
                if member is not None and f"{name}.{member.group()}" in known:
                    name, end = f"{name}.{member.group()}", member.end()
            tokens.append(_Token(_NAME, name, i))
            i = end
        elif text.startswith("**", i):
            tokens.append(_Token(_OP, "**", i))
            i += 2
        elif text.startswith("//", i):
            _fail(text, "unexpected '//': floor division is not allowed; use '/' to divide", i)
        elif c in "+-*/^":
            tokens.append(_Token(_OP, c, i))
            i += 1
        elif c == "(":
            tokens.append(_Token(_LPAREN, c, i))
            i += 1
        elif c == ")":
            tokens.append(_Token(_RPAREN, c, i))
            i += 1
        elif c == ",":
            tokens.append(_Token(_COMMA, c, i))
            i += 1
        elif feedback and c in "<>":
            op = text[i:i + 2] if text.startswith("=", i + 1) else c
            tokens.append(_Token(_CMP, op, i))
            i += len(op)
        elif feedback and (text.startswith("==", i) or text.startswith("!=", i)):
            _fail(text, f"unexpected '{text[i:i + 2]}': a simulated value meets an exact equality "
                        "almost never, so '==' and '!=' are not allowed; compare with <, <=, > "
                        "or >=, as in where(x >= 0, a, b)", i)
        elif feedback and c in "&|":
            word = "and" if c == "&" else "or"
            _fail(text, f"unexpected '{c}': write '{word}' to join two conditions, as in "
                        f"where(x > 0 {word} v > 0, a, b)", i)
        elif c == "=":
            if text.startswith("==", i):
                _fail(text, "unexpected '==': comparisons are not allowed, an expression "
                            "must be a single value", i)
            _fail(text, "unexpected '=': an expression is a value, not an assignment or an "
                        "equation, and functions take no keyword arguments; write only the "
                        "right-hand side", i)
        elif c == ".":
            after = text[i + 1] if i + 1 < n else ""
            if tokens and tokens[-1].kind in (_NAME, _NUM, _RPAREN) and after in _NAME_START:
                attribute = _NAME_RE.match(text, i + 1)
                assert attribute is not None
                dotted = [k for k in (known or ()) if "." in k]
                if dotted and tokens[-1].kind == _NAME:
                    wanted = f"{tokens[-1].text}.{attribute.group()}"
                    near = closest(wanted, dotted, 0.5)
                    _fail(text, f"unknown name '{wanted}'" + (f" (did you mean '{near}'?)" if near else "")
                          + ": a dotted name is a component of a point's, particle's or body's position, "
                          "<point>.x, .y or .z (.z in space)", tokens[-1].pos)
                _fail(text, f"attribute access '.{attribute.group()}' is not allowed: a name "
                            "may contain only letters, digits and '_'", i)
            _fail(text, "unexpected '.': a decimal point must belong to a number such as "
                        "0.5 or .5", i)
        elif c in _BAD_CHARACTERS:
            _fail(text, _BAD_CHARACTERS[c], i)
        elif not c.isascii():
            _fail(text, f"unexpected character '{c}' (U+{ord(c):04X}): names may only use "
                        "ASCII letters, digits and '_' (write theta, not \u03b8)", i)
        else:
            _fail(text, f"unexpected character {c!r}: an expression may only contain "
                        f"{_ALLOWED_SUMMARY}", i)
    tokens.append(_Token(_EOF, "", n))
    return tokens


def _keyword_reason(name: str, feedback: bool = False) -> str:
    if name in ("True", "False", "None"):
        return f"'{name}' is not allowed: an expression stands for a number; write a number"
    if feedback and name in ("if", "else"):
        return (f"'{name}' is not allowed: write a switch as where(condition, a, b), as in "
                "where(q1 > 0, -1, 1)")
    if name in ("and", "or", "not", "is", "in", "if", "else"):
        return (f"'{name}' is not allowed: logical operators, comparisons and conditions "
                "are not part of an expression, which must be a single formula")
    return (f"'{name}' is a Python keyword and is not allowed: an expression is a "
            f"formula, not Python code; it may only use {_ALLOWED_SUMMARY}")


def _number_value(text: str, pos: int, whole: str, fraction: str,
                  exponent: str | None) -> sympy.Rational:
    """The exact value of a number literal, refusing absurdly large or long ones."""
    digits = (whole + fraction).lstrip("0")
    if not digits:
        return sympy.Integer(0)
    if len(digits) > MAX_LITERAL_DIGITS:
        _fail(text, f"number too long: it has more than {MAX_LITERAL_DIGITS} significant "
                    "digits", pos)
    shift = -len(fraction)
    if exponent is not None:
        if len(exponent.lstrip("+-").lstrip("0")) > 6:
            _fail(text, "number too large: its decimal exponent is out of range "
                        f"(at most {MAX_LITERAL_DIGITS})", pos)
        shift += int(exponent)
    if len(digits) + shift > MAX_LITERAL_DIGITS or -shift > MAX_LITERAL_DIGITS:
        _fail(text, "number too large: its decimal exponent is out of range "
                    f"(at most {MAX_LITERAL_DIGITS})", pos)
    mantissa = int(digits)
    if shift >= 0:
        return sympy.Integer(mantissa * 10**shift)
    return sympy.Rational(mantissa, 10**-shift)


# ---------------------------------------------------------------------------
# Syntax tree
# ---------------------------------------------------------------------------

@dataclass(frozen=True, slots=True)
class _Num:
    value: sympy.Rational


@dataclass(frozen=True, slots=True)
class _Name:
    name: str
    pos: int


@dataclass(frozen=True, slots=True)
class _Neg:
    operand: "_Node"


@dataclass(frozen=True, slots=True)
class _Sum:
    terms: tuple[tuple[bool, "_Node"], ...]  # (negated, term)


@dataclass(frozen=True, slots=True)
class _Product:
    factors: tuple[tuple[bool, "_Node", int], ...]  # (divided, factor, operator position)


@dataclass(frozen=True, slots=True)
class _Pow:
    base: "_Node"
    exponent: "_Node"
    pos: int


@dataclass(frozen=True, slots=True)
class _Call:
    function: str
    args: tuple["_Node", ...]
    pos: int


@dataclass(frozen=True, slots=True)
class _Compare:
    """a < b <= c ...: the operators with their positions, and the operands."""
    ops: tuple[tuple[str, int], ...]
    operands: tuple["_Node", ...]
    start: int
    end: int

    @property
    def pos(self) -> int:
        return self.ops[0][1]


@dataclass(frozen=True, slots=True)
class _Logic:
    """c1 and c2 ..., or c1 or c2 ...: `word` at the positions `positions`."""
    word: str
    operands: tuple["_Node", ...]
    positions: tuple[int, ...]
    start: int
    end: int

    @property
    def pos(self) -> int:
        return self.positions[0]


@dataclass(frozen=True, slots=True)
class _Not:
    operand: "_Node"
    pos: int
    start: int
    end: int


_Node = Union[_Num, _Name, _Neg, _Sum, _Product, _Pow, _Call, _Compare, _Logic, _Not]
_CONDITIONS = (_Compare, _Logic, _Not)

_OPERAND_START = (_NUM, _NAME, _LPAREN)


class _Parser:
    """Recursive-descent parser from tokens to a syntax tree.

    It records the unknown names it meets instead of failing on them, so that every
    syntax error is reported first and all unknown names together.
    """

    def __init__(self, text: str, tokens: list[_Token], known: Mapping[str, object],
                 feedback: bool = False):
        self.text = text
        self.tokens = tokens
        self.known = known
        self.feedback = feedback
        self.functions = {**_FUNCTIONS, **_FEEDBACK_FUNCTIONS} if feedback else _FUNCTIONS
        self.index = 0
        self.depth = 0
        self.unknown: dict[str, int] = {}

    # -- helpers ------------------------------------------------------------

    def peek(self) -> _Token:
        return self.tokens[self.index]

    def previous(self) -> _Token | None:
        return self.tokens[self.index - 1] if self.index > 0 else None

    def advance(self) -> _Token:
        token = self.tokens[self.index]
        self.index += 1
        return token

    def fail(self, reason: str, position: int | None) -> NoReturn:
        _fail(self.text, reason, position)

    def enter(self, token: _Token) -> None:
        self.depth += 1
        if self.depth > MAX_DEPTH:
            self.fail(f"expression nested too deeply: more than {MAX_DEPTH} levels of "
                      "parentheses, function calls or powers; simplify it or split it "
                      "into parameters", token.pos)

    def is_known(self, name: str) -> bool:
        return name in self.known or name in _CONSTANTS

    # -- grammar ------------------------------------------------------------

    def parse(self) -> _Node:
        if self.peek().kind == _EOF:
            self.fail("empty expression: write a formula such as 'm*g*h' or "
                      "'1/2*m*x_dot**2'", None)
        node = self.condition() if self.feedback else self.sum()
        self.number(node)
        token = self.peek()
        if token.kind == _RPAREN:
            self.fail("unexpected ')': it has no matching '('; remove it or add the "
                      "missing '('", token.pos)
        if token.kind == _COMMA:
            self.comma_outside_call(token)
        assert token.kind == _EOF, token
        return node

    # -- conditions (feedback laws only) -------------------------------------

    def number(self, node: _Node) -> _Node:
        """`node`, which must stand for a number: a condition there is an error with a fix."""
        if isinstance(node, _CONDITIONS):
            shown = self.text[node.start:node.end].strip()
            self.fail(f"the condition '{shown}' is true or false, not a number: use it as the "
                      f"condition of where({shown}, a, b), as in where({shown}, 1, 0) for 1 "
                      "where it holds and 0 elsewhere", node.pos)
        return node

    def condition_operand(self, node: _Node, word: str, pos: int, shown: str) -> _Node:
        """`node` (source text `shown`), an operand of and, or, not: it must be a condition."""
        if not isinstance(node, _CONDITIONS):
            self.fail(f"'{word}' joins conditions such as q1 > 0, but '{shown}' is a number; "
                      f"compare it with something, as in {shown} > 0", pos)
        return node

    def previous_end(self) -> int:
        token = self.previous()
        return token.pos + len(token.text) if token is not None else 0

    def spanned(self, parse: Callable[[], _Node]) -> tuple[_Node, str]:
        """The node `parse` reads and its source text."""
        start = self.peek().pos
        node = parse()
        return node, self.text[start:self.previous_end()].strip()

    def condition(self) -> _Node:
        return self.logic("or", self.conjunction)

    def conjunction(self) -> _Node:
        return self.logic("and", self.negation)

    def logic(self, word: str, operand: Callable[[], _Node]) -> _Node:
        start = self.peek().pos
        first, shown = self.spanned(operand)
        if not (self.peek().kind == _LOGIC and self.peek().text == word):
            return first
        operands, positions = [first], []
        while self.peek().kind == _LOGIC and self.peek().text == word:
            token = self.advance()
            positions.append(token.pos)
            self.condition_operand(operands[-1], word, token.pos, shown)
            node, shown = self.spanned(operand)
            operands.append(node)
        self.condition_operand(operands[-1], word, positions[-1], shown)
        return _Logic(word, tuple(operands), tuple(positions), start, self.previous_end())

    def negation(self) -> _Node:
        token = self.peek()
        if token.kind == _LOGIC and token.text == "not":
            self.advance()
            self.enter(token)
            operand, shown = self.spanned(self.negation)
            self.condition_operand(operand, "not", token.pos, shown)
            self.depth -= 1
            return _Not(operand, token.pos, token.pos, self.previous_end())
        return self.comparison()

    def comparison(self) -> _Node:
        start = self.peek().pos
        first = self.sum()
        if self.peek().kind != _CMP:
            return first
        operands, ops = [self.number(first)], []
        while self.peek().kind == _CMP:
            token = self.advance()
            ops.append((token.text, token.pos))
            operands.append(self.number(self.sum()))
        return _Compare(tuple(ops), tuple(operands), start, self.previous_end())

    # -- arithmetic -----------------------------------------------------------

    def sum(self) -> _Node:
        terms = [(False, self.product())]
        while self.peek().kind == _OP and self.peek().text in "+-":
            negated = self.advance().text == "-"
            terms.append((negated, self.product()))
        if len(terms) == 1:
            return terms[0][1]
        for _negated, term in terms:
            self.number(term)
        return _Sum(tuple(terms))

    def product(self) -> _Node:
        first = self.unary()
        factors = [(False, first, -1)]
        while self.peek().kind == _OP and self.peek().text in ("*", "/"):
            op = self.advance()
            factors.append((op.text == "/", self.unary(), op.pos))
        if len(factors) == 1:
            return first
        for _divided, factor, _pos in factors:
            self.number(factor)
        return _Product(tuple(factors))

    def unary(self) -> _Node:
        negated = False
        while self.peek().kind == _OP and self.peek().text in "+-":
            negated ^= self.advance().text == "-"
        node = self.power()
        return _Neg(self.number(node)) if negated else node

    def power(self) -> _Node:
        base = self.atom()
        token = self.peek()
        if token.kind == _OP and token.text in ("**", "^"):
            self.number(base)
            self.advance()
            self.enter(token)
            exponent = self.number(self.unary())
            self.depth -= 1
            return _Pow(base, exponent, token.pos)
        if token.kind in _OPERAND_START:
            before = self.previous()
            assert before is not None
            self.fail(f"missing operator between '{before.text}' and '{token.text}': "
                      f"write '{before.text}*{token.text}' to multiply them", token.pos)
        return base

    def atom(self) -> _Node:
        token = self.peek()
        if token.kind == _NUM:
            self.advance()
            assert token.value is not None
            return _Num(token.value)
        if token.kind == _NAME:
            self.advance()
            name = token.text
            if self.peek().kind == _LPAREN:
                return self.call(token)
            if not self.is_known(name):
                if name in self.functions:
                    example = self.functions[name][2]
                    self.fail(f"'{name}' is a function: write its argument in "
                              f"parentheses, as in {example}", token.pos)
                self.unknown.setdefault(name, token.pos)
            return _Name(name, token.pos)
        if token.kind == _LPAREN:
            self.advance()
            self.enter(token)
            if self.peek().kind == _RPAREN:
                self.fail("empty parentheses '()': write an expression inside them",
                          token.pos)
            if self.peek().kind == _EOF:
                self.missing_close(token)
            node = self.condition() if self.feedback else self.sum()
            close = self.peek()
            if close.kind == _COMMA:
                self.comma_outside_call(close)
            if close.kind != _RPAREN:
                self.missing_close(token)
            self.advance()
            self.depth -= 1
            return node
        self.missing_operand(token)

    def call(self, name_token: _Token) -> _Node:
        name = name_token.text
        open_paren = self.advance()
        if name not in self.functions:
            if self.is_known(name):
                self.fail(f"'{name}' is not a function and cannot be called: write "
                          f"'{name}*(...)' to multiply", name_token.pos)
            if name in _FEEDBACK_FUNCTIONS:
                self.fail(f"'{name}' may only be used in an input or an event (a feedback law or "
                          "a switch, which a simulation evaluates), not in the model's energies, "
                          "forces or positions, whose derivatives are taken", name_token.pos)
            self.fail(_unknown_function_reason(name, self.feedback), name_token.pos)
        function, arity, example = self.functions[name]
        self.enter(open_paren)
        if self.peek().kind == _RPAREN:
            plural = "argument" if arity == 1 else "arguments"
            self.fail(f"empty argument: {name}() needs {arity} {plural}, as in {example}",
                      self.peek().pos)
        args: list[_Node] = []
        while True:
            token = self.peek()
            if token.kind == _COMMA:
                self.fail(f"empty argument before ',' in {name}(...): write an expression "
                          f"there, as in {example}", token.pos)
            if token.kind == _RPAREN:
                comma = self.previous()
                assert comma is not None
                self.fail(f"empty argument after ',' in {name}(...): write an expression "
                          f"there or remove the ',', as in {example}", comma.pos)
            if token.kind == _EOF:
                self.missing_close(open_paren)
            args.append(self.condition() if self.feedback else self.sum())
            token = self.advance()
            if token.kind == _RPAREN:
                break
            if token.kind != _COMMA:
                self.missing_close(open_paren)
        self.depth -= 1
        if arity == -2 and len(args) < 2:
            self.fail(f"wrong number of arguments: {name} takes two or more arguments, as in "
                      f"{example}, but got {len(args)}", name_token.pos)
        if arity >= 0 and len(args) != arity:
            plural = "argument" if arity == 1 else "arguments"
            self.fail(f"wrong number of arguments: {name} takes {arity} {plural}, as in "
                      f"{example}, but got {len(args)}", name_token.pos)
        if name == "where":
            if not isinstance(args[0], _CONDITIONS):
                self.fail("the first argument of where(condition, a, b) must be a condition "
                          "such as q1 > 0 or abs(q2) < 0.3 and q2_dot > 0, not a number",
                          name_token.pos)
            args[1:] = [self.number(a) for a in args[1:]]
        else:
            args = [self.number(a) for a in args]
        return _Call(name, tuple(args), name_token.pos)

    # -- error reasons ------------------------------------------------------

    def missing_close(self, open_paren: _Token) -> NoReturn:
        self.fail("missing ')': the '(' here is never closed; add a ')' to close it",
                  open_paren.pos)

    def comma_outside_call(self, comma: _Token) -> NoReturn:
        self.fail("unexpected ',': a comma may only separate the arguments of a function "
                  "call such as atan2(y, x)", comma.pos)

    def missing_operand(self, token: _Token) -> NoReturn:
        before = self.previous()
        hint = "write a number, a name or an expression in parentheses"
        if before is not None and before.kind == _OP:
            if token.kind == _OP:
                self.fail(f"missing operand between '{before.text}' and '{token.text}': "
                          f"{hint} between them", token.pos)
            self.fail(f"missing operand after '{before.text}': {hint} after it", before.pos)
        if token.kind == _OP:
            self.fail(f"missing operand before '{token.text}': {hint} before it", token.pos)
        if token.kind == _RPAREN:
            self.fail("unexpected ')': it has no matching '('; remove it or add the "
                      "missing '('", token.pos)
        if token.kind == _COMMA:
            self.comma_outside_call(token)
        self.fail(f"missing operand: {hint}", token.pos)  # pragma: no cover


def _unknown_function_reason(name: str, feedback: bool = False) -> str:
    allowed = ALLOWED_FUNCTIONS + (FEEDBACK_FUNCTIONS if feedback else ())
    suggestion = _FUNCTION_ALIASES.get(name)
    if suggestion is None and name.lower() in allowed:
        suggestion = name.lower()
    if suggestion is None and feedback:
        suggestion = {"ifelse": "where", "select": "where", "if_else": "where", "piecewise": "where",
                      "clamp": "clip", "sat": "clip", "saturate": "clip", "fmin": "min",
                      "fmax": "max", "minimum": "min", "maximum": "max"}.get(name.lower())
    if suggestion is None:
        suggestion = closest(name, allowed)
    hint = f" (did you mean '{suggestion}'?)" if suggestion else ""
    return (f"unknown function '{name}'{hint}: the allowed functions are "
            + ", ".join(allowed))


# ---------------------------------------------------------------------------
# Evaluation
# ---------------------------------------------------------------------------

_UNDEFINED = (sympy.zoo, sympy.nan, sympy.oo, -sympy.oo)


def _rational_bits(value: sympy.Rational) -> int:
    """Binary digits of the larger of numerator and denominator; 0 for 0, 1 and -1."""
    p, q = abs(int(value.p)), int(value.q)
    if p <= 1 and q == 1:
        return 0
    return max(p.bit_length(), q.bit_length())


class _Evaluator:
    """Build the sympy expression of a syntax tree with ordinary sympy evaluation.

    Each method returns the expression and an upper bound of the size, in bits, of
    the numbers in it, so that a computation that would create a gigantic number is
    refused before it starts.
    """

    def __init__(self, text: str, names: Mapping[str, sympy.Basic]):
        self.text = text
        self.names = names
        self.name_bits: dict[str, int] = {}

    def fail(self, reason: str, position: int | None) -> NoReturn:
        _fail(self.text, reason, position)

    def check_bits(self, bits: int, position: int | None) -> None:
        if bits > MAX_BITS:
            self.fail(f"number too large: this would create a number with more than "
                      f"{MAX_BITS} binary digits; use smaller numbers or keep the "
                      "exponent symbolic", position)

    def build(self, node: _Node) -> tuple[sympy.Expr, int]:
        if isinstance(node, _Num):
            return node.value, _rational_bits(node.value)
        if isinstance(node, _Name):
            return self.name(node)
        if isinstance(node, _Neg):
            value, bits = self.build(node.operand)
            return -value, bits
        if isinstance(node, _Sum):
            values: list[sympy.Expr] = []
            total = 0
            for negated, term in node.terms:
                value, bits = self.build(term)
                values.append(-value if negated else value)
                total += bits
            self.check_bits(total, None)
            return sympy.Add(*values), total
        if isinstance(node, _Product):
            return self.product(node)
        if isinstance(node, _Pow):
            return self.power(node)
        if isinstance(node, _Compare):
            return self.compare(node)
        if isinstance(node, _Logic):
            parts = [self.build(a) for a in node.operands]
            join = sympy.And if node.word == "and" else sympy.Or
            return join(*(p for p, _ in parts)), sum(b for _, b in parts)
        if isinstance(node, _Not):
            value, bits = self.build(node.operand)
            return sympy.Not(value), bits
        return self.call(node)

    def compare(self, node: _Compare) -> tuple[sympy.Basic, int]:
        values = [self.build(a) for a in node.operands]
        links = [_COMPARISONS[op](values[k][0], values[k + 1][0])
                 for k, (op, _pos) in enumerate(node.ops)]
        return (links[0] if len(links) == 1 else sympy.And(*links)), sum(b for _, b in values)

    def name(self, node: _Name) -> tuple[sympy.Expr, int]:
        if node.name in self.names:
            value = self.names[node.name]
        else:
            value = _CONSTANTS[node.name]
        if not isinstance(value, sympy.Basic):
            raise TypeError(f"names[{node.name!r}] must be a sympy object, "
                            f"not {type(value).__name__}")
        bits = self.name_bits.get(node.name)
        if bits is None:
            bits = max((_rational_bits(r) for r in value.atoms(sympy.Rational)), default=0)
            self.name_bits[node.name] = bits
        return value, bits  # type: ignore[return-value]

    def product(self, node: _Product) -> tuple[sympy.Expr, int]:
        values: list[sympy.Expr] = []
        total = 0
        for divided, factor, position in node.factors:
            value, bits = self.build(factor)
            total += bits
            if divided:
                if value.is_Number and value.is_zero:
                    self.fail("division by zero: the divisor here evaluates to 0",
                              position)
                value = sympy.Pow(value, -1)
            values.append(value)
        self.check_bits(total, None)
        return sympy.Mul(*values), total

    def power(self, node: _Pow) -> tuple[sympy.Expr, int]:
        base, base_bits = self.build(node.base)
        exponent, exponent_bits = self.build(node.exponent)
        if exponent.is_Rational:
            if base.is_Number and base.is_zero and exponent.is_negative:
                self.fail("division by zero: 0 raised to a negative power", node.pos)
            # |p/q| * bits, rounded up, compared without building huge numbers.
            p, q = abs(int(exponent.p)), int(exponent.q)
            if base_bits and p > (MAX_BITS * q) // base_bits:
                self.check_bits(MAX_BITS + 1, node.pos)
            bits = -(-p * base_bits // q) + exponent_bits
        else:
            bits = base_bits + exponent_bits
        self.check_bits(bits, node.pos)
        result = sympy.Pow(base, exponent)
        if result in _UNDEFINED:
            self.fail(f"undefined value: this power evaluates to {result}", node.pos)
        return result, bits

    def call(self, node: _Call) -> tuple[sympy.Expr, int]:
        function, _arity, _example = {**_FUNCTIONS, **_FEEDBACK_FUNCTIONS}[node.function]
        args: list[sympy.Expr] = []
        total = 0
        for arg in node.args:
            value, bits = self.build(arg)
            args.append(value)
            total += bits
        if node.function == "clip" and args[1].is_number and args[2].is_number and args[1] > args[2]:
            self.fail(f"clip(x, lo, hi) needs lo <= hi, got lo = {args[1]} > hi = {args[2]}; "
                      "swap them", node.pos)
        result = function(*args)
        if result in _UNDEFINED:
            self.fail(f"undefined value: {node.function}(...) has no finite value for "
                      f"this argument (it evaluates to {result}); check the argument",
                      node.pos)
        return result, total


_FLOAT_FUNCTIONS: dict[str, Callable[..., float]] = {
    "sin": math.sin, "cos": math.cos, "tan": math.tan, "asin": math.asin, "acos": math.acos,
    "atan": math.atan, "atan2": math.atan2, "sinh": math.sinh, "cosh": math.cosh, "tanh": math.tanh,
    "exp": math.exp, "log": math.log, "sqrt": math.sqrt, "abs": abs,
    "sign": lambda x: float((x > 0) - (x < 0)), "min": min, "max": max,
    "clip": lambda x, lo, hi: min(max(x, lo), hi),
}


class _Constants:
    """The floating-point value of every constant part of an expression (None where it depends on
    a name), computed in doubles, so that a constant no double holds (``exp(exp(exp(100)))``,
    ``10**400``) or without a real value (``sqrt(-1)``, ``acos(2)``) is refused before any
    symbolic work on it, and so is a power of a variable with an exponent past
    :data:`lagrangian._limits.MAX_EXPONENT`. Every subexpression is visited, constant or not."""

    def __init__(self, text: str, names: Mapping[str, sympy.Basic]):
        self.text = text
        self.names = names
        self.max_exponent = MAX_EXPONENT.value

    def fail(self, reason: str, position: int | None) -> NoReturn:
        _fail(self.text, reason, position)

    def too_large(self, position: int | None, what: str = "this constant") -> NoReturn:
        self.fail(f"number too large: {what} is beyond the largest floating-point number (about 1.8e308), "
                  "so no simulation can compute it; use smaller numbers", position)

    def finite(self, value, position: int | None, what: str = "this constant") -> float:
        if isinstance(value, complex):
            self.fail(f"not a real number: {what} has no real value; check the signs and the "
                      "functions' domains", position)
        if not math.isfinite(value):
            self.too_large(position, what)
        return value

    def value(self, node: _Node) -> float | None:
        if isinstance(node, _Num):
            try:
                return int(node.value.p) / int(node.value.q)
            except OverflowError:
                self.too_large(None, f"the number {str(node.value)[:20]}...")
        if isinstance(node, _Name):
            value = self.names.get(node.name, _CONSTANTS.get(node.name))
            if isinstance(value, sympy.Rational):
                try:
                    return int(value.p) / int(value.q)
                except OverflowError:
                    self.too_large(node.pos, f"'{node.name}'")
            return math.pi if value is sympy.pi else None
        if isinstance(node, _Neg):
            v = self.value(node.operand)
            return None if v is None else -v
        if isinstance(node, _Sum):
            values = [(negated, self.value(term)) for negated, term in node.terms]
            if any(v is None for _, v in values):
                return None
            try:
                total = math.fsum(-v if negated else v for negated, v in values)
            except OverflowError:  # an intermediate sum past the doubles: 1e308 + 1e308
                self.too_large(None, "this sum")
            return self.finite(total, None, "this sum")
        if isinstance(node, _Product):
            return self.product(node)
        if isinstance(node, _Pow):
            return self.power(node)
        if isinstance(node, _Call):
            return self.call(node)
        operands = node.operands if isinstance(node, (_Compare, _Logic)) else (node.operand,)
        for operand in operands:
            self.value(operand)
        return None

    def product(self, node: _Product) -> float | None:
        result: float | None = 1.0
        for divided, factor, position in node.factors:
            v = self.value(factor)
            if v is None or result is None:
                result = None
                continue
            try:
                result = result / v if divided else result * v
            except ZeroDivisionError:
                self.too_large(position, "this quotient")
            self.finite(result, position, "this product")
        return result

    def power(self, node: _Pow) -> float | None:
        base, exponent = self.value(node.base), self.value(node.exponent)
        if exponent is not None and base is None and abs(exponent) > self.max_exponent:
            self.fail(f"exponent too large: {exponent:g} (in absolute value); {MAX_EXPONENT.how_to_raise()}",
                      node.pos)
        if base is None or exponent is None:
            return None
        try:
            result = base ** exponent
        except OverflowError:
            self.too_large(node.pos, "this power")
        except ZeroDivisionError:
            self.fail("division by zero: 0 raised to a negative power", node.pos)
        return self.finite(result, node.pos, "this power")

    def call(self, node: _Call) -> float | None:
        args = [self.value(a) for a in node.args]
        function = _FLOAT_FUNCTIONS.get(node.function)
        if function is None or any(a is None for a in args):
            return None
        what = f"{node.function}({', '.join(f'{a:g}' for a in args)})"
        try:
            result = function(*args)
        except OverflowError:
            self.too_large(node.pos, what)
        except ValueError:
            self.fail(f"not a real number: {what} has no real value (its argument is outside the "
                      f"domain of {node.function}); check the argument", node.pos)
        return self.finite(result, node.pos, what)


# ---------------------------------------------------------------------------
# Public API
# ---------------------------------------------------------------------------

def parse_expression(text: str, names: Mapping[str, sympy.Basic], *,
                     feedback: bool = False) -> sympy.Expr:
    """Parse a model-file expression into a sympy expression, safely.

    Parameters
    ----------
    text : str
        The expression, e.g. ``"1/2*m*(l*q1_dot)**2 - m*g*l*(1 - cos(q1))"``.
        See the module documentation for the grammar.
    names : mapping of str to sympy.Basic
        Every name the expression may use, with the sympy object it stands for
        (coordinates, velocities such as ``q1_dot``, parameters, inputs, ``t``).
        ``pi`` is always available as ``sympy.pi`` unless `names` defines it.
    feedback : bool
        Read the language of inputs and events: with the functions of
        :data:`FEEDBACK_FUNCTIONS` (min, max, clip, where) and conditions (comparisons joined
        by and, or, not) as the first argument of where.

    Returns
    -------
    sympy.Expr
        The expression, built with ordinary sympy evaluation. Numbers are exact:
        ``0.5`` is ``Rational(1, 2)`` and ``1/2*m`` is ``m/2``.

    Raises
    ------
    ExpressionError
        If the text is not a valid expression (empty, unexpected character, unbalanced
        parentheses, missing operand or operator, unknown function, wrong number of
        arguments, Python-only syntax, too long, nested too deeply, a number too large,
        a division by zero). Its ``position`` is the 0-based offset of the problem.
    UnknownNameError
        If the syntax is valid but names are not defined; it lists all of them, each
        with its position and the closest defined name, if any.
    TypeError
        If `text` is not a str or a used name is not mapped to a sympy object.

    Examples
    --------
    >>> import sympy
    >>> m, x = sympy.symbols("m x")
    >>> parse_expression("1/2*m*x**2", {"m": m, "x": x})
    m*x**2/2
    """
    _check_length(text)
    tokens = _tokenize(text, names, feedback)
    parser = _Parser(text, tokens, names, feedback)
    try:
        tree = parser.parse()
        if parser.unknown:
            candidates = sorted(set(names) | set(_CONSTANTS))
            unknown: list[tuple[str, int, str | None]] = []
            for name, position in parser.unknown.items():
                unknown.append((name, position, closest(name, candidates, 0.5)))
            raise UnknownNameError(text, unknown)
        result, _bits = _Evaluator(text, names).build(tree)
        _Constants(text, names).value(tree)
    except RecursionError:  # pragma: no cover - the depth limit comes first
        _fail(text, "expression nested too deeply: simplify it or split it into "
                    "parameters", None)
    if result.has(*_UNDEFINED):
        _fail(text, "undefined value: the expression contains an infinite or undefined "
                    "quantity; check for a division by zero", None)
    return result



def constant_value(text: str, where: str, names: Mapping[str, float] | None = None) -> float:
    """A number, or a constant expression such as pi/2 (parsed safely); with `names` (name -> value,
    e.g. a model's parameters), also an expression of those, g*l1*(m1/2 + m2), at their values. The
    value of a numeric option (the CLI's, the playground's); a ModelError says `where` it was given."""
    try:
        value = float(text)
    except ValueError:
        pass
    else:
        if not math.isfinite(value):
            raise ModelError(f"{where}: '{text}' is not a finite number; write e.g. 0.5 or pi/2")
        return value
    try:
        value = parse_expression(text, {k: sympy.Float(v) for k, v in (names or {}).items()})
    except ExpressionError as exc:
        also = f", or an expression of the parameters {', '.join(names)}" if names else ""
        raise ModelError(f"{where}: '{text}' is not a number ({exc.reason}); write e.g. 0.5 or pi/2{also}") from None
    return float(value)  # finite and real: the parser refuses every other constant

def identifiers(text: str) -> list[tuple[str, int]]:
    """The names an expression refers to, with their 0-based positions.

    Every occurrence of an identifier is listed, in order, except the function names
    of :data:`ALLOWED_FUNCTIONS` and any identifier directly followed by ``(`` (a
    call). Python keywords are listed like other identifiers. ``pi`` is included.

    Parameters
    ----------
    text : str
        The expression.

    Returns
    -------
    list of (str, int)

    Raises
    ------
    ExpressionError
        If the text is too long or contains a character that cannot start a token.
    """
    _check_length(text)
    tokens = _tokenize(text)
    return [
        (token.text, token.pos)
        for token, following in zip(tokens, tokens[1:])
        if token.kind == _NAME
        and following.kind != _LPAREN
        and token.text not in _FUNCTIONS
    ]
