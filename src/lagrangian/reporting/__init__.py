"""Derivation reports: the whole derivation of a model's equations, step by step, as a
self-contained HTML page (MathML), Markdown or a LaTeX document.

The package is ``lagrangian.reporting`` so that ``lagrangian.report`` can be the function (a
package of the same name would be shadowed by it).

>>> import lagrangian as lg
>>> lg.report("cart-pendulum").save("cart.html")  # doctest: +SKIP
"""

from ._build import report
from ._document import Math, Paragraph, Report, Section, Table, format_of

__all__ = ["report", "Report", "Section", "Paragraph", "Math", "Table", "format_of"]
