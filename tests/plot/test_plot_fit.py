"""FitResult.plot(): one panel per measured column (data, fit) and its residuals below."""

from __future__ import annotations

import numpy as np
import pytest

import lagrangian as lg

pytest.importorskip("matplotlib", reason="the figure needs Matplotlib")


def test_plot_of_a_fit_with_two_experiments():
    import matplotlib

    matplotlib.use("Agg")
    eqs = lg.derive(lg.Model("msd", coordinates=["x"], parameters={"m": 1.0, "k": 4.0, "c": 0.2},
                             T="m*x_dot**2/2", V="k*x**2/2", D="c*x_dot**2/2"))
    data = []
    for i, x0 in enumerate((0.1, -0.2)):
        tr = lg.simulate(eqs, 3.0, initial={"x": x0}, dt=0.05, rtol=1e-10, atol=1e-10)
        data.append({"t": tr.t, "x": tr["x"] + 1e-3 * np.random.default_rng(i).standard_normal(len(tr.t)),
                     "x_dot": tr["x_dot"]})
    r = lg.fit(eqs, data, ["k", "c"], guess={"k": 3.0, "c": 0.5}, noise={"x": 1e-3, "x_dot": 1e-3})
    fig = r.plot()
    axes = fig.axes
    assert len(axes) == 4  # two columns (x, x_dot), values and residuals
    assert axes[0].get_title() == "x" and axes[1].get_title() == "x_dot"
    line = axes[0].lines[1]  # the first experiment's fitted x
    np.testing.assert_allclose(line.get_ydata(), r.fitted[0]["x"])
    np.testing.assert_allclose(axes[2].lines[0].get_ydata(), r.residuals[0]["x"])
    assert "k = " in fig._suptitle.get_text()
    matplotlib.pyplot.close(fig)
