"""Parameter identification: fit a model's parameters to measurements (multiple shooting, exact
sensitivities, Gauss-Newton / Levenberg-Marquardt), and say which parameters the data cannot decide."""

from ._data import Measurements, measurements, read_measurements
from ._fit import fit
from ._identifiability import Identifiability, identifiability, numeric_rank
from ._result import FitResult

__all__ = ["FitResult", "Identifiability", "Measurements", "fit", "identifiability", "measurements", "numeric_rank",
           "read_measurements"]
