"""The floor's small helpers, shared by every layer (see tests/test_layers.py): the "did you mean"
of a misspelt name, read-only arrays for immutable results, and the check of values given by name
(parameters, inputs, initial values). It imports nothing of the package above errors and _limits."""

from __future__ import annotations

import difflib
import math
import numbers
from typing import Iterable, Mapping

import numpy as np
import sympy

from ._limits import value_problem
from .errors import Problem

__all__ = ["closest", "did_you_mean", "read_only", "real_number", "number_array", "named_values", "shown_value"]


def closest(name, candidates: Iterable[str], cutoff: float = 0.6) -> str | None:
    """The candidate closest to `name` (difflib's ratio at least `cutoff`), or None."""
    close = difflib.get_close_matches(str(name), list(candidates), n=1, cutoff=cutoff)
    return close[0] if close else None


def did_you_mean(name, candidates: Iterable[str], cutoff: float = 0.6, *, sentence: bool = False) -> str:
    """" (did you mean 'x'?)" for the candidate closest to `name`, or "" when none is close;
    `sentence` writes it as a sentence of its own, " Did you mean 'x'?"."""
    found = closest(name, candidates, cutoff)
    if found is None:
        return ""
    return f" Did you mean '{found}'?" if sentence else f" (did you mean '{found}'?)"


def read_only(a, dtype=None) -> np.ndarray:
    """A copy of `a` as a NumPy array (of `dtype`, when given) that cannot be written to: the arrays
    of the package's immutable results."""
    a = np.array(a, dtype=dtype)
    a.setflags(write=False)
    return a


def real_number(value) -> float | None:
    """`value` as a finite float when it is a real number (Python, NumPy or a SymPy number such as
    pi/2), else None."""
    if isinstance(value, bool):
        return None
    if isinstance(value, numbers.Real):
        value = float(value)
    elif isinstance(value, sympy.Basic) and value.is_number:
        try:
            value = float(value)
        except TypeError:
            return None
    else:
        return None
    return value if math.isfinite(value) else None


def number_array(value) -> np.ndarray | None:
    """`value` (a number, a sequence or an array of numbers) as a NumPy array of floats, or None where it is not
    numbers: text, bytes, a mapping, None, a ragged list, objects (NumPy's conversion would raise, or read text
    such as "1.5" as a number)."""
    if value is None or isinstance(value, (str, bytes, Mapping)):
        return None
    try:
        arr = np.asarray(value, dtype=float)
    except (TypeError, ValueError):
        return None
    return arr


def shown_value(value, limit: int = 40) -> str:
    """repr(value) on one line (runs of white space as one space), cut to `limit` characters for a message."""
    text = " ".join(repr(value).split())
    return text if len(text) <= limit else text[:limit - 3] + "..."


def named_values(values: Mapping | None, names: tuple[str, ...], what: str, key: str,
                 problems: list[Problem], derived: Mapping | None = None) -> dict[str, float]:
    """{name: value} of a mapping of names (or symbols) to real numbers, for names among `names`;
    every unknown name (with the closest one) and every value that is not a finite number within
    lagrangian._limits.MAX_MAGNITUDE becomes a Problem keyed `key`.name. `what` says what a name
    must be: "a parameter of the model". `derived`: the model's derived parameters (name ->
    expression), whose names are refused with what they are."""
    out: dict[str, float] = {}
    if values is None:
        return out
    if not isinstance(values, Mapping):
        example = f"{{'{names[0]}': 1.0}}" if names else "{}"
        problems.append(Problem(f"{key} must be a mapping of names to numbers, such as {example}, got "
                                f"{type(values).__name__} {shown_value(values)}; give the values by name", key=key))
        return out
    for name, value in values.items():
        name = str(getattr(name, "name", name))
        number = real_number(value)
        if name in (derived or {}) and name not in names:
            uses = ", ".join(sorted(str(s) for s in getattr(derived[name], "free_symbols", ()))) or "none"
            problems.append(Problem(f"'{name}' is a derived parameter, {name} = {derived[name]}: it follows the "
                                    f"parameters it uses ({uses}); give those instead", key=f"{key}.{name}"))
        elif name not in names:
            problems.append(Problem(f"'{name}' is not {what}{did_you_mean(name, names, 0.5)}; the choices are "
                                    f"{', '.join(names) or 'none'}", key=f"{key}.{name}"))
        elif (why := value_problem(name, value if number is None else number)) is not None:
            problems.append(Problem(why, key=f"{key}.{name}"))
        else:
            out[name] = number
    return out
