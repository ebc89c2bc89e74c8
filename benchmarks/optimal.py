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

Reported: the CPU time to the solution (median of the repeats), IPOPT's iterations and the optimal
cost. opty (direct collocation on sympy.physics.mechanics equations) is not in the comparison:
it needs cyipopt, which has no wheel for this platform and cannot be installed here.
"""

from __future__ import annotations

import argparse
import math
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


def timed(fn, repeat: int):
    times, out = [], None
    for _ in range(repeat):
        t0 = time.process_time()
        out = fn()
        times.append(time.process_time() - t0)
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
    for n in (int(v) for v in args.intervals.split(",")):
        for name, fn in (("lagrangian", lambda: by_lagrangian(eqs, n)), ("CasADi by hand", lambda: by_hand(n))):
            seconds, (cost, iterations) = timed(fn, args.repeat)
            print(f"{n:>9}  {name:<22} {1e3 * seconds:>8.0f} ms {iterations:>10d} {cost:>14.8f}")
    t0 = time.process_time()
    motion = lg.optimal_motion(eqs, duration=T, objective="F**2", initial={"x": 0, "th": 0, "x_dot": 0, "th_dot": 0},
                               final={"x": D, "th": math.pi, "x_dot": 0, "th_dot": 0}, inputs={"F": (-UMAX, UMAX)},
                               tolerance=1e-6)
    print(f"lagrangian with mesh refinement to 1e-6 and the replay: {time.process_time() - t0:.2f} s CPU, "
          f"{motion.intervals} intervals, {motion.iterations} iterations, cost {motion.cost:.8f}, "
          f"replay deviation {motion.max_replay_deviation:.1e}")
    print("opty: not installable here (its cyipopt dependency has no wheel), so not compared")


if __name__ == "__main__":
    main()
