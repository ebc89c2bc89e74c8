"""Optimal motions by direct collocation (Hermite-Simpson on the implicit equations, IPOPT via CasADi).

``lagrangian.optimal_motion(equations, duration=2.0, objective="F**2", ...)`` returns an
:class:`OptimalMotion`, checked by replaying its input law with ``simulate``. CasADi is an extra:
``pip install 'lagrangian[optimal]'``.
"""

from ._problem import OptimalControlError, OptimalControlProblem
from ._result import OptimalMotion
from ._solve import optimal_motion

__all__ = ["optimal_motion", "OptimalMotion", "OptimalControlProblem", "OptimalControlError"]
