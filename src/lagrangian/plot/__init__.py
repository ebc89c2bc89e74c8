"""Figures and animations (with Matplotlib, a dependency imported only when used).

``import lagrangian`` never imports this package; ``lagrangian.plot`` imports Matplotlib only
when a figure or an animation is made.

- :func:`time_history`, :func:`phase_portrait`, :func:`energy_drift`: figures of a Trajectory.
- :func:`animate`: the mechanism drawn from its model's geometry -> :class:`Animation`
  (``.save("out.gif" | "out.mp4" | "out.html")``, ``.to_html()``, inline in notebooks).
- :func:`scene_of`: the drawable geometry of a model (nodes, rods, springs, ...).
- :func:`bifurcation_diagram`: branches of a continuation.
"""

from ._animation import FORMATS, Animation, animate
from ._figures import energy_drift, phase_portrait, time_history, units
from ._geometry import Scene, scene_of

__all__ = ["time_history", "phase_portrait", "energy_drift", "animate", "Animation", "FORMATS", "Scene",
           "scene_of", "units", "bifurcation_diagram", "plot_fit"]


def __getattr__(name):
    if name == "bifurcation_diagram":
        from ._bifurcation import bifurcation_diagram

        return bifurcation_diagram
    if name == "plot_fit":
        from ._fit import plot_fit

        return plot_fit
    raise AttributeError(f"module 'lagrangian.plot' has no attribute '{name}'")
