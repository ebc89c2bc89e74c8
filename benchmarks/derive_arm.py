"""Derivation of a serial arm of n revolute joints in space (robot-arm-<n>): lagrangian.derive against
sympy.physics.mechanics' KanesMethod, in the same run.

Run:  python benchmarks/derive_arm.py [n ...]      (default: 3 6)

Prints the median CPU time of each (lagrangian: M and f, what a simulation needs; KanesMethod: its
equations with mass_matrix_full and forcing_full, the peer's documented path) and the ratio;
the target of the bodies-in-space issue is >= 20x for the 6-joint arm. The SymPy arm is built the
same way as lagrangian's (lagrangian.examples.robot_arm_toml): the tests cross-check the two.
"""

from __future__ import annotations

import statistics
import sys
import time

import sympy as sp
from sympy.physics import mechanics as me


def cpu(fn, repeat):
    """Median CPU time of fn() over `repeat` calls, SymPy's cache emptied before each."""
    from sympy.core.cache import clear_cache

    times = []
    for _ in range(repeat):
        clear_cache()
        t0 = time.process_time()
        fn()
        times.append(time.process_time() - t0)
    return statistics.median(times)


def sympy_arm(n: int, method: str = "kane"):
    """The arm of robot-arm-<n> in sympy.physics.mechanics: (q, bodies, loads, N, kd, u), with the
    motor torques tau1..taun as symbols (each on its link, its reaction on the link before);
    gravity as loads for KanesMethod ("kane"), as potential energy for LagrangesMethod ("lagrange")."""
    from lagrangian.examples import ARM_AXES

    axes = [ARM_AXES[k] if k < len(ARM_AXES) else ("y", "x")[k % 2] for k in range(n)]
    q = me.dynamicsymbols(f"q1:{n + 1}")
    u = me.dynamicsymbols(f"u1:{n + 1}")
    m, h, l, r, g = sp.symbols("m h l r g")
    tau = sp.symbols(f"tau1:{n + 1}")
    N = me.ReferenceFrame("N")
    O = me.Point("O")
    O.set_vel(N, 0)
    frames, bodies, loads, kd = [], [], [], []
    parent, joint = N, O
    for k in range(n):
        A = parent.orientnew(f"A{k + 1}", "Axis", (q[k], getattr(parent, axes[k])))
        if method == "kane":
            A.set_ang_vel(parent, u[k] * getattr(parent, axes[k]))
            kd.append(q[k].diff() - u[k])
        if k == 0:
            P = O
            G = O.locatenew("G1", h / 2 * A.z)
            I = me.inertia(A, m * (3 * r**2 + h**2) / 12, m * (3 * r**2 + h**2) / 12, m * r**2 / 2)
        else:
            P = joint.locatenew(f"P{k + 1}", (h * parent.z) if k == 1 else (l * parent.x))
            P.v2pt_theory(joint, N, parent)
            G = P.locatenew(f"G{k + 1}", l / 2 * A.x)
            I = me.inertia(A, m * r**2 / 2, m * (3 * r**2 + l**2) / 12, m * (3 * r**2 + l**2) / 12)
        G.v2pt_theory(P, N, A)
        body = me.RigidBody(f"B{k + 1}", G, A, m, (I, G))
        bodies.append(body)
        loads.append((A, tau[k] * getattr(parent, axes[k])))
        if k > 0:
            loads.append((parent, -tau[k] * getattr(parent, axes[k])))
        if method == "kane":  # gravity as a load; LagrangesMethod takes it as potential energy
            loads.append((G, -m * g * N.z))
        else:
            body.potential_energy = m * g * G.pos_from(O).dot(N.z)
        frames.append(A)
        parent, joint = A, P
    return q, bodies, loads, N, kd, u


def kane(n: int):
    q, bodies, loads, N, kd, u = sympy_arm(n, "kane")
    km = me.KanesMethod(N, q_ind=q, u_ind=u, kd_eqs=kd)
    km.kanes_equations(bodies, loads)
    return km.mass_matrix_full, km.forcing_full


def ours(n: int):
    import lagrangian as lg

    model = lg.load(f"robot-arm-{n}")
    return lambda: lg.derive(model).core.f


def run(sizes=(3, 6), repeat: int = 5) -> dict[int, tuple[float, float]]:
    out = {}
    print(f"{'joints':>6} {'lagrangian':>12} {'KanesMethod':>12} {'ratio':>8}")
    for n in sizes:
        t_ours = cpu(ours(n), repeat)
        t_kane = cpu(lambda: kane(n), max(1, repeat // 2))
        out[n] = (t_ours, t_kane)
        print(f"{n:6d} {t_ours:11.4f}s {t_kane:11.3f}s {t_kane / t_ours:7.0f}x")
    return out


if __name__ == "__main__":
    run([int(a) for a in sys.argv[1:]] or [3, 6])
