"""Cost per step of the compiled constrained integration against the compiled unconstrained one.

Run:  python benchmarks/constrained.py [--repeat N] [--split-ab] [--zeros-ab] [--only MODEL ...]   (default 15)
      python benchmarks/constrained.py --parts MODEL [MODEL ...] [--repeat N]

For each constrained example, the compiled DOP853 kernel is timed (CPU time, median over the
repeats, kernel call only: no Python post-processing) on the constrained model (saddle-point
right-hand side, projection after every accepted step, one more evaluation of the right-hand side
there) and on the same equations with the constraints dropped (the unconstrained compiled path:
LDL^T of M alone), and the costs per step and per evaluation of the right-hand side are compared.
The two runs do not take the same steps (the unconstrained mechanism falls apart), which is why
the cost is compared per step. The issue's target: at most 1.5x per step.

With --parts MODEL [MODEL ...] it says instead where a constrained model's step cost goes: the
compiled rhs cut after each step of the saddle-point solve (the numba module's source with
``return r`` written into lg_saddle before the next step: expression evaluation of M, f, G, c
alone, then + LDL^T and the test of f, G, c, + Z = L^-1 G^T, + the QR, + step 3, the whole rhs;
and the rhs as generated where it factors M and G before evaluating f and c, SPLIT_MIN),
the unconstrained rhs, and the projection's parts (lg_position, lg_velocity, the whole project from
a state 1e-7 off the constraints), each timed in a numba loop (thread CPU time per call, median and
quartiles over the repeats, all alternating in one process). A step costs about 12 evaluations of
the rhs and one projection.

The machine this runs on is often a loaded, shared one: the two runs alternate within each repeat
(the same moment's load for both), and the ratio quoted is the median of the repeats' ratios.
"""

from __future__ import annotations

import argparse
import importlib.util
import statistics
import tempfile
import time
from pathlib import Path

import numpy as np
import sympy

import lagrangian as lg
from lagrangian.numeric._codegen_constrained import work_size
from lagrangian.numeric._fast import _address, compile_numba, run_dop853
from lagrangian.numeric._simulate import _input_programs

CASES = (("four-bar", 40.0), ("slider-crank", 40.0), ("cartesian-pendulum", 200.0), ("whipple-bicycle", 60.0))
TARGET = 1.5


def per_step(cm, x0, times, p, prog, **kw):
    """(CPU time per step, per evaluation of the right-hand side, steps) of one run."""
    t0 = time.process_time()
    raw = run_dop853(cm, x0, times, p, prog, 1e-10, 1e-10, progress=False, **kw)
    dt = time.process_time() - t0
    return dt / max(raw.nstep, 1), dt / max(raw.nfev, 1), raw.nstep


def _cut_modules(eqs, folder: Path) -> dict:
    """{label: module}: the numba module of `eqs` and its copies with lg_saddle cut after each step
    (the written-out form, n and m <= UNROLL_MAX; the markers are the first line of each step)."""
    from lagrangian.numeric import _codegen_constrained
    from lagrangian.numeric._codegen import numba_source
    from lagrangian.numeric._codegen_constrained import layout

    generated = numba_source(eqs)
    saved, _codegen_constrained.SPLIT_MIN = _codegen_constrained.SPLIT_MIN, 10**9
    try:  # the rhs that calls lg_saddle after M, f, G, c (the cut points are lg_saddle's)
        source = numba_source(eqs)
    finally:
        _codegen_constrained.SPLIT_MIN = saved
    at = layout(eqs.n, len(eqs.multipliers))
    head, saddle = source.split("def lg_saddle(work):", 1)
    saddle = "def lg_saddle(work):" + saddle
    rhs_call = "    r = lg_saddle(work)\n"
    cuts = {"M f G c only": None, "+ LDL, finite": f"    work[{at['Q0']}] = work[{at['G0']}]\n",
            "+ Z = L^-1 G^T": "    r = min(r, lg_qr(work))\n", "+ QR": f"    work[{at['A0']}] = work[{at['F0']}]\n"}
    texts = {}
    for label, marker in cuts.items():
        if marker is None:
            if rhs_call not in saddle:
                return {}
            texts[label] = head + saddle.replace(rhs_call, "    r = 1.0\n")
        elif marker in saddle:
            texts[label] = head + saddle.replace(marker, "    return r\n" + marker, 1)
        else:
            return {}  # the loop form: no cut points
    texts["whole rhs (+ step 3)"] = source
    if generated != source:
        texts["as generated (split)"] = generated
    modules = {}
    for k, (label, text) in enumerate(texts.items()):
        path = folder / f"lg_cut_{k}.py"
        path.write_text(text, encoding="utf-8")
        spec = importlib.util.spec_from_file_location(f"lg_cut_{k}", path)
        modules[label] = importlib.util.module_from_spec(spec)
        spec.loader.exec_module(modules[label])
    return modules


def _dense(eqs, fast, folder: Path):
    """`fast` with the numba rhs and projection generated without the structural zeros of M and G
    (every product of the written-out solve taken, as before _codegen_constrained._structure), or
    None where the solve is not written out (n or m > UNROLL_MAX: nothing is left out)."""
    import dataclasses

    from lagrangian.numeric import _codegen_constrained
    from lagrangian.numeric._codegen import numba_source

    generated = numba_source(eqs)
    saved, _codegen_constrained._structure = _codegen_constrained._structure, lambda eq, consts: {}
    try:
        source = numba_source(eqs)
    finally:
        _codegen_constrained._structure = saved
    if source == generated:
        return None
    path = folder / "lg_dense.py"
    path.write_text(source, encoding="utf-8")
    spec = importlib.util.spec_from_file_location("lg_dense", path)
    module = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(module)
    return dataclasses.replace(fast, rhs_c=module.rhs, project_c=module.project)


def _unsplit(eqs, fast, folder: Path):
    """`fast` with the numba rhs that evaluates M, f, G, c and then calls lg_saddle (SPLIT_MIN
    raised), or None where the generated rhs is not split."""
    import dataclasses

    from lagrangian.numeric import _codegen_constrained
    from lagrangian.numeric._codegen import numba_source

    generated = numba_source(eqs)
    saved, _codegen_constrained.SPLIT_MIN = _codegen_constrained.SPLIT_MIN, 10**9
    try:
        source = numba_source(eqs)
    finally:
        _codegen_constrained.SPLIT_MIN = saved
    if source == generated:
        return None
    path = folder / "lg_unsplit.py"
    path.write_text(source, encoding="utf-8")
    spec = importlib.util.spec_from_file_location("lg_unsplit", path)
    module = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(module)
    return dataclasses.replace(fast, rhs_c=module.rhs, project_c=module.project)


def parts(names: list[str], repeat: int) -> None:
    """Where the constrained step cost goes (see the module)."""
    from numba import njit

    from lagrangian.numeric._kernels_numba import _ptr, _rc

    @njit
    def rhs_loop(addr, x, u, p, dx, work, count):
        for _ in range(count):
            _rc(addr, 0.1, _ptr(x, 0), _ptr(u, 0), _ptr(p, 0), _ptr(dx, 0), _ptr(work, 0))

    @njit
    def project_loop(addr, x0, x, u, p, work, drift, count):
        for _ in range(count):
            x[:] = x0
            _rc(addr, 0.1, _ptr(x, 0), _ptr(u, 0), _ptr(p, 0), _ptr(work, 0), _ptr(drift, 0))  # (returns its code)

    def part_loop(f):
        @njit
        def loop(x, u, p, work, count):
            for _ in range(count):
                f(0.1, x, u, p, work)
        return loop

    count = 4000
    for name in names:
        eqs = lg.derive(lg.load(name))
        free = eqs.model.copy()
        free._constraints, free._wheels = [], []
        n, m = eqs.n, len(eqs.multipliers)
        p = np.array([float(v) for v in eqs.parameters.values()])
        start = lg.simulate(eqs, t_end=0.01)
        x0 = np.array([start[s][0] for s in eqs.state_names])
        u = np.zeros(max(1, len(eqs.inputs)))
        off = x0 + 1e-7 * np.random.default_rng(0).standard_normal(2 * n)
        work, dx, xs, drift = np.zeros(work_size(n, m)), np.zeros(2 * n), off.copy(), np.zeros(2)
        with tempfile.TemporaryDirectory() as folder:
            modules = _cut_modules(eqs, Path(folder))
            if not modules:
                print(f"{name}: the solve is not written out (n or m > 12): no cut points")
                continue
            whole = modules["whole rhs (+ step 3)"]
            plain = compile_numba(lg.derive(free))
            timed = {"unconstrained rhs": lambda c: rhs_loop(_address(plain.rhs_c), x0, u, p, dx, work, c)}
            for label, module in modules.items():
                timed[f"rhs: {label}"] = (lambda a: lambda c: rhs_loop(a, x0, u, p, dx, work, c))(module.rhs.address)
            for helper in ("lg_position", "lg_velocity"):
                if hasattr(whole, helper):
                    timed[f"project: {helper}"] = (lambda f: lambda c: f(x0, u, p, work, c))(
                        part_loop(getattr(whole, helper)))
            timed["project (whole)"] = lambda c: project_loop(whole.project.address, off, xs, u, p, work, drift, c)
            for run in timed.values():
                run(2)  # compile
            times: dict[str, list[float]] = {label: [] for label in timed}
            for _ in range(repeat):
                for label, run in timed.items():
                    t0 = time.thread_time()
                    run(count)
                    times[label].append((time.thread_time() - t0) / count * 1e9)
        print(f"{name} (n = {n}, m = {m}): ns per call, median [quartiles] of {repeat} repeats of {count} calls")
        base = times["unconstrained rhs"]
        for label, v in times.items():
            q1, q3 = np.percentile(v, [25, 75])
            ratio = statistics.median(a / b for a, b in zip(v, base))
            print(f"  {label:<28} {statistics.median(v):8.1f} [{q1:7.1f}, {q3:7.1f}]  {ratio:5.2f}x unconstrained rhs")


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--repeat", type=int, default=15)
    parser.add_argument("--parts", nargs="+", metavar="MODEL", help="where the step cost goes (see the module)")
    parser.add_argument("--split-ab", action="store_true",
                        help="also time the rhs not split (M, f, G, c, then lg_saddle) where it is split")
    parser.add_argument("--zeros-ab", action="store_true",
                        help="also time the rhs and projection generated without the structural zeros of M and G")
    parser.add_argument("--only", nargs="+", metavar="MODEL", help="these examples only")
    args = parser.parse_args()
    if args.parts:
        parts(args.parts, args.repeat)
        return
    print(f"{'model':<20} {'constrained':>14} {'unconstrained':>14} {'per step':>9} {'per f':>7}")
    for name, t_end in CASES:
        if args.only and name not in args.only:
            continue
        model = lg.load(name)
        eqs = lg.derive(model)
        free = model.copy()
        free._constraints, free._wheels = [], []
        feqs = lg.derive(free)
        fast, plain = compile_numba(eqs), compile_numba(feqs)
        p = np.array([float(v) for v in eqs.parameters.values()])
        start = lg.simulate(eqs, t_end=0.01)  # a consistent initial state
        x0 = np.array([start[s][0] for s in eqs.state_names])
        times = np.linspace(0.0, t_end, 11)
        prog = _input_programs(eqs, [sympy.Integer(0)] * len(eqs.inputs))
        kw = dict(project=_address(fast.project_c), nwork=work_size(eqs.n, len(eqs.multipliers)))
        per_step(fast, x0, times, p, prog, **kw)  # compile the kernels first
        per_step(plain, x0, times, p, prog)
        with tempfile.TemporaryDirectory() as folder:
            unsplit = _unsplit(eqs, fast, Path(folder)) if args.split_ab else None
            if unsplit is not None:
                ukw = dict(kw, project=_address(unsplit.project_c))
                per_step(unsplit, x0, times, p, prog, **ukw)
            dense = _dense(eqs, fast, Path(folder)) if args.zeros_ab else None
            if dense is not None:
                dkw = dict(kw, project=_address(dense.project_c))
                per_step(dense, x0, times, p, prog, **dkw)
            rounds, others, denses = [], [], []
            for _ in range(args.repeat):
                rounds.append((per_step(fast, x0, times, p, prog, **kw), per_step(plain, x0, times, p, prog)))
                if unsplit is not None:
                    others.append(per_step(unsplit, x0, times, p, prog, **ukw)[0] / rounds[-1][1][0])
                if dense is not None:
                    denses.append(per_step(dense, x0, times, p, prog, **dkw)[0] / rounds[-1][1][0])
        (_, _, c_n), (_, _, u_n) = rounds[0]
        c_step, c_eval, u_step, u_eval = (statistics.median(r[a][b] for r in rounds) for a in (0, 1) for b in (0, 1))
        ratios = [c[0] / u[0] for c, u in rounds]
        ratio = statistics.median(ratios)
        ratio_f = statistics.median(c[1] / u[1] for c, u in rounds)
        q1, q3 = np.percentile(ratios, [25, 75])
        print(f"{name:<20} {c_step * 1e6:>10.2f} us {u_step * 1e6:>10.2f} us {ratio:>8.2f}x {ratio_f:>6.2f}x"
              f"  ({c_n} and {u_n} steps) {'holds' if ratio <= TARGET else 'missed'} (target {TARGET}x);"
              f" per-step ratio quartiles [{q1:.2f}, {q3:.2f}]")
        if denses:
            o1, o3 = np.percentile(denses, [25, 75])
            print(f"{'':<20} without the structural zeros: {statistics.median(denses):.2f}x per step"
                  f" [{o1:.2f}, {o3:.2f}], alternating with the runs above")
        if others:
            o1, o3 = np.percentile(others, [25, 75])
            print(f"{'':<20} the same rhs not split (SPLIT_MIN): {statistics.median(others):.2f}x per step"
                  f" [{o1:.2f}, {o3:.2f}], alternating with the runs above")


if __name__ == "__main__":
    main()
