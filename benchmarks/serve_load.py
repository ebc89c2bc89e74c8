"""Load test of the playground's server: hundreds of concurrent derive and simulate requests.

Run:  python benchmarks/serve_load.py [--requests 600] [--concurrency 200] [--url http://127.0.0.1:PORT/]

Without --url it starts `lagrangian serve --port 0 --no-browser` itself (its default workers: one per
core, 2 to 4) and stops it at the end with Ctrl-C (SIGINT). Every request goes to this machine's
loopback address only, the run is bounded in count and time, and it stops by itself.

1. Warm-up: each simulated model is simulated once per worker (the first simulation of a model in a
   worker compiles it, about a second); not measured.
2. The load: --requests requests, half `POST /api/derive` (the built-in examples' files, in turn, but
   for SLOW_DERIVATIONS) and half `POST /api/simulate` (five small models, 5 s each, with random
   initial values and parameter values), all sent at once from --concurrency threads, one connection
   each. Meanwhile a prober asks `GET /api/info` every 0.2 s: the event loop's responsiveness while
   the workers are busy.
3. The short lane: --slow slow simulations at once (the double pendulum for 40 s with RK45 at
   rtol = atol = 1e-11, a few seconds each), twice as many as the workers, while a prober sends a
   small derivation (a one-coordinate oscillator) every 0.2 s: how long a user typing waits for
   the check of the model while the workers are busy with slow work.

It prints how many were answered, the status codes, the latency percentiles (p50, p90, p99, max) of
each kind and the throughput, and exits with status 1 when a request got no answer or a 5xx.
"""

from __future__ import annotations

import argparse
import http.client
import json
import random
import re
import signal
import statistics
import subprocess
import sys
import threading
import time
from concurrent.futures import ThreadPoolExecutor
from urllib.parse import urlparse

SIMULATED = ("double-pendulum", "cart-pendulum", "mck", "rotating-pendulum", "spring-mass-damper-chain-3")
TIMEOUT = 600.0  # seconds, one request (queued behind hundreds of others)
#: Examples left out of the derive requests: the derivation alone takes tens of seconds (the bicycle's:
#: about 25 s), and the load test measures the server, not one derivation.
SLOW_DERIVATIONS = ("whipple-bicycle",)


def start_server() -> tuple[subprocess.Popen, str]:
    proc = subprocess.Popen([sys.executable, "-m", "lagrangian", "serve", "--port", "0", "--no-browser"],
                            stdout=subprocess.PIPE, text=True)
    line = proc.stdout.readline()
    m = re.search(r"http://[^ ]+/", line)
    if not m:
        proc.kill()
        raise SystemExit(f"the server did not start: {line!r}")
    return proc, m.group(0)


def request(url: str, method: str, path: str, body: bytes | None = None) -> tuple[int | None, float, str]:
    """(status or None, seconds, error text)."""
    parts = urlparse(url)
    start = time.perf_counter()
    try:
        conn = http.client.HTTPConnection(parts.hostname, parts.port, timeout=TIMEOUT)
        try:
            conn.request(method, path, body=body)
            r = conn.getresponse()
            data = r.read()
            status = r.status
        finally:
            conn.close()
    except OSError as exc:
        return None, time.perf_counter() - start, f"{type(exc).__name__}: {exc}"
    error = "" if status < 400 else data[:300].decode(errors="replace")
    return status, time.perf_counter() - start, error


def percentiles(values: list[float]) -> str:
    if not values:
        return "(none)"
    v = sorted(values)

    def p(q):
        return v[min(len(v) - 1, int(round(q / 100 * (len(v) - 1))))]

    return (f"p50 {p(50) * 1000:8.1f} ms   p90 {p(90) * 1000:8.1f} ms   p99 {p(99) * 1000:8.1f} ms   "
            f"max {v[-1] * 1000:8.1f} ms   mean {statistics.fmean(v) * 1000:8.1f} ms")


OSCILLATOR = 'coordinates = ["x"]\n[energy]\nT = "x_dot**2/2"\nV = "x**2/2"\n'


def short_lane(url: str, slow: int) -> bool:
    """Phase 3: small derivations sent every 0.2 s while `slow` slow simulations keep the workers busy;
    True when every request was answered with 200."""
    from lagrangian.examples import example_source

    body = json.dumps({"model": example_source("double-pendulum"), "t_end": 40, "dt": 0.01, "method": "RK45",
                       "rtol": 1e-11, "atol": 1e-11}).encode()
    small: list[tuple[int | None, float, str]] = []
    running = threading.Event()
    running.set()

    def probe():
        time.sleep(0.5)  # the slow ones have reached the workers
        while running.is_set():
            small.append(request(url, "POST", "/api/derive", OSCILLATOR.encode()))
            time.sleep(0.2)

    prober = threading.Thread(target=probe)
    start = time.perf_counter()
    with ThreadPoolExecutor(max_workers=slow) as pool:
        futures = [pool.submit(request, url, "POST", "/api/simulate", body) for _ in range(slow)]
        prober.start()
        slow_results = [f.result() for f in futures]
    running.clear()
    prober.join()
    wall = time.perf_counter() - start
    ok = all(r[0] == 200 for r in slow_results + small)
    print(f"short lane: {slow} slow simulations at once, answered in {wall:.1f} s: "
          f"{percentiles([r[1] for r in slow_results])}")
    print(f"{'derive':>9} ({len(small)} small ones meanwhile, "
          f"{sum(r[0] == 200 for r in small)} answered 200): {percentiles([r[1] for r in small])}")
    if not ok:
        bad = [r for r in slow_results + small if r[0] != 200]
        print(f"  failed: status {bad[0][0]}: {bad[0][2]}")
    return ok


def main(argv=None) -> int:
    from lagrangian.examples import example_descriptions, example_source

    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--requests", type=int, default=600, help="requests in the load (half derive, half simulate)")
    ap.add_argument("--concurrency", type=int, default=200, help="requests in flight at once (threads)")
    ap.add_argument("--url", help="a running server (default: start one)")
    ap.add_argument("--seed", type=int, default=1)
    ap.add_argument("--slow", type=int, help="slow simulations of the short-lane phase (default: 2 per worker; "
                    "0 leaves the phase out)")
    args = ap.parse_args(argv)
    proc = None
    url = args.url
    if url is None:
        proc, url = start_server()
    try:
        parts = urlparse(url)
        conn = http.client.HTTPConnection(parts.hostname, parts.port, timeout=30)
        conn.request("GET", "/api/info")
        info = json.loads(conn.getresponse().read())
        conn.close()
        workers = info["workers"]
        rng = random.Random(args.seed)
        derived = [name for name in example_descriptions() if "<n>" not in name and name not in SLOW_DERIVATIONS] + [
            f"pendulum-chain-{n}" for n in (2, 3, 4, 5)]
        texts = {name: example_source(name).encode() for name in derived}
        models = {name: example_source(name) for name in SIMULATED}

        def simulate_body(name):
            initial = {"double-pendulum": {"theta1": rng.uniform(-2, 2), "theta2": rng.uniform(-2, 2)},
                       "cart-pendulum": {"q2": rng.uniform(0.5, 2.5)},
                       "mck": {},
                       "rotating-pendulum": {"theta": rng.uniform(-1, 1)},
                       "spring-mass-damper-chain-3": {"x1": rng.uniform(-0.2, 0.2)}}[name]
            params = {"rotating-pendulum": {"Omega": rng.uniform(0, 8)},
                      "double-pendulum": {"m2": rng.uniform(0.5, 2)}}.get(name, {})
            return json.dumps({"model": models[name], "t_end": 5.0, "dt": 0.01, "initial": initial,
                               "params": params}).encode()

        print(f"server {url}: {workers} workers, time limit {info['time_limit_s']:g} s")
        start = time.perf_counter()
        with ThreadPoolExecutor(max_workers=max(1, workers * len(SIMULATED))) as pool:
            warm = list(pool.map(lambda name: request(url, "POST", "/api/simulate", simulate_body(name)),
                                 [name for name in SIMULATED for _ in range(workers)]))
        bad = [w for w in warm if w[0] != 200]
        print(f"warm-up: {len(warm)} simulations in {time.perf_counter() - start:.1f} s"
              + (f", {len(bad)} failed: {bad[0]}" if bad else ""))

        jobs = []
        for k in range(args.requests):
            if k % 2 == 0:
                name = derived[(k // 2) % len(derived)]
                jobs.append(("derive", "/api/derive", texts[name]))
            else:
                jobs.append(("simulate", "/api/simulate", simulate_body(SIMULATED[(k // 2) % len(SIMULATED)])))
        rng.shuffle(jobs)

        probes: list[float] = []
        stop = threading.Event()

        def probe():
            while not stop.is_set():
                status, seconds, _ = request(url, "GET", "/api/info")
                if status == 200:
                    probes.append(seconds)
                stop.wait(0.2)

        prober = threading.Thread(target=probe)
        prober.start()
        gate = threading.Barrier(min(args.concurrency, len(jobs)))

        def send(k, job):
            kind, path, body = job
            if k < gate.parties:  # the first wave starts together
                try:
                    gate.wait(timeout=60)
                except threading.BrokenBarrierError:
                    pass
            return kind, *request(url, "POST", path, body)

        start = time.perf_counter()
        with ThreadPoolExecutor(max_workers=args.concurrency) as pool:
            results = list(pool.map(send, range(len(jobs)), jobs))
        wall = time.perf_counter() - start
        stop.set()
        prober.join()

        answered = [r for r in results if r[1] is not None]
        codes: dict = {}
        for r in results:
            codes[r[1]] = codes.get(r[1], 0) + 1
        print(f"load: {len(results)} requests ({args.concurrency} at once), {len(answered)} answered in "
              f"{wall:.1f} s: {len(results) / wall:.1f} requests/s")
        print("status codes: " + ", ".join(f"{code}: {n}" for code, n in sorted(codes.items(), key=str)))
        for kind in ("derive", "simulate"):
            lat = [r[2] for r in results if r[0] == kind and r[1] == 200]
            print(f"{kind:>9} ({len(lat)} answered 200): {percentiles(lat)}")
        print(f"{'all':>9} ({len(answered)}): {percentiles([r[2] for r in answered])}")
        print(f"{'GET info':>9} ({len(probes)} probes during the load): {percentiles(probes)}")
        errors = [r for r in results if r[1] is None or r[1] >= 500]
        for r in errors[:5]:
            print(f"  failed: {r[0]}: status {r[1]}: {r[3]}")
        ok = len(answered) == len(results) and not errors and all(r[1] == 200 for r in results)
        slow = 2 * workers if args.slow is None else args.slow
        if slow > 0:
            ok = short_lane(url, slow) and ok
        print("result: " + ("every request answered, none 5xx" if ok else
                            f"{len(results) - len(answered)} unanswered, {len(errors)} failed"))
        return 0 if ok else 1
    finally:
        if proc is not None:
            proc.send_signal(signal.SIGINT)
            try:
                proc.wait(30)
            except subprocess.TimeoutExpired:
                proc.kill()


if __name__ == "__main__":
    sys.exit(main())
