"""Models: coordinates, parameters, inputs, elements and energies."""

from ._constraints import Constraint
from ._elements import (Contribution, Damper, Element, Force, Gravity, Particle, Point, RigidBody,
                        RigidBody3D, Spring, Torque, Torque3D)
from ._frames import WORLD, Factor, Frame
from ._joints import quaternion_rates
from ._model import Model
from ._symbols import FUNCTION_NAMES, RESERVED_NAMES, ddot, dot, t

__all__ = ["Model", "Element", "Particle", "RigidBody", "RigidBody3D", "Point", "Spring", "Damper", "Gravity",
           "Force", "Torque", "Torque3D", "Contribution", "Constraint", "Frame", "Factor", "WORLD", "dot", "ddot", "t",
           "FUNCTION_NAMES", "RESERVED_NAMES", "quaternion_rates"]
