"""Readable equations: `lagrangian derive`, `check` and `report` against sympy's KanesMethod,
measured in one run, with the targets of issue 10 ("readable equations in well under a second").

Run:  python benchmarks/display.py [--repeat N]      (about 2 minutes on 2 cores)

(a) whole processes, median wall time of N runs, interleaved so that both sides see the same
    load: `lagrangian derive pendulum-chain-20` (text, and --json) against a script that builds the
    20-link chain with sympy.physics.mechanics KanesMethod and forms kanes_equations and
    mass_matrix_full / forcing_full (derive_chain.kane_chain); target: ours >= 3x faster.
(b) in process, median CPU time, each repetition in a fresh process (cold caches on both sides):
    derive plus the readable mass_matrix and forcing of a 10-link chain against KanesMethod's
    kanes_equations + mass_matrix_full / forcing_full; target: >= 20x.
(c) `lagrangian report pendulum-chain-4 -o x.html`, median wall time; target: < 3 s.
(d) `lagrangian check pendulum-chain-20`, median wall time (no target: "seconds at most").
"""

from __future__ import annotations

import argparse
import shutil
import statistics
import subprocess
import sys
import tempfile
import time
from pathlib import Path

HERE = Path(__file__).resolve().parent

# The peer as a whole process: KanesMethod of the n-link chain, its equations and full M and f.
_KANE_PROCESS = f"""
import sys
sys.path.insert(0, {str(HERE)!r})
from derive_chain import kane_chain
km = kane_chain(int(sys.argv[1]))[0]
km.mass_matrix_full, km.forcing_full
"""

# In process: the CPU time of the work alone (imports done), printed by a fresh process.
_KANE_IN_PROCESS = f"""
import sys, time
sys.path.insert(0, {str(HERE)!r})
from derive_chain import kane_chain
t0 = time.process_time()
km = kane_chain(int(sys.argv[1]))[0]
km.mass_matrix_full, km.forcing_full
print(time.process_time() - t0)
"""

_OURS_IN_PROCESS = """
import sys, time
import lagrangian as lg
model = lg.load(f"pendulum-chain-{sys.argv[1]}")
t0 = time.process_time()
eqs = lg.derive(model)
eqs.mass_matrix, eqs.forcing
print(time.process_time() - t0)
"""


def _cli() -> list[str]:
    path = shutil.which("lagrangian")
    return [path] if path else [sys.executable, "-m", "lagrangian"]


def _wall(cmd: list[str]) -> float:
    t0 = time.perf_counter()
    subprocess.run(cmd, check=True, stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL)
    return time.perf_counter() - t0


def _printed(cmd: list[str]) -> float:
    return float(subprocess.run(cmd, check=True, capture_output=True, text=True).stdout.split()[-1])


def _interleaved(commands: dict[str, list[str]], repeat: int, measure=_wall) -> dict[str, float]:
    """Median of `repeat` measurements of each command, the commands run in turn."""
    times: dict[str, list[float]] = {name: [] for name in commands}
    for _ in range(repeat):
        for name, cmd in commands.items():
            times[name].append(measure(cmd))
    return {name: statistics.median(t) for name, t in times.items()}


def run(repeat: int = 5) -> dict[str, float]:
    """Measure everything; prints a Markdown table and the targets, returns the medians."""
    cli = _cli()
    out: dict[str, float] = {}

    print(f"(a) whole processes, 20-link chain, median wall time of {repeat} runs", flush=True)
    out.update(_interleaved({
        "derive20": [*cli, "derive", "pendulum-chain-20"],
        "derive20_json": [*cli, "derive", "pendulum-chain-20", "--json"],
        "kane20_process": [sys.executable, "-c", _KANE_PROCESS, "20"],
    }, repeat))

    print(f"(b) in process, 10-link chain, median CPU time of {repeat} fresh processes", flush=True)
    medians = _interleaved({
        "ours10_cpu": [sys.executable, "-c", _OURS_IN_PROCESS, "10"],
        "kane10_cpu": [sys.executable, "-c", _KANE_IN_PROCESS, "10"],
    }, repeat, measure=_printed)
    out.update(medians)

    print(f"(c, d) report of pendulum-chain-4 and check of pendulum-chain-20, median wall time of {repeat}",
          flush=True)
    with tempfile.TemporaryDirectory(prefix="lagrangian-bench-report-") as folder:
        out.update(_interleaved({
            "report4": [*cli, "report", "pendulum-chain-4", "-o", str(Path(folder) / "x.html")],
            "check20": [*cli, "check", "pendulum-chain-20"],
        }, repeat))

    print()
    print("| what | lagrangian | KanesMethod | ratio |")
    print("|---|---:|---:|---:|")
    k = out["kane20_process"]
    print(f"| `lagrangian derive pendulum-chain-20`, whole process (wall) | {out['derive20']:.2f} s | {k:.2f} s | "
          f"{k / out['derive20']:.1f}x |")
    print(f"| `lagrangian derive pendulum-chain-20 --json`, whole process (wall) | {out['derive20_json']:.2f} s | "
          f"{k:.2f} s | {k / out['derive20_json']:.1f}x |")
    print(f"| 10-link chain in process: derive + readable M and f (CPU) | {out['ours10_cpu'] * 1e3:.0f} ms | "
          f"{out['kane10_cpu'] * 1e3:.0f} ms | {out['kane10_cpu'] / out['ours10_cpu']:.0f}x |")
    print(f"| `lagrangian report pendulum-chain-4 -o x.html` (wall) | {out['report4']:.2f} s | | |")
    print(f"| `lagrangian check pendulum-chain-20` (wall) | {out['check20']:.2f} s | | |")
    print()
    for target, measured, ok in targets(out):
        print(f"- {target}: {measured} ({'holds' if ok else 'missed'})")
    return out


def targets(out: dict[str, float]) -> list[tuple[str, str, bool]]:
    """(target, what was measured, whether it holds) for each target of issue 10, part 3."""
    k = out["kane20_process"]
    r_text, r_json = k / out["derive20"], k / out["derive20_json"]
    r_in = out["kane10_cpu"] / out["ours10_cpu"]
    return [
        ("`lagrangian derive` of a 20-link chain >= 3x faster than KanesMethod, whole processes (text)",
         f"{r_text:.1f}x", r_text >= 3),
        ("the same with --json", f"{r_json:.1f}x", r_json >= 3),
        ("derive + readable M and f of a 10-link chain >= 20x faster than KanesMethod, in process",
         f"{r_in:.0f}x", r_in >= 20),
        ("report of pendulum-chain-4 < 3 s", f"{out['report4']:.2f} s", out["report4"] < 3),
        ("check of pendulum-chain-20 in seconds (< 5 s)", f"{out['check20']:.2f} s", out["check20"] < 5),
    ]


def main(argv=None) -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--repeat", type=int, default=5, help="runs of each measurement (default 5)")
    run(ap.parse_args(argv).repeat)


if __name__ == "__main__":
    main()
