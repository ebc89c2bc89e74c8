"""The solvers of :func:`lagrangian.simulate`: each integrator as an object that says what it supports.

``simulate(method=...)`` takes one of these objects, or its name as a shortcut ("DOP853",
"variational", "RK45", "RK23", "Radau", "BDF", "LSODA"). A solver's :meth:`Solver.problems` is the
one place a simulation is refused for what its integrator cannot do (events, sampled inputs,
Python functions as inputs, output times, constraints), each refusal with its fix.

============  ========  =====  ======  =======  ===========  ======  ===========
solver        compiled  SciPy  events  sampled  constraints  t_eval  Python u(t)
============  ========  =====  ======  =======  ===========  ======  ===========
DOP853        yes       yes    yes*    yes      yes          yes     yes (SciPy)
Variational   yes       no     no      no       no           no      no
SciPyMethod   no        yes    no      yes      yes          yes     yes
============  ========  =====  ======  =======  ===========  ======  ===========

(*) events are watched by the compiled DOP853.
"""

from __future__ import annotations

import numbers
from dataclasses import dataclass

from .._limits import number_problem
from .._util import did_you_mean
from ..errors import Problem

__all__ = ["DOP853", "METHODS", "SciPyMethod", "Solver", "Variational", "solver_of"]

#: The names ``method`` accepts: DOP853 (compiled by default, or SciPy's), SciPy's other solve_ivp
#: methods, and "variational" (the compiled midpoint variational integrator, fixed step).
METHODS = ("DOP853", "RK45", "RK23", "Radau", "BDF", "LSODA", "variational")
SCIPY_METHODS = ("DOP853", "RK45", "RK23", "Radau", "BDF", "LSODA")
#: The methods by their names in capitals (a name is read in any case).
_BY_UPPER = {m.upper(): m for m in METHODS}


@dataclass(frozen=True)
class Solver:
    """An integrator and what it supports.

    Attributes
    ----------
    name : str
        Its name, as ``method=`` takes it and ``Trajectory.stats["method"]`` says it.
    compiled : bool
        Runs in compiled code (numba or C), no Python call per step.
    scipy : bool
        Runs on SciPy's ``solve_ivp`` (the portable path; Python functions as inputs need it).
    events : bool
        Watches event functions (``events=``, ``stop_on=``).
    sampled_inputs : bool
        Holds sampled inputs (``sample_time=``).
    constraints : bool
        Integrates models with constraints (projected onto them after every step).
    t_eval : bool
        Outputs at arbitrary times (``t_eval=``), not only every dt.
    """

    name: str = "DOP853"
    compiled: bool = True
    scipy: bool = True
    events: bool = True
    sampled_inputs: bool = True
    constraints: bool = True
    t_eval: bool = True

    @property
    def callable_inputs(self) -> bool:
        """Takes inputs given as Python functions u(t) or u(t, x): only on SciPy's path."""
        return self.scipy

    def problems(self, *, backend: str, sample_time=None, t_eval=None, callable_inputs: bool = False,
                 velocity_dependent_mass: bool = False, events: bool = False) -> list[Problem]:
        """What this solver cannot do of what is asked, each with its fix (nothing when it can)."""
        out = []
        if not self.scipy and backend == "scipy":
            out.append(Problem(f"method '{self.name}' runs in compiled code only: use backend='auto' or "
                               "'numba' (--backend numba), or a SciPy method with backend='scipy'", key="backend"))
        if sample_time is not None and not self.sampled_inputs:
            out.append(Problem(f"method '{self.name}' does not sample inputs: use method='DOP853' with "
                               "sample_time", key="sample_time"))
        if t_eval is not None and not self.t_eval:
            out.append(Problem(f"method '{self.name}' outputs every dt: pass dt=... (--dt) instead of t_eval",
                               key="t_eval"))
        if callable_inputs and not self.callable_inputs:
            out.append(Problem(f"method '{self.name}' runs in compiled code, which cannot call a Python "
                               "function: give each input as an expression string such as '1.5*sin(3*t)'",
                               key="inputs"))
        if events and not self.events:
            out.append(Problem(f"events are watched by the compiled DOP853 only, not by method '{self.name}'",
                               key="events"))
        return out


@dataclass(frozen=True)
class DOP853(Solver):
    """Dormand and Prince's explicit Runge-Kutta method of order 8 (Hairer's DOP853) with error
    control, dense output, events and sampled inputs: compiled by default, or SciPy's."""


@dataclass(frozen=True)
class Variational(Solver):
    """The midpoint variational (symplectic) integrator: a fixed step (`step`, made to divide dt;
    default: dt divided into steps of at most 1e-3), an energy error that stays bounded over long
    runs of a conservative model. Compiled only; needs T* quadratic in the velocities."""

    name: str = "variational"
    scipy: bool = False
    events: bool = False
    sampled_inputs: bool = False
    constraints: bool = False
    t_eval: bool = False
    step: float | None = None

    def problems(self, *, velocity_dependent_mass: bool = False, **asked) -> list[Problem]:
        out = super().problems(**asked)
        if self.step is not None and number_problem(self.step, "step", positive=True):
            out.append(Problem(number_problem(self.step, "step", positive=True) + " (Variational(step=...): the fixed "
                               "step in seconds)", key="step"))
        if velocity_dependent_mass:
            out.append(Problem(f"method '{self.name}' needs T* quadratic in the velocities (M free of q_dot); "
                               "use method='DOP853'", key="method"))
        return out

    def steps(self, dt: float) -> int:
        """The fixed steps in each output interval dt."""
        import math

        return max(1, math.ceil(dt / (self.step if self.step is not None else min(dt, 1e-3)) - 1e-9))


@dataclass(frozen=True)
class SciPyMethod(Solver):
    """One of SciPy's ``solve_ivp`` methods by name (RK45, RK23, Radau, BDF, LSODA, DOP853): always
    on SciPy, events not watched."""

    name: str = "Radau"
    compiled: bool = False
    events: bool = False

    def problems(self, **asked) -> list[Problem]:
        out = super().problems(**asked)
        if self.name not in SCIPY_METHODS:
            out.append(Problem(f"SciPyMethod('{self.name}') is not one of SciPy's solve_ivp methods"
                               f"{did_you_mean(str(self.name), SCIPY_METHODS, 0.5)}; choose one of "
                               f"{', '.join(SCIPY_METHODS)}", key="method"))
        return out


def solver_of(method, step=None, problems: list[Problem] | None = None) -> Solver | None:
    """The solver object of ``method``: a Solver as it is, or a name of METHODS (any case); `step`
    is the fixed step of "variational". An unknown name is a problem (None is returned)."""
    if isinstance(method, Solver):
        if step is not None and isinstance(method, Variational) and method.step is None:
            return Variational(step=step)
        return method
    name = _BY_UPPER.get(str(method).upper(), method)
    if name == "DOP853":
        return DOP853()
    if name == "variational":
        return Variational(step=step if isinstance(step, numbers.Real) else None)
    if name in SCIPY_METHODS:
        return SciPyMethod(name)
    if problems is not None:
        problems.append(Problem(f"unknown method '{name}'{did_you_mean(str(name), METHODS, 0.5)}; "
                                f"choose one of {', '.join(METHODS)}", key="method"))
    return None
