"""simulate_batch(...) -> BatchResult: many initial states and/or parameter sets in one call,
integrated by the compiled DOP853 in parallel on all cores (numba prange), or on a Dask cluster
when a client is given."""

from __future__ import annotations

import itertools
import math
import numbers
from dataclasses import dataclass, field
from typing import Mapping

import numpy as np

from .._limits import MAX_ROWS
from .._util import did_you_mean, number_array, read_only, shown_value
from ..errors import ModelError, Problem, Status
from ._kernels import STATUS
from ._trajectory import Trajectory

__all__ = ["simulate_batch", "BatchResult", "grid"]


@dataclass(frozen=True, eq=False)
class BatchResult:
    """The trajectories of a batch run (returned by :func:`simulate_batch`).

    Attributes
    ----------
    t : ndarray, shape (N,)
        Output times, shared by every run.
    x : ndarray, shape (B, N, 2n)
        States: run, time, state (columns in `state_names` order). NaN after a run stopped.
    state_names : tuple of str
    parameters : ndarray, shape (B, k)
        The parameter values of each run, columns in `parameter_names` order.
    parameter_names : tuple of str
    initial : ndarray, shape (B, 2n)
        The initial states.
    status : ndarray of int, shape (B,)
        0 when the run reached the end; otherwise see `statuses` (the codes as members of
        :class:`~lagrangian.errors.Status`: 1 or 2, the mass matrix became singular, 3, the forcing
        was not finite, -1, the step size became too small) and `messages`.
    stop_time : ndarray, shape (B,)
        Where each run stopped (t_end when it did not).
    nfev : ndarray of int, shape (B,)
        Right-hand-side evaluations per run.
    output_names : tuple of str
        The model's named outputs (``[outputs]``, ``Model.add_output``); ``batch[name]`` gives each
        as an array (B, N), NaN after a run stopped, evaluated on first use.
    """

    t: np.ndarray
    x: np.ndarray
    state_names: tuple[str, ...]
    parameters: np.ndarray
    parameter_names: tuple[str, ...]
    initial: np.ndarray
    status: np.ndarray
    stop_time: np.ndarray
    nfev: np.ndarray
    backend: str = "numba"
    _model: object = field(default=None, repr=False)
    output_names: tuple[str, ...] = ()
    _outputs_of: object = field(default=None, repr=False, compare=False)  # run i -> {name: (N,)}, None without
    _outputs: dict = field(default_factory=dict, repr=False, compare=False)  # run i -> its outputs, filled on use

    def __len__(self) -> int:
        return self.x.shape[0]

    @property
    def ok(self) -> np.ndarray:
        """Whether each run reached the end, shape (B,)."""
        return self.status == 0

    @property
    def final(self) -> np.ndarray:
        """The states at the last output time, shape (B, 2n)."""
        return self.x[:, -1, :]

    @property
    def statuses(self) -> list[Status]:
        """The status of each run as a :class:`~lagrangian.errors.Status` (its ``message`` and
        ``fix``); `status` holds the same codes as integers."""
        return [Status.of(s) for s in self.status]

    @property
    def messages(self) -> list[str]:
        """The integrator's message for each run."""
        return [STATUS.get(int(s), f"status {int(s)}") for s in self.status]

    def __getitem__(self, name: str) -> np.ndarray:
        """A state or output column of every run by name, shape (B, N); "t" gives the times."""
        if name == "t":
            return self.t
        if name in self.state_names:
            return self.x[:, :, self.state_names.index(name)]
        if name in self.output_names:
            return read_only(np.stack([self._run_outputs(i)[name] for i in range(len(self))]), float)
        raise KeyError(f"the batch has no column '{name}'; its columns are t, "
                       f"{', '.join((*self.state_names, *self.output_names))}")

    def _run_outputs(self, i: int) -> dict[str, np.ndarray]:
        """The named outputs of run `i` at the output times, NaN after it stopped."""
        if i not in self._outputs:
            self._outputs[i] = self._outputs_of(i) if self._outputs_of is not None else {}
        return self._outputs[i]

    def trajectory(self, i: int) -> Trajectory:
        """Run `i` as a :class:`Trajectory`: its states and named outputs (no inputs or energy column)."""
        return Trajectory(self.t, self.x[i], self.state_names,
                          parameters=dict(zip(self.parameter_names, map(float, self.parameters[i]))),
                          nfev=int(self.nfev[i]), message=self.messages[i],
                          stats={"backend": self.backend, "method": "DOP853", "nfev": int(self.nfev[i]),
                                 "status": self.statuses[i]},
                          model=self._model, outputs=self._run_outputs(i))

    def __repr__(self) -> str:
        return (f"<BatchResult: {len(self)} runs ({int(np.sum(self.ok))} reached the end), {len(self.t)} "
                f"output times, states {', '.join(self.state_names)}>")


def grid(axes: Mapping[str, object]) -> dict[str, np.ndarray]:
    """Every combination of the values on each axis, as flat arrays for :func:`simulate_batch`.

    ``grid({"k": [1, 2, 3], "c": [0.1, 0.2]})`` gives k = [1, 1, 2, 2, 3, 3], c = [0.1, 0.2, ...].
    """
    example = "grid({'k': [1, 2, 3], 'c': [0.1, 0.2]})"
    if not isinstance(axes, Mapping):
        raise ModelError([Problem(f"grid() takes a mapping of names to the values of each axis, such as {example}, "
                                  f"got {type(axes).__name__} {shown_value(axes)}", key="axes")])
    names = list(axes)
    values, problems = [], []
    for k in names:
        arr = number_array(axes[k])
        if arr is None or arr.ndim > 1 or arr.size == 0 or not np.all(np.isfinite(arr)):
            problems.append(Problem(f"the values of axis '{k}' must be one finite number or a non-empty list of "
                                    f"finite numbers, such as {example}, got {shown_value(axes[k])}",
                                    key=f"axes.{k}"))
            continue
        values.append(np.atleast_1d(arr))
    if problems:
        raise ModelError(problems)
    size = math.prod(len(v) for v in values)
    if size > MAX_ROWS.value:
        raise ModelError([Problem(f"the grid has {size:.3g} combinations ({' x '.join(str(len(v)) for v in values)}), "
                                  f"more than the limit of {MAX_ROWS.value}: use fewer values on an axis; "
                                  f"{MAX_ROWS.how_to_raise()}", key="axes")])
    combos = list(itertools.product(*values))
    return {k: np.array([c[i] for c in combos]) for i, k in enumerate(names)}


def _size(value) -> int | None:
    """None for one number (every run's), the length of a 1-d array of numbers (one per run), -1 otherwise."""
    if isinstance(value, numbers.Real) and not isinstance(value, bool):
        return None
    arr = number_array(value)
    return int(arr.shape[0]) if arr is not None and arr.ndim == 1 else -1


def simulate_batch(system, t_end: float | None = None, initial=None, *, params: Mapping | None = None,
                   inputs: Mapping | None = None, dt: float | None = None, t_eval=None,
                   rtol: float | None = None, atol: float | None = None, max_step: float = math.inf,
                   backend: str = "auto", client=None, progress: bool | None = None,
                   chunk_size: int | None = None, lanes: int | None = None) -> BatchResult:
    """Integrate many runs of one model: initial states and/or parameter sets, in parallel.

    Parameters
    ----------
    system : Model, Equations or CompiledModel
    t_end : float
        Final time (default: the model's [simulation] t_end).
    initial : array_like, shape (B, 2n) or (2n,), or mapping of str to float or array (B,)
        Initial states: one row per run, or by name with a number (shared by every run) or an
        array (one value per run); names not given keep the model's [simulation] initial values
        (0 where it has none), as in :func:`simulate`. Default: the model's initial values.
    params : mapping of str to float or array_like, shape (B,)
        Parameter values that override the model's: a number for every run, or one per run
        (see :func:`grid` for every combination of several parameters).
    inputs : mapping of str to float or str
        Each input as a constant or an expression of t, the coordinates, velocities and
        parameters (per run's values), a feedback law included (its runs are integrated one at
        a time, without lanes).
    dt, t_eval
        Output times, as in :func:`simulate`; ``t_eval=[t_end]`` keeps only the final states.
    rtol, atol : float
        Tolerances of DOP853 (default 1e-9 both).
    max_step : float
        Largest step.
    backend : {"auto", "numba", "c"}
        The compiled backend (both run the same compiled DOP853).
    client : dask.distributed.Client, optional
        Run the chunks of the batch on this Dask cluster instead of this machine's cores.
    progress : bool, optional
        Show a progress bar on stderr (default: when stderr is a terminal and the run takes more
        than a second).
    chunk_size : int, optional
        Runs per parallel chunk (and per Dask task); default: about 1/50 of the batch.
    lanes : int, optional
        Runs integrated together, in blocks of this many: each run keeps its own steps and error
        control (the same steps as alone; the states agree to rounding), while the right-hand
        side of all of them is evaluated at once, with SIMD instructions (16 or more, a
        multiple of 16, vectorizes). Default: 64, 32 or 16, the most whose stages fit in the
        L1 cache (16 x 2n x lanes numbers at most 256 x 16) with a block for each core.
        ``lanes=1`` integrates each run alone. Lanes need the numba backend and at most 12
        coordinates; otherwise, and for the runs after the last full block, runs are integrated
        alone. A block in which a run meets a nearly singular mass matrix, a non-finite force
        or an angle beyond 1e5 rad is run again one run at a time, so that each run stops or
        fails as it would alone. The runs of a constrained model are integrated alone (no lanes),
        each from its consistent initial state (found as :func:`simulate` finds it) and projected
        onto the constraints after every step; one that reaches a dead point (the constraints
        dependent there) stops with status 6, ``Status.SINGULAR_CONSTRAINTS``.

    Returns
    -------
    BatchResult
        Arrays: ``x[run, time, state]``; a run that fails does not stop the others: its
        `status` says why and its states are NaN from then on.
    """
    from ._simulate import (_Names, _as_numeric, _input_function, _input_programs, _parameters,
                            _work_problems, requested_times)
    from ._fast import BACKENDS, CompiledModel
    from ._inputs import signal_problems
    from ._options import SimulationOptions

    nm = _as_numeric(system)
    eq = nm.equations
    names = nm if isinstance(nm, (_Names, CompiledModel)) else _Names(eq)
    defaults = eq.model.simulation
    problems: list[Problem] = []
    options = SimulationOptions.from_model(eq.model).merged(t_end=t_end, dt=dt, rtol=rtol, atol=atol,
                                                            initial=initial, inputs=inputs
                                                            ).read_signals()  # simulate's rule
    t_end, dt, rtol, atol = options.t_end, options.dt, options.rtol, options.atol
    problems += options.problems()  # simulate's checks of t_end, dt, rtol and atol, and their messages
    problems += _work_problems(t_end, dt, t_eval, None, "DOP853")  # the output rows of each run (LAGRANGIAN_MAX_ROWS)
    if lanes is not None and (isinstance(lanes, bool) or not isinstance(lanes, numbers.Integral) or lanes < 1):
        problems.append(Problem(f"lanes must be a positive integer, got {lanes!r}", key="lanes"))
    if chunk_size is not None and (isinstance(chunk_size, bool) or not isinstance(chunk_size, numbers.Integral)
                                   or chunk_size < 1):
        problems.append(Problem(f"chunk_size must be a positive integer (runs per chunk), such as chunk_size=64, got "
                                f"{shown_value(chunk_size)}", key="chunk_size"))
    if not isinstance(backend, str) or backend not in BACKENDS or backend == "scipy":
        problems.append(Problem(f"simulate_batch runs in compiled code: backend must be one of auto, numba, c, "
                                f"got '{backend}'{did_you_mean(backend, BACKENDS, 0.5)}", key="backend"))
    given_initial = initial
    initial = options.initial
    params = dict(params or {})

    # sizes: every per-run array must have the same length B
    sizes = {}
    if initial is not None and not isinstance(initial, Mapping):
        arr = number_array(initial)
        if arr is None:
            problems.append(Problem(f"the initial states must be numbers: an array of shape (B, {2 * names.n}) "
                                    f"({', '.join(names.state_names)}), or a mapping of these names to a number or "
                                    f"a 1-d array (one value per run); got {shown_value(initial, 80)}", key="initial"))
        elif arr.ndim == 2:
            sizes["initial"] = arr.shape[0]
        if arr is not None and (arr.shape[-1:] != (2 * names.n,) or arr.ndim > 2):
            problems.append(Problem(f"the initial states must have shape (B, {2 * names.n}) "
                                    f"({', '.join(names.state_names)}), got shape {arr.shape}", key="initial"))
    for what, mapping in (("initial", initial if isinstance(initial, Mapping) else {}), ("params", params)):
        for k, v in mapping.items():
            s = _size(v)
            if s == -1:
                problems.append(Problem(f"{what}.{getattr(k, 'name', k)} must be a number or a 1-d array of numbers "
                                        f"(one value per run), got {shown_value(v, 80)}",
                                        key=f"{what}.{getattr(k, 'name', k)}"))
            elif s is not None:
                sizes[f"{what}.{getattr(k, 'name', k)}"] = s
    if len(set(sizes.values())) > 1:
        problems.append(Problem("the per-run arrays have different lengths: "
                                + ", ".join(f"{k}: {v}" for k, v in sizes.items()), key="batch"))
    B = next(iter(sizes.values())) if sizes else 1
    if B == 0:
        problems.append(Problem("the batch is empty (arrays of length 0)", key="batch"))

    def first(v):
        return float(np.asarray(v, dtype=float).ravel()[0]) if _size(v) not in (None, -1) and np.size(v) else v

    p0 = _parameters(names, {k: first(v) for k, v in params.items()}, problems)
    if isinstance(initial, Mapping):
        from ._simulate import _named_values

        _named_values({k: first(v) for k, v in initial.items()}, names.state_names, "a coordinate or velocity",
                      "initial", problems)
    _, u_exprs = _input_function(names, options.inputs, p0, problems)
    problems += signal_problems(options.inputs, names.equations.t, 0.0, options.t_end)
    if u_exprs is None:
        problems.append(Problem("simulate_batch runs in compiled code, which cannot call a Python function: give "
                                "each input as an expression string such as '1.5*sin(3*t)'", key="inputs"))
    if problems:
        raise ModelError(problems)

    # the arrays
    k = len(names.parameter_names)
    P = np.tile(p0, (B, 1))
    for name, v in params.items():
        P[:, names.parameter_names.index(getattr(name, "name", name))] = np.asarray(v, dtype=float)
    X0 = np.zeros((B, 2 * names.n))
    if isinstance(initial, Mapping):
        for name, v in initial.items():
            X0[:, names.state_names.index(getattr(name, "name", name))] = np.asarray(v, dtype=float)
    elif initial is not None:
        X0[:] = np.asarray(initial, dtype=float)
    bad = [f"{what} row {i}" for what, A in (("initial", X0), ("params", P))
           for i in np.nonzero(~np.all(np.isfinite(A), axis=1))[0][:3]]
    if bad:
        raise ModelError(f"every initial value and parameter must be a finite number: not so in {', '.join(bad)}")

    times = requested_times(t_end, dt, t_eval)

    from ._compiled import compile_equations

    cm = nm if isinstance(nm, CompiledModel) else compile_equations(eq, backend)
    if not isinstance(cm, CompiledModel):  # "auto" for a large model without a C compiler: lanes need numba
        cm = compile_equations(eq, "numba")
    project = nwork = 0
    if eq.is_constrained:  # each run from its consistent state, projected after every step
        project, nwork = _constrained_starts(cm, X0, P[:, :k], given_initial, defaults.get("initial"))
    prog = _input_programs(eq, u_exprs)
    rtol = float(rtol)  # at least 100 machine epsilons (SimulationOptions.problems)
    X = np.full((B, len(times), 2 * names.n), np.nan)
    INFO = np.zeros((B, 2 + 2 * names.n))
    STATS = np.zeros((B, 4), dtype=np.int64)
    STATUS_ = np.zeros(B, dtype=np.int64)
    if lanes is None:
        lanes = default_lanes(names.n, B)
    if prog.reads_state or prog.nswitch or project:  # feedback laws, switches, constraints: one run at a time
        lanes = 1
    rcl = cm.rhs_lanes_address(lanes) if lanes > 1 and B >= lanes else None
    if chunk_size is None:
        chunk_size = max(64, -(-B // 50))
    if rcl:  # whole blocks per chunk
        chunk_size = -(-chunk_size // lanes) * lanes
    chunks = [(a, min(B, a + chunk_size)) for a in range(0, B, chunk_size)]
    from .._progress import Progress

    with Progress(B, "simulating", enabled=progress) as bar:
        if client is None:
            for a, b in chunks:
                _run(cm.rhs_address, rcl, names.n, lanes, X0[a:b], times, _nonempty_rows(P[a:b]), prog, rtol,
                     float(atol), float(max_step), X[a:b], INFO[a:b], STATS[a:b], STATUS_[a:b], project=project,
                     nwork=nwork)
                bar.update(b - a)
        else:
            _run_on_dask(client, cm, names.n, lanes if rcl else 1, chunks, X0, P, times, prog, rtol, float(atol),
                         float(max_step), X, INFO, STATS, STATUS_, bar, nwork=nwork)
    if project:
        _dead_points(cm, INFO, P[:, :k], STATUS_)
    for i in np.nonzero(STATUS_ != 0)[0]:
        X[i, STATS[i, 3]:] = np.nan
    stop = np.where(STATUS_ == 0, times[-1], INFO[:, 0])
    output_names = tuple(eq.model.outputs) if eq.model is not None else ()
    return BatchResult(read_only(times, float), read_only(X, float), names.state_names, read_only(P[:, :k], float),
                       names.parameter_names, read_only(X0, float), read_only(STATUS_, np.int64),
                       read_only(stop, float), read_only(STATS[:, 0], np.int64), cm.backend, eq.model,
                       output_names, _outputs_at(cm, eq, prog, times, X, P, k) if output_names else None)


def _outputs_at(cm, eq, prog, times, X, P, k):
    """Run i -> its named outputs: the inputs at its rows computed in compiled code (as simulate
    computes its input columns), then the outputs vectorised by the one numeric model; NaN after
    the run stopped."""
    from ._fast import inputs_and_energy
    from ._trajectory import evaluate_outputs

    def outputs_of(i: int) -> dict[str, np.ndarray]:
        rows = int(np.argmax(~np.all(np.isfinite(X[i]), axis=1))) if not np.all(np.isfinite(X[i])) else len(times)
        U, _ = inputs_and_energy(cm, times[:rows], X[i, :rows], P[i], prog)
        values = evaluate_outputs(eq, times[:rows], X[i, :rows], U, P[i, :k])
        full = {}
        for name, v in values.items():
            column = np.full(len(times), np.nan)
            column[:rows] = v
            full[name] = read_only(column, float)
        return full

    return outputs_of


def default_lanes(n: int, runs: int) -> int:
    """64, 32 or 16: the most lanes whose 16 stages of 2n numbers each fit in the L1 cache
    (256 numbers a stage) and leave a block for each core; 1 when there are too few runs."""
    import numba

    for lanes in (64, 32):
        if 2 * n * lanes <= 256 and lanes * numba.get_num_threads() <= runs:
            return lanes
    return 16 if runs >= 16 else 1


def _nonempty_rows(P: np.ndarray) -> np.ndarray:
    return P if P.shape[1] else np.zeros((P.shape[0], 1))


def _run(rc: int, rcl: int | None, n: int, lanes: int, X0, times, P, prog, rtol, atol, max_step, X, INFO, STATS,
         STATUS_, project: int = 0, nwork: int = 0) -> None:
    """One chunk, in parallel on this machine's cores: in blocks of `lanes` runs evaluated
    together (rcl, the address of rhs_lanes), or one run at a time (rcl None; `project`, `nwork`: a
    constrained model's projection address and work size, see dop853)."""
    from ._fast import run_batch

    run_batch(rc, rcl, n, lanes, X0, times, P, prog, rtol, atol, max_step, X, INFO, STATS, STATUS_, project, nwork)


def _run_on_dask(client, cm, n, lanes, chunks, X0, P, times, prog, rtol, atol, max_step, X, INFO, STATS, STATUS_,
                 bar, nwork: int = 0):
    from dask.distributed import as_completed

    sources = (cm.source, cm.lanes_source(lanes) if lanes > 1 else None)
    futures = {}
    for a, b in chunks:
        fut = client.submit(run_chunk, sources, n, lanes, X0[a:b], times, _nonempty_rows(P[a:b]), prog.ops,
                            prog.args, prog.starts, prog.nstack, rtol, atol, max_step, nwork=nwork, pure=False)
        futures[fut] = (a, b)
    for fut in as_completed(list(futures)):
        a, b = futures[fut]
        X[a:b], INFO[a:b], STATS[a:b], STATUS_[a:b] = fut.result()
        bar.update(b - a)


def run_chunk(sources, n: int, lanes: int, X0, times, P, ops, args, starts, nstack, rtol, atol, max_step,
              nwork: int = 0):
    """One chunk of a batch, on a Dask worker: loads (or writes and compiles) the model's modules
    from their sources (that of the main module and that of the lanes module, or None), keyed by
    the hash of the source itself, then runs the parallel DOP853 (`nwork` > 0: a constrained model's,
    projected by its main module's project). Returns (X, INFO, STATS, STATUS)."""
    from ._codegen import cached_module
    from ._inputs import Programs

    main = cached_module(sources[0])[2]
    lane_module = cached_module(sources[1])[2] if sources[1] else None
    B = X0.shape[0]
    X = np.full((B, len(times), 2 * n), np.nan)
    INFO = np.zeros((B, 2 + 2 * n))
    STATS = np.zeros((B, 4), dtype=np.int64)
    STATUS_ = np.zeros(B, dtype=np.int64)
    _run(main.rhs.address, lane_module.rhs_lanes.address if lane_module else None, n, lanes,
         np.ascontiguousarray(X0), times, np.ascontiguousarray(P), Programs(ops, args, starts, nstack), rtol, atol,
         max_step, X, INFO, STATS, STATUS_, project=main.project.address if nwork else 0, nwork=nwork)
    return X, INFO, STATS, STATUS_


def _constrained_starts(cm, X0, P, initial, model_initial) -> tuple[int, int]:
    """Move each run's initial state (rows of X0, in place) onto the constraints as simulate does
    (see _simulate_constrained: the independent coordinates and speeds and the values given kept,
    the others found); (the address of the model's projection, the size of its work array)."""
    from ._codegen_constrained import work_size
    from ._constrained import consistent_state
    from ._fast import _address
    from ._simulate import _consistent_guess, _constrained_numbers

    if cm.project_c is None:  # pragma: no cover - both compiled backends generate the projection
        raise ModelError("simulate_batch integrates a constrained model with its compiled projection, and this "
                         "compiled model has none: compile it again with backend='auto'")
    eq = cm.equations
    ccm = _constrained_numbers(eq)
    for b in range(X0.shape[0]):
        guess, fixed = _consistent_guess(eq, X0[b], initial, model_initial)
        try:
            X0[b] = consistent_state(ccm, guess, fixed, P[b])
        except ModelError as exc:
            values = ", ".join(f"{k} = {v:.6g}" for k, v in zip(cm.parameter_names, P[b])) or "no parameters"
            raise ModelError([Problem(f"run {b} of the batch ({values}): {p.message}", key=p.key)
                              for p in exc.problems]) from None
    return _address(cm.project_c), work_size(ccm.n, ccm.m)


def _dead_points(cm, INFO, P, STATUS_) -> None:
    """Runs of a constrained model that stopped at a singular saddle-point system (status 1 or 2)
    stopped at a dead point where the rank measure of G is the smaller of the kernel's two measures
    (as simulate classifies them: ConstrainedModel.measures); their status says so
    (Status.SINGULAR_CONSTRAINTS); the others keep the singular mass matrix's."""
    from ..errors import Status
    from ._simulate import _constrained_numbers

    ccm = _constrained_numbers(cm.equations)
    u0 = np.zeros(len(cm.input_names))  # M and G do not depend on the inputs
    for b in np.nonzero((STATUS_ == 1) | (STATUS_ == 2))[0]:
        r_M, rho = ccm.measures(INFO[b, 0], INFO[b, 2:], u0, P[b])
        if rho < r_M:
            STATUS_[b] = Status.SINGULAR_CONSTRAINTS
