"""The document model of a derivation report: sections of paragraphs, displayed mathematics
(SymPy expressions, never pre-printed strings) and tables, rendered by three writers.

Every class is a frozen dataclass, so a :class:`Report` is an immutable value: the writers
(:meth:`Report.to_html`, :meth:`Report.to_markdown`, :meth:`Report.to_latex`) only read it.
"""

from __future__ import annotations

import os
from dataclasses import dataclass
from typing import Union

import sympy

from ._printing import MAX_NODES

__all__ = ["Report", "Section", "Paragraph", "Math", "Table", "Terms", "Block"]

#: A sum written in the given order (SymPy would sort the terms of an ``Add``).
Terms = tuple


@dataclass(frozen=True)
class Paragraph:
    """A paragraph: text, with inline mathematics as SymPy objects between the strings.

    Attributes
    ----------
    parts : tuple of str, sympy.Basic or Math
        ``("det M vanishes where ", Eq(q2, pi/2), ".")``; a :class:`Math` part is shown inline.
    """

    parts: tuple

    @classmethod
    def of(cls, *parts) -> "Paragraph":
        return cls(tuple(parts))

    def text(self) -> str:
        """The paragraph as plain text (mathematics in SymPy syntax)."""
        def text(p):
            if isinstance(p, str):
                return p
            if isinstance(p, Math):
                sides = [" + ".join(map(sympy.sstr, s)) if isinstance(s, tuple) else sympy.sstr(s)
                         for s in (p.lhs, p.rhs) if s is not None]
                return f" {p.relation} ".join(sides)
            return sympy.sstr(p)

        return "".join(text(p) for p in self.parts)


@dataclass(frozen=True)
class Math:
    """Displayed mathematics: ``lhs relation rhs`` (or `rhs` alone when `lhs` is None).

    Attributes
    ----------
    rhs : sympy.Basic or tuple of sympy.Basic
        An expression, a matrix, or a tuple of terms printed as a sum in the given order.
    lhs : sympy.Basic or tuple of sympy.Basic or None
        The same kinds as `rhs`.
    relation : str
        ``"="`` (the default) or ``"=>"`` (implies, for a derived form).
    key : str
        A stable name to find the block by (``Report.math("equation[q1]")``); "" for none.
    label : str
        Text shown before the mathematics (``"(1)"``, ``"cart:"``), or "".
    """

    rhs: object
    lhs: object = None
    relation: str = "="
    key: str = ""
    label: str = ""

    def parts(self) -> tuple:
        """The SymPy objects of the block, in order (tuples of terms flattened)."""
        out = []
        for side in (self.lhs, self.rhs):
            if side is None:
                continue
            out.extend(side if isinstance(side, tuple) else (side,))
        return tuple(out)


@dataclass(frozen=True)
class Table:
    """A table of text and inline mathematics.

    Attributes
    ----------
    header : tuple of str
    rows : tuple of tuple of (str or sympy.Basic)
    """

    header: tuple
    rows: tuple


Block = Union[Paragraph, Math, Table]


@dataclass(frozen=True)
class Section:
    """A titled section of the report.

    Attributes
    ----------
    key : str
        A stable name (``"coordinates"``, ``"equations"``, ...).
    title : str
    blocks : tuple of Paragraph, Math or Table
    """

    key: str
    title: str
    blocks: tuple


@dataclass(frozen=True)
class Report:
    """A derivation report (returned by :func:`lagrangian.report`).

    It follows the recipe of the seed's slides: bodies, coordinates, positions and velocities
    of every element, T*, V, D, generalized forces Q from virtual work, the Lagrangian, each
    Lagrange equation, the matrix form, the state form, the mass-matrix diagnosis, and the
    equilibria with their stability when available.

    Attributes
    ----------
    title : str
    model_name : str
    description : str
    sections : tuple of Section
    max_nodes : int
        Expressions with more nodes than this are not printed (the writers say so in their place):
        ``_printing.MAX_NODES``, less for a model too large to expand (``_build.LARGE_MODEL_NODES``).
    """

    title: str
    model_name: str
    description: str
    sections: tuple
    max_nodes: int = MAX_NODES

    # ------------------------------------------------------------------ lookup
    def section(self, key: str) -> Section:
        """The section named `key` (``"equations"``, ``"matrix-form"``, ...)."""
        for s in self.sections:
            if s.key == key:
                return s
        raise KeyError(f"the report has no section '{key}'; its sections are "
                       f"{', '.join(s.key for s in self.sections)}")

    def math_blocks(self) -> tuple[Math, ...]:
        """Every displayed block, in order."""
        return tuple(b for s in self.sections for b in s.blocks if isinstance(b, Math))

    def keys(self) -> tuple[str, ...]:
        """The keys of the displayed blocks that have one."""
        return tuple(b.key for b in self.math_blocks() if b.key)

    def math(self, key: str) -> Math:
        """The displayed block named `key` (see :meth:`keys`)."""
        for b in self.math_blocks():
            if b.key == key:
                return b
        raise KeyError(f"the report has no mathematics named '{key}'; see Report.keys()")

    def expression(self, key: str):
        """The right-hand side of the block named `key`: a SymPy expression or matrix."""
        return self.math(key).rhs

    # ----------------------------------------------------------------- writers
    def to_html(self) -> str:
        """A self-contained HTML page; the mathematics is MathML (no script, no network)."""
        from ._writers import to_html

        return to_html(self)

    def to_markdown(self) -> str:
        """Markdown, with the mathematics as LaTeX between ``$$`` (and ``$`` inline)."""
        from ._writers import to_markdown

        return to_markdown(self)

    def to_latex(self) -> str:
        """A complete LaTeX document (article class, amsmath)."""
        from ._writers import to_latex

        return to_latex(self)

    def render(self, format: str) -> str:
        """The report as ``"html"``, ``"markdown"`` (or ``"md"``) or ``"latex"`` (or ``"tex"``)."""
        writers = {"html": self.to_html, "markdown": self.to_markdown, "md": self.to_markdown,
                   "latex": self.to_latex, "tex": self.to_latex}
        key = str(format).lower().lstrip(".")
        if key not in writers:
            raise ValueError(f"unknown report format '{format}': use html, markdown (md) or latex (tex)")
        return writers[key]()

    def save(self, path: str | os.PathLike) -> None:
        """Write the report; the format follows the suffix: ``.html``, ``.md`` or ``.tex``."""
        fmt = format_of(path)
        text = self.render(fmt)
        from ..io._files import write_output

        write_output(os.fspath(path), text, "Report.save")

    def __repr__(self) -> str:
        return f"<Report of {self.model_name!r}: {len(self.sections)} sections>"


_SUFFIXES = {".html": "html", ".htm": "html", ".md": "markdown", ".markdown": "markdown", ".tex": "latex"}


def format_of(path: str | os.PathLike) -> str:
    """The report format named by the suffix of `path` ("html", "markdown" or "latex")."""
    suffix = os.path.splitext(os.fspath(path))[1].lower()
    if suffix not in _SUFFIXES:
        raise ValueError(f"{os.fspath(path)}: cannot tell the report format from the suffix "
                         f"'{suffix or '(none)'}'; use .html, .md or .tex")
    return _SUFFIXES[suffix]
