"""What the writers share: the equations of the system, the model's C identifier, the
parameter and start values, and the result object."""

from __future__ import annotations

from dataclasses import dataclass
from pathlib import Path
from typing import Mapping

from .._codetext import module_identifier
from ..equations import Equations, derive
from ..errors import ModelError, Problem
from ..model import Model

__all__ = ["ExportResult", "equations_of", "identifier", "parameter_values", "start_state", "energy_name",
           "output_file", "held_names", "consistent_start", "named_outputs"]


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
    """The Equations of a Model, an Equations object, or a built-in example's name or a model file
    (constrained models included: see :func:`start_state` and docs/export.md)."""
    return _equations(system)


def _equations(system) -> Equations:
    if isinstance(system, Equations):
        return system
    if isinstance(system, Model):
        return derive(system)
    if isinstance(system, str):
        from ..io import load

        return derive(load(system))
    raise TypeError(f"export expects a Model, Equations or a model name, got {type(system).__name__}")


def identifier(name: str) -> str:
    """A C identifier from a model name: cart-pendulum -> cart_pendulum (see
    lagrangian._codetext.module_identifier: never a reserved name such as main, math or fmu)."""
    return module_identifier(name, "c")


def parameter_values(eq: Equations, params: Mapping | None) -> list[float]:
    """The model's parameter values with `params` overriding them; every one must have a value."""
    from ..numeric._simulate import _named_values

    names = tuple(p.name for p in eq.parameters)
    problems: list[Problem] = []
    given = _named_values(params or {}, names, "a parameter of the model", "params", problems)
    values = [given.get(i, v) for i, v in enumerate(eq.parameters.values())]
    for name, v in zip(names, values):
        if v is None and f"params.{name}" not in {p.key for p in problems}:
            problems.append(Problem(f"parameter '{name}' has no value: an exported model needs one; give it in the "
                                    f"model or pass params={{'{name}': ...}} (--param {name}=...)",
                                    key=f"params.{name}"))
    if problems:
        raise ModelError(problems)
    return [float(v) for v in values]


def output_file(path, suffix: str, option: str, what: str) -> Path:
    """`path` as a Path, checked: its suffix, and a folder that exists."""
    path = Path(path)
    if path.suffix.lower() != suffix:
        raise ModelError(f"{option} {path}: {what} ends in {suffix} (for example {path.with_suffix(suffix)})")
    if path.is_dir() or not path.parent.resolve().is_dir():
        raise ModelError(f"{option} {path}: the folder {path.parent.resolve()} does not exist or the path is a folder; "
                         "give a file name in an existing folder")
    return path


def start_state(eq: Equations, initial: Mapping | None, params: Mapping | None = None) -> list[float]:
    """The start values of x = [q, q_dot]: the model's [simulation] initial values updated by
    `initial`, name by name (SimulationOptions.merged: simulate's rule); others 0. For a
    constrained model the state is then moved onto
    the constraints as :func:`lagrangian.simulate` moves its initial state (the same values held:
    the independent coordinates and speeds, and those given in `initial`; the others found by
    Newton from the model file's values), with the parameter values of `params`."""
    from ..numeric import SimulationOptions
    from ..numeric._simulate import _named_values

    problems: list[Problem] = []
    x0 = [0.0] * (2 * eq.n)
    merged = SimulationOptions.from_model(eq.model).merged(initial=initial).initial
    for i, v in _named_values(merged, eq.state_names, "a coordinate or velocity", "initial", problems).items():
        x0[i] = v
    if problems:
        raise ModelError(problems)
    if eq.is_constrained:
        x0 = [float(v) for v in consistent_start(eq, x0, initial or None, parameter_values(eq, params))]
    return x0


def held_names(eq: Equations) -> set[str]:
    """The coordinates and velocities that the model itself holds when its state is made
    consistent: [simulation] independent, and independent_speeds (default: the independent
    coordinates' velocities): SimulationOptions.held."""
    from ..numeric import SimulationOptions

    return set(SimulationOptions.from_model(eq.model).held)


def consistent_start(eq: Equations, x0, initial: Mapping | None, p) -> list[float]:
    """x0 moved onto the constraints by simulate's rule, with simulate's own function
    (numeric._simulate._consistent_guess): held are the independent coordinates and speeds and the
    names given in `initial`; without `initial`, the model file's given names."""
    import numpy as np

    from ..numeric import SimulationOptions
    from ..numeric._compiled import compile_equations
    from ..numeric._constrained import consistent_state, constrained_model
    from ..numeric._simulate import _consistent_guess

    cm = constrained_model(eq, compile_equations(eq))
    guess, fixed = _consistent_guess(eq, x0, initial or None, SimulationOptions.from_model(eq.model).initial)
    return list(consistent_state(cm, guess, fixed, np.array(p, float)))


def energy_name(eq: Equations) -> str:
    """"energy" when T* = T2 (h = T* + V), "jacobi_integral" otherwise; a name the model does not use."""
    name = "energy" if eq._natural else "jacobi_integral"  # Equations.energy_name, also where L depends on t
    taken = set(eq.state_names) | {u.name for u in eq.inputs} | {p.name for p in eq.parameters}
    while name in taken:
        name += "_"
    return name


def named_outputs(eq: Equations, taken=()) -> dict:
    """The model's named outputs (``[outputs]``, ``Model.add_output``) that an export carries after its
    other variables, in the order they were declared: name -> SymPy expression; {} without outputs.
    An output may not take the name of the exported energy (``energy_`` when a parameter is named
    ``energy``) or of another exported variable (`taken`): refused, with the fix."""
    outputs = dict(eq.model.outputs) if eq.model is not None else {}
    energy = energy_name(eq)
    base = "energy" if eq._natural else "jacobi_integral"
    used = {name: "another exported variable" for name in taken}
    used[energy] = f"the exported {base.replace('_', ' ')}, named '{energy}' since the model uses '{base}'"
    problems = [Problem(f"output '{name}': the export already has a variable of that name ({used[name]}); rename "
                        "the output", key=f"outputs.{name}") for name in outputs if name in used]
    if problems:
        raise ModelError(problems)
    return outputs
