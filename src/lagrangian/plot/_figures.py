"""Figures of a trajectory: time histories, phase portraits, the drift of the energy.

Every function returns the Matplotlib figure, for further styling or saving.
"""

from __future__ import annotations

from typing import Sequence

import numpy as np
import sympy

from .._codetext import plot_text
from ..errors import ModelError

__all__ = ["time_history", "phase_portrait", "energy_drift", "units", "pyplot", "matplotlib_module"]

_TRIG = (sympy.sin, sympy.cos, sympy.tan, sympy.cot, sympy.sec, sympy.csc)


#: Matplotlib is a dependency of lagrangian; this says what to do where it is missing all the same.
MISSING_MATPLOTLIB = ("plots and animations need Matplotlib, a dependency of lagrangian that is missing from this "
                      "Python environment: install it with `python -m pip install matplotlib`, or reinstall "
                      "lagrangian (`python -m pip install -e .` in a clone)")


def matplotlib_module(name: str = "matplotlib"):
    """Import a Matplotlib module, or raise an ImportError that says how to install Matplotlib."""
    import importlib

    try:
        return importlib.import_module(name)
    except ImportError as exc:
        raise ImportError(MISSING_MATPLOTLIB) from exc


def pyplot():
    """matplotlib.pyplot, or an ImportError that says how to install it."""
    return matplotlib_module("matplotlib.pyplot")


def _only_in_trig(expr, q) -> bool:
    """Whether every occurrence of the symbol `q` in `expr` is inside a trigonometric function."""
    if expr == q:
        return False
    if isinstance(expr, _TRIG):
        return True
    return all(_only_in_trig(a, q) for a in expr.args)


def units(model) -> dict[str, str]:
    """Units known from the model's structure: a coordinate that enters the model only through
    trigonometric functions is an angle (rad, its velocity rad/s), time is in s. Nothing else is
    guessed (parameters carry no units)."""
    out = {"t": "s"}
    if model is None:
        return out
    exprs = [model.T, model.V, model.D, *model.Q.values()]
    for e in model.elements:
        exprs += list(e.expressions().values())
    for q in model.q:
        uses = [e for e in exprs if q in e.free_symbols]
        if uses and all(_only_in_trig(e, q) for e in uses):
            out[q.name] = "rad"
            out[q.name + "_dot"] = "rad/s"
    return out


def _label(name: str, unit: dict) -> str:
    return f"{name} [{unit[name]}]" if name in unit else name


def _check_names(traj, names, what="a column") -> list[str]:
    names = [names] if isinstance(names, str) else list(names)
    bad = [n for n in names if n not in traj.columns or n == "t"]
    if bad:
        raise ModelError(f"the trajectory has no column '{bad[0]}' to plot; its columns are "
                         f"{', '.join(c for c in traj.columns if c != 't')}")
    return names


def time_history(traj, names: Sequence[str] | str | None = None, *, figsize=None, sharex: bool = True):
    """Each named column of `traj` against time, one panel each, with labelled axes.

    Parameters
    ----------
    traj : Trajectory
    names : str or sequence of str, optional
        Columns to plot (coordinates, velocities, inputs, the energy); default: the coordinates.
    figsize : (float, float), optional

    Returns
    -------
    matplotlib.figure.Figure
        One axes per name, in order (``fig.axes``).
    """
    plt = pyplot()
    names = _check_names(traj, traj.state_names[: traj.n] if names is None else names)
    unit = units(traj.model)
    fig, axes = plt.subplots(len(names), 1, sharex=sharex, squeeze=False,
                             figsize=figsize or (6.4, 1.2 + 1.6 * len(names)), layout="constrained")
    for ax, name in zip(axes[:, 0], names):
        ax.plot(traj.t, traj[name], label=name)
        ax.set_ylabel(_label(name, unit))
        ax.grid(True, alpha=0.3)
    axes[-1, 0].set_xlabel(_label("t", unit))
    if traj.model is not None:
        fig.suptitle(plot_text(traj.model.name))
    return fig


def phase_portrait(traj, q: Sequence[str] | str | None = None, *, figsize=None):
    """The phase portrait (q, q_dot) of each named coordinate, with the start marked.

    Parameters
    ----------
    traj : Trajectory
    q : str or sequence of str, optional
        Coordinates (default: all of them).

    Returns
    -------
    matplotlib.figure.Figure
        One axes per coordinate.
    """
    plt = pyplot()
    coords = list(traj.state_names[: traj.n])
    q = coords if q is None else ([q] if isinstance(q, str) else list(q))
    for name in q:
        if name not in coords:
            raise ModelError(f"phase_portrait: '{name}' is not a coordinate of the trajectory; "
                             f"the coordinates are {', '.join(coords)}")
    unit = units(traj.model)
    fig, axes = plt.subplots(1, len(q), squeeze=False, figsize=figsize or (4.2 * len(q), 4.0),
                             layout="constrained")
    for ax, name in zip(axes[0], q):
        ax.plot(traj[name], traj[name + "_dot"], lw=1)
        ax.plot(traj[name][:1], traj[name + "_dot"][:1], "o", color="C3", label="start")
        ax.set_xlabel(_label(name, unit))
        ax.set_ylabel(_label(name + "_dot", unit))
        ax.grid(True, alpha=0.3)
        ax.legend(loc="best", fontsize="small")
    if traj.model is not None:
        fig.suptitle(plot_text(traj.model.name))
    return fig


def energy_drift(traj, *, relative: bool = False, figsize=None):
    """E(t) - E(0) of the energy (or the Jacobi integral), which stays at zero for a conservative system.

    Parameters
    ----------
    traj : Trajectory
    relative : bool
        Plot (E - E(0)) / |E(0)| instead (when E(0) != 0).

    Returns
    -------
    matplotlib.figure.Figure
    """
    if traj.energy is None:
        raise ModelError("the trajectory has no energy to plot: its Lagrangian depends explicitly on t, so "
                         "neither the energy nor the Jacobi integral is defined as a conserved quantity")
    plt = pyplot()
    unit = units(traj.model)
    E = traj.energy
    drift = E - E[0]
    label = f"{traj.energy_name} - {traj.energy_name}(0)"
    if relative:
        if E[0] == 0:
            raise ModelError(f"relative drift: {traj.energy_name}(0) is 0; use relative=False")
        drift = drift / abs(E[0])
        label = f"({label}) / |{traj.energy_name}(0)|"
    fig, ax = plt.subplots(figsize=figsize or (6.4, 3.2), layout="constrained")
    ax.plot(traj.t, drift)
    ax.set_xlabel(_label("t", unit))
    ax.set_ylabel(label)
    ax.grid(True, alpha=0.3)
    kind = "conserved" if traj.conservative else "not conserved (D, Q or inputs act)"
    ax.set_title(plot_text(f"{traj.model.name + ': ' if traj.model is not None else ''}"
                           f"{traj.energy_name.replace('_', ' ')} ({kind}); max |drift| = {np.max(np.abs(drift)):.2e}"),
                 fontsize="medium")
    return fig
