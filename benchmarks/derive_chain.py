"""Derivation of an n-link pendulum chain: lagrangian.derive against sympy.physics.mechanics.

Run:  python benchmarks/derive_chain.py [n ...]      (default: 5 10 20)

Prints the median CPU time of each, measured in this run, and the ratios. KanesMethod is the
fast peer in sympy; LagrangesMethod is far slower and is timed only up to 10 links.
"""

from __future__ import annotations

import statistics
import sys
import time

import sympy as sp
from sympy.physics import mechanics as me


def cpu(fn, repeat):
    """Median CPU time of fn() over `repeat` calls."""
    times = []
    for _ in range(repeat):
        t0 = time.process_time()
        fn()
        times.append(time.process_time() - t0)
    return statistics.median(times)


def ours(n):
    import lagrangian as lg  # here, so that a process timing KanesMethod alone does not import it

    model = lg.load(f"pendulum-chain-{n}")
    return lambda: lg.derive(model).core.f  # M and f: what a simulation needs


def kane_chain(n):
    """sympy.physics.mechanics KanesMethod of the n-link chain, with its equations formed, and its
    symbols (q, u, (m, l, g))."""
    q, u, (m, l, g), N, particles, loads, kd = _chain(n, "kane")
    km = me.KanesMethod(N, q_ind=q, u_ind=u, kd_eqs=kd)
    km.kanes_equations(particles, loads)
    return km, q, u, (m, l, g)


def _chain(n, method):
    q = me.dynamicsymbols(f"q1:{n + 1}")
    u = me.dynamicsymbols(f"u1:{n + 1}")
    m, l, g = sp.symbols("m l g")
    N = me.ReferenceFrame("N")
    O = me.Point("O")
    O.set_vel(N, 0)
    P = O
    particles, loads, kd = [], [], []
    for i in range(n):
        Ai = N.orientnew(f"A{i}", "Axis", [q[i], N.z])
        Pi = P.locatenew(f"P{i}", l * Ai.y * -1)
        if method == "kane":
            Ai.set_ang_vel(N, u[i] * N.z)
            kd.append(q[i].diff() - u[i])
        Pi.v2pt_theory(P, N, Ai)
        particles.append(me.Particle(f"Pa{i}", Pi, m))
        loads.append((Pi, -m * g * N.y))
        P = Pi
    return q, u, (m, l, g), N, particles, loads, kd


def sympy_chain(n, method):
    def run():
        if method == "kane":
            km = kane_chain(n)[0]
            return km.mass_matrix, km.forcing
        q, _, _, N, particles, loads, _ = _chain(n, "lagrange")
        L = me.Lagrangian(N, *particles)
        lm = me.LagrangesMethod(L, q, forcelist=loads, frame=N)
        lm.form_lagranges_equations()
        return lm.mass_matrix, lm.forcing
    return run


def main(sizes):
    print(f"{'links':>5} {'lagrangian':>12} {'KanesMethod':>12} {'ratio':>8} {'LagrangesMethod':>16} {'ratio':>8}")
    for n in sizes:
        t_ours = cpu(ours(n), 5)
        t_kane = cpu(sympy_chain(n, "kane"), 1 if n > 10 else 3)
        if n <= 10:
            t_lag = cpu(sympy_chain(n, "lagrange"), 1)
            lag = f"{t_lag:16.3f} {t_lag / t_ours:7.0f}x"
        else:
            lag = f"{'(skipped)':>16} {'':>8}"
        print(f"{n:5d} {t_ours:11.4f}s {t_kane:11.3f}s {t_kane / t_ours:7.0f}x {lag}")


if __name__ == "__main__":
    main([int(a) for a in sys.argv[1:]] or [5, 10, 20])
