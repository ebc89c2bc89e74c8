"""Figures of a trajectory: labelled axes (units where known) and data equal to the trajectory's."""

import subprocess
import sys

import matplotlib

matplotlib.use("Agg")

import numpy as np
import pytest

import lagrangian as lg
from lagrangian import plot


@pytest.fixture(scope="module")
def cart():
    return lg.simulate(lg.load("cart-pendulum"), t_end=1.0, dt=0.05)


@pytest.mark.slow
@pytest.mark.subprocess
def test_import_lagrangian_does_not_import_matplotlib():
    code = "import sys, lagrangian; tr = lagrangian.simulate(lagrangian.load('mck'), t_end=0.1); " \
           "print('matplotlib' in sys.modules)"
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, check=True)
    assert out.stdout.strip() == "False"


def test_time_history_labels_and_data(cart):
    fig = plot.time_history(cart)
    assert [ax.get_ylabel() for ax in fig.axes] == ["q1", "q2 [rad]"]
    assert fig.axes[-1].get_xlabel() == "t [s]"
    for ax, name in zip(fig.axes, ["q1", "q2"]):
        x, y = ax.lines[0].get_data()
        np.testing.assert_array_equal(x, cart.t)
        np.testing.assert_array_equal(y, cart[name])


def test_time_history_of_chosen_columns(cart):
    fig = cart.plot(["q2_dot", "F"])
    assert [ax.get_ylabel() for ax in fig.axes] == ["q2_dot [rad/s]", "F"]
    np.testing.assert_array_equal(fig.axes[0].lines[0].get_ydata(), cart["q2_dot"])


def test_unknown_column_is_named(cart):
    with pytest.raises(lg.ModelError, match="the trajectory has no column 'q3' to plot; its columns are q1, q2"):
        plot.time_history(cart, "q3")


def test_units_only_for_angles():
    assert plot.units(lg.load("sliding-mass-pendulum")) == {"t": "s", "q2": "rad", "q2_dot": "rad/s"}
    assert plot.units(lg.load("rotating-pendulum-energy"))["theta"] == "rad"
    assert plot.units(lg.load("mck")) == {"t": "s"}


def test_phase_portrait(cart):
    fig = cart.phase_portrait("q2")
    (ax,) = fig.axes
    assert (ax.get_xlabel(), ax.get_ylabel()) == ("q2 [rad]", "q2_dot [rad/s]")
    x, y = ax.lines[0].get_data()
    np.testing.assert_array_equal(x, cart["q2"])
    np.testing.assert_array_equal(y, cart["q2_dot"])
    assert len(plot.phase_portrait(cart).axes) == 2
    with pytest.raises(lg.ModelError,
                       match="'q2_dot' is not a coordinate of the trajectory; the coordinates are q1, q2"):
        plot.phase_portrait(cart, "q2_dot")


def test_energy_drift_is_energy_minus_initial():
    traj = lg.simulate(lg.load("double-pendulum"), t_end=1.0, dt=0.05)
    fig = plot.energy_drift(traj)
    (ax,) = fig.axes
    x, y = ax.lines[0].get_data()
    np.testing.assert_array_equal(x, traj.t)
    np.testing.assert_allclose(y, traj.energy - traj.energy[0])
    assert np.max(np.abs(y)) < 1e-6
    assert ax.get_ylabel() == "energy - energy(0)"
    assert "(conserved)" in ax.get_title()


def test_energy_drift_of_jacobi_integral():
    traj = lg.simulate(lg.load("rotating-pendulum"), t_end=0.5, dt=0.05)
    ax = plot.energy_drift(traj, relative=True).axes[0]
    assert ax.get_ylabel() == "(jacobi_integral - jacobi_integral(0)) / |jacobi_integral(0)|"


def test_energy_drift_needs_an_energy():
    m = lg.Model("driven", coordinates=["x"], parameters={"k": 1.0}, T="x_dot**2/2", V="k*(1 + t)*x**2/2")
    traj = lg.simulate(m, t_end=0.1, initial={"x": 0.1})
    assert traj.energy is None
    with pytest.raises(lg.ModelError,
                       match="the trajectory has no energy to plot: its Lagrangian depends explicitly on t"):
        plot.energy_drift(traj)


def test_rich_display():
    model = lg.load("cart-pendulum")
    html = model._repr_html_()
    assert "Model cart-pendulum" in html and "$q_{1}$" in html and "particle pendulum" in html
    eqs = lg.derive(model)
    assert eqs._repr_latex_().startswith("$$")
    lin = lg.derive(lg.load("mck")).linear
    assert lin._repr_latex_() == "$$" + lin.latex() + "$$"
    traj = lg.simulate(eqs, t_end=0.2)
    html = traj._repr_html_()
    assert "Trajectory of cart-pendulum" in html
    assert "samples</th><td style='text-align:left'>21</td>" in html
    assert "(not conserved)" in html  # the force input F may act
