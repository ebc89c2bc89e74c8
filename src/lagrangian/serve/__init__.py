"""The browser playground: a local web app over the same functions as the CLI.

``lagrangian serve [MODEL]`` (or :func:`run`) starts it on 127.0.0.1: a page with a model-file
editor, the derived equations and their analysis rendered as MathML, a simulation with sliders,
the animation of the mechanism and plots of the states and the energy; and the HTTP API the page
uses (see :mod:`lagrangian.serve._app` and docs/conventions.md). Everything it needs ships in the
package: no network. The derivations and simulations run in worker processes
(:mod:`lagrangian.serve._workers`), each request with a time limit and a memory limit, slow
requests leaving one worker to the short ones. The API answers the page itself and scripts, never
another web page (see docs/playground.md, Security).
"""

from __future__ import annotations

import asyncio
import errno
import signal
import socket
import sys
from typing import Callable

from ..errors import ModelError

__all__ = ["run", "DEFAULT_PORT", "DEFAULT_TIME_LIMIT", "DEFAULT_MEMORY_LIMIT"]

DEFAULT_PORT = 8765
DEFAULT_TIME_LIMIT = 60.0
#: MiB of memory one request may take in its worker (beyond the worker's own footprint).
DEFAULT_MEMORY_LIMIT = 2048


def _is_loopback(host: str) -> bool:
    if host in ("localhost", "::1"):
        return True
    try:
        return socket.inet_aton(host)[0] == 127 if host.count(".") == 3 else False
    except OSError:
        return False


def check_model(model: str | None) -> None:
    """Raise the CLI's error when MODEL is neither a built-in example nor a readable model file
    (before the server starts). Problems inside the file are shown by the page, at their lines."""
    if model is None:
        return
    from pathlib import Path

    from ..examples import example_source

    if example_source(model) is not None:
        return
    if not Path(model).is_file():
        from ..io import load

        load(model)  # raises the CLI's message: no such file, or no such example (did you mean ...)


def run(model: str | None = None, *, host: str = "127.0.0.1", port: int = DEFAULT_PORT, open_browser: bool = True,
        workers: int | None = None, time_limit: float = DEFAULT_TIME_LIMIT,
        memory_limit: int = DEFAULT_MEMORY_LIMIT, announce: Callable[[str], None] | None = None) -> None:
    """Serve the playground until Ctrl-C (SIGINT) or SIGTERM.

    Parameters
    ----------
    model : str, optional
        A built-in example name or a model-file path the page opens with (a file is read anew at
        each visit of the page). Default: the cart with an inverted pendulum.
    host : str
        The address to bind: 127.0.0.1 by default (this machine only). Another address serves
        the network: ``announce`` gets a warning first.
    port : int
        0 picks a free port.
    open_browser : bool
        Open the page in the default web browser.
    workers : int, optional
        Worker processes (default: one per core, 2 to 4). Slow requests (simulations, equilibria,
        reports, FMUs) take at most all but one of them: derivations and analyses find one free.
    time_limit : float
        Seconds of work allowed to one request (then its worker is killed, with the processes it
        started, and replaced).
    memory_limit : int
        MiB of memory allowed to one request, beyond its worker's footprint when idle (Linux:
        the worker's RLIMIT_DATA); past it the request gets an error and the worker is replaced.
    announce : callable, optional
        Receives the lines to show the user (default: print to stdout).

    Raises
    ------
    ModelError
        MODEL is neither an example nor a file, the port is in use, or an option is out of range.
    """
    import tornado.netutil

    from ._workers import default_workers

    say = announce or (lambda line: print(line, flush=True))
    check_model(model)
    if not 0 <= port <= 65535:
        raise ModelError(f"--port {port}: expected a port number from 1 to 65535 (or 0 for a free one)")
    if not time_limit > 0:
        raise ModelError(f"--time-limit {time_limit:g}: expected a positive number of seconds")
    if not memory_limit > 0:
        raise ModelError(f"--memory-limit {memory_limit}: expected a positive number of MiB (default "
                         f"{DEFAULT_MEMORY_LIMIT})")
    workers = default_workers() if workers is None else workers
    if workers < 1:
        raise ModelError(f"--workers {workers}: expected at least 1")
    loopback = _is_loopback(host)
    try:
        sockets = tornado.netutil.bind_sockets(port, host, backlog=1024)  # a class opening the page at once
    except OSError as exc:
        if exc.errno == errno.EADDRINUSE:
            raise ModelError(f"port {port} on {host} is in use (another `lagrangian serve`?): choose another with "
                             "--port, or --port 0 for a free one") from None
        raise ModelError(f"cannot listen on {host}:{port}: {exc.strerror or exc}; check --host and --port") from None
    bound = sockets[0].getsockname()[1]
    shown = f"[{host}]" if ":" in host else host
    url = f"http://{shown}:{bound}/"
    if not loopback:
        say(f"lagrangian serve: warning: serving on {host}, reachable from other machines: anyone who can reach "
            f"this address can use the playground and its workers; use the default --host 127.0.0.1 to serve "
            "this machine only")
    asyncio.run(_serve(sockets, url, model, workers, time_limit, memory_limit, loopback, open_browser, say))


async def _serve(sockets, url, model, workers, time_limit, memory_limit, loopback, open_browser, say) -> None:
    import tornado.httpserver

    from ._app import DRAIN_LIMIT, Settings, make_app
    from ._workers import WorkerPool

    pool = WorkerPool(workers, time_limit=time_limit, memory_limit=memory_limit * 1024 * 1024)
    pool.start()
    app = make_app(Settings(pool, model=model, check_host=loopback))
    server = tornado.httpserver.HTTPServer(app, max_body_size=DRAIN_LIMIT, idle_connection_timeout=60,
                                          body_timeout=60)
    server.add_sockets(sockets)
    stop = asyncio.Event()
    loop = asyncio.get_running_loop()
    for sig in (signal.SIGINT, signal.SIGTERM):
        try:
            loop.add_signal_handler(sig, stop.set)
        except (NotImplementedError, RuntimeError, ValueError):  # Windows: Ctrl-C raises KeyboardInterrupt
            pass
    say(f"lagrangian serve: the playground is at {url} (press Ctrl-C to stop)")
    if open_browser:
        import webbrowser

        loop.run_in_executor(None, webbrowser.open, url)
    try:
        await stop.wait()
    finally:
        server.stop()
        pool.close()
        say("lagrangian serve: stopped")
        sys.stdout.flush()
