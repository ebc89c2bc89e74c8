"""A chain of rods in space (PyDy's 3D n-body pendulum without contact): lagrangian against
sympy.physics.mechanics' KanesMethod on the same chain, in one run.

Run:  python benchmarks/spatial_chain.py [n] [--repeat R]      (default: n = 3, R = 3)

The chain is tests/models/spatial-chain-3.toml for n = 3 (and the same text for any n): rod k hangs on a
spherical joint at the end of rod k - 1, turned by body-fixed x, y, z angles relative to it; each rod
carries a ball (inertia iXX, iYY, iZZ) at its middle, its own mass m_link (inertia m_link l^2/12 across)
and a dot of mass m1 on the ball. KanesMethod is written as PyDy's example writes it: the generalized
speeds are each rod's angular velocity in its own axes, and its printed size is that of
mass_matrix_full and forcing_full (str), as the issue measured it.

Prints, for each, the median CPU time to M and f (lagrangian: derive, then the named form it prints;
KanesMethod: kanes_equations, mass_matrix_full and forcing_full) and the size of the printed forms,
with the ratios; then the expanded form's size for comparison (lagrangian --expanded, n = 3 only).

Large models stay usable (issue 22): the whole pipeline, each run a fresh process, stage by stage:

    python benchmarks/spatial_chain.py 20 --pipeline [--repeat R] [--backends auto,numba,c,scipy] [--t-end T]
    python benchmarks/spatial_chain.py --panda [--repeat R] [--backends auto,numba,c,scipy] [--t-end T]

load, derive, compile (each backend named: auto, the default, is what a user gets without naming one: numba, or
C for a large model where a compiler is present (numeric._compiled.auto_backend: 5 rods and more); numba, scipy the
portable SymEngine path, c the generated C compiled by the system's compiler; none: load and derive only)
and simulate T seconds (default 1) of the n-rod chain (--pipeline) or of the 7-joint Franka Emika Panda
read from example-robot-data's URDF (--panda; its fingers removed: a mimic joint). Each repeat runs the
model twice: first under a model name never used before (its generated code is new: written, compiled and
stored in the compile cache, $LAGRANGIAN_CACHE_DIR or ~/.cache/lagrangian, whose integrator kernels are
compiled already), then the same model again (cached: the generated module or library is loaded from the
cache). Prints the median CPU (the C compiler's included) and wall seconds of each stage over the repeats.
The chain is simulated from its file's initial angles without its spin (qy_dot = 0): the file's qy_dot = 7.5 takes
a rod's middle body-fixed angle through pi/2 within the first second at 20 rods, where M is singular (the angles'
gimbal lock), and simulate stops there.
"""

from __future__ import annotations

import json
import os
import statistics
import subprocess
import sys
import tempfile
import time
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]


def cpu(fn, repeat):
    """(median CPU seconds of fn() over `repeat` calls, the last result); SymPy's cache emptied first."""
    from sympy.core.cache import clear_cache

    times, out = [], None
    for _ in range(repeat):
        clear_cache()
        t0 = time.process_time()
        out = fn()
        times.append(time.process_time() - t0)
    return statistics.median(times), out


def chain_text(n: int) -> str:
    """The model file of the n-rod chain (that of tests/models/spatial-chain-3.toml for n = 3)."""
    coords = [f"q{a}{i}" for i in range(1, n + 1) for a in "xyz"]
    lines = [f'name = "spatial-chain-{n}"',
             f'description = "{n} rods in space, each on a spherical joint (body-fixed x, y, z angles)"',
             "coordinates = [" + ", ".join(f'"{c}"' for c in coords) + "]", "",
             "[parameters]", "m = 1.0", "m1 = 0.2", "m_link = 0.5", "l = 6.0", "r = 1.5", "g = 9.8",
             "iXX = 0.9", "iYY = 0.9", "iZZ = 0.9", ""]
    for i in range(1, n + 1):
        parent = "world" if i == 1 else f"rod{i - 1}"
        origin = '["0", "0", "0"]' if i == 1 else '["0", "l", "0"]'
        lines += ["[[frames]]", f'name = "rod{i}"', f'parent = "{parent}"', f"origin = {origin}",
                  f'rotation = [["x", "qx{i}"], ["y", "qy{i}"], ["z", "qz{i}"]]', ""]
    for i in range(1, n + 1):
        lines += ["[[bodies]]", f'name = "ball{i}"', 'mass = "m"', f'frame = "rod{i}"',
                  'inertia = ["iXX", "iYY", "iZZ"]', 'center = ["0", "l/2", "0"]', "",
                  "[[bodies]]", f'name = "link{i}"', 'mass = "m_link"', f'frame = "rod{i}"',
                  'inertia = ["m_link*l**2/12", "0", "m_link*l**2/12"]', 'center = ["0", "l/2", "0"]', "",
                  "[[particles]]", f'name = "dot{i}"', 'mass = "m1"', f'frame = "rod{i}"',
                  'position = ["0", "l/2", "r"]', ""]
    lines += ["[gravity]", 'g = "g"', 'direction = ["0", "-1", "0"]', "", "[simulation]", "t_end = 5.0",
              "dt = 0.01", "initial = { qx1 = 0.2, qy1 = 0.2, qz1 = 0.2, "
              + ", ".join(f"qy{i}_dot = 7.5" for i in range(1, n + 1)) + " }"]
    return "\n".join(lines) + "\n"


def ours(n: int):
    import lagrangian as lg
    from lagrangian.io import loads_model

    text = chain_text(n)

    def run():
        eqs = lg.derive(loads_model(text))
        return eqs.text()  # the named form (what `lagrangian derive` prints)

    return run


def kane(n: int):
    """PyDy's 3D n-body pendulum without the contact forces and the reaction force's auxiliary speeds."""
    import sympy as sm
    import sympy.physics.mechanics as me

    def run():
        m, m1, m_link, g, r, l = sm.symbols("m m1 m_link g r l")
        iXX, iYY, iZZ = sm.symbols("iXX iYY iZZ")
        q, u, A, P, Dmc, punkt = [], [], [], [], [], []
        for i in range(n):
            for j in "xyz":
                q.append(me.dynamicsymbols(f"q{j}{i}"))
                u.append(me.dynamicsymbols(f"u{j}{i}"))
            A.append(me.ReferenceFrame(f"A{i}"))
            P.append(me.Point(f"P{i}"))
            Dmc.append(me.Point(f"Dmc{i}"))
            punkt.append(me.Point(f"punkt{i}"))
        N = me.ReferenceFrame("N")
        P0 = me.Point("P0")
        P0.set_vel(N, 0)
        rot, rot1 = [], []
        for i in range(n):
            A[i].orient_body_fixed(N if i == 0 else A[i - 1], (q[3 * i], q[3 * i + 1], q[3 * i + 2]), "123")
            rot.append(A[i].ang_vel_in(N))
            A[i].set_ang_vel(N, u[3 * i] * A[i].x + u[3 * i + 1] * A[i].y + u[3 * i + 2] * A[i].z)
            rot1.append(A[i].ang_vel_in(N))
        P[0].set_pos(P0, 0)
        P[0].set_vel(N, 0)
        for i in range(n):
            if i > 0:
                P[i].set_pos(P[i - 1], l * A[i - 1].y)
                P[i].v2pt_theory(P[i - 1], N, A[i - 1])
            Dmc[i].set_pos(P[i], l / 2 * A[i].y)
            Dmc[i].v2pt_theory(P[i], N, A[i])
            punkt[i].set_pos(Dmc[i], r * A[i].z)
            punkt[i].v2pt_theory(Dmc[i], N, A[i])
        bodies = []
        for i in range(n):
            bodies.append(me.RigidBody(f"ball{i}", Dmc[i], A[i], m, (me.inertia(A[i], iXX, iYY, iZZ), Dmc[i])))
            bodies.append(me.Particle(f"dot{i}", punkt[i], m1))
            bodies.append(me.RigidBody(f"link{i}", Dmc[i], A[i], m_link,
                                       (me.inertia(A[i], m_link * l**2 / 12, 0, m_link * l**2 / 12), Dmc[i])))
        loads = [(Dmc[i], -(m + m_link) * g * N.y) for i in range(n)] + [(punkt[i], -m1 * g * N.y) for i in range(n)]
        kd = [me.dot(rot[i] - rot1[i], uv) for i in range(n) for uv in A[i]]
        km = me.KanesMethod(N, q_ind=q, u_ind=u, kd_eqs=kd)
        km.kanes_equations(bodies, loads)
        MM, FF = km.mass_matrix_full, km.forcing_full
        return str(MM) + "\n" + str(FF)

    return run


#: Run in a fresh process: argv = [kind ("chain" or "urdf"), n or the URDF path, model name, backend, t_end];
#: prints {stage: [cpu, wall]} as JSON.
_STAGES = r"""
import json, os, sys, time
clock = lambda: (sum(os.times()[:4]), time.perf_counter())  # CPU of this process and its children (the C compiler)
out, c0 = {}, clock()
def stage(name):
    global c0
    c1 = clock()
    out[name] = [c1[0] - c0[0], c1[1] - c0[1]]
    c0 = clock()
kind, what, name, backend, t_end = sys.argv[1:6]
import lagrangian as lg
stage("import")
if kind == "chain":
    sys.path.insert(0, sys.argv[6])
    from spatial_chain import chain_text
    from lagrangian.io import loads_model
    text = chain_text(int(what))
    model = loads_model(text.replace('name = "spatial-chain-' + what + '"', 'name = "' + name + '"', 1))
else:
    from lagrangian.io._urdf import load_urdf
    model = load_urdf(what)
stage("load")
eqs = lg.derive(model)
stage("derive")
traj = None
if backend != "none":  # (none: load and derive only)
    lg.compile(eqs, backend)
stage("compile")
if backend != "none":  # (the chain without its file's spin: see the docstring)
    spin = {f"qy{i}_dot": 0.0 for i in range(1, int(what) + 1)} if kind == "chain" else None
    traj = lg.simulate(eqs, t_end=float(t_end), backend=backend, initial=spin)
stage("simulate")
out["n"] = len(model.q)
out["backend"] = traj.stats["backend"] if traj is not None else None
out["energy_drift"] = (float(abs(traj.energy[-1] - traj.energy[0]) / abs(traj.energy[0]))
                       if traj is not None and traj.energy is not None else None)  # relative
print(json.dumps(out))
"""

STAGE_NAMES = ("import", "load", "derive", "compile", "simulate")


def _panda_urdf(folder: Path, name: str) -> Path:
    """The Panda arm of example-robot-data without its fingers, under the robot name `name`."""
    import site
    import xml.etree.ElementTree as ET

    for base in [*site.getsitepackages(), site.getusersitepackages()]:
        path = Path(base) / "cmeel.prefix" / "share" / "example-robot-data" / "robots" / "panda_description"
        if path.is_dir():
            break
    else:
        raise SystemExit("--panda needs example-robot-data (pip install example-robot-data)")
    tree = ET.parse(path / "urdf" / "panda.urdf")
    root = tree.getroot()
    root.set("name", name)
    for tag in ("joint", "link"):
        for el in list(root.findall(tag)):
            if "finger" in el.get("name"):
                root.remove(el)
    out = folder / f"{name}.urdf"
    tree.write(out)
    return out


def pipeline(kind: str, n: int, repeat: int, backends: list[str], t_end: float) -> dict:
    """{backend: {"first": [{stage: (cpu, wall)}], "cached": [...]}} over `repeat` fresh models."""
    folder = Path(tempfile.mkdtemp(prefix="lagrangian-bench-large-"))
    results: dict = {}
    for backend in backends:
        runs: dict = {"first": [], "cached": []}
        for r in range(repeat):
            name = f"large_{kind}_{os.getpid()}_{int(time.time() * 1000) % 10**8}_{backend}_{r}"
            what = str(n) if kind == "chain" else str(_panda_urdf(folder, name))
            for label in ("first", "cached"):
                proc = subprocess.run([sys.executable, "-c", _STAGES, kind, what, name, backend, str(t_end),
                                       str(Path(__file__).resolve().parent)], capture_output=True, text=True)
                if proc.returncode != 0:
                    raise SystemExit(f"{kind} {backend} {label} run failed:\n{proc.stderr[-3000:]}")
                out = json.loads(proc.stdout.strip().splitlines()[-1])
                runs[label].append(out)
                print(f"  {backend:>6} {label:>6}: " + ", ".join(f"{s} {out[s][0]:.2f}/{out[s][1]:.2f}"
                                                             for s in STAGE_NAMES)
                      + f"  (cpu/wall s; ran on {out['backend']}, energy drift {out['energy_drift']})", flush=True)
        results[backend] = runs
    return results


def print_pipeline(title: str, results: dict, repeat: int) -> None:
    print(f"\n{title}: median over {repeat} fresh models, CPU / wall seconds, each run a fresh process")
    print("| backend | run | " + " | ".join(STAGE_NAMES) + " | total |")
    print("|---|---|" + "---:|" * (len(STAGE_NAMES) + 1))
    for backend, runs in results.items():
        for label, outs in runs.items():
            cells = []
            for s in (*STAGE_NAMES, "total"):
                cpu_s = [sum(o[x][0] for x in STAGE_NAMES) if s == "total" else o[s][0] for o in outs]
                wall_s = [sum(o[x][1] for x in STAGE_NAMES) if s == "total" else o[s][1] for o in outs]
                cells.append(f"{statistics.median(cpu_s):.2f} / {statistics.median(wall_s):.2f}")
            print(f"| {backend} | {label} | " + " | ".join(cells) + " |")


def main(argv):
    repeat = 3
    if "--repeat" in argv:
        k = argv.index("--repeat")
        repeat = int(argv[k + 1])
        argv = argv[:k] + argv[k + 2:]
    backends, t_end = ["auto"], 1.0
    if "--backends" in argv:
        k = argv.index("--backends")
        backends = argv[k + 1].split(",")
        argv = argv[:k] + argv[k + 2:]
    if "--t-end" in argv:
        k = argv.index("--t-end")
        t_end = float(argv[k + 1])
        argv = argv[:k] + argv[k + 2:]
    if "--panda" in argv:
        results = pipeline("urdf", 0, repeat, backends, t_end)
        print_pipeline(f"Franka Emika Panda (7 joints, URDF), simulate {t_end:g} s", results, repeat)
        return
    if "--pipeline" in argv:
        argv = [a for a in argv if a != "--pipeline"]
        n = int(argv[0]) if argv else 20
        results = pipeline("chain", n, repeat, backends, t_end)
        print_pipeline(f"spatial chain of {n} rods ({3 * n} coordinates), simulate {t_end:g} s", results, repeat)
        return
    n = int(argv[0]) if argv else 3
    t_ours, text_ours = cpu(ours(n), repeat)
    t_kane, text_kane = cpu(kane(n), repeat)
    print(f"spatial chain of {n} rods ({3 * n} coordinates), median CPU over {repeat} runs")
    print(f"{'':<28}{'time to M and f':>16}{'printed':>12}")
    print(f"{'lagrangian (named form)':<28}{t_ours:15.3f}s{len(text_ours) / 1e3:10.1f} KB")
    print(f"{'KanesMethod (full)':<28}{t_kane:15.3f}s{len(text_kane) / 1e3:10.1f} KB")
    print(f"ratios KanesMethod / lagrangian: time {t_kane / t_ours:.1f}x, size {len(text_kane) / len(text_ours):.2f}x")


if __name__ == "__main__":
    main(sys.argv[1:])
