"""Printing for reports: LaTeX and presentation MathML with the project's symbol names
(``q1_dot`` as q with a dot and subscript 1, ``theta`` as the Greek letter), unevaluated
operators (partial and total time derivatives, elementary rotations, the constraint forces
(G^T lambda)_i) and a size guard for large expressions."""

from __future__ import annotations

import html
import html.entities
import re

import sympy
from sympy.printing.conventions import split_super_sub
from sympy.printing.latex import LatexPrinter
from sympy.printing.mathml import MathMLPresentationPrinter
from sympy.printing.printer import Printer
from sympy.printing.pretty.pretty_symbology import greek_unicode
from sympy.utilities.iterables import iterable

__all__ = ["Partial", "TimeDerivative", "Rotation", "Given", "ConstraintForce", "latex", "mathml", "too_large",
           "MAX_NODES"]

#: Expressions with more nodes than this are not printed (the report says so instead).
MAX_NODES = 2500

_ACCENTS = (("_ddot", "ddot", "\u00a8"), ("_dot", "dot", "\u02d9"))
_SPECIAL = {"ell": "\u2113"}
_MATHML_NS = "http://www.w3.org/1998/Math/MathML"


class Partial(sympy.Expr):
    """The unevaluated partial derivative d`f`/d`x` of a named function (printing only)."""

    def __new__(cls, f, x):
        return sympy.Expr.__new__(cls, sympy.sympify(f), sympy.sympify(x))

    def _latex(self, printer):
        f, x = self.args
        return f"\\frac{{\\partial {printer._print(f)}}}{{\\partial {printer._print(x)}}}"

    def _mathml_presentation(self, printer):
        f, x = self.args
        dom = printer.dom
        frac = dom.createElement("mfrac")
        for var in (f, x):
            row = dom.createElement("mrow")
            mo = dom.createElement("mo")
            mo.appendChild(dom.createTextNode("\u2202"))
            row.appendChild(mo)
            row.appendChild(printer._print(var))
            frac.appendChild(row)
        return frac

    def _sympystr(self, printer):
        return f"d{printer._print(self.args[0])}/d{printer._print(self.args[1])}"


class TimeDerivative(sympy.Expr):
    """The unevaluated total time derivative d/dt(`f`) (printing only)."""

    def __new__(cls, f):
        return sympy.Expr.__new__(cls, sympy.sympify(f))

    def _latex(self, printer):
        return f"\\frac{{d}}{{dt}}\\left({printer._print(self.args[0])}\\right)"

    def _mathml_presentation(self, printer):
        dom = printer.dom
        row = dom.createElement("mrow")
        frac = dom.createElement("mfrac")
        for text in ("d", "dt"):
            mi = dom.createElement("mi")
            mi.setAttribute("mathvariant", "normal")
            mi.appendChild(dom.createTextNode(text))
            frac.appendChild(mi)
        row.appendChild(frac)
        for piece in ("(", None, ")"):
            if piece is None:
                row.appendChild(printer._print(self.args[0]))
            else:
                mo = dom.createElement("mo")
                mo.appendChild(dom.createTextNode(piece))
                row.appendChild(mo)
        return row

    def _sympystr(self, printer):
        return f"d/dt({printer._print(self.args[0])})"


class Rotation(sympy.Expr):
    """The unevaluated elementary rotation R_axis(angle) (printing only; not commutative, so that
    a product of rotations keeps its order). `axis` is "x", "y", "z" or a unit vector."""

    is_commutative = False

    def __new__(cls, axis, angle):
        axis = sympy.Symbol(axis) if isinstance(axis, str) else sympy.ImmutableMatrix(axis).T
        return sympy.Expr.__new__(cls, axis, sympy.sympify(angle))

    def _latex(self, printer):
        axis, angle = self.args
        return f"R_{{{printer._print(axis)}}}\\left({printer._print(angle)}\\right)"

    def _mathml_presentation(self, printer):
        axis, angle = self.args
        dom = printer.dom
        row = dom.createElement("mrow")
        sub = dom.createElement("msub")
        mi = dom.createElement("mi")
        mi.appendChild(dom.createTextNode("R"))
        sub.appendChild(mi)
        sub.appendChild(printer._print(axis))
        row.appendChild(sub)
        for piece in ("(", None, ")"):
            if piece is None:
                row.appendChild(printer._print(angle))
            else:
                mo = dom.createElement("mo")
                mo.appendChild(dom.createTextNode(piece))
                row.appendChild(mo)
        return row

    def _sympystr(self, printer):
        axis, angle = self.args
        axis = axis.name if isinstance(axis, sympy.Symbol) else printer._print(list(axis))
        return f"R_{axis}({printer._print(angle)})"


class Given(sympy.Expr):
    """A given matrix as a factor of a product of rotations (printing only; not commutative)."""

    is_commutative = False

    def __new__(cls, matrix):
        return sympy.Expr.__new__(cls, sympy.ImmutableMatrix(matrix))

    def _latex(self, printer):
        return printer._print(self.args[0])

    def _mathml_presentation(self, printer):
        return printer._print(self.args[0])

    def _sympystr(self, printer):
        return printer._print(self.args[0])


class ConstraintForce(sympy.Expr):
    """The unevaluated i-th generalized constraint force (G^T lambda)_i (printing only)."""

    def __new__(cls, i):
        return sympy.Expr.__new__(cls, sympy.sympify(i))

    def _latex(self, printer):
        return f"\\left(G^{{T}} \\lambda\\right)_{{{printer._print(self.args[0])}}}"

    def _mathml_presentation(self, printer):
        dom = printer.dom
        sub = dom.createElement("msub")
        row = dom.createElement("mrow")

        def add(tag, text):
            el = dom.createElement(tag)
            el.appendChild(dom.createTextNode(text))
            row.appendChild(el)

        add("mo", "(")
        sup = dom.createElement("msup")
        for text in ("G", "T"):
            mi = dom.createElement("mi")
            mi.appendChild(dom.createTextNode(text))
            sup.appendChild(mi)
        row.appendChild(sup)
        add("mi", "\u03bb")
        add("mo", ")")
        sub.appendChild(row)
        sub.appendChild(printer._print(self.args[0]))
        return sub

    def _sympystr(self, printer):
        return f"(G^T*lambda)_{printer._print(self.args[0])}"


def _split_name(name: str) -> tuple[str, str | None]:
    """(base name, accent) for ``q1_dot`` -> ("q1", "dot")."""
    for suffix, accent, _ in _ACCENTS:
        if name.endswith(suffix) and len(name) > len(suffix):
            return name[: -len(suffix)], accent
    return name, None


class _Latex(LatexPrinter):
    def _print_Symbol(self, expr, style="plain"):
        base, accent = _split_name(expr.name)
        if accent is None:
            return super()._print_Symbol(expr, style)
        name, supers, subs = split_super_sub(base)
        main = f"\\{accent}{{{super()._print_Symbol(sympy.Symbol(name), style)}}}"
        if subs:
            main += "_{" + " ".join(subs) + "}"
        if supers:
            main += "^{" + " ".join(supers) + "}"
        return main


#: The MathML of the symbols printed so far, by (name, style): at most _SYMBOLS_KEPT of them.
_SYMBOLS: dict[tuple[str, str], str] = {}
_SYMBOLS_KEPT = 4096


class _MathML(MathMLPresentationPrinter):
    def doprint(self, expr):
        """SymPy's doprint, with the printed tree written out by :func:`_xml` instead of minidom's
        ``toxml`` (the same text: a quarter of the bicycle's printing time went to minidom's writer)."""
        node = Printer._print(self, expr)
        parts: list[str] = []
        if not _xml(node, parts, type(self.dom.createTextNode(""))):
            return super().doprint(expr)
        return "".join(parts).encode("ascii", "xmlcharrefreplace").decode()

    def _print_Symbol(self, sym, style="plain"):
        """A symbol's MathML (a function of its name and style), made once per process and given as a raw
        text node: the bicycle's report prints 4000 symbols, each a name split, looked up and built anew."""
        key = (sym.name, style)
        text = _SYMBOLS.get(key)
        if text is None:
            node = self._symbol_node(sym, style)
            parts: list[str] = []
            text = "".join(parts) if _xml(node, parts, type(self.dom.createTextNode(""))) else node.toxml()
            if len(_SYMBOLS) < _SYMBOLS_KEPT:
                _SYMBOLS[key] = text
        return self.dom.createTextNode(text)

    def _symbol_node(self, sym, style="plain"):
        base, accent = _split_name(sym.name)
        name, supers, subs = split_super_sub(base)
        dom = self.dom

        def token(text):
            # a name is escaped: SymPy writes its text nodes raw (a model's names are identifiers, but
            # the Python API takes SymPy symbols of any name)
            text = _SPECIAL.get(text) or greek_unicode.get(text) or html.escape(text, quote=False)
            number = re.fullmatch(r"-?[0-9]+", text) is not None
            el = dom.createElement("mn" if number else "mi")
            text = text.replace("-", "\u2212") if number else text
            el.appendChild(dom.createTextNode(text))
            return el

        def group(items):
            if len(items) == 1:
                return token(items[0])
            row = dom.createElement("mrow")
            for i, item in enumerate(items):
                if i:
                    mo = dom.createElement("mo")
                    mo.setAttribute("separator", "true")
                    mo.appendChild(dom.createTextNode(","))
                    row.appendChild(mo)
                row.appendChild(token(item))
            return row

        x = token(name)
        if accent is not None:
            over = dom.createElement("mover")
            over.setAttribute("accent", "true")
            over.appendChild(x)
            mo = dom.createElement("mo")
            mo.appendChild(dom.createTextNode(dict((a, c) for _, a, c in _ACCENTS)[accent]))
            over.appendChild(mo)
            x = over
        if subs and supers:
            out = dom.createElement("msubsup")
            for part in (x, group(subs), group(supers)):
                out.appendChild(part)
            x = out
        elif subs or supers:
            out = dom.createElement("msub" if subs else "msup")
            out.appendChild(x)
            out.appendChild(group(subs or supers))
            x = out
        if style == "bold":
            x.setAttribute("mathvariant", "bold")
        return x


#: Characters minidom escapes in an attribute's value (which ones depends on the Python version).
_ESCAPED = re.compile(r"[&<>\"\r\n\t]")


def _xml(node, out: list, raw: type) -> bool:
    """Append to `out` what ``node.toxml()`` writes for the tree SymPy's MathML printer makes: elements
    (their attributes in order, ``<tag/>`` when empty) and its unescaped text nodes (of class `raw`).
    False (`out` then incomplete) where the tree holds anything else, or an attribute value minidom
    would escape: the caller writes it with minidom then."""
    if node.nodeType == node.TEXT_NODE:
        if type(node) is not raw:
            return False
        if node.data:
            out.append(node.data)
        return True
    if node.nodeType != node.ELEMENT_NODE:
        return False
    try:
        attrs = node._attrs  # minidom's own (None until an attribute is set): node.attributes would make it
    except AttributeError:
        return False
    out.append("<" + node.tagName)
    if attrs:
        for name, attr in attrs.items():
            value = attr.value
            if _ESCAPED.search(value):
                return False
            out.append(f' {name}="{value}"')
    children = node.childNodes
    if not children:
        out.append("/>")
        return True
    out.append(">")
    for child in children:
        if not _xml(child, out, raw):
            return False
    out.append(f"</{node.tagName}>")
    return True


_ENTITY = re.compile(r"&([A-Za-z][A-Za-z0-9]*);")


def _numeric_entities(text: str) -> str:
    """Named character references (``&InvisibleTimes;``) as numeric ones, so that the MathML is
    well-formed XML as well as valid HTML."""

    def repl(m):
        name = m.group(1)
        if name in ("lt", "gt", "amp", "quot", "apos"):
            return m.group(0)
        chars = html.entities.html5.get(name + ";")
        if chars is None:
            return m.group(0)
        return "".join(f"&#x{ord(c):X};" for c in chars)

    return _ENTITY.sub(repl, text)


def latex(expr) -> str:
    """LaTeX of a SymPy object with the report's symbol names."""
    return _Latex().doprint(expr)


#: The MathML of the expressions printed last, by expression (a pure function of its structure, which SymPy's
#: equality compares): a report prints a tenth of its expressions more than once. At most _PRINTED_KEPT of them.
_PRINTED: dict = {}
_PRINTED_KEPT = 2048


def mathml(expr) -> str:
    """Presentation MathML of a SymPy object (the content of a ``<math>`` element)."""
    if not isinstance(expr, sympy.Basic):
        return _printed(expr)
    try:
        hit = _PRINTED.get(expr)
    except TypeError:  # not hashable (a mutable matrix): printed each time
        return _printed(expr)
    if hit is None or type(hit[0]) is not type(expr):
        hit = (expr, _printed(expr))
        if len(_PRINTED) >= _PRINTED_KEPT:
            _PRINTED.clear()
        _PRINTED[expr] = hit
    return hit[1]


def _printed(expr) -> str:
    return _numeric_entities(_MathML().doprint(expr)).replace("<mo>-</mo>", "<mo>&#x2212;</mo>")


def math_element(inner: str, *, block: bool) -> str:
    """Wrap presentation MathML into a ``<math>`` element."""
    display = ' display="block"' if block else ""
    return f'<math xmlns="{_MATHML_NS}"{display}>{inner}</math>'


def too_large(obj, limit: int = MAX_NODES) -> int | None:
    """None when `obj` (an expression, matrix or tuple of them) has at most `limit` nodes,
    else the number of nodes counted so far (more than `limit`). Stops counting early.

    The nodes are those sympy.preorder_traversal visits (a LatticeOp's argument set, the items of an
    iterable that is not an expression), counted from a stack instead of its nested generators (each
    node passed up through every generator above it: a third of the bicycle's HTML time)."""
    count = 0
    items = obj if isinstance(obj, tuple) else (obj,)
    stack = [item for item in items if isinstance(item, sympy.Basic)]
    basic = sympy.Basic
    while stack:
        node = stack.pop()
        count += 1
        if count > limit:
            return count
        if isinstance(node, basic):
            stack.extend(node._argset if hasattr(node, "_argset") else node.args)
        elif iterable(node):
            stack.extend(node)
    return None
