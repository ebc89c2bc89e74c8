"""Feedback laws in the compiled path (issue 12): what a law of the state costs, against a time
input, no input, and the same law as a Python function (the SciPy path); what a new law costs
(it compiles nothing); and a discontinuous law's switches located as events against SciPy's
solve_ivp crawling through them.

Run:   python benchmarks/feedback.py     (about 10 s on 2 cores, once the model is compiled)

Each number is the median wall time of lg.simulate(...) end to end (parsing the law, the
integration, the Trajectory), over several runs after a first one that compiles the model; us/nfev
is that time per evaluation of the right-hand side (the runs differ in their number of steps).
"""

from __future__ import annotations

import math
import statistics
import time

import numpy as np
import sympy

import lagrangian as lg

LQR = "1.0*q1 - 41.93*(q2 - pi/2) + 2.559*q1_dot - 11.72*q2_dot"


def median_ms(fn, repeat: int) -> float:
    times = []
    for _ in range(repeat):
        t0 = time.perf_counter()
        fn()
        times.append(time.perf_counter() - t0)
    return 1e3 * statistics.median(times)


def main() -> None:
    eqs = lg.derive(lg.load("cart-pendulum"))
    run = dict(rtol=1e-9, atol=1e-9, dt=0.01)
    lg.simulate(eqs, 1.0, {"q2": 1.3}, inputs={"F": LQR}, **run)  # compiles the model once

    T = 100.0
    track = "1.0*(q1 - 0.3*sin(t)) - 41.93*(q2 - pi/2) + 2.559*q1_dot - 11.72*q2_dot"
    print(f"cart-pendulum from q2 = 1.3, {T:g} s, rtol = atol = 1e-9, {int(T / 0.01) + 1} output rows")
    print(f"  {'input':<58} {'ms':>8} {'nfev':>7} {'us/nfev':>8} backend")
    K = np.array([-1.0, 41.93, -2.559, 11.72])
    x0 = np.array([0.0, math.pi / 2, 0.0, 0.0])

    def python_law(t, x):
        return float(-K @ (x - x0) + 0.3 * math.sin(t))

    cases = [
        ("F = 0 (no input: the pendulum falls and swings)", {"F": 0.0}, {}, 10),
        ("F = 0.5*sin(3*t) (a time input)", {"F": "0.5*sin(3*t)"}, {}, 10),
        ("F = the LQR law tracking q1 = 0.3 sin t (an expression)", {"F": track}, {}, 10),
        ("F = clip(that law, -6, 6), sampled every 0.02 s", {"F": f"clip({track}, -6, 6)"}, {"sample_time": 0.02}, 10),
        ("F = that law as a Python function u(t, x)", {"F": python_law}, {}, 3),
    ]
    for label, inputs, extra, repeat in cases:
        tr = lg.simulate(eqs, T, {"q2": 1.3}, inputs=inputs, **run, **extra)
        ms = median_ms(lambda: lg.simulate(eqs, T, {"q2": 1.3}, inputs=inputs, **run, **extra), repeat)
        per = 1e3 * ms / tr.stats["nfev"]
        print(f"  {label:<58} {ms:8.2f} {tr.stats['nfev']:7d} {per:8.2f} {tr.stats['backend']}")

    print("\na law never seen before (a new gain each time): the first simulate of each")
    firsts = []
    for k in range(5):
        law = f"1.0*q1 - {41.93 + 0.01 * (k + 1):.2f}*(q2 - pi/2) + 2.559*q1_dot - 11.72*q2_dot + {k}e-9"
        t0 = time.perf_counter()
        lg.simulate(eqs, 10.0, {"q2": 1.3}, inputs={"F": law}, **run)
        firsts.append(1e3 * (time.perf_counter() - t0))
    print(f"  median {statistics.median(firsts):.2f} ms, the slowest {max(firsts):.2f} ms: nothing is compiled")

    print("\nbang-bang x'' = where(x > 0, -1, 1) from x = 1, 10 s (4 switches), rtol = atol = 1e-10")
    di = lg.derive(lg.Model("double-integrator", coordinates=["x"], inputs=["F"], T="x_dot**2/2", Q={"x": "F"}))
    r2 = math.sqrt(2)
    for backend in ("numba", "scipy"):
        kw = dict(inputs={"F": "where(x > 0, -1, 1)"}, dt=0.05, rtol=1e-10, atol=1e-10, backend=backend)
        tr = lg.simulate(di, 10.0, {"x": 1.0}, **kw)
        ms = median_ms(lambda: lg.simulate(di, 10.0, {"x": 1.0}, **kw), 10 if backend == "numba" else 3)
        k = np.floor((tr.t + r2) / (2 * r2))
        s = tr.t - 2 * r2 * k
        exact = np.where(k % 2 == 0, 1.0, -1.0) * (1 - s ** 2 / 2)
        error = np.max(np.abs(tr["x"] - exact))
        located = f", {tr.stats['switches']} switches located" if "switches" in tr.stats else ""
        print(f"  {backend:<6} {ms:8.2f} ms, nfev {tr.stats['nfev']:6d}, largest error {error:.1e}{located}")

    print("\nthe swing-up (energy pumping, caught by the LQR through a where switch), 15 s, rtol = atol = 1e-10")
    lin = lg.linearize(eqs, at={"q2": sympy.pi / 2})
    catch = lin.lqr({"q1": 1, "q2": 10, "q1_dot": 1, "q2_dot": 1}, {"F": 1}).law(wrap=["q2"])["F"]
    energy = "(M2*L**2*q2_dot**2/2 + M2*g*L*(sin(q2) - 1))"
    law = f"where(sin(q2) > 0.9, {catch}, clip(-8*{energy}*q2_dot*sin(q2) - 0.5*q1 - q1_dot, -8, 8))"
    kw = dict(inputs={"F": law}, rtol=1e-10, atol=1e-10)
    tr = lg.simulate(eqs, 15.0, {"q2": -math.pi / 2 + 0.1}, **kw)
    ms = median_ms(lambda: lg.simulate(eqs, 15.0, {"q2": -math.pi / 2 + 0.1}, **kw), 5)
    caught = tr.t[np.argmax(np.sin(tr["q2"]) > 0.9)]
    print(f"  {ms:.2f} ms, nfev {tr.stats['nfev']}, {tr.stats['switches']} switch(es), caught at t = {caught:.2f} s, "
          f"sin(q2) at the end {math.sin(tr['q2'][-1]):.12f}")


if __name__ == "__main__":
    main()
