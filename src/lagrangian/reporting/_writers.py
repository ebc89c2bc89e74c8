"""The three writers of a Report: HTML with MathML, Markdown with LaTeX, and a LaTeX document.

An expression larger than :data:`~lagrangian.report._printing.MAX_NODES` nodes (the report's
``max_nodes``: fewer for a model too large to expand) is not printed; the report says so in its place
(printing it would take long and help nobody).
"""

from __future__ import annotations

import html

import sympy

from .._codetext import without_controls
from ._document import Math, Paragraph, Report, Table
from ._printing import latex, math_element, mathml, too_large

__all__ = ["to_html", "to_markdown", "to_latex"]

_RELATIONS = {"=": ("<mo>=</mo>", "="), "=>": ("<mo>&#x21D2;</mo>", "\\Rightarrow")}


def _too_large_text(report: Report, nodes: int) -> str:
    return (f"(expression too large to print: more than {report.max_nodes} nodes; "
            f"`lagrangian derive {report.model_name} --json` gives it in full)")


def _terms(side, printer, plus: str, minus: str, wrap) -> str:
    """A side of a relation: one object, or a tuple of terms printed as a sum in order."""
    if not isinstance(side, tuple):
        return printer(side)
    out = []
    for k, term in enumerate(side):
        if k and isinstance(term, sympy.Expr) and term.could_extract_minus_sign():
            out += [minus, printer(-term)]
        else:
            out += ([plus] if k else []) + [printer(term)]
    return wrap("".join(out)) if wrap else " ".join(out)


def _relation_parts(block: Math, printer, plus, minus, wrap):
    rhs = _terms(block.rhs, printer, plus, minus, wrap)
    lhs = None if block.lhs is None else _terms(block.lhs, printer, plus, minus, wrap)
    return lhs, rhs


# --------------------------------------------------------------------- HTML
_CSS = """
body { font-family: system-ui, -apple-system, "Segoe UI", Roboto, sans-serif; line-height: 1.5;
       color: #1a1a1a; background: #fff; margin: 0; }
main { max-width: 62rem; margin: 0 auto; padding: 1.5rem 2rem 4rem; }
h1 { font-size: 1.7rem; margin-bottom: 0.2rem; }
h2 { font-size: 1.25rem; margin-top: 2.2rem; border-bottom: 1px solid #ddd; padding-bottom: 0.2rem; }
p.description { color: #444; margin-top: 0; }
nav ul { columns: 2; font-size: 0.95rem; list-style: none; padding-left: 1rem; }
div.math { display: flex; align-items: center; gap: 1rem; overflow-x: auto; margin: 0.6rem 0 0.6rem 1rem;
           padding: 0.2rem 0; }
math { font-size: 1.15em; }
div.math math { margin: 0; }
mover[accent="true"] > mo { font-size: 1.3em; font-weight: bold; }  /* the dots of q_dot, q_ddot: visible */
span.label { color: #555; min-width: 2rem; }
p.too-large { color: #8a4b00; font-style: italic; margin-left: 1rem; }
table { border-collapse: collapse; margin: 0.6rem 0 0.6rem 1rem; }
th, td { border: 1px solid #ccc; padding: 0.25rem 0.7rem; text-align: left; vertical-align: middle; }
th { background: #f4f4f4; }
footer { margin-top: 3rem; color: #666; font-size: 0.85rem; }
"""


def _html_relation(block: Math) -> str:
    lhs, rhs = _relation_parts(block, mathml, "<mo>+</mo>", "<mo>&#x2212;</mo>", _html_wrap)
    rel = _RELATIONS[block.relation][0]
    return rhs if lhs is None else f"<mrow>{lhs}{rel}{rhs}</mrow>"


def _html_inline(part) -> str:
    if isinstance(part, str):
        return html.escape(part)
    if too_large(part.parts() if isinstance(part, Math) else part, 400) is not None:
        return "<em>(large expression)</em>"
    return math_element(_html_relation(part) if isinstance(part, Math) else mathml(part), block=False)


def _html_wrap(inner: str) -> str:
    return f"<mrow>{inner}</mrow>"


def _html_block(report: Report, block) -> str:
    if isinstance(block, Paragraph):
        return "<p>" + "".join(_html_inline(p) for p in block.parts) + "</p>"
    if isinstance(block, Table):
        head = "".join(f"<th>{html.escape(h)}</th>" for h in block.header)
        rows = "".join("<tr>" + "".join(f"<td>{_html_inline(c)}</td>" for c in row) + "</tr>"
                       for row in block.rows)
        return f"<table><thead><tr>{head}</tr></thead><tbody>{rows}</tbody></table>"
    nodes = too_large(block.parts(), report.max_nodes)
    key = f' data-key="{html.escape(block.key)}"' if block.key else ""
    if nodes is not None:
        return f'<p class="too-large"{key}>{html.escape(_too_large_text(report, nodes))}</p>'
    inner = _html_relation(block)
    label = f'<span class="label">{html.escape(block.label)}</span>' if block.label else ""
    return f'<div class="math"{key}>{label}{math_element(inner, block=True)}</div>'


def to_html(report: Report) -> str:
    """The report as one self-contained HTML page (MathML; no script, style sheet or font to fetch)."""
    out = ["<!DOCTYPE html>", '<html lang="en">', "<head>", '<meta charset="utf-8">',
           '<meta name="viewport" content="width=device-width, initial-scale=1">',
           '<meta name="generator" content="lagrangian">',
           f"<title>{html.escape(report.title)}</title>", f"<style>{_CSS}</style>", "</head>", "<body>",
           "<main>", f"<h1>{html.escape(report.title)}</h1>"]
    if report.description:
        out.append(f'<p class="description">{html.escape(report.description)}</p>')
    out.append("<nav><ul>" + "".join(f'<li><a href="#{s.key}">{html.escape(s.title)}</a></li>'
                                      for s in report.sections) + "</ul></nav>")
    for s in report.sections:
        out.append(f'<section id="{s.key}">')
        out.append(f"<h2>{html.escape(s.title)}</h2>")
        out += [_html_block(report, b) for b in s.blocks]
        out.append("</section>")
    out.append(f"<footer>Derived by lagrangian from the model {html.escape(report.model_name)}.</footer>")
    out += ["</main>", "</body>", "</html>", ""]
    return "\n".join(out)


# ----------------------------------------------------------------- Markdown
_MD_SPECIAL = set("\\`*_[]#")
_MD_HTML = {"<": "&lt;", ">": "&gt;", "&": "&amp;"}


def _md_text(text: str) -> str:
    """Text as Markdown that shows it as it is: Markdown's punctuation escaped, HTML's special
    characters as entities (a description cannot become a tag or a link), no line break or control
    character (a heading stays one line)."""
    text = without_controls(text)
    return "".join(_MD_HTML.get(c) or ("\\" + c if c in _MD_SPECIAL else c) for c in text)


def _latex_inline(part, text, large: str) -> str:
    """Inline text (escaped by `text`) or $maths$, shared by the Markdown and LaTeX writers."""
    if isinstance(part, str):
        return text(part)
    if too_large(part.parts() if isinstance(part, Math) else part, 400) is not None:
        return large
    return f"${_latex_relation(part) if isinstance(part, Math) else latex(part)}$"


def _md_inline(part) -> str:
    return _latex_inline(part, _md_text, "*(large expression)*")


def _md_block(report: Report, block) -> str:
    if isinstance(block, Paragraph):
        return "".join(_md_inline(p) for p in block.parts)
    if isinstance(block, Table):
        def cell(c):
            return _md_inline(c).replace("|", "\\|")
        lines = ["| " + " | ".join(block.header) + " |", "|" + "---|" * len(block.header)]
        lines += ["| " + " | ".join(cell(c) for c in row) + " |" for row in block.rows]
        return "\n".join(lines)
    nodes = too_large(block.parts(), report.max_nodes)
    if nodes is not None:
        return f"*{_md_text(_too_large_text(report, nodes))}*"
    return "$$\n" + _latex_relation(block) + "\n$$"


def _latex_relation(block: Math) -> str:
    lhs, rhs = _relation_parts(block, latex, "+", "-", None)
    rel = _RELATIONS[block.relation][1]
    body = rhs if lhs is None else f"{lhs} {rel} {rhs}"
    if block.label:
        body = f"\\text{{{block.label}}}\\quad {body}"
    return body


def to_markdown(report: Report) -> str:
    """The report as Markdown; mathematics as LaTeX between ``$$`` (display) and ``$`` (inline)."""
    out = [f"# {_md_text(report.title)}", ""]
    if report.description:
        out += [_md_text(report.description), ""]
    for s in report.sections:
        out += [f"## {s.title}", ""]
        for b in s.blocks:
            out += [_md_block(report, b), ""]
    return "\n".join(out)


# -------------------------------------------------------------------- LaTeX
_TEX_ESCAPES = {"\\": "\\textbackslash{}", "&": "\\&", "%": "\\%", "$": "\\$", "#": "\\#", "_": "\\_",
                "{": "\\{", "}": "\\}", "~": "\\textasciitilde{}", "^": "\\textasciicircum{}",
                "<": "\\textless{}", ">": "\\textgreater{}", "|": "\\textbar{}"}


def _tex_text(text: str) -> str:
    """Text as LaTeX that typesets it: TeX's special characters as commands, control characters
    (a NUL, a form feed; newlines too) as spaces, other non-ASCII characters as ?."""
    text = without_controls(text)
    out = "".join(_TEX_ESCAPES.get(c, c) for c in text)
    return out.encode("ascii", "replace").decode("ascii") if not out.isascii() else out


def _tex_inline(part) -> str:
    return _latex_inline(part, _tex_text, "\\emph{(large expression)}")


def _tex_block(report: Report, block) -> str:
    if isinstance(block, Paragraph):
        return "\\noindent " + "".join(_tex_inline(p) for p in block.parts) + "\n"
    if isinstance(block, Table):
        cols = "l" * len(block.header)
        lines = [f"\\begin{{tabular}}{{{cols}}}", "\\hline",
                 " & ".join(f"\\textbf{{{_tex_text(h)}}}" for h in block.header) + " \\\\", "\\hline"]
        lines += [" & ".join(_tex_inline(c) for c in row) + " \\\\" for row in block.rows]
        lines += ["\\hline", "\\end{tabular}", ""]
        return "\\begin{center}\n" + "\n".join(lines) + "\\end{center}\n"
    nodes = too_large(block.parts(), report.max_nodes)
    if nodes is not None:
        return f"\\noindent\\emph{{{_tex_text(_too_large_text(report, nodes))}}}\n"
    return "\\[\n" + _latex_relation(block) + "\n\\]\n"


_PREAMBLE = r"""\documentclass[11pt]{article}
\usepackage[T1]{fontenc}
\usepackage[margin=2cm]{geometry}
\usepackage{amsmath,amssymb}
\setcounter{MaxMatrixCols}{40}
\allowdisplaybreaks
"""


def to_latex(report: Report) -> str:
    """The report as a complete LaTeX document (article class with amsmath; compiles with pdflatex)."""
    out = [_PREAMBLE, f"\\title{{{_tex_text(report.title)}}}", "\\date{}", "\\begin{document}", "\\maketitle"]
    if report.description:
        out.append(_tex_text(report.description) + "\n")
    for s in report.sections:
        out.append(f"\\section*{{{_tex_text(s.title)}}}")
        out += [_tex_block(report, b) for b in s.blocks]
    out += ["\\end{document}", ""]
    return "\n".join(out)
