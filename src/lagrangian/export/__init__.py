"""The model, taken elsewhere: an FMI 2.0 FMU (Model Exchange and Co-Simulation), a self-contained
Modelica model, and C99 source. Each writer works from the same Equations (and the same generated
C code as lagrangian.numeric's C backend for the FMU and the C sources)."""

from ._c import export_c
from ._common import ExportResult
from ._fmu import export_fmu
from ._modelica import export_modelica

__all__ = ["export_fmu", "export_modelica", "export_c", "ExportResult"]
