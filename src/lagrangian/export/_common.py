"""What the writers share: the equations of the system, the model's C identifier, the
parameter and start values, and the result object."""

from __future__ import annotations

import math
import numbers
import re
from dataclasses import dataclass
from typing import Mapping

from ..equations import Equations, derive
from ..errors import ModelError, Problem
from ..model import Model

__all__ = ["ExportResult", "equations_of", "identifier", "parameter_values", "start_state", "energy_name"]


@dataclass(frozen=True)
class ExportResult:
    """What an export wrote.

    Attributes
    ----------
    files : tuple of str
        The files written (for an FMU: the .fmu archive).
    binary : str or None
        The FMI platform whose binary an FMU carries ("linux64", "darwin64", "win64"), or None
        for a sources-only FMU (and for the other exports).
    warnings : tuple of str
        What the user should know (a sources-only FMU: why, and how to build the binary).
    """

    files: tuple[str, ...]
    binary: str | None = None
    warnings: tuple[str, ...] = ()


def equations_of(system) -> Equations:
    """The Equations of a Model, an Equations object, or a built-in example's name or a model file."""
    if isinstance(system, Equations):
        return system
    if isinstance(system, Model):
        return derive(system)
    if isinstance(system, str):
        from ..io import load

        return derive(load(system))
    raise TypeError(f"export expects a Model, Equations or a model name, got {type(system).__name__}")


def identifier(name: str) -> str:
    """A C identifier from a model name: cart-pendulum -> cart_pendulum."""
    ident = re.sub(r"\W", "_", name, flags=re.ASCII).strip("_") or "model"
    if ident[0].isdigit():
        ident = "m_" + ident
    return ident


def parameter_values(eq: Equations, params: Mapping | None) -> list[float]:
    """The model's parameter values with `params` overriding them; every one must have a value."""
    from ..numeric._simulate import _closest

    given = {getattr(k, "name", k): v for k, v in (params or {}).items()}
    names = [p.name for p in eq.parameters]
    problems = []
    for name, value in given.items():
        if name not in names:
            problems.append(Problem(f"'{name}' is not a parameter of the model{_closest(name, names)}; its "
                                    f"parameters are {', '.join(names) or 'none'}", key=f"params.{name}"))
        elif not isinstance(value, numbers.Real) or isinstance(value, bool) or not math.isfinite(value):
            problems.append(Problem(f"the value of '{name}' must be a finite number, got {value!r}",
                                    key=f"params.{name}"))
    values = []
    for p, v in eq.parameters.items():
        v = given.get(p.name, v)
        if v is None:
            problems.append(Problem(f"parameter '{p.name}' has no value: an exported model needs one; give it in the "
                                    f"model or pass params={{'{p.name}': ...}} (--param {p.name}=...)",
                                    key=f"params.{p.name}"))
        values.append(float(v) if isinstance(v, numbers.Real) else math.nan)
    if problems:
        raise ModelError(problems)
    return values


def start_state(eq: Equations, initial: Mapping | None) -> list[float]:
    """The start values of x = [q, q_dot]: the model's [simulation] initial values with
    `initial` overriding them; others 0."""
    from ..numeric._simulate import _named_values

    problems: list[Problem] = []
    x0 = [0.0] * (2 * eq.n)
    for source in (eq.model.simulation.get("initial") or {}, initial or {}):
        for i, v in _named_values(source, eq.state_names, "a coordinate or velocity", "initial", problems).items():
            x0[i] = v
    if problems:
        raise ModelError(problems)
    return x0


def energy_name(eq: Equations) -> str:
    """"energy" when T* = T2 (h = T* + V), "jacobi_integral" otherwise; a name the model does not use."""
    from ..numeric._simulate import _is_natural

    name = "energy" if _is_natural(eq) else "jacobi_integral"
    taken = set(eq.state_names) | {u.name for u in eq.inputs} | {p.name for p in eq.parameters}
    while name in taken:
        name += "_"
    return name
