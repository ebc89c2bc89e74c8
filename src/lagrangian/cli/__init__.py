"""The command-line interface: a thin layer over the library.

Exit status: 0 on success, 2 for bad input (a bad model file, option or name), 1 when a
computation fails (a singular mass matrix reached by a simulation, an integrator failure).
Errors go to stderr, without a traceback.
"""

from __future__ import annotations

import argparse
import os
import sys
from typing import Sequence

from ._common import check_numbers
from ..errors import (ExpressionError, LagrangianError, ModelError, OutputFileError, SimulationError,
                      SingularMassMatrixError)

__all__ = ["main"]


class _Parser(argparse.ArgumentParser):
    def error(self, message):  # exit 2 with a one-line hint, no usage dump
        self.exit(2, f"lagrangian: error: {message}\nRun `{self.prog} --help` for the options and an example.\n")


def _parser() -> argparse.ArgumentParser:
    p = _Parser(prog="lagrangian", description="Lagrangian dynamics of mechanical systems: derive Lagrange's "
                "equations, diagnose the mass matrix and simulate, from a TOML model file or a built-in example.",
                epilog="Example: lagrangian derive cart-pendulum")
    p.add_argument("--version", action="version", version=f"lagrangian {_version()}")
    sub = p.add_subparsers(dest="command", metavar="COMMAND", parser_class=_Parser)
    fmt = argparse.RawDescriptionHelpFormatter
    for module in _command_modules():
        module.register(sub, fmt)
    return p


def _command_modules():
    """Each module adds its commands with `register(sub, fmt)`, each command setting `handler`."""
    from . import _analysis, _control, _core, _fit, _kinematics, _report, _serve, _visual, _optimize

    return [_core, _analysis, _kinematics, _visual, _report, _serve, _control, _optimize, _fit]


def _version() -> str:
    from .._version import __version__

    return __version__


def main(argv: Sequence[str] | None = None) -> int:
    """Run the CLI; returns the exit status."""
    parser = _parser()
    args = parser.parse_args(argv)
    if args.command is None:
        parser.print_help(sys.stderr)
        return 2
    try:
        check_numbers(args)
        return args.handler(args)
    except (SingularMassMatrixError, SimulationError) as exc:
        print(f"lagrangian {args.command}: error: {exc}", file=sys.stderr)
        return 1
    except (ModelError, ExpressionError, OutputFileError) as exc:
        print(f"lagrangian {args.command}: error: {exc}", file=sys.stderr)
        return 2
    except LagrangianError as exc:
        print(f"lagrangian {args.command}: error: {exc}", file=sys.stderr)
        return 1
    except BrokenPipeError:  # the reader of our output went away (| head): not an error of ours
        try:
            devnull = os.open(os.devnull, os.O_WRONLY)
            os.dup2(devnull, sys.stdout.fileno())
        except OSError:
            pass
        return 0
    except OSError as exc:
        print(f"lagrangian {args.command}: error: {exc.strerror or exc}: {exc.filename or ''}", file=sys.stderr)
        return 2
    except KeyboardInterrupt:
        print("lagrangian: interrupted", file=sys.stderr)
        return 130
