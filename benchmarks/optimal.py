"""The cart-pole swing-up: lagrangian's optimal_motion against a hand-written CasADi formulation.

Run:  python benchmarks/optimal.py [--repeat N] [--intervals 50,100]      (defaults 5; 50,100)

The problem of Kelly (2017), "An Introduction to Trajectory Optimization", section 6: cart 1 kg,
point mass 0.3 kg on a 0.5 m massless pole, from hanging at rest to upright at rest 1 m further in
2 s, |F| <= 20 N, minimum integral of F^2. Both solve the same transcription (Hermite-Simpson,
separated, on the same uniform mesh, the same first guess: states linear between the ends) with
the same IPOPT (CasADi's, MUMPS, tol 1e-9, exact Hessian):

* lagrangian: ``lg.optimal_motion`` on the derived equations, the implicit form M a = f with the
  accelerations as unknowns, the SX graph translated from the symbolic equations; no mesh
  refinement and no replay here (``max_refinements=0, replay=False``), so that the two do the same
  work; the time includes building the NLP from the equations (derive is timed apart);
* CasADi by hand: Kelly's explicit equations of motion (appendix E) typed in, x' = f(x, u).

* opty (direct collocation on SymPy equations of motion, the peer the issue names), when it is
  installed: its most accurate rule, the implicit midpoint, on as many nodes as Hermite-Simpson has
  points (2n + 1), the same bounds, ends and first guess, the trapezoidal integral of F^2, its own
  IPOPT (cyipopt's: pip cannot install cyipopt from a wheel here; it builds against Debian's
  coinor-libipopt-dev, liblapack-dev and libblas-dev), tol 1e-9, its Cython backend (the time
  includes generating and compiling the C code, a child process: the CPU time counts children).
  Its optimal cost differs from the others' by its discretization error (a second-order rule).

Reported: the CPU time to the solution (median of the repeats; this process and its children),
IPOPT's iterations and the optimal cost.
"""

from __future__ import annotations

import argparse
import importlib.util
import math
import os
import statistics
import time

import numpy as np

import lagrangian as lg

M1, M2, L, G, D, T, UMAX = 1.0, 0.3, 0.5, 9.81, 1.0, 2.0, 20.0


def cart_pole():
    return lg.Model(coordinates=["x", "th"], parameters=dict(m1=M1, m2=M2, l=L, g=G), inputs=["F"], Q={"x": "F"},
                    T="(m1 + m2)/2*x_dot**2 + m2*l*cos(th)*x_dot*th_dot + m2*l**2/2*th_dot**2",
                    V="-m2*g*l*cos(th)")


def by_lagrangian(eqs, n: int):
    motion = lg.optimal_motion(eqs, duration=T, objective="F**2", initial={"x": 0, "th": 0, "x_dot": 0, "th_dot": 0},
                               final={"x": D, "th": math.pi, "x_dot": 0, "th_dot": 0}, inputs={"F": (-UMAX, UMAX)},
                               intervals=n, max_refinements=0, replay=False)
    return motion.cost, motion.iterations


def by_hand(n: int):
    """Hermite-Simpson (separated) written by hand in CasADi on Kelly's explicit equations."""
    import casadi as ca

    x, u = ca.SX.sym("x", 4), ca.SX.sym("u")
    s, c = ca.sin(x[1]), ca.cos(x[1])
    ddx = (L * M2 * s * x[3] ** 2 + u + M2 * G * c * s) / (M1 + M2 * (1 - c**2))
    ddth = -(L * M2 * c * s * x[3] ** 2 + u * c + (M1 + M2) * G * s) / (L * M1 + L * M2 * (1 - c**2))
    f = ca.Function("f", [x, u], [ca.vertcat(x[2], x[3], ddx, ddth)])
    P = 2 * n + 1
    X, U = ca.SX.sym("X", 4, P), ca.SX.sym("U", 1, P)
    F = f.map(P)(X, U)
    h = T / n
    i0, im, i1 = list(range(0, P - 2, 2)), list(range(1, P - 1, 2)), list(range(2, P, 2))
    g = ca.vertcat(ca.vec(X[:, im] - (X[:, i0] + X[:, i1]) / 2 - h / 8 * (F[:, i0] - F[:, i1])),
                   ca.vec(X[:, i1] - X[:, i0] - h / 6 * (F[:, i0] + 4 * F[:, im] + F[:, i1])))
    J = ca.sum2(h / 6 * (U[:, i0] ** 2 + 4 * U[:, im] ** 2 + U[:, i1] ** 2))
    lb, ub = np.full((5, P), -np.inf), np.full((5, P), np.inf)
    lb[4], ub[4] = -UMAX, UMAX
    lb[:4, 0] = ub[:4, 0] = 0.0
    lb[:4, -1] = ub[:4, -1] = [D, math.pi, 0.0, 0.0]
    tau = np.linspace(0, 1, P)
    w0 = np.zeros((5, P))
    w0[0], w0[1] = D * tau, math.pi * tau
    w0[2], w0[3] = D / T, math.pi / T
    solver = ca.nlpsol("by_hand", "ipopt", {"x": ca.vec(ca.vertcat(X, U)), "f": J, "g": g},
                       {"print_time": False, "ipopt": {"print_level": 0, "sb": "yes", "tol": 1e-9, "max_iter": 3000}})
    sol = solver(x0=w0.ravel(order="F"), lbx=lb.ravel(order="F"), ubx=ub.ravel(order="F"), lbg=0, ubg=0)
    return float(sol["f"]), int(solver.stats()["iter_count"])


def by_opty(n: int):
    """The same problem in opty: Kelly's explicit equations as SymPy expressions of dynamicsymbols,
    the implicit midpoint rule on 2n + 1 nodes."""
    import sympy as sm
    import sympy.physics.mechanics as me
    from opty import Problem

    t = me.dynamicsymbols._t
    x, th, v, w, F = me.dynamicsymbols("x th v w F")
    s, c = sm.sin(th), sm.cos(th)
    ddx = (L * M2 * s * w**2 + F + M2 * G * c * s) / (M1 + M2 * (1 - c**2))
    ddth = -(L * M2 * c * s * w**2 + F * c + (M1 + M2) * G * s) / (L * M1 + L * M2 * (1 - c**2))
    eom = sm.Matrix([x.diff(t) - v, th.diff(t) - w, v.diff(t) - ddx, w.diff(t) - ddth])
    N = 2 * n + 1
    h = T / (N - 1)

    def objective(z):  # the trapezoidal integral of F^2
        u = z[4 * N:]
        return h * (np.sum(u**2) - (u[0] ** 2 + u[-1] ** 2) / 2)

    def gradient(z):
        g = np.zeros_like(z)
        u = z[4 * N:]
        g[4 * N:] = 2 * h * u
        g[4 * N] -= h * u[0]
        g[-1] -= h * u[-1]
        return g

    ends = (x.func(0.0), th.func(0.0), v.func(0.0), w.func(0.0), x.func(T) - D, th.func(T) - math.pi, v.func(T),
            w.func(T))
    problem = Problem(objective, gradient, eom, (x, th, v, w), N, h, instance_constraints=ends,
                      bounds={F: (-UMAX, UMAX)}, integration_method="midpoint", time_symbol=t)
    for key, value in (("tol", 1e-9), ("print_level", 0), ("sb", "yes"), ("max_iter", 3000)):
        problem.add_option(key, value)
    problem.obj_value.clear()  # opty appends the objective at each iteration
    tau = np.linspace(0, 1, N)
    z0 = np.zeros(5 * N)
    z0[:N], z0[N:2 * N] = D * tau, math.pi * tau
    z0[2 * N:3 * N], z0[3 * N:4 * N] = D / T, math.pi / T
    t0 = _cpu()
    _, info = problem.solve(z0)
    OPTY_SOLVE.append(_cpu() - t0)
    if info["status"] != 0:
        raise RuntimeError(f"opty's IPOPT: {info['status_msg']!r}")
    return float(info["obj_val"]), len(problem.obj_value) - 1


#: opty's CPU time in IPOPT alone (after generating and compiling its code), per run
OPTY_SOLVE: list[float] = []


def _cpu() -> float:
    """CPU time of this process and its finished children (opty compiles its C code in one)."""
    t = os.times()
    return t.user + t.system + t.children_user + t.children_system


def timed(fn, repeat: int):
    times, out = [], None
    for _ in range(repeat):
        t0 = _cpu()
        out = fn()
        times.append(_cpu() - t0)
    return statistics.median(times), out


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--repeat", type=int, default=5)
    parser.add_argument("--intervals", default="50,100")
    args = parser.parse_args()
    t0 = time.process_time()
    eqs = lg.derive(cart_pole())
    print(f"derive: {1e3 * (time.process_time() - t0):.0f} ms CPU (once)")
    print(f"{'intervals':>9}  {'formulation':<22} {'CPU time':>10} {'iterations':>10} {'optimal cost':>14}")
    have_opty = importlib.util.find_spec("opty") is not None
    for n in (int(v) for v in args.intervals.split(",")):
        rows = [("lagrangian", lambda: by_lagrangian(eqs, n)), ("CasADi by hand", lambda: by_hand(n))]
        if have_opty:
            rows.append((f"opty ({2 * n + 1} nodes)", lambda: by_opty(n)))
        for name, fn in rows:
            OPTY_SOLVE.clear()
            seconds, (cost, iterations) = timed(fn, args.repeat)
            solve = f"  (of which IPOPT {1e3 * statistics.median(OPTY_SOLVE):.0f} ms)" if OPTY_SOLVE else ""
            print(f"{n:>9}  {name:<22} {1e3 * seconds:>8.0f} ms {iterations:>10d} {cost:>14.8f}{solve}")
    t0 = time.process_time()
    motion = lg.optimal_motion(eqs, duration=T, objective="F**2", initial={"x": 0, "th": 0, "x_dot": 0, "th_dot": 0},
                               final={"x": D, "th": math.pi, "x_dot": 0, "th_dot": 0}, inputs={"F": (-UMAX, UMAX)},
                               tolerance=1e-6)
    print(f"lagrangian with mesh refinement to 1e-6 and the replay: {time.process_time() - t0:.2f} s CPU, "
          f"{motion.intervals} intervals, {motion.iterations} iterations, cost {motion.cost:.8f}, "
          f"replay deviation {motion.max_replay_deviation:.1e}")
    if not have_opty:
        print("opty: not installed (pip install opty needs cyipopt built against an IPOPT library), so not compared")


if __name__ == "__main__":
    main()
