"""The bicycle where users meet it first: `lagrangian derive`, `report`, `steady`, and the playground's
/api/derive and /api/analysis, each as a whole process (issue 22: each under 3 s).

Run:  python benchmarks/bicycle_cli.py [--repeat N] [--only derive,report,...]      (several minutes)

Each command runs in a fresh process (interpreter start, imports, load, the work, the output); printed:
the median wall time and the median CPU time (user + system of the child: the fair number on a shared
machine) of N runs, and whether it is under the target. The playground's calls run the server's own
task functions (serve/_tasks.py: what the HTTP handler calls) in a fresh process, without the HTTP layer.

Measured on the shared 2-core machine (CPU s of the child, median; before: one run, load 2-4, after: 3 runs):
derive 1.40 -> 2.12 (noise: unchanged code), derive --json 10.35 -> 2.69, report 40.1 -> 18.5, steady 21.2 -> 6.3,
/api/derive 10.0 -> 1.8, /api/analysis 24.0 -> 11.2. Report and /api/analysis still over 3 s: the readable
expansions of the bicycle's M, G, c and C (about 4 s), the constrained steady-state search of the report's
equilibria (about 4 s) and the diagnosis of M's singular configuration (about 2 s).
"""

from __future__ import annotations

import argparse
import os
import resource
import shutil
import statistics
import subprocess
import sys
import tempfile
import time
from pathlib import Path

TARGET = 3.0

_TASK = """
import sys
from importlib import resources
from lagrangian.serve import _tasks
text = (resources.files("lagrangian.examples") / "whipple-bicycle.toml").read_bytes()
reply = getattr(_tasks, sys.argv[1])(text)
assert reply.status == 200, reply.status
"""


def _cli() -> list[str]:
    path = shutil.which("lagrangian")
    return [path] if path else [sys.executable, "-m", "lagrangian"]


def commands(folder: str) -> dict[str, list[str]]:
    cli = _cli()
    return {
        "derive": [*cli, "derive", "whipple-bicycle"],
        "derive --json": [*cli, "derive", "whipple-bicycle", "--json"],
        "report": [*cli, "report", "whipple-bicycle", "-o", str(Path(folder) / "bicycle.html")],
        "steady": [*cli, "steady", "whipple-bicycle"],
        "/api/derive": [sys.executable, "-c", _TASK, "derive_task"],
        "/api/analysis": [sys.executable, "-c", _TASK, "analysis_task"],
    }


def measure(cmd: list[str]) -> tuple[float, float]:
    """(wall, CPU of the child) of one run."""
    before = resource.getrusage(resource.RUSAGE_CHILDREN)
    t0 = time.perf_counter()
    subprocess.run(cmd, check=True, stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL,
                   env={**os.environ, "PYTHONHASHSEED": "0"})
    wall = time.perf_counter() - t0
    after = resource.getrusage(resource.RUSAGE_CHILDREN)
    return wall, (after.ru_utime - before.ru_utime) + (after.ru_stime - before.ru_stime)


def main(argv=None) -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--repeat", type=int, default=3, help="runs of each command (default 3)")
    ap.add_argument("--only", default="", help="comma-separated names (derive, 'derive --json', report, steady, "
                                              "/api/derive, /api/analysis)")
    args = ap.parse_args(argv)
    with tempfile.TemporaryDirectory(prefix="lagrangian-bench-bicycle-") as folder:
        todo = commands(folder)
        if args.only:
            todo = {k: v for k, v in todo.items() if k in {s.strip() for s in args.only.split(",")}}
        print(f"whipple-bicycle, whole processes, median of {args.repeat} runs", flush=True)
        print(f"| {'what':<16} | {'wall':>8} | {'CPU':>8} | under {TARGET:g} s (CPU) |")
        print(f"|{'-' * 18}|{'-' * 10}:|{'-' * 10}:|---|")
        for name, cmd in todo.items():
            runs = [measure(cmd) for _ in range(args.repeat)]
            wall = statistics.median(w for w, _ in runs)
            cpu = statistics.median(c for _, c in runs)
            print(f"| {name:<16} | {wall:7.2f}s | {cpu:7.2f}s | {'yes' if cpu < TARGET else 'no'} |", flush=True)


if __name__ == "__main__":
    main()
