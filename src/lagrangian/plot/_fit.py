"""The figure of a fit: each measured column against the model's fitted values, and the residuals."""

from __future__ import annotations

import numpy as np

from .._codetext import plot_text
from ._figures import pyplot

__all__ = ["plot_fit"]


def plot_fit(result, *, ax=None):
    """Draw a :class:`~lagrangian.identification.FitResult`: one panel per measured column (the data
    as dots, the fitted model as a line, one colour per experiment), the residuals below it.

    Parameters
    ----------
    result : FitResult
    ax : array of matplotlib Axes, optional
        Two rows of axes (values, residuals) with one column per measured column; default a new figure.

    Returns
    -------
    matplotlib.figure.Figure
    """
    columns = list(dict.fromkeys(c for d in result.fitted for c in d))
    if ax is None:
        plt = pyplot()
        fig, ax = plt.subplots(2, len(columns), figsize=(4.5 * len(columns), 5), squeeze=False, sharex="col",
                               gridspec_kw={"height_ratios": (3, 1)})
    else:
        ax = np.reshape(np.asarray(ax), (2, len(columns)))
        fig = ax[0, 0].figure
    for j, col in enumerate(columns):
        for e, (data, fitted, resid) in enumerate(zip(result.data, result.fitted, result.residuals)):
            if col not in fitted:
                continue
            color = f"C{e % 10}"
            label = plot_text(data.source) if len(result.data) > 1 else None
            ax[0, j].plot(data.t, data.columns[col], ".", ms=2.5, color=color, alpha=0.6)
            ax[0, j].plot(data.t, fitted[col], "-", lw=1.2, color=color, label=label)
            ax[1, j].plot(data.t, resid[col], ".", ms=2, color=color)
        ax[0, j].set_title(plot_text(col))
        ax[1, j].axhline(0.0, color="0.5", lw=0.8)
        ax[1, j].set_xlabel("t [s]")
        if len(result.data) > 1:
            ax[0, j].legend(fontsize="small")
    ax[0, 0].set_ylabel("measured (dots), fitted (line)")
    ax[1, 0].set_ylabel("residual")
    fig.suptitle(plot_text(f"fit of {result.model_name}: " + ", ".join(
        f"{p} = {result.estimates[p]:.4g} ± {result.standard_errors[p]:.2g}" for p in result.parameters)),
        fontsize="medium")
    return fig
