"""The report's MathML written without minidom's writer, and each symbol's MathML made once: the same
text as SymPy's printer with minidom's ``toxml`` and the symbols built anew (issue 22: a quarter of the
bicycle's printing time was minidom's writer)."""

from __future__ import annotations

from xml.dom.minidom import Document

import pytest
import sympy
from sympy.printing.mathml import MathMLPresentationPrinter

import lagrangian as lg
from lagrangian.reporting import _printing
from lagrangian.reporting._printing import ConstraintForce, Partial, Rotation, TimeDerivative, _xml, mathml


class _Reference(_printing._MathML):
    """SymPy's doprint (minidom's toxml) and each symbol built anew: what the report printed before."""

    doprint = MathMLPresentationPrinter.doprint
    _print_Symbol = _printing._MathML._symbol_node


def _reference(expr) -> str:
    text = _printing._numeric_entities(_Reference().doprint(expr))
    return text.replace("<mo>-</mo>", "<mo>&#x2212;</mo>")


a, b, theta, q1_dot, x_ddot = sympy.symbols("a b theta q1_dot x_ddot")
EXPRESSIONS = [
    a, theta, q1_dot, x_ddot, sympy.Symbol("lambda_front_contact"), sympy.Symbol("m_1^2"), sympy.Symbol("ell"),
    -a * sympy.sin(theta) / (1 + b ** 2), sympy.sqrt(a) * q1_dot ** 3 - sympy.Rational(3, 7),
    sympy.Matrix([[a, -b], [sympy.cos(theta), 0]]), sympy.Lt(a, b), sympy.Eq(a, b - 1), sympy.Float(0.1, 6) * a,
    Partial(sympy.Symbol("L"), q1_dot), TimeDerivative(a * q1_dot), Rotation("z", theta) * Rotation("x", a),
    ConstraintForce(2), sympy.Tuple(sympy.Eq(a, 1), sympy.Eq(b, sympy.pi / 2)), sympy.Symbol("Q_1"),
    sympy.Integer(-3), sympy.Symbol("x") * sympy.Symbol("y"), sympy.exp(-a) * sympy.log(b),
]


@pytest.mark.parametrize("expr", EXPRESSIONS, ids=range(len(EXPRESSIONS)))
def test_the_same_text_as_minidom(expr):
    _printing._SYMBOLS.clear()
    first = mathml(expr)
    assert first == _reference(expr)
    assert mathml(expr) == first  # the symbols' kept MathML


@pytest.mark.parametrize("example", ["cart-pendulum", "double-pendulum", "four-bar", "rolling-disk"])
def test_every_expression_of_a_report_prints_as_before(example):
    rep = lg.report(example, equilibria=False)
    exprs = [p for block in rep.math_blocks() for p in block.parts()
             if _printing.too_large(p, rep.max_nodes) is None]
    assert exprs
    for expr in exprs:
        assert mathml(expr) == _reference(expr)


def test_what_the_writer_does_not_know_goes_to_minidom():
    doc = Document()
    el = doc.createElement("mi")
    el.setAttribute("title", 'a "quoted" & <odd> value')  # minidom escapes it (how depends on the version)
    el.appendChild(doc.createTextNode("x"))
    assert _xml(el, [], type(doc.createTextNode(""))) is False  # a Text that is not SymPy's raw text, too
    plain = doc.createElement("mrow")
    plain.appendChild(doc.createComment("no"))
    assert _xml(plain, [], type(doc.createTextNode(""))) is False
    empty = doc.createElement("mspace")
    empty.setAttribute("width", "1em")
    out: list = []
    assert _xml(empty, out, type(doc.createTextNode(""))) is True
    assert "".join(out) == empty.toxml() == '<mspace width="1em"/>'


def test_a_symbol_whose_name_is_markup_is_escaped_as_before():
    name = sympy.Symbol("a<b>&c")
    _printing._SYMBOLS.clear()
    assert mathml(name) == _reference(name)


def test_a_symbol_name_with_markup_is_escaped_in_mathml():
    """SymPy's MathML printer writes text nodes raw; a symbol named with markup (possible from the Python
    API's SymPy symbols, not from a model file) must not become markup in a report."""
    import sympy

    from lagrangian.reporting._printing import mathml

    out = mathml(sympy.Symbol("a<b>&c") ** 2 + sympy.Symbol("x</mi><script>") + 1)
    assert "<b>" not in out and "<script>" not in out
    assert "a&lt;b&gt;&amp;c" in out and "x&lt;/mi&gt;&lt;script&gt;" in out
    assert mathml(sympy.Symbol("theta")) == "<mi>&#952;</mi>" and mathml(sympy.Symbol("ell")) == "<mi>&#8467;</mi>"


def test_too_large_counts_the_nodes_preorder_traversal_visits():
    """_printing.too_large counts from a stack the nodes sympy.preorder_traversal visits (nested sums and
    products, a shared subexpression counted at each place, a matrix, Max's argument set, a tuple with text in
    it): None up to the limit, limit + 1 past it, at every limit around each object's size."""
    x, y, z = sympy.symbols("x y z")
    shared = sympy.sin(x + y) * sympy.cos(z) + x ** 2
    objects = [x, sympy.Integer(3), shared, shared * (shared + 1) - sympy.sqrt(shared), sympy.Max(x, y, shared),
               sympy.ImmutableMatrix([[shared, x], [0, sympy.exp(-y)]]), (shared, "text", x + 1), ("only text",),
               sympy.Eq(x, shared, evaluate=False)]

    def traversal(obj, limit):
        count = 0
        for item in obj if isinstance(obj, tuple) else (obj,):
            if isinstance(item, sympy.Basic):
                for _ in sympy.preorder_traversal(item):
                    count += 1
                    if count > limit:
                        return count
        return None

    for obj in objects:
        size = 0 if traversal(obj, 0) is None else next(n for n in range(1, 1000) if traversal(obj, n) is None)
        for limit in sorted({0, 1, 2, size - 1, size, size + 1, 400} - {-1}):
            assert _printing.too_large(obj, limit) == traversal(obj, limit), (obj, limit)


def test_mathml_printed_once_per_expression_never_mixes_equal_hashes():
    """_printing.mathml keeps the MathML of the expressions it printed (by expression): objects whose hashes
    are equal but that are not equal (2 and 2.0, one float at two precisions, True and 1) each print as
    themselves, whichever came first; a mutable matrix (not hashable) is printed each time."""
    pairs = [(sympy.Integer(2), sympy.Float(2.0)), (sympy.Float(0.5, 6), sympy.Float(0.5, 15)),
             (sympy.S.true, sympy.Integer(1)), (sympy.Integer(1), sympy.Float(1, 3))]
    for a, b in pairs:
        assert hash(a) == hash(b) and a != b
        for first, second in ((a, b), (b, a)):
            _printing._PRINTED.clear()
            want = _printing._printed(second)
            _printing.mathml(first)
            assert _printing.mathml(second) == want
    _printing._PRINTED.clear()
    M = sympy.Matrix([[1, sympy.Symbol("x")]])
    assert _printing.mathml(M) == _printing._printed(M) == _printing.mathml(sympy.ImmutableMatrix(M))
    assert not any(isinstance(k, sympy.MutableDenseMatrix) for k in _printing._PRINTED)
