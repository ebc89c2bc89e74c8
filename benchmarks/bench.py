"""lagrangian against its peers, measured in one run: prints each section's numbers, the ratios,
and a summary of the targets of issue 4 (fast numerics).

Run:   python benchmarks/bench.py            (about 3 minutes on 2 cores, and up to 10 more for the
                                             bicycle's peer)
       python benchmarks/bench.py --quick    (fewer repeats, no 20-link KanesMethod, no bicycle peer)

Sections
  derivation   M and f of n-link pendulum chains (n = 5, 10, 20) against sympy.physics.mechanics
               KanesMethod and LagrangesMethod (median CPU time)
  simulation   a 20 s double pendulum and a 6-link chain, each tool at the loosest tolerance that
               reaches a final error <= 2.5e-7 (equal accuracy): lagrangian's compiled DOP853
               (the integrator call alone, and simulate() end to end), sympy.lambdify of
               KanesMethod's full mass matrix and forcing, solved by numpy at each call, + scipy
               solve_ivp(DOP853), and a plain C
               DOP853 loop compiled with gcc -O2 (benchmarks/c_floor, the floor)
  batch        double-pendulum trajectories of 10 s at rtol 1e-8 per second of wall time
  output-stage a 20 s double pendulum at rtol = atol = 1e-8: the integration alone against simulate()
               end to end with the model's default output (2001 points and the energy column)
  new model    derive + generate + compile, cold and cached, in fresh processes; the CLI's first
               and second `lagrangian simulate` of a new model file
  40 links     derivation, code generation and compilation times, separately
  display      readable equations: `lagrangian derive` of a 20-link chain (text and --json) and a
               KanesMethod script as whole processes, derive + readable M and f of a 10-link chain
               in process against KanesMethod, the report of pendulum-chain-4 and the check of
               pendulum-chain-20 (benchmarks/display.py; the targets of issue 10)
  bodies       M and f of serial arms of rigid bodies in space (robot-arm-3, robot-arm-6) against
               KanesMethod (benchmarks/derive_arm.py; the arm target of the bodies-in-space issue)
  bicycle      the Whipple bicycle (whipple-bicycle) loaded, derived and linearized at v = 5 m/s in
               fresh processes, against sympy.physics.mechanics KanesMethod + linearize (one run,
               stopped after 600 s), the eigenvalues checked against the paper's
               (benchmarks/bicycle.py; the target of the bicycle issue: under 2 s)
"""

from __future__ import annotations

import argparse
import itertools
import os
import shutil
import statistics
import subprocess
import sys
import tempfile
import textwrap
import time
from pathlib import Path

import numpy as np

HERE = Path(__file__).resolve().parent
sys.path.insert(0, str(HERE))

import lagrangian as lg  # noqa: E402
from lagrangian.numeric import _codegen  # noqa: E402
from lagrangian.numeric._fast import compile_numba, kernels, run_dop853  # noqa: E402
from lagrangian.numeric._inputs import constant_programs  # noqa: E402
from derive_chain import cpu  # noqa: E402

TARGET_ERROR = 2.5e-7
RESULTS: dict[str, object] = {}


def wall(fn, repeat: int) -> float:
    times = []
    for _ in range(repeat):
        t0 = time.perf_counter()
        fn()
        times.append(time.perf_counter() - t0)
    return statistics.median(times)


def header(text: str) -> None:
    print(f"\n## {text}\n", flush=True)


# ------------------------------------------------------------------------------ derivation
def derivation(quick: bool) -> None:
    from derive_chain import ours, sympy_chain

    header("Derivation of an n-link pendulum chain (M and f), median CPU time")
    print("| links | lagrangian | KanesMethod | ratio | LagrangesMethod | ratio |")
    print("|---:|---:|---:|---:|---:|---:|")
    for n in (5, 10, 20):
        t_ours = cpu(ours(n), 5)
        if quick and n == 20:
            print(f"| {n} | {t_ours:.4f} s | (skipped) | | | |")
            continue
        t_kane = cpu(sympy_chain(n, "kane"), 1 if n > 10 else 3)
        lag = "(not run) | "
        if n <= 10:
            t_lag = cpu(sympy_chain(n, "lagrange"), 1)
            lag = f"{t_lag:.2f} s | {t_lag / t_ours:.0f}x"
        print(f"| {n} | {t_ours:.4f} s | {t_kane:.3f} s | {t_kane / t_ours:.0f}x | {lag} |", flush=True)
        RESULTS[f"derive{n}"] = (t_ours, t_kane)


# ------------------------------------------------------------------------------ simulation
def kane_rhs(n: int, explicit: bool = False):
    """A student's state equations from KanesMethod, lambdified (x = [q, u]): M and f solved by
    numpy at each call, or (`explicit`) the symbolically solved x' = km.rhs() lambdified."""
    import sympy as sp
    from derive_chain import kane_chain

    km, q, u, (m, l, g) = kane_chain(n)
    # the mass matrix and forcing of the full state equations, lambdified, and solved numerically
    # at each call (as sympy's and PyDy's n-link pendulum examples do; lambdifying the symbolic
    # LU solution km.rhs() instead is far slower for 6 links)
    params = (1.0, 1.0, 9.81)
    if explicit:
        rhs = sp.lambdify([list(q) + list(u), (m, l, g)], km.rhs(), "numpy")
        return lambda t, x: rhs(x, params).ravel()
    Mf = sp.lambdify([list(q) + list(u), (m, l, g)], km.mass_matrix_full, "numpy")
    ff = sp.lambdify([list(q) + list(u), (m, l, g)], km.forcing_full, "numpy")
    return lambda t, x: np.linalg.solve(Mf(x, params), ff(x, params)).ravel()


def c_floor(eqs, folder: Path):
    """Build the C floor for `eqs`; returns a function (tol) -> (seconds, nfev, final state) or None."""
    gcc = shutil.which("gcc") or shutil.which("cc")
    if gcc is None:
        return None
    from scipy.integrate._ivp import dop853_coefficients as c

    def comb(row, var="K"):
        terms = [f"{float(a)!r} * {var}[{j}][i]" for j, a in enumerate(row) if a != 0.0]
        return " + ".join(terms) or "0.0"

    lines = ["static int dop_stages(double t, double h, const double *y, double K[16][NX], double *xs, "
             "double *ynew, const double *p, double *work, double *r) {"]
    for s in range(1, 13):
        lines.append(f"    for (int i = 0; i < NX; i++) xs[i] = y[i] + h * ({comb(c.A[s, :s])});")
        lines.append(f"    *r = rhs(t + {float(c.C[s])!r} * h, xs, p, K[{s}], work);")
        lines.append("    if (*r <= 1e-12) return 2;")
    lines += ["    for (int i = 0; i < NX; i++) ynew[i] = xs[i];", "    return 0;", "}", "",
              "static void dop_errors(double K[16][NX], const double *y, const double *ynew, double rtol, "
              "double atol, double *e5, double *e3) {",
              "    *e5 = 0.0; *e3 = 0.0;",
              "    for (int i = 0; i < NX; i++) {",
              "        double sc = atol + fmax(fabs(y[i]), fabs(ynew[i])) * rtol;",
              f"        double d5 = ({comb(c.E5)}) / sc;",
              f"        double d3 = ({comb(c.E3)}) / sc;",
              "        *e5 += d5 * d5; *e3 += d3 * d3;", "    }", "}"]
    (folder / "dop853_stages.h").write_text("\n".join(lines) + "\n")
    (folder / "model.c").write_text(_codegen.c_source(eqs))
    exe = folder / f"floor{eqs.n}"
    cmd = [gcc, "-O2", f"-DN={eqs.n}", '-DMODEL="model.c"', f"-I{folder}", str(HERE / "c_floor" / "dop853.c"),
           "-o", str(exe), "-lm"]
    subprocess.run(cmd, check=True, cwd=folder)
    p = lg.compile(eqs).parameter_values

    def run(tol, x0, t_end, repeats):
        out = subprocess.run([str(exe), repr(t_end), repr(tol), repr(tol), str(repeats),
                              *map(repr, map(float, x0)), *map(repr, map(float, p))],
                             capture_output=True, text=True, check=True).stdout.split()
        return float(out[0]), int(out[1]), np.array(list(map(float, out[4:])))
    return run


def search(tols, error) -> dict[float, float]:
    """Errors from the loosest tolerance on, until two in a row reach the target."""
    out, hits = {}, 0
    for tol in tols:
        out[tol] = error(tol)
        hits = hits + 1 if out[tol] <= TARGET_ERROR else 0
        if hits == 2:
            break
    return out


def loosest(errors: dict[float, float]) -> float:
    ok = [tol for tol, e in errors.items() if e <= TARGET_ERROR]
    return max(ok) if ok else min(errors)


def simulation(quick: bool) -> None:
    from scipy.integrate import solve_ivp

    header(f"Simulation at equal accuracy (20 s, final error <= {TARGET_ERROR:g}), median CPU time")
    tols = [10.0 ** (-k / 2) for k in range(10, 27)]  # 1e-5 .. 1e-13
    rows = []
    folder = Path(tempfile.mkdtemp(prefix="lagrangian-bench-"))
    for label, n in (("double pendulum", 2), ("6-link chain", 6)):
        model = lg.load(f"pendulum-chain-{n}")
        eqs = lg.derive(model)
        cm = compile_numba(eqs)
        p = cm.parameter_values
        x0 = np.zeros(2 * n)
        x0[:n] = 0.5
        t_end = 20.0
        prog = constant_programs([])
        ends = np.array([0.0, t_end])
        ref = run_dop853(cm, x0, ends, p, prog, 1e-13, 1e-13).x[-1]
        sref = solve_ivp(lambda t, x: cm.rhs(t, x, [], p), (0, t_end), x0, method="DOP853", rtol=1e-13,
                         atol=1e-13).y[:, -1]
        print(f"{label}: reference (DOP853 at 1e-13, ours vs SciPy's) agree to {np.max(np.abs(ref - sref)):.1e}")

        def err(x):
            return float(np.max(np.abs(x - ref)))

        # ours: the compiled integrator call, and simulate() end to end
        e_ours = search(tols, lambda tol: err(run_dop853(cm, x0, ends, p, prog, tol, tol).x[-1]))
        tol_o = loosest(e_ours)
        reps = 20 if quick else 100
        t_kernel = cpu(lambda: run_dop853(cm, x0, ends, p, prog, tol_o, tol_o), reps)
        nfev_o = run_dop853(cm, x0, ends, p, prog, tol_o, tol_o).nfev
        t_api = cpu(lambda: lg.simulate(eqs, t_end, x0, t_eval=ends, rtol=tol_o, atol=tol_o), reps)
        # the peer: lambdify + solve_ivp
        t0 = time.process_time()
        f = kane_rhs(n)
        t_build = time.process_time() - t0
        print(f"  KanesMethod + lambdify: {t_build:.1f} s", flush=True)
        e_peer = search(tols, lambda tol: err(solve_ivp(f, (0, t_end), x0, method="DOP853", rtol=tol,
                                                        atol=tol).y[:, -1]))
        tol_p = loosest(e_peer)
        t_peer = cpu(lambda: solve_ivp(f, (0, t_end), x0, method="DOP853", rtol=tol_p, atol=tol_p),
                     1 if n > 2 else 3)
        nfev_p = solve_ivp(f, (0, t_end), x0, method="DOP853", rtol=tol_p, atol=tol_p).nfev
        # the explicit peer (km.rhs() lambdified), for the double pendulum only: building it for 6
        # links takes minutes
        t_explicit = float("nan")
        if n == 2:
            fx = kane_rhs(n, explicit=True)
            e_x = search(tols, lambda tol: err(solve_ivp(fx, (0, t_end), x0, method="DOP853", rtol=tol,
                                                         atol=tol).y[:, -1]))
            tol_x = loosest(e_x)
            t_explicit = cpu(lambda: solve_ivp(fx, (0, t_end), x0, method="DOP853", rtol=tol_x, atol=tol_x), 3)
            print(f"  explicit km.rhs() + lambdify + solve_ivp: {t_explicit * 1e3:.1f} ms at {tol_x:.0e}", flush=True)
        # the C floor
        floor = c_floor(eqs, folder)
        if floor is not None:
            e_c = search(tols, lambda tol: err(floor(tol, x0, t_end, 1)[2]))
            tol_c = loosest(e_c)
            t_c, nfev_c, _ = floor(tol_c, x0, t_end, 201 if not quick else 41)
        else:
            tol_c = t_c = nfev_c = float("nan")
        print(f"  {label}: done (ours {tol_o:.0e}, peer {tol_p:.0e}, C {tol_c:.0e})", flush=True)
        rows.append((label, tol_o, e_ours[tol_o], nfev_o, t_kernel, t_api, tol_p, e_peer[tol_p], nfev_p, t_peer,
                     t_build, tol_c, nfev_c, t_c))
        RESULTS[f"sim{n}"] = dict(kernel=t_kernel, api=t_api, peer=t_peer, floor=t_c, explicit=t_explicit)
    shutil.rmtree(folder, ignore_errors=True)
    print()
    print("| system | tool | tolerance | final error | nfev | CPU time |")
    print("|---|---|---:|---:|---:|---:|")
    for (label, tol_o, e_o, nfev_o, t_kernel, t_api, tol_p, e_p, nfev_p, t_peer, t_build, tol_c, nfev_c,
         t_c) in rows:
        print(f"| {label} | lagrangian, compiled DOP853 (integrator call) | {tol_o:.0e} | {e_o:.1e} | {nfev_o} | "
              f"{t_kernel * 1e3:.3f} ms |")
        print(f"| {label} | lagrangian, `simulate()` end to end | {tol_o:.0e} | {e_o:.1e} | {nfev_o} | "
              f"{t_api * 1e3:.3f} ms |")
        print(f"| {label} | sympy.lambdify + solve_ivp(DOP853) | {tol_p:.0e} | {e_p:.1e} | {nfev_p} | "
              f"{t_peer * 1e3:.1f} ms (lambdify: {t_build:.1f} s once) |")
        print(f"| {label} | C DOP853 loop, gcc -O2 (floor) | {tol_c:.0e} | | {nfev_c} | {t_c * 1e3:.3f} ms |")
    print()
    print("| system | lambdify+solve_ivp / ours (integrator) | / ours (simulate) | ours (integrator) / C floor | "
          "ours (simulate) / C floor |")
    print("|---|---:|---:|---:|---:|")
    for row in rows:
        label, t_kernel, t_api, t_peer, t_c = row[0], row[4], row[5], row[9], row[13]
        print(f"| {label} | {t_peer / t_kernel:.0f}x | {t_peer / t_api:.0f}x | {t_kernel / t_c:.2f} | "
              f"{t_api / t_c:.2f} |")


# ------------------------------------------------------------------------------------ batch
def batch(quick: bool) -> None:
    import numba

    header("Batch: double-pendulum trajectories (10 s, rtol = atol = 1e-8) per second of wall time")
    eqs = lg.derive(lg.load("double-pendulum"))
    B = 2000 if quick else 10000
    rng = np.random.default_rng(1)
    X0 = np.zeros((B, 4))
    X0[:, :2] = rng.uniform(-1.0, 1.0, (B, 2))
    run = lambda: lg.simulate_batch(eqs, 10.0, X0, t_eval=[10.0], rtol=1e-8, atol=1e-8, progress=False)  # noqa
    result = run()  # compiles (once per machine) and warms up
    print(f"{B} trajectories, mean nfev {result.nfev.mean():.0f}, all reached the end: {bool(result.ok.all())}")
    print("| threads | trajectories per second |")
    print("|---:|---:|")
    threads = numba.get_num_threads()
    for k in sorted({1, threads}):
        numba.set_num_threads(k)
        rate = B / wall(run, 3)
        print(f"| {k} | {rate:,.0f} |", flush=True)
        RESULTS[f"batch{k}"] = rate
    numba.set_num_threads(threads)
    RESULTS["batch"] = RESULTS[f"batch{threads}"]
    RESULTS["threads"] = threads


# ---------------------------------------------------------------------------- output stage
def _rhs_call_ns(cm, x0, p, count: int = 200_000) -> float:
    """Nanoseconds per call of the model's compiled rhs from compiled code (as the kernels call it)."""
    from numba import njit

    k = kernels()
    call, ptr = k._rc, k._ptr

    @njit
    def loop(rc, x, p, count):
        dx, work, u, xs, s = np.empty(x.shape[0]), np.empty(x.shape[0] ** 2), np.empty(1), x.copy(), 0.0
        for j in range(count):
            xs[0] = x[0] + j * 1e-9
            s += call(rc, 0.0, ptr(xs, 0), ptr(u, 0), ptr(p, 0), ptr(dx, 0), ptr(work, 0)) + dx[-1]
        return s

    loop(cm.rhs_address, x0, p, 10)
    return statistics.median(cpu(lambda: loop(cm.rhs_address, x0, p, count), 1) for _ in range(5)) / count * 1e9


def output_stage(quick: bool) -> None:
    """The double pendulum of the model file (20 s, the model's output every 0.01 s: 2001 points and
    the energy column) at rtol = atol = 1e-8: the integration alone (the compiled DOP853 to t = 20,
    no outputs) against `simulate()` end to end, and where the difference goes. The aim (issue 20):
    end to end at most 1.3x the integration."""
    header("Output stage: a 20 s double pendulum at rtol = atol = 1e-8, wall time (median [quartiles] of "
           "interleaved rounds)")
    eqs = lg.derive(lg.load("double-pendulum"))
    cm = compile_numba(eqs)
    cm.energy_rows.compile()  # (compiled lazily, numeric/_fast.EnergyRows: here the repeated runs' steady state)
    p = cm.parameter_values
    x0 = np.array([2.0, 2.5, 0.0, 0.0])  # the model file's initial state
    prog = constant_programs([])
    ends = np.array([0.0, 20.0])
    grid = np.linspace(0.0, 20.0, 2001)
    X = run_dop853(cm, x0, grid, p, prog, 1e-8, 1e-8).x
    E = np.empty(len(grid))

    def energies(rows: int):
        kernels().energies((cm.energy_address, rows), grid, X, p, prog.ops, prog.args, prog.starts, prog.nstack, E,
                           np.empty((len(grid), 0)), np.zeros(1, np.int64))

    runs = {
        "integration alone (run_dop853 to t = 20)": lambda: run_dop853(cm, x0, ends, p, prog, 1e-8, 1e-8),
        "integration with the 2001 outputs, no energy": lambda: run_dop853(cm, x0, grid, p, prog, 1e-8, 1e-8,
                                                                             outputs=False),
        "integration with the 2001 outputs (run_dop853)": lambda: run_dop853(cm, x0, grid, p, prog, 1e-8, 1e-8),
        "simulate() end to end (2001 points, energy)": lambda: lg.simulate(eqs, rtol=1e-8, atol=1e-8),
        # every call new (a parameter sweep: m1 differs in the last bits): the options merged and checked each time
        "simulate() end to end, a call not made before": lambda: lg.simulate(
            eqs, rtol=1e-8, atol=1e-8, params={"m1": 1.0 + 1e-12 * next(sweep)}),
        "the energy of the 2001 rows, energy_rows (vectorized)": lambda: energies(cm.energy_rows_address),
        "the energy of the 2001 rows, energy row by row": lambda: energies(0),
    }
    sweep = itertools.count()
    tr = lg.simulate(eqs, rtol=1e-8, atol=1e-8)
    assert len(tr.t) == 2001 and tr.energy is not None
    rounds, reps = (5, 40) if quick else (15, 60)
    times: dict[str, list] = {label: [] for label in runs}
    for _ in range(rounds):  # interleaved rounds: a noisy machine slows all of them alike
        for label, fn in runs.items():
            fn()
            times[label].append(wall(fn, reps))
    print("| run | median | quartiles |")
    print("|---|---:|---:|")
    med = {}
    for label, values in times.items():
        med[label] = statistics.median(values)
        q1, _, q3 = statistics.quantiles(values, n=4)
        print(f"| {label} | {med[label] * 1e3:.3f} ms | [{q1 * 1e3:.3f}, {q3 * 1e3:.3f}] |")
    alone, dense, outputs, end, new, e_rows, e_one = med.values()
    print(f"\nend to end / integration alone: {end / alone:.2f} (aim: at most 1.3)")
    # where the rest goes, measured
    a = run_dop853(cm, x0, ends, p, prog, 1e-8, 1e-8)
    b = run_dop853(cm, x0, grid, p, prog, 1e-8, 1e-8)
    rhs_ns = _rhs_call_ns(cm, x0, p)
    extra = b.nfev - a.nfev
    print(f"steps: {b.nstep} accepted, {b.nreject} rejected (the same with and without outputs); right-hand sides: "
          f"{a.nfev} alone (12 a step tried), {b.nfev} with the outputs ({extra / b.nstep:.2f} more a step: the "
          f"interpolant's 3 stages; every step holds an output, {len(grid) / b.nstep:.1f} on average); one rhs "
          f"{rhs_ns:.1f} ns from compiled code")
    print(f"dense output: {(dense - alone) * 1e6:.1f} us = the 3 stages' rhs {extra * rhs_ns / 1e3:.1f} us + the "
          f"stages' states, the interpolant's coefficients (7 x 2n a step) and the {len(grid)} rows "
          f"{(dense - alone) * 1e6 - extra * rhs_ns / 1e3:.1f} us")
    print(f"energy column: {(outputs - dense) * 1e6:.1f} us in the run (its arrays included); the energy of the rows "
          f"alone: {e_rows * 1e6:.1f} us by energy_rows, {e_one * 1e6:.1f} us row by row")
    # the rest is Python: a call made again with the same arguments (as here) takes the options, checks and
    # compiled model of the first (numeric/_simulate.py, _checked_key), so what is left is the key, the run's
    # arrays and the Trajectory, which takes them without copies; a call not made before merges and checks
    # everything
    print(f"Python around the run: {(end - outputs) * 1e6:.1f} us ({(new - outputs) * 1e6:.1f} us for a call not "
          f"made before)")
    around, prep = _python_around(eqs, cm, x0, grid, p, prog)
    print(f"Python around a repeated simulate(), the kernel stubbed (it writes a real run's arrays; CPU time, "
          f"medians of interleaved rounds): {around * 1e6:.1f} us (the key, the kept call, the output arrays, the "
          f"finiteness check, the Trajectory; the kept call runs a prepared kernel call); run_dop853's own: "
          f"{prep * 1e6:.1f} us")
    RESULTS["output"] = (alone, end)


def _python_around(eqs, cm, x0, grid, p, prog, rounds: int = 15, reps: int = 300) -> tuple[float, float]:
    """The Python of a repeated simulate() and of run_dop853 (seconds): the kernel replaced by a stub that
    writes a real run's states, energy and counts, less the stub's own work (interleaved rounds, CPU time)."""
    k = kernels()
    real = k.dop853
    ref = lg.simulate(eqs, rtol=1e-8, atol=1e-8)
    rows, RX, RE = len(ref.t), ref.x.copy(), ref.energy.copy()
    counts = (ref.stats["nfev"], ref.stats["nstep"], ref.stats["nreject"], rows, 0)

    def stub(model, x0_, t_out, p_, prog_, control, events, sampling, out):
        X, info, stats, U, E, done = out
        X[:] = RX
        E[:] = RE
        stats[:] = counts
        done[0] = rows
        return 0

    def stub_only():
        stub(None, None, None, None, None, None, None, None,
             (np.empty((rows, RX.shape[1])), None, np.zeros(5, np.int64), None, np.empty(rows), np.zeros(1, np.int64)))

    runs = {"stub": stub_only, "simulate": lambda: lg.simulate(eqs, rtol=1e-8, atol=1e-8),
            "run_dop853": lambda: run_dop853(cm, x0, grid, p, prog, 1e-8, 1e-8, progress=False)}
    times: dict[str, list] = {label: [] for label in runs}

    def repeat(fn):  # (each result dropped at once, as a loop of simulate() calls does)
        for _ in range(reps):
            fn()

    k.dop853 = stub
    try:
        for _ in range(rounds):
            for label, fn in runs.items():
                fn()
                times[label].append(cpu(lambda: repeat(fn), 1) / reps)
    finally:
        k.dop853 = real
    less = [statistics.median([b - a for a, b in zip(times["stub"], times[label])])
            for label in ("simulate", "run_dop853")]
    return less[0], less[1]


# ------------------------------------------------------------------------------- new model
_PROBE = textwrap.dedent("""
    import time, sys
    t0 = time.perf_counter()
    import lagrangian as lg
    from lagrangian.numeric import _codegen
    from lagrangian.numeric._fast import compile_numba, kernels
    t1 = time.perf_counter()
    model = lg.load(sys.argv[1])
    eqs = lg.derive(model)
    t2 = time.perf_counter()
    fresh = not (_codegen.cache_dir() / f"lagrangian_index_{_codegen.fingerprint(eqs, 'numba-main')}.txt").exists()
    if fresh:
        text = _codegen.numba_source(eqs)
    t3 = time.perf_counter()
    cm = compile_numba(eqs)
    kernels()
    t4 = time.perf_counter()
    tr = lg.simulate(eqs, 1.0)
    t5 = time.perf_counter()
    rows = cm.energy_rows.address != 0  # found on disk (compiled before)
    c0 = time.process_time()
    cm.energy_rows.compile()  # (lazy: what its compile costs, or its loading when found on disk)
    print(t1 - t0, t2 - t1, t3 - t2, t4 - t3, t5 - t4, time.process_time() - c0, int(rows))
""")


def new_model(quick: bool) -> None:
    header("A new model: one-time cost (fresh processes, wall time)")
    folder = Path(tempfile.mkdtemp(prefix="lagrangian-bench-model-"))
    from lagrangian.examples import example_source

    tag = f"{os.getpid()}{int(time.time()) % 100000}"
    text = example_source("double-pendulum").replace("theta", f"phi{tag}_")
    path = folder / "new-model.toml"
    path.write_text(text)
    env = dict(os.environ)

    def probe():
        out = subprocess.run([sys.executable, "-c", _PROBE, str(path)], capture_output=True, text=True, env=env,
                             check=True).stdout.split()
        return [float(v) for v in out]

    print("| run | import | derive | generate | compile (or load) | simulate 1 s | energy_rows (lazy) |")
    print("|---|---:|---:|---:|---:|---:|---:|")
    for label in ("new model (kernels already compiled)", "same model again (cached)"):
        imp, der, gen, comp, sim, rows, found = probe()
        print(f"| {label} | {imp:.2f} s | {der:.3f} s | {gen:.3f} s | {comp:.2f} s | {sim:.3f} s | "
              f"{'loaded at compile, ' if found else 'not compiled; its compile: '}{rows:.2f} s of CPU |", flush=True)
    cli = shutil.which("lagrangian")
    text2 = text.replace(f"phi{tag}_", f"psi{tag}_")
    path2 = folder / "new-model-cli.toml"
    path2.write_text(text2)
    times = []
    for _ in range(2):
        t0 = time.perf_counter()
        subprocess.run([cli or sys.executable, *([] if cli else ["-m", "lagrangian"]), "simulate", str(path2),
                        "--t-end", "10", "-o", str(folder / "out.csv")], check=True, capture_output=True, env=env)
        times.append(time.perf_counter() - t0)
    print(f"\n`lagrangian simulate` of a new model file (10 s, output every 0.01 s): first run {times[0]:.2f} s, "
          f"second run {times[1]:.2f} s")
    RESULTS["cli"] = times
    if not quick:  # the very first use on a machine: an empty cache, the kernels compile too
        env["LAGRANGIAN_CACHE_DIR"] = str(folder / "empty-cache")
        imp, der, gen, comp, sim, _, _ = probe()
        print(f"first use on a machine (empty cache: the integrator kernels compile once, then are cached): "
              f"compile {comp:.1f} s, first simulate {sim:.1f} s, total {imp + der + gen + comp + sim:.1f} s")
        RESULTS["first_use"] = imp + der + gen + comp + sim
    shutil.rmtree(folder, ignore_errors=True)


# -------------------------------------------------------------------------------- 40 links
def forty(quick: bool) -> None:
    header("A 40-link chain: derivation, code generation and compilation, separately (wall time)")
    folder = Path(tempfile.mkdtemp(prefix="lagrangian-bench-40-"))
    old = os.environ.get("LAGRANGIAN_CACHE_DIR")
    os.environ["LAGRANGIAN_CACHE_DIR"] = str(folder)
    try:
        model = lg.load("pendulum-chain-40")
        t0 = time.perf_counter()
        eqs = lg.derive(model)
        eqs.core.f
        t1 = time.perf_counter()
        text = _codegen.numba_source(eqs)
        t2 = time.perf_counter()
        path = folder / "chain40.py"
        path.write_text(text)
        _codegen.load_module(path, f"chain40_{os.getpid()}")
        t3 = time.perf_counter()
        csrc = _codegen.c_source(eqs)
        t4 = time.perf_counter()
        (folder / "chain40.c").write_text(csrc)
        gcc = shutil.which("gcc") or shutil.which("cc")
        t_gcc = float("nan")
        if gcc:
            t5 = time.perf_counter()
            subprocess.run([gcc, "-O2", "-shared", "-fPIC", "-o", str(folder / "chain40.so"), str(folder / "chain40.c"),
                            "-lm"], check=True)
            t_gcc = time.perf_counter() - t5
        print("| step | time |")
        print("|---|---:|")
        print(f"| derive (M and f) | {t1 - t0:.2f} s |")
        print(f"| generate numba code (CSE, {len(text) / 1e6:.1f} MB of source) | {t2 - t1:.2f} s |")
        print(f"| compile with numba (rhs and energy) | {t3 - t2:.2f} s |")
        print(f"| generate C code | {t4 - t3:.2f} s |")
        print(f"| compile C with gcc -O2 | {t_gcc:.2f} s |")
        RESULTS["forty"] = (t1 - t0, t2 - t1, t3 - t2, t4 - t3, t_gcc)
    finally:
        if old is None:
            os.environ.pop("LAGRANGIAN_CACHE_DIR", None)
        else:
            os.environ["LAGRANGIAN_CACHE_DIR"] = old
        shutil.rmtree(folder, ignore_errors=True)


# --------------------------------------------------------------------------------- display
def display(quick: bool) -> None:
    import display as readable_display

    header("Readable equations: derive, check and report against KanesMethod (medians)")
    RESULTS["display"] = readable_display.run(repeat=3 if quick else 5)


# --------------------------------------------------------------------------------- bodies
def bodies(quick: bool) -> None:
    import derive_arm

    header("Bodies in space: robot arms against KanesMethod (median CPU time)")
    RESULTS["arm"] = derive_arm.run((3, 6), repeat=3 if quick else 5)


# -------------------------------------------------------------------------------- bicycle
def bicycle(quick: bool) -> None:
    import bicycle as whipple

    header("The Whipple bicycle: derived and linearized at one speed, against KanesMethod (medians)")
    RESULTS["bicycle"] = whipple.run(repeat=3 if quick else 5, peer=not quick)


# --------------------------------------------------------------------------------- summary
def summary() -> None:
    header("Targets")
    R = RESULTS

    def mark(ok):
        return "holds" if ok else "MISSED"

    print("| target | measured | |")
    print("|---|---|---|")
    for n, label in ((2, "double pendulum"), (6, "6-link chain")):
        s = R.get(f"sim{n}")
        if s:
            r_peer = s["peer"] / s["kernel"]
            r_floor = s["kernel"] / s["floor"]
            print(f"| {label}: >= 300x faster than lambdify + solve_ivp | {r_peer:.0f}x (integrator call), "
                  f"{s['peer'] / s['api']:.0f}x (simulate() end to end) | {mark(r_peer >= 300)} |")
            if s["explicit"] == s["explicit"]:
                r_x = s["explicit"] / s["kernel"]
                print(f"| {label}: >= 300x faster than lambdify of the explicit km.rhs() + solve_ivp | "
                      f"{r_x:.0f}x (integrator call), {s['explicit'] / s['api']:.0f}x (simulate() end to end) | "
                      f"{mark(r_x >= 300)} |")
            print(f"| {label}: within 1.3x of the C floor | {r_floor:.2f}x (integrator call), "
                  f"{s['api'] / s['floor']:.2f}x (simulate()) | {mark(r_floor <= 1.3)} |")
    if "batch" in R:
        print(f"| batch: >= 15,000 double pendulums per second on {R['threads']} cores (aim 59,000) | "
              f"{R['batch']:,.0f}/s | {mark(R['batch'] >= 15000)} |")
    if "output" in R:
        alone, end = R["output"]
        print(f"| output stage: simulate() end to end at most 1.3x the integration alone (20 s double pendulum, "
              f"2001 points and energy) | {end / alone:.2f}x ({end * 1e3:.3f} ms against {alone * 1e3:.3f} ms) | "
              f"{mark(end / alone <= 1.3)} |")
    if "cli" in R:
        first, second = R["cli"]
        print(f"| new model from the CLI: first run < 5 s | {first:.2f} s | {mark(first < 5)} |")
        print(f"| new model from the CLI: second run < 1.5 s | {second:.2f} s | {mark(second < 1.5)} |")
    if "derive10" in R:
        ours, kane = R["derive10"]
        print(f"| derivation: >= 50x faster than KanesMethod at 10 links | {kane / ours:.0f}x | "
              f"{mark(kane / ours >= 50)} |")
    if "forty" in R:
        d, g, c, _, _ = R["forty"]
        print(f"| 40-link chain derived in a few seconds | derive {d:.2f} s, generate {g:.1f} s, compile {c:.1f} s "
              f"| {mark(d < 5)} |")
    if "display" in R:
        import display as readable_display

        for target, measured, ok in readable_display.targets(R["display"]):
            print(f"| {target} | {measured} | {mark(ok)} |")
    if "arm" in R and 6 in R["arm"]:
        ours, kane = R["arm"][6]
        print(f"| a 6-joint arm in space derived >= 20x faster than KanesMethod | {kane / ours:.0f}x | "
              f"{mark(kane / ours >= 20)} |")
    if "bicycle" in R:
        import bicycle as whipple

        for target, measured, ok in whipple.targets(R["bicycle"]):
            print(f"| {target} | {measured} | {mark(ok)} |")


def main(argv=None) -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--quick", action="store_true", help="fewer repeats; skip the slowest peers")
    ap.add_argument("--only", nargs="*", choices=["derivation", "simulation", "batch", "output-stage", "new-model",
                                                  "forty", "display", "bodies", "bicycle"],
                    help="run only these sections")
    args = ap.parse_args(argv)
    sections = {"derivation": derivation, "simulation": simulation, "batch": batch, "output-stage": output_stage,
                "new-model": new_model, "forty": forty, "display": display, "bodies": bodies, "bicycle": bicycle}
    import platform

    print(f"# lagrangian benchmarks ({platform.processor() or platform.machine()}, {os.cpu_count()} cores, "
          f"Python {platform.python_version()})")
    for name, fn in sections.items():
        if args.only and name not in args.only:
            continue
        fn(args.quick)
    summary()


if __name__ == "__main__":
    main()
