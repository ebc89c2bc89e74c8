"""The `report` command: the derivation report of a model as HTML (MathML), Markdown or LaTeX."""

from __future__ import annotations

import argparse

from ..errors import ModelError
from ._common import MODEL_HELP, check_writable, write_output

_FORMATS = ("html", "md", "tex")


def register(sub, fmt) -> None:
    r = sub.add_parser("report", help="write the derivation report (HTML, Markdown or LaTeX)",
                       formatter_class=fmt,
                       description="Write the whole derivation of a model's equations, step by step: bodies, "
                       "coordinates, the position and velocity of every element, T*, V, D, the generalized forces "
                       "from virtual work, the Lagrangian, each Lagrange equation, the matrix form, the state form, "
                       "the mass-matrix diagnosis, and the equilibria with their stability. The format follows the "
                       "suffix of the output file: .html (a self-contained page whose mathematics is MathML, "
                       "readable with no network), .md (Markdown with LaTeX) or .tex (a LaTeX document).",
                       epilog="Examples:\n  lagrangian report cart-pendulum -o cart.html\n"
                              "  lagrangian report my_model.toml -o my_model.tex\n"
                              "  lagrangian report cart-pendulum -o - --format md | less")
    r.add_argument("model", help=MODEL_HELP)
    r.add_argument("--output", "-o", required=True, metavar="FILE",
                   help="the report file: .html, .md or .tex ('-' writes to stdout; give --format then)")
    r.add_argument("--format", choices=_FORMATS, type=str.lower,
                   help="html, md or tex (default: from the suffix of --output)")
    r.add_argument("--title", help="the report's title (default: Lagrange's equations of <model>)")
    r.add_argument("--no-equilibria", action="store_true",
                   help="leave out the equilibria and their stability (the slowest part for large models)")
    r.set_defaults(handler=_cmd_report)


def _format(args: argparse.Namespace) -> str:
    if args.format:
        return args.format
    if args.output == "-":
        raise ModelError("--output -: give --format html, md or tex to write the report to stdout")
    from ..reporting import format_of

    try:
        return {"html": "html", "markdown": "md", "latex": "tex"}[format_of(args.output)]
    except ValueError:
        raise ModelError(f"--output {args.output}: cannot tell the report format from the file name; "
                         "end it in .html, .md or .tex, or give --format html, md or tex") from None


def _cmd_report(args: argparse.Namespace) -> int:
    from .. import derive, load
    from ..io._files import is_stdout
    from ..reporting import report

    fmt = _format(args)
    check_writable(args.output, example=f"report.{fmt}")
    model = load(args.model)
    rep = report(derive(model), title=args.title, equilibria=not args.no_equilibria)
    text = rep.render(fmt)
    write_output(args.output, text)
    if not is_stdout(args.output):
        print(f"wrote the report of {model.name} ({len(rep.sections)} sections, {fmt}) to {args.output}")
    return 0
