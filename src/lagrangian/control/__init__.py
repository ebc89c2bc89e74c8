"""Controllers designed on a linearization, and their laws as inputs for ``simulate``.

``LinearModel.lqr(Q, R)`` and ``LinearModel.place(poles)`` (or :func:`lqr` and :func:`place`)
return a :class:`StateFeedback`: the gain K with the state and input names, the closed-loop
eigenvalues, and the law u = u0 - K (x - x0) as an expression for each input, ready for
``simulate(..., inputs=fb.inputs)`` and ``--input``.
"""

from ._feedback import DesignError, StateFeedback, discretize, lqr, place

__all__ = ["StateFeedback", "DesignError", "lqr", "place", "discretize"]
