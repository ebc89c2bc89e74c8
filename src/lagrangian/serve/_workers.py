"""Worker processes for the playground's CPU-bound requests (derive, analyse, simulate, report).

The server's event loop never computes: each request's task runs in one of a few worker
processes, so that

* the server answers other requests (the page, the examples, other users) while it works;
* a request that runs past its time limit is stopped by killing its process (a thread could not
  be stopped), with every process it started (the C compiler of an FMU: each worker leads a
  process group of its own, and the group is killed), and a new process takes its place;
* each request gets a temporary folder of its own (``TMPDIR`` and :mod:`tempfile`'s folder in the
  worker, so also the compiler's), which the server removes when the request ends, killed or not;
* a request that needs more memory than ``memory_limit`` (the worker's data segment is capped with
  ``RLIMIT_DATA`` at its size after the warm-up plus that much) gets an error reply, and its
  process is replaced;
* a crash in a worker (a segmentation fault in compiled code, the memory killer) loses that one
  request, never the server;
* slow requests (simulations, equilibria, reports, FMUs) hold at most all workers but one, so that
  the short ones (derivations and analyses, the page's checks as the user types) always find a
  worker within one short request's time (the lanes; :meth:`WorkerPool.state` shows them).

Each process imports lagrangian and loads the compiled integrators once, when it starts (the
warm-up), and then serves one request at a time; a request's time limit counts from when its
process starts working on it, not from when it was queued.
"""

from __future__ import annotations

import asyncio
import collections
import concurrent.futures
import itertools
import multiprocessing
import os
import shutil
import signal
import tempfile
import time

from ._tasks import Reply, errors_reply

__all__ = ["WorkerPool", "SHORT_TASKS", "DEFAULT_MEMORY_LIMIT_MIB"]

#: How long a new process may take to import lagrangian and load (on a machine's first use:
#: compile) the integrators before its first request.
STARTUP_LIMIT = 600.0
#: The memory one request may take in its worker by default (MiB, beyond the worker's own footprint).
DEFAULT_MEMORY_LIMIT_MIB = 2048
#: The tasks of the short lane: they may take any idle worker; the others leave one to them.
SHORT_TASKS = frozenset({"derive", "analysis"})
#: What a worker sends instead of a reply when its request ran out of memory (then it exits).
OUT_OF_MEMORY = "out of memory"


def _data_size() -> int:
    """This process's data segment in bytes (Linux: VmData), or 0 where it cannot be read."""
    try:
        with open("/proc/self/status") as fh:
            for line in fh:
                if line.startswith("VmData:"):
                    return int(line.split()[1]) * 1024
    except (OSError, ValueError, IndexError):
        pass
    return 0


def _cap_memory(limit: int | None) -> None:
    """Cap this process's data segment (heap and private mappings: what Python, NumPy and the
    compiled code allocate) at its present size plus `limit` bytes."""
    if limit is None:
        return
    try:
        import resource
    except ImportError:  # not POSIX: no cap
        return
    cap = _data_size() + limit
    try:
        _, hard = resource.getrlimit(resource.RLIMIT_DATA)
        if hard != resource.RLIM_INFINITY:
            cap = min(cap, hard)
        resource.setrlimit(resource.RLIMIT_DATA, (cap, hard))
    except (ValueError, OSError, AttributeError):
        pass


_TEMP_VARIABLES = ("TMPDIR", "TEMP", "TMP")


def _in_folder(folder: str | None, work):
    """work() with `folder` as the temporary folder of this process and of the processes it starts."""
    if folder is None:
        return work()
    saved = {k: os.environ.get(k) for k in _TEMP_VARIABLES}
    saved_tempdir = tempfile.tempdir
    os.environ.update({k: folder for k in _TEMP_VARIABLES})
    tempfile.tempdir = folder
    try:
        return work()
    finally:
        tempfile.tempdir = saved_tempdir
        for k, v in saved.items():
            if v is None:
                os.environ.pop(k, None)
            else:
                os.environ[k] = v


def _serve_requests(conn, warm: bool, memory_limit: int | None) -> None:  # the worker process's main function
    if hasattr(os, "setsid"):
        os.setsid()  # a process group of our own: a time-out kills it with the processes we started
    signal.signal(signal.SIGINT, signal.SIG_IGN)  # Ctrl-C stops the server, which stops us
    from . import _tasks

    if warm:
        _tasks.warm_up()
    _cap_memory(memory_limit)
    conn.send("ready")
    while True:
        try:
            message = conn.recv()
        except (EOFError, OSError):
            return
        if message is None:
            return
        kind, body, args, options, folder = message
        try:
            reply = _in_folder(folder, lambda: _tasks.run(kind, body, *args, **options))
        except MemoryError:
            reply = None
        if reply is None:
            conn.send(OUT_OF_MEMORY)  # and exit: a new process, with all its memory free, takes our place
            return
        conn.send((reply.status, reply.body, reply.content_type, reply.headers))


class _Timeout(Exception):
    pass


class _OutOfMemory(Exception):
    pass


class _Worker:
    def __init__(self, context, warm: bool, memory_limit: int | None):
        self.conn, child = context.Pipe()
        self.process = context.Process(target=_serve_requests, args=(child, warm, memory_limit), daemon=True,
                                       name="lagrangian-serve-worker")
        self.process.start()
        child.close()
        self.ready = False

    def call(self, message, time_limit: float):
        """Send one request and wait for its reply (in a thread of the pool): raises _Timeout past
        `time_limit` seconds of work, _OutOfMemory past the memory limit, EOFError when the process died."""
        if not self.ready:
            if not self.conn.poll(STARTUP_LIMIT):
                raise _Timeout()
            if self.conn.recv() != "ready":
                raise EOFError("the worker did not start")
            self.ready = True
        self.conn.send(message)
        if not self.conn.poll(time_limit):
            raise _Timeout()
        reply = self.conn.recv()
        if reply == OUT_OF_MEMORY:
            raise _OutOfMemory()
        return reply

    def stop(self, kill: bool = False) -> None:
        """Stop the process (asked to, or killed with its process group when `kill` or when it does
        not stop within a second)."""
        if not kill and self.process.is_alive():
            try:
                self.conn.send(None)
            except (OSError, ValueError):
                pass
            self.process.join(1.0)
        self._kill_group()
        if self.process.is_alive():
            self.process.kill()
        self.process.join(5.0)
        self.conn.close()

    def _kill_group(self) -> None:
        """Kill the processes the worker started (its group), the worker included: also those left
        running after the worker died."""
        if not hasattr(os, "killpg") or not self.ready:  # before "ready" it may not lead its group yet
            return
        try:
            os.killpg(self.process.pid, signal.SIGKILL)
        except (ProcessLookupError, PermissionError):
            pass


def _remove(folder: str) -> None:
    """Remove a request's temporary folder (again, a moment later, if a process just killed was
    still writing into it)."""
    for _ in range(20):
        shutil.rmtree(folder, ignore_errors=True)
        if not os.path.exists(folder):
            return
        time.sleep(0.05)


class WorkerPool:
    """A fixed number of worker processes serving tasks in two lanes.

    Parameters
    ----------
    size : int
        Number of processes (each serves one request at a time).
    time_limit : float
        Seconds of work allowed to one request; past it the request gets a 422 reply that says so
        and its process (with the processes it started) is replaced.
    memory_limit : int, optional
        Bytes of memory one request may take in its worker (beyond the worker's footprint after its
        warm-up); past it the request gets a 422 reply and its process is replaced. None: no cap.
    warm : bool
        Load the compiled integrators in each process when it starts.
    max_waiting : int
        Requests allowed to wait for a process; more get a 503 reply (the server is overloaded).

    Requests wait in one queue, served in order of arrival; those of the long lane (every task not
    in :data:`SHORT_TASKS`) may hold at most ``long_limit`` = size - 1 processes (1 when size is 1),
    so that a short request never waits behind slow ones when there are two workers or more.
    """

    def __init__(self, size: int, *, time_limit: float, memory_limit: int | None = None, warm: bool = True,
                 max_waiting: int = 5000):
        self.size = max(1, int(size))
        self.time_limit = float(time_limit)
        self.memory_limit = memory_limit
        self.max_waiting = max_waiting
        self.long_limit = max(1, self.size - 1)
        self._warm = warm
        self._context = multiprocessing.get_context("spawn")  # no fork of the server's threads
        self._threads = concurrent.futures.ThreadPoolExecutor(self.size + 2, thread_name_prefix="lagrangian-serve")
        self._idle: list[_Worker] = []
        self._waiting = {"short": collections.deque(), "long": collections.deque()}  # (arrival, future)
        self._arrivals = itertools.count()
        self._running = {"short": 0, "long": 0}
        self._workers: list[_Worker] = []
        self.replaced = 0  # processes replaced after a time-out, a crash or running out of memory
        self._closed = False

    def start(self) -> None:
        """Start the processes (call from the event loop's thread)."""
        for _ in range(self.size):
            w = self._new_worker()
            self._workers.append(w)
            self._idle.append(w)

    def _new_worker(self) -> _Worker:
        return _Worker(self._context, self._warm, self.memory_limit)

    @property
    def pids(self) -> list[int]:
        return [w.process.pid for w in self._workers]

    def state(self) -> dict:
        """The lanes now: requests running and waiting in each, and the long lane's limit."""
        return {"workers": self.size, "long_limit": self.long_limit, "running": dict(self._running),
                "waiting": {lane: sum(1 for _, f in q if not f.done()) for lane, q in self._waiting.items()},
                "replaced": self.replaced}

    # -------------------------------------------------------------- the lanes
    def _head(self, lane: str):
        """The oldest request still waiting in `lane` (cancelled ones dropped), or None."""
        queue = self._waiting[lane]
        while queue and queue[0][1].done():
            queue.popleft()
        return queue[0] if queue else None

    def _dispatch(self) -> None:
        """Give idle workers to the oldest waiting requests whose lane may take one more."""
        while self._idle:
            heads = [(head, lane) for lane in ("short", "long")
                     if (head := self._head(lane)) is not None
                     and (lane == "short" or self._running["long"] < self.long_limit)]
            if not heads:
                return
            (_, future), lane = min(heads, key=lambda h: h[0][0])
            self._waiting[lane].popleft()
            self._running[lane] += 1
            future.set_result(self._idle.pop())

    async def _acquire(self, lane: str) -> _Worker:
        future = asyncio.get_running_loop().create_future()
        self._waiting[lane].append((next(self._arrivals), future))
        self._dispatch()
        try:
            return await future
        except asyncio.CancelledError:
            if future.done() and not future.cancelled():
                self._release(future.result(), lane)
            raise

    def _release(self, worker: _Worker, lane: str) -> None:
        self._running[lane] -= 1
        self._idle.append(worker)
        self._dispatch()

    def _replace(self, old: _Worker) -> _Worker:
        old.stop(kill=True)
        if self._closed:  # the server stops: no new process
            return old
        new = self._new_worker()
        self._workers[self._workers.index(old)] = new
        self.replaced += 1
        return new

    # -------------------------------------------------------------- requests
    async def run(self, kind: str, body: bytes, *args, what: str = "request", options: dict | None = None) -> Reply:
        """Run task `kind` in a worker (``run(kind, body, *args, **options)`` of
        :mod:`lagrangian.serve._tasks`), in a temporary folder of its own that is removed after it;
        a time-out, too much memory or a crash becomes an error reply."""
        waiting = sum(len(q) for q in self._waiting.values())
        if waiting >= self.max_waiting:
            return errors_reply(503, [f"the server is busy: {waiting} requests are waiting; try again "
                                      "in a moment"])
        try:
            folder = tempfile.mkdtemp(prefix="lagrangian-request-")
        except OSError as exc:
            return errors_reply(503, [f"the server cannot create a temporary folder for the {what} in "
                                      f"{tempfile.gettempdir()} ({exc.strerror or exc}): check that this folder "
                                      "exists, is writable and has free space, or start the server with TMPDIR set "
                                      "to another folder"])
        lane = "short" if kind in SHORT_TASKS else "long"
        try:
            worker = await self._acquire(lane)
        except BaseException:
            _remove(folder)
            raise
        start = time.monotonic()
        try:
            status, data, content_type, headers = await self._off_loop(
                worker.call, (kind, body, args, options or {}, folder), self.time_limit)
            return Reply(status, data, content_type, headers)
        except _Timeout:
            worker = await self._off_loop(self._replace, worker)
            return errors_reply(422, [
                f"the {what} took longer than the limit of {self.time_limit:g} s per request and was stopped: "
                "make the model or the simulation smaller (a shorter t_end, a larger dt, looser rtol and atol), "
                "or start the server with a larger --time-limit"])
        except _OutOfMemory:
            worker = await self._off_loop(self._replace, worker)
            mib = (self.memory_limit or 0) // (1024 * 1024)
            return errors_reply(422, [
                f"the {what} needed more memory than the limit of {mib} MiB per request and was stopped: make "
                "the model or the simulation smaller (fewer output rows: a larger dt or a shorter t_end), or "
                "start the server with a larger --memory-limit"])
        except (EOFError, OSError) as exc:
            code = await self._off_loop(_exit_code, worker.process)
            worker = await self._off_loop(self._replace, worker)
            why = f"exit status {code}" if code is not None and code >= 0 else \
                f"signal {-code}" if code is not None else str(exc) or type(exc).__name__
            return errors_reply(500, [f"the worker process running this {what} stopped unexpectedly ({why}) after "
                                      f"{time.monotonic() - start:.1f} s; the server goes on with a new one. "
                                      "Try again; if it happens again with this model, please report it"])
        finally:
            await self._off_loop(_remove, folder)
            self._release(worker, lane)

    async def _off_loop(self, function, *args):
        """function(*args) in a thread of the pool, or here once the pool is closed (the server stops)."""
        try:
            future = asyncio.get_running_loop().run_in_executor(self._threads, function, *args)
        except RuntimeError:  # the executor is shut down
            return function(*args)
        return await future

    def close(self) -> None:
        """Stop every process (and the processes they started)."""
        self._closed = True
        for w in self._workers:
            w.stop(kill=not w.ready)
        self._workers.clear()
        self._threads.shutdown(wait=False, cancel_futures=True)


def _exit_code(process) -> int | None:
    """The exit code of a process that has just died (reaped first)."""
    process.join(2.0)
    return process.exitcode


def default_workers() -> int:
    """One process per core, at least 2 (the short lane needs a second one) and at most 4."""
    return max(2, min(4, os.cpu_count() or 1))
