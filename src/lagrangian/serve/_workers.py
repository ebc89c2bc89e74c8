"""Worker processes for the playground's CPU-bound requests (derive, analyse, simulate, report).

The server's event loop never computes: each request's task runs in one of a few worker
processes, so that

* the server answers other requests (the page, the examples, other users) while it works;
* a request that runs past its time limit is stopped by killing its process (a thread could not
  be stopped), and a new process takes its place;
* a crash in a worker (a segmentation fault in compiled code, the memory killer) loses that one
  request, never the server.

Each process imports lagrangian and loads the compiled integrators once, when it starts (the
warm-up), and then serves one request at a time; a request's time limit counts from when its
process starts working on it, not from when it was queued.
"""

from __future__ import annotations

import asyncio
import concurrent.futures
import multiprocessing
import os
import signal
import time

from ._tasks import Reply, errors_reply

__all__ = ["WorkerPool"]

#: How long a new process may take to import lagrangian and load (on a machine's first use:
#: compile) the integrators before its first request.
STARTUP_LIMIT = 600.0


def _serve_requests(conn, warm: bool) -> None:  # the worker process's main function
    signal.signal(signal.SIGINT, signal.SIG_IGN)  # Ctrl-C stops the server, which stops us
    from . import _tasks

    if warm:
        _tasks.warm_up()
    conn.send("ready")
    while True:
        try:
            message = conn.recv()
        except (EOFError, OSError):
            return
        if message is None:
            return
        kind, body, args = message
        reply = _tasks.run(kind, body, *args)
        conn.send((reply.status, reply.body, reply.content_type, reply.headers))


class _Timeout(Exception):
    pass


class _Worker:
    def __init__(self, context, warm: bool):
        self.conn, child = context.Pipe()
        self.process = context.Process(target=_serve_requests, args=(child, warm), daemon=True,
                                       name="lagrangian-serve-worker")
        self.process.start()
        child.close()
        self.ready = False

    def call(self, message, time_limit: float):
        """Send one request and wait for its reply (in a thread of the pool): raises _Timeout past
        `time_limit` seconds of work, EOFError when the process died."""
        if not self.ready:
            if not self.conn.poll(STARTUP_LIMIT):
                raise _Timeout()
            if self.conn.recv() != "ready":
                raise EOFError("the worker did not start")
            self.ready = True
        self.conn.send(message)
        if not self.conn.poll(time_limit):
            raise _Timeout()
        return self.conn.recv()

    def stop(self, kill: bool = False) -> None:
        if not kill and self.process.is_alive():
            try:
                self.conn.send(None)
            except (OSError, ValueError):
                pass
            self.process.join(1.0)
        if self.process.is_alive():
            self.process.kill()
            self.process.join(5.0)
        self.conn.close()


class WorkerPool:
    """A fixed number of worker processes serving tasks from an asyncio queue.

    Parameters
    ----------
    size : int
        Number of processes (each serves one request at a time).
    time_limit : float
        Seconds of work allowed to one request; past it the request gets a 422 reply that says so
        and its process is replaced.
    warm : bool
        Load the compiled integrators in each process when it starts.
    max_waiting : int
        Requests allowed to wait for a process; more get a 503 reply (the server is overloaded).
    """

    def __init__(self, size: int, *, time_limit: float, warm: bool = True, max_waiting: int = 5000):
        self.size = max(1, int(size))
        self.time_limit = float(time_limit)
        self.max_waiting = max_waiting
        self._warm = warm
        self._context = multiprocessing.get_context("spawn")  # no fork of the server's threads
        self._threads = concurrent.futures.ThreadPoolExecutor(self.size, thread_name_prefix="lagrangian-serve")
        self._idle: asyncio.Queue | None = None
        self._workers: list[_Worker] = []
        self._waiting = 0
        self.replaced = 0  # processes replaced after a time-out or a crash

    def start(self) -> None:
        """Start the processes (call from the event loop's thread)."""
        self._idle = asyncio.Queue()
        for _ in range(self.size):
            w = _Worker(self._context, self._warm)
            self._workers.append(w)
            self._idle.put_nowait(w)

    @property
    def pids(self) -> list[int]:
        return [w.process.pid for w in self._workers]

    def _replace(self, old: _Worker) -> _Worker:
        old.stop(kill=True)
        new = _Worker(self._context, self._warm)
        self._workers[self._workers.index(old)] = new
        self.replaced += 1
        return new

    async def run(self, kind: str, body: bytes, *args, what: str = "request") -> Reply:
        """Run task `kind` in a worker; a time-out or a crash becomes an error reply."""
        if self._waiting >= self.max_waiting:
            return errors_reply(503, [f"the server is busy: {self._waiting} requests are waiting; try again "
                                      "in a moment"])
        self._waiting += 1
        try:
            worker = await self._idle.get()
        finally:
            self._waiting -= 1
        loop = asyncio.get_running_loop()
        start = time.monotonic()
        try:
            status, data, content_type, headers = await loop.run_in_executor(
                self._threads, worker.call, (kind, body, args), self.time_limit)
            return Reply(status, data, content_type, headers)
        except _Timeout:
            worker = await loop.run_in_executor(self._threads, self._replace, worker)
            return errors_reply(422, [
                f"the {what} took longer than the limit of {self.time_limit:g} s per request and was stopped: "
                "make the model or the simulation smaller (a shorter t_end, a larger dt, looser rtol and atol), "
                "or start the server with a larger --time-limit"])
        except (EOFError, OSError) as exc:
            code = await loop.run_in_executor(self._threads, _exit_code, worker.process)
            worker = await loop.run_in_executor(self._threads, self._replace, worker)
            why = f"exit status {code}" if code is not None and code >= 0 else \
                f"signal {-code}" if code is not None else str(exc) or type(exc).__name__
            return errors_reply(500, [f"the worker process running this {what} stopped unexpectedly ({why}) after "
                                      f"{time.monotonic() - start:.1f} s; the server goes on with a new one. "
                                      "Try again; if it happens again with this model, please report it"])
        finally:
            self._idle.put_nowait(worker)

    def close(self) -> None:
        """Stop every process."""
        for w in self._workers:
            w.stop(kill=not w.ready)
        self._workers.clear()
        self._threads.shutdown(wait=False, cancel_futures=True)


def _exit_code(process) -> int | None:
    """The exit code of a process that has just died (reaped first)."""
    process.join(2.0)
    return process.exitcode


def default_workers() -> int:
    """One process per core, at least 1 and at most 4."""
    return max(1, min(4, os.cpu_count() or 1))
