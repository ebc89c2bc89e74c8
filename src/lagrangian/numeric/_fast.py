"""The compiled backends: numba (default) and C (cffi, when a compiler is present).

``compile_equations(equations, backend="numba")`` returns a :class:`CompiledModel`: the same
functions as the portable :class:`NumericModel` (rhs, mass_matrix, forcing, accelerations,
energy), evaluated by generated code, plus the integrators that run entirely in compiled code
(DOP853 with dense output and the singular-mass-matrix event, the batch driver and the midpoint
variational integrator).
"""

from __future__ import annotations

import functools
import os
import sys
import threading
from dataclasses import dataclass, field
from typing import NamedTuple

import numpy as np

from .. import _progress
from ..equations import Equations
from ._cache import CACHE
from ._codegen import cache_dir, load_module, model_module, store
from ._inputs import constant_programs

__all__ = ["CompiledModel", "compile_numba", "BACKENDS"]

#: Backends accepted by ``backend``: "auto" picks numba when it can, else "scipy".
BACKENDS = ("auto", "numba", "c", "scipy")

_CACHE = CACHE  # the one cache, per Equations (_cache.py): "numba", "c", "variational", "lanes<L>", ...
_LOCK = threading.Lock()


#: Output rows whose energy a model evaluates one by one (its energy, about 28 ns a row for a double
#: pendulum) before its energy_rows (about 7 ns a row, vectorized) is compiled: the compile costs a new model
#: about as much (0.6-0.8 s of CPU for a double pendulum, 1.2-1.5 s for a 6-link chain), so it is paid only
#: once the rows one by one have cost as much (the rent-or-buy rule: at most twice the better choice, in
#: hindsight); a double pendulum's 2001 outputs: about 12,000 runs.
ENERGY_ROWS_AFTER = 25_000_000


class EnergyRows:
    """A model's energy_rows (the generated plain function and its signature; see
    _codegen._energy_rows), compiled lazily: at once where numba's cache already holds it (a model
    compiled before on this machine: loading it takes milliseconds), otherwise when the rows the model
    evaluated one by one (``count``: the output stage's energy row by row, the same numbers bit for
    bit) reach ENERGY_ROWS_AFTER, or when asked (``compile``). ``address``: 0 until compiled (the
    kernels then call the energy row by row)."""

    __slots__ = ("function", "signature", "address", "rows", "compiled")

    def __init__(self, function, signature):
        self.function, self.signature = function, signature
        self.address = 0
        self.rows = 0  # rows evaluated one by one so far
        self.compiled = None  # the cfunc
        if _cached_cfunc(function):
            self.compile()

    def compile(self) -> int:
        """Compile (or load from numba's cache) energy_rows; its address."""
        with _LOCK:
            if self.compiled is None:
                from numba import cfunc

                self.compiled = cfunc(self.signature, cache=True, error_model="numpy")(self.function)
                self.address = int(self.compiled.address)
        return self.address

    def count(self, rows: int) -> int:
        """Count `rows` evaluated one by one; the address (compiled once they reach ENERGY_ROWS_AFTER)."""
        self.rows += rows
        if self.rows >= ENERGY_ROWS_AFTER:
            return self.compile()
        return self.address


def _cached_cfunc(function) -> bool:
    """Whether numba's cache on disk has an entry for the cfunc of `function` (its index file; False
    when it cannot tell)."""
    try:
        from numba.core.caching import FunctionCache

        return os.path.exists(FunctionCache(function)._cache_file._index_path)
    except Exception:  # another numba's internals: compiled when the rows have cost its compile
        return False


@dataclass(frozen=True, eq=False)
class CompiledModel:
    """The numerical state equations of `equations`, generated and compiled by numba (or C).

    It implements :class:`~lagrangian.numeric._compiled.NumericContract` as :class:`NumericModel`
    does, every function taking ``(t, x, u, p)`` (the generated module's docstring, ``source``,
    lists the state, input and parameter names in argument order): rhs, solve, mass_matrix,
    forcing, accelerations and energy by the generated code; the constraint parts and the
    Jacobians analysis needs (``constraint_parts``, ``constraint_residuals``, ``jacobians``,
    ``state_jacobians``, ``momenta``, ``damping``, ``static``, ``statics``) by the NumericModel it
    carries (``numeric``).

    Attributes
    ----------
    backend : str
        "numba" or "c".
    path : str
        The generated module's file (in the cache directory).
    key : str
        The hash of the generated source that names the module.
    """

    equations: Equations = field(repr=False)
    backend: str
    state_names: tuple[str, ...]
    input_names: tuple[str, ...]
    parameter_names: tuple[str, ...]
    parameter_values: np.ndarray = field(repr=False)
    path: str
    key: str
    rhs_c: object = field(repr=False)
    energy_c: object = field(repr=False)
    project_c: object = field(default=None, repr=False)  # a constrained model's projection
    energy_rows: EnergyRows | None = field(default=None, repr=False)  # the energy at many rows (numba, small models)

    @property
    def n(self) -> int:
        return len(self.state_names) // 2

    @property
    def m(self) -> int:
        """The number of constraints (0 without)."""
        return len(self.equations.core.g)

    @property
    def numeric(self):
        """The portable NumericModel of the same equations (the Jacobians and constraint parts)."""
        from ._compiled import compile_equations

        return compile_equations(self.equations, "scipy")

    def constraint_parts(self, t, x, u, p):
        """(G, c, g, w), shapes (m, n), (m,), (m,), (m,) (by ``numeric``)."""
        return self.numeric.constraint_parts(*self._args(t, x, u, p, trim=True))

    def function(self, name: str, build):
        """(t, x, u, p) -> array of other expressions of the model's symbols (by ``numeric``)."""
        return self.numeric.function(name, build)

    def constraint_residuals(self, t, x, u, p):
        """(G, g, w) (by ``numeric``)."""
        return self.numeric.constraint_residuals(*self._args(t, x, u, p, trim=True))

    def jacobians(self, t, x, u, p, qdd=None):
        """M, f, df/dq, df/dq_dot, df/du, d(M a)/dq at a = qdd (by ``numeric``)."""
        return self.numeric.jacobians(*self._args(t, x, u, p, trim=True), qdd)

    def state_jacobians(self, t, x, u, p):
        """(d rhs/dx, d rhs/du) for m = 0 (by ``numeric``)."""
        return self.numeric.state_jacobians(*self._args(t, x, u, p, trim=True))

    def momenta(self, t, x, u, p):
        """(dL/dq_dot, its Jacobian in q, M) (by ``numeric``)."""
        return self.numeric.momenta(*self._args(t, x, u, p, trim=True))

    def damping(self, t, x, u, p):
        """The damping matrix, shape (n, n) (by ``numeric``)."""
        return self.numeric.damping(*self._args(t, x, u, p, trim=True))

    def static(self, t, q, u, p):
        """(f, df/dq) at rest in the configuration q (by ``numeric``)."""
        return self.numeric.static(t, q, u, p)

    def statics(self, t, z, u, p):
        """(f + G^T lambda, g, its Jacobian in q, G) at rest in z = (q, lambda) (by ``numeric``)."""
        return self.numeric.statics(t, z, u, p)

    @property
    def source(self) -> str:
        """The generated source (its docstring documents the argument order)."""
        with open(self.path) as fh:
            return fh.read()

    def _second(self):
        """The module with mass_forcing and lagrange_parts (generated on first use)."""
        per = _CACHE.setdefault(self.equations, {})
        if self.backend == "c":
            return per["c-second"]
        if "variational" not in per:
            per["variational"] = _module(self.equations, "variational")[2]
        return per["variational"]

    @functools.cached_property
    def rhs_address(self) -> int:
        """The address of the compiled rhs (what the kernels call)."""
        return _address(self.rhs_c)

    def rhs_lanes_address(self, lanes: int) -> int | None:
        """The address of the compiled rhs_lanes for blocks of `lanes` states (the right-hand
        side of all of them at once, vectorized; see _codegen), generated on first use; None for
        the C backend and for models with more than UNROLL_MAX coordinates."""
        from ._codegen import UNROLL_MAX

        if self.backend != "numba" or self.n > UNROLL_MAX:
            return None
        per = _CACHE.setdefault(self.equations, {})
        part = f"lanes{int(lanes)}"
        if part not in per:
            per[part] = _module(self.equations, part)
        return _address(per[part][2].rhs_lanes)

    def lanes_source(self, lanes: int) -> str | None:
        """The generated source of rhs_lanes for blocks of `lanes` (None where there is none)."""
        if self.rhs_lanes_address(lanes) is None:
            return None
        with open(_CACHE[self.equations][f"lanes{int(lanes)}"][0]) as fh:
            return fh.read()

    @functools.cached_property
    def energy_address(self) -> int:
        return _address(self.energy_c)

    @property
    def energy_rows_address(self) -> int:
        """The address of the generated energy_rows (the energy at many output rows at once, vectorized;
        see _codegen.ENERGY_ROWS_MAX), 0 where there is none or it is not compiled yet (EnergyRows: the
        kernels then call the energy row by row, the same numbers)."""
        return 0 if self.energy_rows is None else self.energy_rows.address

    def count_energy_rows(self, rows: int) -> int:
        """Count `rows` whose energy was evaluated one by one (see EnergyRows); energy_rows_address."""
        return 0 if self.energy_rows is None else self.energy_rows.count(rows)

    @functools.cached_property
    def mass_forcing_address(self) -> int:
        return _address(self.mass_forcing_c)

    @functools.cached_property
    def lagrange_parts_address(self) -> int:
        return _address(self.lagrange_parts_c)

    @property
    def mass_forcing_c(self):
        """The cfunc of M and f."""
        return self._second().mass_forcing

    @property
    def lagrange_parts_c(self):
        """The cfunc of dL/dq_dot and dL/dq - dD/dq_dot + Q."""
        return self._second().lagrange_parts

    def _args(self, t, x, u, p, trim=False):
        """(t, x, u, p) checked, as contiguous float arrays; u and p of length 1 at least (the
        compiled functions take a pointer) unless `trim`."""
        x = np.ascontiguousarray(x, dtype=float)
        if x.shape != (2 * self.n,):
            raise ValueError(f"x must have shape ({2 * self.n},), got {x.shape}")
        u = np.ascontiguousarray(u, dtype=float)
        if u.shape != (len(self.input_names),):
            raise ValueError(f"u must have shape ({len(self.input_names)},), got {u.shape}")
        p = np.ascontiguousarray(p, dtype=float)
        if p.shape != (len(self.parameter_names),):
            raise ValueError(f"p must have shape ({len(self.parameter_names)},), got {p.shape}")
        return (float(t), x, u, p) if trim else (float(t), x, _nonempty(u), _nonempty(p))

    def rhs(self, t, x, u, p) -> np.ndarray:
        """x' = [q_dot, q_ddot], shape (2n,) (NaN where M is singular or f not finite)."""
        if self.m:
            return np.concatenate((np.asarray(x, float)[self.n:], self.solve(t, x, u, p)[0]))
        return kernels().rhs(self.rhs_address, self.n, *self._args(t, x, u, p))[0]

    def solve(self, t, x, u, p) -> tuple[np.ndarray, float]:
        """(q_ddot, inertia measure of M): q_ddot is NaN where the measure is at or below
        SINGULAR_RATIO, and the measure is -1.0 where f is not finite (the one failure value of
        NumericContract). With constraints: the saddle-point system's q_ddot and its measure
        min(r_M, rho_G), by the generated code (its work array holds work_size(n, m) values)."""
        if self.m:
            from ._codegen_constrained import compiled_solve
            from ._compiled import SINGULAR_RATIO

            qdd, _, r = compiled_solve(self, *self._args(t, x, u, p))
            return (qdd if r > SINGULAR_RATIO else np.full(self.n, np.nan)), float(r)
        dx, r = kernels().rhs(self.rhs_address, self.n, *self._args(t, x, u, p))
        return dx[self.n:], float(r)

    def mass_matrix(self, t, x, u, p) -> np.ndarray:
        """M at the state, shape (n, n)."""
        return kernels().mass_forcing(self.mass_forcing_address, self.n, *self._args(t, x, u, p))[0]

    def forcing(self, t, x, u, p) -> np.ndarray:
        """f at the state, shape (n,)."""
        return kernels().mass_forcing(self.mass_forcing_address, self.n, *self._args(t, x, u, p))[1]

    def accelerations(self, t, x, u, p) -> np.ndarray:
        """q_ddot solving M q_ddot = f, shape (n,)."""
        return self.rhs(t, x, u, p)[self.n:]

    def singular_ratio(self, t, x, u, p) -> float:
        """inertia_measure(M) at the state: 1 for a diagonal M, 0 for a singular one."""
        from ..equations._singular import inertia_measure

        return inertia_measure(self.mass_matrix(t, x, u, p))

    def energy(self, t, x, u, p) -> float:
        """The Jacobi integral h = q_dot . dL/dq_dot - L."""
        t, x, u, p = self._args(t, x, u, p)
        m = len(self.input_names)
        prog = constant_programs(u[:m])
        out, U = np.empty(1), np.empty((1, m))
        kernels().energies((self.energy_address, 0), np.array([t]), x[None, :], p, prog.ops, prog.args,
                           prog.starts, prog.nstack, out, U, np.zeros(max(1, m), np.int64))
        return float(out[0])


def _address(fn) -> int:
    """The address of a compiled function: a numba cfunc or a cffi function of the C backend.
    The kernels take addresses, not function objects: typing a function object costs numba
    several microseconds per call."""
    address = getattr(fn, "address", None)
    if address is not None:
        return int(address)
    import cffi

    return int(cffi.FFI().cast("uintptr_t", fn))


def _nonempty(a: np.ndarray) -> np.ndarray:
    """A length-1 array for an empty one (the compiled functions take a pointer)."""
    return a if a.size else np.zeros(1)


def kernels():
    """The compiled kernels module, _kernels_numba.py, loaded from the cache folder: a copy named by
    the hash of its text, of _kernels.py (the constants it reads) and of numba's version, so that
    numba caches its compiled code there, beside the models', once per machine (a read-only
    installation included) and a changed kernel is a new entry."""
    global _KERNELS
    if _KERNELS is None:
        with _LOCK:
            if _KERNELS is None:
                import hashlib

                import numba

                from . import _kernels

                source = _kernels.kernel_source()
                with open(_kernels.__file__, "rb") as fh:
                    constants = fh.read()
                key = hashlib.sha256(source.encode() + constants + f"|{numba.__version__}".encode()).hexdigest()[:24]
                path = cache_dir() / f"lagrangian_kernels_{key}.py"
                store(path, source)
                try:
                    _KERNELS = load_module(path, f"lagrangian_kernels_{key}")
                except BaseException:  # a broken entry is removed, never reused
                    path.unlink(missing_ok=True)
                    raise
    return _KERNELS


_KERNELS = None


def _module(equations: Equations, part: str):
    """(path, key, module) of the numba module `part` of `equations` (see _codegen.model_module)."""
    return model_module(equations, part)


def compile_numba(equations: Equations) -> "CompiledModel":
    """The numba-compiled model of `equations` (generated once per content hash and cached on
    disk, with numba's compiled code beside it)."""
    with _LOCK:
        per = _CACHE.setdefault(equations, {})
        if "numba" in per:
            return per["numba"]
    path, key, module = _module(equations, "main")
    values = np.array([np.nan if v is None else v for v in equations.parameters.values()], dtype=float)
    cm = CompiledModel(equations, "numba", equations.state_names, tuple(u.name for u in equations.inputs),
                       tuple(p.name for p in equations.parameters), values, str(path), key,
                       module.rhs, module.energy, getattr(module, "project", None),
                       EnergyRows(module.energy_rows, module.ENERGY_ROWS_SIGNATURE)
                       if hasattr(module, "energy_rows") else None)
    with _LOCK:
        return per.setdefault("numba", cm)


def _empty(*shape, dtype=float) -> np.ndarray:
    a = np.zeros(shape, dtype)
    a.setflags(write=False)
    return a


class RawRun(NamedTuple):
    """What a compiled integrator returns (internal; a named tuple: immutable and quick to make,
    once per simulate())."""

    status: int
    t: np.ndarray  # output times reached
    x: np.ndarray  # states at those times
    stop_t: float  # where it stopped (status != 0)
    stop_measure: float
    stop_x: np.ndarray
    nfev: int
    nstep: int
    nreject: int
    event_t: np.ndarray = _empty(0)  # event crossings: times,
    event_k: np.ndarray = _empty(0, dtype=np.int64)  # which event,
    event_x: np.ndarray = _empty(0, 0)  # states
    nswitch: int = 0  # switches located
    held: np.ndarray = _empty(0, 0)  # sampled inputs at the sample times
    u: np.ndarray | None = None  # the output stage: the inputs at the output times (None: not computed)
    energy: np.ndarray | None = None  # and the Jacobi integral there


def stage_table() -> tuple:
    """Nothing any more: the kernels write DOP853's stages out with their coefficients as named
    constants (kept for callers that passed ``*stage_table()``)."""
    return ()


#: Most event crossings recorded in one run.
MAX_EVENTS = 100_000


#: What the progress bar says while numba compiles the integrators (a machine's first run: about 20 s).
COMPILING = "compiling the integrators, once per machine"


def compiled(dispatcher) -> bool:
    """Whether numba has `dispatcher` (a kernel) compiled: in this process, or in its cache on disk
    (loading it then takes well under a second). False when it cannot tell."""
    if dispatcher.signatures:
        return True
    try:
        return os.path.exists(dispatcher._cache._cache_file._index_path)
    except AttributeError:  # no cache on disk (cache=False), or another numba's internals
        return False


def _with_progress(call, stats, total: int, enabled: bool | None, compiling: bool = False):
    """Run the compiled integrator; on a terminal, in a thread (the kernel releases the GIL) while
    this one draws a progress bar from the outputs done so far (stats[3]), after saying that it
    compiles the integrators while it does (`compiling`: before the first output). The results are
    the same either way."""
    if enabled is None and not _progress._is_terminal(sys.stderr):  # (as Progress decides: no bar, so no thread)
        return call()
    bar = _progress.Progress(total, "simulating", enabled=enabled)
    if not bar.enabled:
        return call()
    if callable(compiling):  # asked only when a bar is drawn (numba's signatures cost tens of microseconds)
        compiling = compiling()
    if compiling:
        bar.wait(COMPILING)
    import threading

    result: dict = {}

    def target():
        try:
            result["status"] = call()
        except BaseException as exc:  # pragma: no cover - re-raised below
            result["error"] = exc

    worker = threading.Thread(target=target, daemon=True)
    worker.start()
    with bar:
        while True:  # the count after the run too, also when it ended before the first look (a short run)
            worker.join(0.1)
            bar.set(int(stats[3]))
            if not worker.is_alive():
                break
    if "error" in result:  # pragma: no cover
        raise result["error"]
    return result["status"]


_NO_EVENTS: dict = {}


def _no_events(n: int):
    """(events, eterm, ev_t, ev_k, ev_x, ev_n) of a run without events, shared (read only)."""
    if n not in _NO_EVENTS:
        from ._inputs import Programs

        _NO_EVENTS[n] = (Programs([], [], [0], 1), np.zeros(1, np.int64), np.zeros(1), np.zeros(1, np.int64),
                         np.zeros((1, 2 * n)), np.zeros(1, np.int64))
    return _NO_EVENTS[n]

#: The smallest relative tolerance (as SciPy's solve_ivp): 100 machine epsilons.
_MIN_RTOL = 100 * 2.220446049250313e-16


@dataclass(frozen=True)
class Sampling:
    """Sampled inputs (internal): hold[i] = 1 for a sampled input; its values are computed at
    the times `samples` where which[s, i] = 1 and held in between."""

    hold: np.ndarray
    samples: np.ndarray
    which: np.ndarray


_NO_SAMPLING: dict = {}


def no_sampling(m: int) -> tuple[Sampling, np.ndarray]:
    """(no sampled input, a history array) for m inputs, shared (the kernel only reads them when
    there are no sample times)."""
    if m not in _NO_SAMPLING:
        _NO_SAMPLING[m] = (Sampling(np.zeros(max(1, m), np.int64), np.zeros(0), np.zeros((1, max(1, m)), np.int64)),
                           np.zeros((1, max(1, m))))
    return _NO_SAMPLING[m]


def _dop853_arguments(cm, energy, prog, rtol, atol, max_step, first_step, project, nwork, watched, held,
                      events_nstack) -> tuple:
    """The kernel's argument tuples (model, program, control, watched, held) of run_dop853 and PreparedDop853."""
    model = (cm.rhs_address, cm.n, int(project), int(nwork), *energy)
    program = (prog.ops, prog.args, prog.starts, max(prog.nstack, events_nstack))
    control = (0.0, max(float(rtol), _MIN_RTOL), float(atol), float(max_step), float(first_step))  # see MIN_RTOL
    return model, program, control, watched, held


def _call_dop853(args, x0, times, p, arrays, progress) -> int:
    """The compiled DOP853 on the prepared `args` into `arrays` (X, info, stats, U, E, done), with the
    progress bar where asked (see run_dop853)."""
    model, program, control, watched, held = args

    def call():
        return kernels().dop853(model, x0, times, p, program, control, watched, held, arrays)

    if progress is False:
        return call()
    return _with_progress(call, arrays[2], len(times), progress, lambda: not compiled(kernels().dop853))


def run_dop853(cm: CompiledModel, x0, times, p, prog, rtol: float, atol: float, max_step: float = np.inf,
               first_step: float = 0.0, events=None, terminal=(), progress: bool | None = None,
               sampling: Sampling | None = None, project: int = 0, nwork: int = 0, outputs: bool = True) -> RawRun:
    """DOP853 in compiled code from (0, x0); states at `times` (increasing, >= 0). `project`, `nwork`:
    a constrained model's projection (its address) and the size of its rhs's work array. `events`:
    the Programs of event functions of (t, x, u, p); `terminal`: 1 for those that stop it.
    `progress`: draw a progress bar (default: when stderr is a terminal and it takes over 1 s).
    `sampling`: the sampled inputs (default: none). `outputs`: the output stage, the inputs and the
    Jacobi integral at the output times, evaluated in the compiled loop (RawRun.u and .energy; not
    with sampled inputs, whose held values inputs_and_energy reads from the run's history)."""
    n = cm.n
    m = len(prog.starts) - 1
    if sampling is None:
        sampling, hist = no_sampling(m)
    else:
        hist = np.zeros((max(1, len(sampling.samples)), max(1, m)))
        outputs = False
    if events is None:  # no events: the kernel only reads these arrays, so they are shared
        events, eterm, ev_t, ev_k, ev_x, ev_n = _no_events(n)
        nev = 0
    else:
        nev = len(events.starts) - 1
        cap = MAX_EVENTS if nev else 1
        ev_t, ev_k, ev_x, ev_n = np.zeros(cap), np.zeros(cap, np.int64), np.zeros((cap, 2 * n)), np.zeros(1, np.int64)
        eterm = np.zeros(max(1, nev), np.int64)
        eterm[:len(terminal)] = terminal
    times = np.ascontiguousarray(times, dtype=float)
    X = np.empty((len(times), 2 * n))
    info = np.zeros(2 + 2 * n)
    stats = np.zeros(5, dtype=np.int64)
    if outputs:
        U, E, energy = np.empty((len(times), m)), np.empty(len(times)), (cm.energy_address, cm.energy_rows_address)
    else:
        U, E, energy = _NO_OUTPUTS[0], _NO_OUTPUTS[1], (0, 0)
    args = _dop853_arguments(cm, energy, prog, rtol, atol, max_step, first_step, project, nwork,
                             (events.ops, events.args, events.starts, eterm, ev_t, ev_k, ev_x, ev_n),
                             (sampling.hold, sampling.samples, sampling.which, hist), events.nstack)
    p = _nonempty(np.ascontiguousarray(p, dtype=float))
    done = np.zeros(1, np.int64)
    status = _call_dop853(args, np.array(x0, dtype=float), times, p, (X, info, stats, U, E, done), progress)
    nfev, nstep, nreject, k, nswitch = stats.tolist()
    if outputs and k > done[0]:  # the rows written where it stopped: their output stage
        d = int(done[0])
        kernels().energies(energy, times[d:k], X[d:k], p, prog.ops, prog.args, prog.starts, prog.nstack, E[d:k], U[d:k],
                           sampling.hold)
    if outputs and not energy[1]:  # their energy row by row (see EnergyRows)
        cm.count_energy_rows(k)
    m = int(ev_n[0]) if nev else 0
    if m:
        order = np.argsort(ev_t[:m], kind="stable")
        ev_t, ev_k, ev_x = ev_t[:m][order], ev_k[:m][order], ev_x[:m][order]
    else:
        ev_t, ev_k, ev_x = ev_t[:0], ev_k[:0], ev_x[:0]
    if k < len(times):  # (all of them, as a rule: the arrays as they are)
        times, X, U, E = times[:k], X[:k], U[:k], E[:k]
    stop_t, stop_measure = info[:2].tolist()
    return RawRun(int(status), times, X, stop_t, stop_measure, info[2:].copy(), nfev, nstep, nreject, ev_t, ev_k, ev_x,
                  nswitch, hist, U if outputs else None, E if outputs else None)


#: The output arrays of a run without the output stage (the kernel does not touch them).
_NO_OUTPUTS = (np.zeros((1, 1)), np.zeros(1))


class PreparedDop853:
    """run_dop853's call with the output stage, prepared once for the same run again (simulate()'s
    repeated call: see numeric/_simulate.py, _Repeat): a run without events and sampled inputs, its
    arguments (the model's addresses, the input programs, the tolerances, the read-only shared
    arrays) built here once, as run_dop853 builds them; `run` allocates the output arrays and calls
    the kernel: the same arguments, so the same numbers bit for bit."""

    __slots__ = ("n", "m", "times", "x0", "p", "args", "energy", "prog", "rows")

    def __init__(self, cm: CompiledModel, x0, times, p, prog, rtol: float, atol: float, max_step: float = np.inf):
        n = self.n = cm.n
        m = self.m = len(prog.starts) - 1
        sampling, hist = no_sampling(m)
        events, eterm, ev_t, ev_k, ev_x, ev_n = _no_events(n)
        self.times = np.ascontiguousarray(times, dtype=float)
        self.x0 = np.array(x0, dtype=float)
        self.p = _nonempty(np.ascontiguousarray(p, dtype=float))
        self.prog = prog
        self.energy = (cm.energy_address, cm.energy_rows_address)
        self.rows = cm.energy_rows if cm.energy_rows is not None and not self.energy[1] else None  # (EnergyRows)
        self.args = _dop853_arguments(cm, self.energy, prog, rtol, atol, max_step, 0.0, 0, 0,
                                      (events.ops, events.args, events.starts, eterm, ev_t, ev_k, ev_x, ev_n),
                                      (sampling.hold, sampling.samples, sampling.which, hist), events.nstack)

    def run(self, progress: bool | None = None):
        """(status, X, U, E, stats, info, done) of one run (the kernel's own arrays; see raw)."""
        rows = len(self.times)
        X, U, E = np.empty((rows, 2 * self.n)), np.empty((rows, self.m)), np.empty(rows)
        info, stats, done = np.zeros(2 + 2 * self.n), np.zeros(5, dtype=np.int64), np.zeros(1, np.int64)
        status = _call_dop853(self.args, self.x0.copy(), self.times, self.p, (X, info, stats, U, E, done), progress)
        if self.rows is not None and self.rows.count(int(stats[3])):  # energy_rows compiled: the next runs use it
            self.energy = (self.energy[0], self.rows.address)
            self.args = ((*self.args[0][:5], self.rows.address), *self.args[1:])
            self.rows = None
        return status, X, U, E, stats, info, done

    def raw(self, status, X, U, E, stats, info, done) -> RawRun:
        """The RawRun of a run's arrays, as run_dop853 makes it (the rows' output stage where it stopped)."""
        times, prog = self.times, self.prog
        nfev, nstep, nreject, k, nswitch = stats.tolist()
        if k > done[0]:
            d = int(done[0])
            kernels().energies(self.energy, times[d:k], X[d:k], self.p, prog.ops, prog.args, prog.starts, prog.nstack,
                               E[d:k], U[d:k], self.args[4][0])
        if k < len(times):
            times, X, U, E = times[:k], X[:k], U[:k], E[:k]
        stop_t, stop_measure = info[:2].tolist()
        return RawRun(int(status), times, X, stop_t, stop_measure, info[2:].copy(), nfev, nstep, nreject,
                      _empty(0), _empty(0, dtype=np.int64), _empty(0, 2 * self.n), nswitch, self.args[4][3], U, E)


def run_variational(cm: CompiledModel, x0, h: float, nsteps: int, every: int, p, prog) -> RawRun:
    """The midpoint variational integrator from (0, x0): `nsteps` steps of size h, output every
    `every` steps."""
    n = cm.n
    nout = nsteps // every + 1
    X = np.empty((nout, 2 * n))
    info = np.zeros(2 + 2 * n)
    stats = np.zeros(4, dtype=np.int64)
    status = kernels().variational((cm.mass_forcing_address, cm.lagrange_parts_address, n), np.array(x0, dtype=float),
                                   0.0, float(h), int(nsteps), int(every),
                                   _nonempty(np.ascontiguousarray(p, dtype=float)),
                                   (prog.ops, prog.args, prog.starts, prog.nstack), (X, info, stats))
    k = int(stats[3])
    return RawRun(int(status), np.arange(k) * (every * h), X[:k], float(info[0]), float(info[1]),
                  info[2:].copy(), int(stats[0]), int(stats[1]), 0)


def run_batch(rc: int, rcl: int | None, n: int, lanes: int, X0, times, P, prog, rtol: float, atol: float,
              max_step: float, X, INFO, STATS, STATUS_, project: int = 0, nwork: int = 0) -> None:
    """DOP853 for each row of X0 and P, in parallel on this machine's cores, into the rows of X,
    INFO, STATS and STATUS_: in blocks of `lanes` runs evaluated together (rcl, the address of
    rhs_lanes), or one run at a time (rcl None; `project`, `nwork`: a constrained model's
    projection address and work size, see run_dop853)."""
    model = (rc, n, int(project), int(nwork), 0, 0)
    program = (prog.ops, prog.args, prog.starts, prog.nstack)
    control = (0.0, float(rtol), float(atol), float(max_step), 0.0)
    if rcl:
        kernels().dop853_batch_lanes(model, rcl, lanes, X0, times, P, program, control, X, INFO, STATS, STATUS_)
    else:
        kernels().dop853_batch(model, X0, times, P, program, control, X, INFO, STATS, STATUS_)


def inputs_and_energy(cm: CompiledModel, times, X, p, prog, held=None, run: RawRun | None = None
                      ) -> tuple[np.ndarray, np.ndarray]:
    """(U, energy) at the rows of (times, X), computed in compiled code. `held`: (hold, U0) for
    sampled inputs: hold[i] = 1 where U0[:, i] holds the values of input i at the times. `run`: the
    RawRun whose first rows X are: its output stage (computed in its compiled loop) is taken
    when it has one."""
    times = np.ascontiguousarray(times, dtype=float)
    if run is not None and run.energy is not None and held is None and len(times) <= len(run.energy):
        if len(times) == len(run.energy):
            return run.u, run.energy
        return run.u[:len(times)], run.energy[:len(times)]
    m = len(cm.input_names)
    U = np.empty((len(times), m))
    hold = np.zeros(max(1, m), np.int64)
    if held is not None:
        hold, U[:] = held
    energy = np.empty(len(times))
    rows = cm.energy_rows_address
    kernels().energies((cm.energy_address, rows), times, np.ascontiguousarray(X, dtype=float),
                       _nonempty(np.ascontiguousarray(p, dtype=float)), prog.ops, prog.args, prog.starts, prog.nstack,
                       energy, U, hold)
    if not rows:  # (see EnergyRows)
        cm.count_energy_rows(len(times))
    return U, energy


def compile_c(equations: Equations) -> CompiledModel:
    """The model's functions generated in C and compiled with cffi (see _cbackend.py)."""
    from ._cbackend import compile_c as build

    return build(equations)
