"""FitResult: what a fit found, how sure it is, and what the data cannot decide."""

from __future__ import annotations

import math
from dataclasses import dataclass, field

import numpy as np

from .._util import read_only

__all__ = ["FitResult"]


@dataclass(frozen=True, eq=False)
class FitResult:
    """The result of :func:`lagrangian.fit`.

    Attributes
    ----------
    parameters : tuple of str
        The fitted parameters (those the data determine), in the order asked.
    estimates, standard_errors : dict of str to float
        Each fitted parameter's estimate and standard error.
    intervals : dict of str to (float, float)
        The confidence interval of each, at level `confidence` (Student's t when the noise was
        estimated, the normal distribution when it was given).
    covariance, correlation : ndarray, shape (p, p)
        Of the fitted parameters, in `parameters` order.
    held : dict of str to float
        Parameters asked for that the data cannot determine (structurally or numerically): held at
        their guesses, NOT fitted; `held_reasons` says which, `combinations` what is determined.
    combinations : dict of str to (float, float)
        The combinations of parameters the equations determine (from the structural analysis), with
        their value and standard error at the estimates.
    identifiability
        The structural analysis (``identification._identifiability``), or None where unavailable.
    singular_values : ndarray
        Relative singular values of the sensitivity of the data to the fitted parameters (scaled by
        their magnitudes, the initial states projected out) at the estimates; `rank` counts those
        above 1e-7: the numeric confirmation.
    data, fitted, residuals : tuple, one item per experiment
        The measurements, the model's values of each measured column at the sample times, and
        measured minus fitted.
    noise : dict of str to float
        The standard deviation of each measured column: given, or estimated from the residuals.
    initial_states : tuple of dict
        Each experiment's initial state (estimated, or as given).
    cost : float
        Half the weighted sum of squared data residuals.
    iterations : int
        Evaluations of the residuals and Jacobian by the Gauss-Newton/LM engine.
    max_defect : float
        The largest continuity defect (or constraint residual) left between shooting intervals,
        relative to the states' ranges (0 at an exact solution).
    """

    parameters: tuple
    estimates: dict
    standard_errors: dict
    intervals: dict
    confidence: float
    covariance: np.ndarray = field(repr=False)
    correlation: np.ndarray = field(repr=False)
    held: dict = field(default_factory=dict)
    held_reasons: dict = field(default_factory=dict, repr=False)
    combinations: dict = field(default_factory=dict)
    identifiability: object = field(default=None, repr=False)
    identifiability_note: str = field(default="", repr=False)
    singular_values: np.ndarray = field(default=None, repr=False)
    rank: int = 0
    data: tuple = field(default=(), repr=False)
    fitted: tuple = field(default=(), repr=False)
    residuals: tuple = field(default=(), repr=False)
    noise: dict = field(default_factory=dict, repr=False)
    noise_estimated: bool = True
    initial_states: tuple = field(default=(), repr=False)
    cost: float = 0.0
    degrees_of_freedom: int = 0
    iterations: int = 0
    success: bool = True
    message: str = ""
    intervals_per_experiment: tuple = field(default=(), repr=False)
    substeps: int = 1
    max_defect: float = 0.0
    model_name: str = ""

    def __post_init__(self):
        object.__setattr__(self, "covariance", read_only(self.covariance, float))
        object.__setattr__(self, "correlation", read_only(self.correlation, float))
        object.__setattr__(self, "singular_values", read_only(self.singular_values, float))
        object.__setattr__(self, "fitted", tuple({k: read_only(v, float) for k, v in d.items()}
                                                 for d in self.fitted))
        object.__setattr__(self, "residuals", tuple({k: read_only(v, float) for k, v in d.items()}
                                                    for d in self.residuals))

    @property
    def not_identifiable(self) -> tuple[str, ...]:
        """The parameters asked for that were held, not fitted."""
        return tuple(self.held)

    def __getitem__(self, name: str) -> float:
        return self.estimates[name]

    def text(self) -> str:
        """The table the command line prints."""
        pct = f"{100 * self.confidence:g} %"
        lines = [f"fit of {self.model_name}: {len(self.data)} experiment(s), "
                 f"{sum(len(d.t) for d in self.data)} samples, {self.iterations} iterations "
                 f"({'converged' if self.success else 'NOT converged: ' + self.message})"]
        w = max([len(p) for p in self.parameters] + [9])
        lines.append(f"  {'parameter':<{w}}  {'estimate':>13}  {'std. error':>11}  {pct + ' interval':>30}")
        for p in self.parameters:
            lo, hi = self.intervals[p]
            lines.append(f"  {p:<{w}}  {self.estimates[p]:>13.6g}  {self.standard_errors[p]:>11.3g}  "
                         f"[{lo:>12.6g}, {hi:>12.6g}]")
        for p, v in self.held.items():
            lines.append(f"  {p:<{w}}  {'not fitted':>13}  held at {v:.6g}: not identifiable "
                         f"{self.held_reasons.get(p, '')}")
        for text, (v, s) in self.combinations.items():
            lines.append(f"  determined: {text} = {v:.6g} +- {s:.3g}")
        if len(self.parameters) > 1:
            big = [(a, b, self.correlation[i, j]) for i, a in enumerate(self.parameters)
                   for j, b in enumerate(self.parameters) if i < j and abs(self.correlation[i, j]) > 0.9]
            for a, b, r in big:
                lines.append(f"  strongly correlated: {a} and {b} (r = {r:+.3f})")
        noise = ", ".join(f"{k} {v:.3g}" for k, v in self.noise.items())
        lines.append(f"  noise ({'estimated' if self.noise_estimated else 'given'}): {noise}")
        lines.append(f"  rank of the sensitivity: {self.rank} of {len(self.parameters)}"
                     + (f"; {self.identifiability_note}" if self.identifiability_note else ""))
        return "\n".join(lines)

    def __str__(self) -> str:
        return self.text()

    def to_dict(self) -> dict:
        """JSON-ready: estimates, errors, intervals, correlation, what was held and why, the residuals' RMS."""
        def num(x):
            return float(x) if math.isfinite(x) else None

        return {
            "model": self.model_name,
            "parameters": {p: {"estimate": num(self.estimates[p]), "standard_error": num(self.standard_errors[p]),
                               "interval": [num(self.intervals[p][0]), num(self.intervals[p][1])]}
                           for p in self.parameters},
            "confidence": self.confidence,
            "correlation": [[num(v) for v in row] for row in self.correlation],
            "not_identifiable": {p: {"held_at": v, "reason": self.held_reasons.get(p, "")}
                                 for p, v in self.held.items()},
            "combinations": {k: {"value": num(v), "standard_error": num(s)} for k, (v, s) in self.combinations.items()},
            "rank": self.rank,
            "singular_values": [float(v) for v in self.singular_values],
            "noise": dict(self.noise),
            "noise_estimated": self.noise_estimated,
            "initial_states": [dict(d) for d in self.initial_states],
            "residual_rms": [{k: float(np.sqrt(np.mean(v ** 2))) for k, v in r.items()} for r in self.residuals],
            "cost": self.cost,
            "degrees_of_freedom": self.degrees_of_freedom,
            "iterations": self.iterations,
            "success": self.success,
            "message": self.message,
            "max_defect": self.max_defect,
            "experiments": [d.source for d in self.data],
        }

    def plot(self, ax=None):
        """The fitted columns against the measurements, one panel per column (Matplotlib)."""
        from ..plot import plot_fit

        return plot_fit(self, ax=ax)
