"""What the CLI tests share: the CLI run in-process (tests/serve/serve_support.py is the server's)."""

from __future__ import annotations

from lagrangian.cli import main


def run_cli(capsys, *args):
    """Run the CLI in-process: (exit status, stdout, stderr). argparse exits are caught (--help: 0)."""
    try:
        rc = main([str(a) for a in args])
    except SystemExit as exc:  # argparse: --help, usage errors
        rc = exc.code if isinstance(exc.code, int) else (0 if exc.code is None else 1)
    out, err = capsys.readouterr()
    return rc, out, err
