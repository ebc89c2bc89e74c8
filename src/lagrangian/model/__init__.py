"""Models: coordinates, parameters, inputs, elements and energies."""

from ._elements import (Contribution, Damper, Element, Force, Gravity, Particle, Point, RigidBody,
                        Spring, Torque)
from ._model import Model
from ._symbols import FUNCTION_NAMES, RESERVED_NAMES, ddot, dot, t

__all__ = ["Model", "Element", "Particle", "RigidBody", "Point", "Spring", "Damper", "Gravity",
           "Force", "Torque", "Contribution", "dot", "ddot", "t", "FUNCTION_NAMES", "RESERVED_NAMES"]
