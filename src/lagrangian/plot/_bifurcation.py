"""The bifurcation diagram of a continuation: equilibria against the parameter, stable branches
solid, unstable ones dashed (as in Preumont's Fig. 1.9(c)), critical values marked."""

from __future__ import annotations

import numpy as np
import sympy

from .._codetext import plot_text
from ..errors import ModelError
from ._figures import pyplot, units

__all__ = ["bifurcation_diagram"]


def bifurcation_diagram(continuation, coordinate: str | None = None, *, ax=None, color: str = "black"):
    """Draw the branches of a :class:`~lagrangian.analysis.Continuation`.

    Parameters
    ----------
    continuation : Continuation
    coordinate : str, optional
        The coordinate on the vertical axis (default: the first one that varies along some branch,
        or the first coordinate).
    ax : matplotlib Axes, optional
        Draw into these axes instead of a new figure.
    color : str
        Colour of the branches.

    Returns
    -------
    matplotlib.figure.Figure
    """
    names = continuation.coordinate_names
    if coordinate is None:
        varying = [c for c in names if any(np.ptp(b.coordinate(c)) > 0 for b in continuation.branches
                                             if len(b.points) > 1)]
        coordinate = (varying or list(names))[0]
    if coordinate not in names:
        raise ModelError(f"'{coordinate}' is not a coordinate of {continuation.equations.model.name}; "
                         f"choose one of {', '.join(names)}")
    plt = pyplot()
    if ax is None:
        fig, ax = plt.subplots(figsize=(6.4, 4.2))
    else:
        fig = ax.figure
    styles = {True: dict(linestyle="-", linewidth=2.0), False: dict(linestyle="--", linewidth=1.4)}
    labelled = set()
    for branch in continuation.branches:
        p, y, stable = branch.params, branch.coordinate(coordinate), branch.stable
        start = 0
        for k in range(1, len(p) + 1):
            if k == len(p) or stable[k] != stable[start]:
                # extend each run to the next point so that the line has no gap where stability changes
                stop = min(k + 1, len(p))
                s = bool(stable[start])
                label = ("stable" if s else "unstable") if s not in labelled else None
                labelled.add(s)
                if stop - start == 1:
                    ax.plot(p[start:stop], y[start:stop], "o" if s else "x", color=color, label=label,
                            markersize=3)
                else:
                    ax.plot(p[start:stop], y[start:stop], color=color, label=label, **styles[s])
                start = k
    for value, exact in zip(continuation.critical_values, continuation.critical_exact):
        ax.axvline(value, color="tab:red", linestyle=":", linewidth=1)
        text = f"${sympy.latex(exact)} = {value:.4g}$" if exact is not None else f"{value:.4g}"
        ax.annotate(text, (value, 0.0), xycoords=("data", "axes fraction"), xytext=(4, 6),
                    textcoords="offset points", color="tab:red", fontsize=9)
    unit = units(continuation.equations.model).get(coordinate)
    ax.set_xlabel(continuation.parameter)
    ax.set_ylabel(f"{coordinate} ({unit})" if unit else coordinate)
    ax.set_title(plot_text(f"Equilibria of {continuation.equations.model.name}"))
    ax.legend(loc="best", fontsize=9)
    return fig
