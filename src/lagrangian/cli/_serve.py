"""The `serve` command: the browser playground (see lagrangian.serve)."""

from __future__ import annotations

import argparse

from ._common import MODEL_HELP, option_number


def register(sub, fmt) -> None:
    from ..serve import DEFAULT_MEMORY_LIMIT, DEFAULT_PORT, DEFAULT_TIME_LIMIT

    s = sub.add_parser("serve", help="start the browser playground: write a model, see its equations, motion "
                       "and analysis", formatter_class=fmt,
                       description="Start a local web app and open it in the browser: a model-file editor (the "
                       "built-in examples as templates, errors shown at their line as you type), the derived "
                       "equations, the matrix form, the mass-matrix diagnosis, the equilibria and modes as "
                       "mathematics, a simulation with sliders for the parameters and initial values, the "
                       "animation of the mechanism and plots of the states and the energy, and downloads of the "
                       "model file, the CSV, the report and the FMU. It serves this machine only (127.0.0.1) unless "
                       "--host says otherwise, needs no network, and runs until Ctrl-C.",
                       epilog="Examples:\n  lagrangian serve\n  lagrangian serve double-pendulum --port 8800\n"
                              "  lagrangian serve my_model.toml --no-browser\n"
                              "Then open the address it prints; http://127.0.0.1:PORT/?example=NAME opens an example.")
    s.add_argument("model", nargs="?", help=MODEL_HELP + "; the page opens with it (default: cart-pendulum)")
    s.add_argument("--port", type=option_number("--port", integer=True, minimum=0, maximum=65535,
                                                example="--port 8800"),
                   default=DEFAULT_PORT, help=f"the port (default {DEFAULT_PORT}; 0 picks a free one)")
    s.add_argument("--host", default="127.0.0.1",
                   help="the address to listen on (default 127.0.0.1: this machine only; another address, such as "
                        "0.0.0.0, serves the network and prints a warning)")
    s.add_argument("--no-browser", action="store_true", help="do not open the page in a browser")
    s.add_argument("--workers", type=option_number("--workers", integer=True, minimum=1, maximum=256,
                                                   example="--workers 2"),
                   help="worker processes for derivations and simulations "
                   "(default: one per core, 2 to 4); simulations, equilibria, reports and FMUs take all but one, "
                   "so that derivations never wait behind them")
    s.add_argument("--time-limit", type=option_number("--time-limit", positive=True, example="--time-limit 30"),
                   default=DEFAULT_TIME_LIMIT, metavar="SECONDS",
                   help=f"the most seconds of work one request may take (default {DEFAULT_TIME_LIMIT:g}); past it "
                        "its worker is stopped, with the processes it started (the C compiler)")
    s.add_argument("--memory-limit", type=option_number("--memory-limit", integer=True, minimum=64,
                                                        example="--memory-limit 2048"),
                   default=DEFAULT_MEMORY_LIMIT, metavar="MIB",
                   help=f"the most memory one request may take in its worker, in MiB (default {DEFAULT_MEMORY_LIMIT}; "
                        "on Linux)")
    s.set_defaults(handler=_cmd_serve)


def _cmd_serve(args: argparse.Namespace) -> int:
    from ..serve import run

    run(args.model, host=args.host, port=args.port, open_browser=not args.no_browser, workers=args.workers,
        time_limit=args.time_limit, memory_limit=args.memory_limit)
    return 0
