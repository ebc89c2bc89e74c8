"""The command-line interface: a thin layer over the library.

Exit status: 0 on success, 2 for bad input (a bad model file, option or name), 1 when a
computation fails (a singular mass matrix reached by a simulation, an integrator failure).
Errors go to stderr, without a traceback.
"""

from __future__ import annotations

import argparse
import importlib
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


def _parser(argv: Sequence[str] | None = None) -> argparse.ArgumentParser:
    """The parser of the command line `argv` (sys.argv[1:] when None): with every command, or, when
    `argv` starts with a command of :data:`COMMANDS`, with that command alone (what it parses and
    prints is the same; the others' options are not built: `lagrangian derive` starts faster)."""
    p = _Parser(prog="lagrangian", description="Lagrangian dynamics of mechanical systems: derive Lagrange's "
                "equations, diagnose the mass matrix and simulate, from a TOML model file or a built-in example.",
                epilog="Example: lagrangian derive cart-pendulum")
    p.add_argument("--version", action="version", version=f"lagrangian {_version()}")
    sub = p.add_subparsers(dest="command", metavar="COMMAND", parser_class=_Parser)
    fmt = argparse.RawDescriptionHelpFormatter
    args = sys.argv[1:] if argv is None else argv
    named = COMMANDS.get(args[0]) if len(args) > 0 and isinstance(args[0], str) else None
    for module in [importlib.import_module(f".{named}", __name__)] if named else _command_modules():
        module.register(sub, fmt)
    return p


#: The module of each command, so that a command line naming one builds (and imports) its module
#: alone; a command not listed here still works (every module is registered). Kept equal to what
#: the modules register by tests/cli/test_cli.py.
COMMANDS = {
    **dict.fromkeys(("derive", "simulate", "check", "examples"), "_core"),
    **dict.fromkeys(("equilibria", "steady", "linearize", "modes", "sweep"), "_analysis"),
    **dict.fromkeys(("kinematics", "inverse-dynamics"), "_kinematics"),
    "animate": "_visual", "report": "_report", "serve": "_serve",
    **dict.fromkeys(("lqr", "place", "export"), "_control"),
    "optimize": "_optimize", "fit": "_fit", "load": "_load",
}


def _command_modules():
    """Each module adds its commands with `register(sub, fmt)`, each command setting `handler`."""
    from . import _analysis, _control, _core, _fit, _kinematics, _load, _report, _serve, _visual, _optimize

    return [_core, _analysis, _kinematics, _visual, _report, _serve, _control, _optimize, _fit, _load]


def _version() -> str:
    from .._version import __version__

    return __version__


def _freeze_at_exit() -> None:
    """Have the objects a command leaves frozen (``gc.freeze``) when the process exits, once per process:
    Python's collections at shutdown then do not walk them. A command that built large symbolic
    expressions leaves millions (the bicycle's report: 0.5 s of CPU after its last line, of 4). Nothing
    else changes: the exit handlers run, the files and streams are flushed and closed as before.

    Also, once: the youngest generation's threshold is raised to _GEN0 objects (where it was lower), so that
    the collector runs less often over the symbolic work's many young objects: the bicycle's report 3.85 ->
    3.5 s of CPU with the same peak memory (289 MB). Cyclic garbage is still collected."""
    global _FREEZE_REGISTERED
    if not _FREEZE_REGISTERED:
        import atexit
        import gc

        atexit.register(gc.freeze)
        threshold = gc.get_threshold()
        if threshold[0] < _GEN0:
            gc.set_threshold(_GEN0, *threshold[1:])
        _FREEZE_REGISTERED = True


_FREEZE_REGISTERED = False
#: The youngest generation's collection threshold the command line sets (Python's default: 700).
_GEN0 = 20_000


def main(argv: Sequence[str] | None = None) -> int:
    """Run the CLI; returns the exit status."""
    _freeze_at_exit()
    parser = _parser(argv)
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
