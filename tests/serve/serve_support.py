"""The real playground server for the tests: `lagrangian serve --port 0 --no-browser` in a process of
its own, the address read from what it prints, requests with the standard library's http.client."""

from __future__ import annotations

import http.client
import json
import os
import re
import selectors
import signal
import subprocess
import sys
import time
from urllib.parse import urlparse


class Server:
    def __init__(self, *args: str, workers: int = 2, time_limit: float = 60.0, cwd=None, env=None):
        env = dict(os.environ, PYTHONUNBUFFERED="1", **(env or {}))
        self.argv = [sys.executable, "-m", "lagrangian", "serve", "--port", "0", "--no-browser",
                     "--workers", str(workers), "--time-limit", str(time_limit), *args]
        self.process = subprocess.Popen(self.argv, stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True,
                                        env=env, cwd=cwd)
        self.lines = []  # what it printed up to its address
        while not self.lines or ("the playground is at" not in self.lines[-1] and self.lines[-1]):
            self.lines.append(self._read_line(60))
        self.first_line = self.lines[-1]
        m = re.search(r"http://[^ ]+/", self.first_line)
        if not m:
            self.process.kill()
            raise RuntimeError(f"the server did not print its address: {self.lines!r} "
                               f"{self.process.stderr.read()[-2000:]}")
        self.url = m.group(0)
        parts = urlparse(self.url)
        self.host, self.port = parts.hostname, parts.port

    def _read_line(self, timeout: float) -> str:
        sel = selectors.DefaultSelector()
        sel.register(self.process.stdout, selectors.EVENT_READ)
        if not sel.select(timeout):
            self.process.kill()
            raise RuntimeError(f"the server printed nothing in {timeout} s")
        return self.process.stdout.readline()

    def request(self, method: str, path: str, body=None, headers=None, timeout: float = 120.0):
        """(status, headers, body bytes)."""
        if isinstance(body, (dict, list)):
            body = json.dumps(body)
        if isinstance(body, str):
            body = body.encode()
        conn = http.client.HTTPConnection(self.host, self.port, timeout=timeout)
        try:
            conn.request(method, path, body=body, headers=headers or {})
            r = conn.getresponse()
            return r.status, dict(r.getheaders()), r.read()
        finally:
            conn.close()

    def post_json(self, path: str, body, **kw):
        """(status, decoded JSON) of a POST."""
        status, headers, data = self.request("POST", path, body, **kw)
        assert headers.get("Content-Type", "").startswith("application/json"), (status, headers, data[:300])
        return status, json.loads(data)

    def status(self) -> dict:
        """GET /api/status: the worker lanes now."""
        status, _, data = self.request("GET", "/api/status")
        assert status == 200, data
        return json.loads(data)

    def worker_pids(self) -> list[int]:
        """The pids of the server's worker processes (its children running multiprocessing's spawn)."""
        out = []
        for name in os.listdir("/proc"):
            if not name.isdigit():
                continue
            try:
                with open(f"/proc/{name}/stat") as fh:
                    ppid = int(fh.read().rsplit(")", 1)[1].split()[1])
                with open(f"/proc/{name}/cmdline", "rb") as fh:
                    cmd = fh.read()
            except (OSError, ValueError, IndexError):
                continue
            if ppid == self.process.pid and b"multiprocessing" in cmd and b"resource_tracker" not in cmd:
                out.append(int(name))
        return out

    def stop(self, sig=signal.SIGINT, timeout: float = 30.0) -> tuple[int, str, str]:
        """Stop it as Ctrl-C does; (exit status, the rest of stdout, stderr)."""
        if self.process.poll() is None:
            self.process.send_signal(sig)
        try:
            out, err = self.process.communicate(timeout=timeout)
        except subprocess.TimeoutExpired:
            self.process.kill()
            out, err = self.process.communicate()
        return self.process.returncode, out, err


def alive(pid: int) -> bool:
    """The process exists and is not a zombie (dead, waiting to be reaped)."""
    try:
        with open(f"/proc/{pid}/stat") as fh:
            return fh.read().rsplit(")", 1)[1].split()[0] != "Z"
    except (OSError, IndexError):
        return False


def wait_until(predicate, timeout: float, step: float = 0.1):
    end = time.monotonic() + timeout
    while True:
        value = predicate()
        if value or time.monotonic() > end:
            return value
        time.sleep(step)
