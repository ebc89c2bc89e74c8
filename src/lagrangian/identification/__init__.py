"""Parameter identification: fit a model's parameters to measurements (multiple shooting, exact
sensitivities, Gauss-Newton / Levenberg-Marquardt), and say which parameters the data cannot decide."""

from ._identifiability import Identifiability, identifiability, numeric_rank

__all__ = ["Identifiability", "identifiability", "numeric_rank"]
