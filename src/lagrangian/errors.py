"""The exceptions of `lagrangian`.

Every error a user can hit derives from :class:`LagrangianError`. Errors about the
user's input also derive from :class:`ValueError`, so ``except ValueError`` keeps working.
A message says what is wrong, where (file, key, symbol), what was expected and how to fix it.
"""

from __future__ import annotations

import enum
from dataclasses import dataclass
from typing import Sequence

__all__ = [
    "LagrangianError",
    "ModelError",
    "ModelFileError",
    "Problem",
    "ExpressionError",
    "UnknownNameError",
    "SingularMassMatrixError",
    "SimulationError",
    "Status",
    "OutputFileError",
    "DesignError",
]


class LagrangianError(Exception):
    """Base class of every error raised by `lagrangian`."""


@dataclass(frozen=True)
class Problem:
    """One problem found while checking a model or a model file.

    Attributes
    ----------
    message : str
        What is wrong and how to fix it.
    key : str or None
        Where: the model-file key (``"energy.T"``, ``"particles[0].mass"``) or the
        name of the element or symbol concerned.
    line : int or None
        Line of the model file, when known.
    """

    message: str
    key: str | None = None
    line: int | None = None

    def format(self, file: str | None = None) -> str:
        where = []
        if file:
            where.append(f"{file}" + (f":{self.line}" if self.line else ""))
        if self.key:
            where.append(f"[{self.key}]")
        prefix = " ".join(where)
        return f"{prefix}: {self.message}" if prefix else self.message


class ModelError(LagrangianError, ValueError):
    """A model is invalid. Holds every problem found, not only the first.

    Attributes
    ----------
    problems : tuple of Problem
    """

    def __init__(self, problems: Sequence[Problem] | str, *, file: str | None = None):
        if isinstance(problems, str):
            problems = (Problem(problems),)
        self.problems = tuple(problems)
        self.file = file
        super().__init__(self._render())

    def _render(self) -> str:
        lines = [p.format(self.file) for p in self.problems]
        if len(lines) == 1:
            return lines[0]
        head = f"{len(lines)} problems" + (f" in {self.file}" if self.file else "") + ":"
        return "\n".join([head] + [f"  - {line}" for line in lines])


class ModelFileError(ModelError):
    """A model file is invalid: every problem carries the file, the key and the line."""


class ExpressionError(LagrangianError, ValueError):
    """An expression string could not be parsed.

    Attributes
    ----------
    text : str
        The expression.
    position : int or None
        0-based character offset of the problem in `text`, when it has one.
    reason : str
        What is wrong and how to fix it (without the expression itself).
    """

    def __init__(self, text: str, reason: str, position: int | None = None):
        self.text = text
        self.reason = reason
        self.position = position
        msg = reason
        if position is not None:
            msg = f"{reason} at position {position + 1}:\n    {text}\n    {' ' * position}^"
        super().__init__(msg)


class UnknownNameError(ExpressionError):
    """An expression uses names that are not defined.

    Attributes
    ----------
    unknown : tuple of (name, position, suggestion)
        Each unknown name, its 0-based offset in the text and the closest known
        name (or None).
    """

    def __init__(self, text: str, unknown):
        self.unknown = tuple(unknown)
        parts = []
        for name, _pos, suggestion in self.unknown:
            hint = f" (did you mean '{suggestion}'?)" if suggestion else ""
            parts.append(f"'{name}'{hint}")
        reason = ("unknown name " if len(parts) == 1 else "unknown names ") + ", ".join(parts)
        super().__init__(text, reason, self.unknown[0][1] if self.unknown else None)


class SingularMassMatrixError(LagrangianError, ArithmeticError):
    """The mass matrix is singular where the equations must be solved for q_ddot.

    Attributes
    ----------
    time : float or None
        The simulation time at which it happened, when raised by a simulation.
    state : dict or None
        The state {name: value} there.
    diagnosis : str
        Where det M vanishes, the velocity combination with no inertia, the likely
        cause and a fix.
    partial : Trajectory or None
        In a simulation, the output rows computed before it stopped (marked as partial:
        ``partial.failure`` holds this message); None when there are none.
    """

    def __init__(self, message: str, *, time: float | None = None,
                 state: dict[str, float] | None = None, diagnosis: str = "", partial=None):
        self.time = time
        self.state = state
        self.diagnosis = diagnosis
        self.partial = partial
        super().__init__(message)


class Status(enum.IntEnum):
    """How a simulation ended: the one enumeration of the integrators' status codes (the compiled
    kernels return these integers, SciPy's solve_ivp its own 0, 1 and -1, read as these members).

    A member is an int (``status == -1`` holds for STEP_TOO_SMALL) and carries its ``message``
    (what happened, as the integrator says it) and its ``fix`` (what to do about it; "" for a run
    that ended as asked). :class:`SimulationError`, ``BatchResult.statuses`` and
    ``Trajectory.stats["status"]`` hold members.
    """

    def __new__(cls, value: int, message: str, fix: str):
        member = int.__new__(cls, value)
        member._value_ = value
        member.message = message
        member.fix = fix
        return member

    SUCCESS = (0, "The solver successfully reached the end of the integration interval.", "")
    SINGULAR_EVENT = (1, "A termination event occurred.",
                      "the mass matrix became singular: see the error's diagnosis (where det M vanishes and why)")
    SINGULAR_MASS_MATRIX = (2, "The mass matrix is singular at a stage of a step.",
                            ("the mass matrix is singular there: see the error's diagnosis (where det M vanishes "
                             "and why)"))
    FORCING_NOT_FINITE = (3, "The forcing f is not finite.",
                          ("check the model's parameters and expressions (a division by zero, a log or sqrt of a "
                           "negative number)"))
    STEP_TOO_SMALL = (-1, "Required step size is less than spacing between numbers.",
                      ("try a smaller rtol/atol, a stiff method such as method='Radau', or check the model's "
                       "parameters"))
    SOLUTION_NOT_FINITE = (-2, "The solution is not finite (NaN or infinity).",
                           "check the model's parameters and initial state")
    VARIATIONAL_NOT_CONVERGED = (-3, "The implicit midpoint step of the variational integrator did not converge.",
                                 "try a smaller step")
    EVENT_STOP = (4, "An event stopped the integration.", "")
    CHATTERING = (5, "The inputs switch at every step (chattering: a sliding mode).",
                  ("smooth the switch with a boundary layer, e.g. clip(s/0.01, -1, 1) instead of sign(s), or "
                   "sample the law (sample_time=...)"))
    SINGULAR_CONSTRAINTS = (6, "The constraints are singular (their Jacobian G has lost rank: a dead point).",
                            "see the error's message: where G loses rank, and which coordinates to drive instead")
    PROJECTION_SINGULAR = (7, ("The projection onto the constraints met a singular system (the Jacobian of the "
                               "constraints lost rank, or M is singular, where a step ended or at an output)."),
                           ("see the error's message: where G loses rank (a dead point: drive other coordinates "
                            "or start away from it), or try a smaller rtol/atol"))
    PROJECTION_NOT_FINITE = (8, ("The projection onto the constraints met values that are not finite (NaN or "
                                 "infinity in the constraints g, their Jacobian G, M or the projected state)."),
                             ("check the model's parameters, its constraints' expressions (a division by zero, a "
                              "log or sqrt of a negative number) and the initial state"))

    @property
    def ok(self) -> bool:
        """Whether the run ended as asked: at t_end, or stopped by one of its events."""
        return self in (Status.SUCCESS, Status.EVENT_STOP)

    @classmethod
    def of(cls, code) -> Status | int:
        """The member of an integer status code; the integer itself when no member has it."""
        try:
            return cls(int(code))
        except ValueError:
            return int(code)


class SimulationError(LagrangianError, RuntimeError):
    """The integrator failed. `status` is the member of :class:`Status` saying why (an int: the
    integrator's status code), `time` where it stopped, `partial` the Trajectory of the output rows
    computed before the failure (marked as partial: ``partial.failure`` holds this message), or None
    when there are none."""

    def __init__(self, message: str, *, status: int | None = None, time: float | None = None, partial=None):
        self.status = None if status is None else Status.of(status)
        self.time = time
        self.partial = partial
        super().__init__(message)


class DesignError(LagrangianError):
    """A controller cannot be designed for this linearization (an uncontrollable unstable mode, a
    Riccati equation without a stabilizing solution, poles that cannot be placed). Raised by
    :mod:`lagrangian.control`, which re-exports it."""


class OutputFileError(LagrangianError, ValueError):
    """An output cannot be written where it was asked, or writing it there would lose a file of the
    user's (a file an export did not write, a symbolic link, a folder, a device).

    Attributes
    ----------
    path : str
        The path given.
    """

    def __init__(self, message: str, *, path: str):
        self.path = path
        super().__init__(message)
