"""magcilia: magnetic cilia force and flow sensors.

Field models (the paper's distributed dipoles and an exact reference), the AMR sensor, calibration,
sensitivity analysis, firmware approximations, large-deflection bending and read-out. SI units in
the whole API (m, rad, T, V, A/m, A·m², N, Pa).
"""

from __future__ import annotations

from magcilia._errors import MagciliaError, MissingDependencyError
from magcilia.centreline import Centreline
from magcilia.config import load_setup, save_setup
from magcilia.geometry import Cilium
from magcilia.material import Material
from magcilia.reference import exact_field
from magcilia.sensor import Sensor
from magcilia.setup import Setup

__version__ = "0.1.0"

__all__ = [
    "Centreline",
    "Cilium",
    "MagciliaError",
    "Material",
    "MissingDependencyError",
    "Sensor",
    "Setup",
    "__version__",
    "exact_field",
    "load_setup",
    "save_setup",
]

# --- issue 3: calibration ---
from magcilia.calibration import CalibrationResult, ParameterCovariance, calibrate
from magcilia.measurements import Measurement, read_measurements

__all__ += ["CalibrationResult", "Measurement", "ParameterCovariance", "calibrate", "read_measurements"]

# --- issue 4: sensitivity and approximations (helper-owned block) ---
from magcilia.approximation import LookupTable, PiecewiseLinear, lookup_table, piecewise_linear
from magcilia.firmware import to_c_header
from magcilia.sensitivity import (
    OATResult,
    SensitivityStudy,
    SobolResult,
    oat_sweep,
    placement_map,
    sensitivity_study,
    sobol_indices,
)
from magcilia.tolerance import PlacementTolerance, placement_tolerance

__all__ += [
    "LookupTable", "OATResult", "PiecewiseLinear", "PlacementTolerance", "SensitivityStudy",
    "SobolResult", "lookup_table", "oat_sweep", "piecewise_linear", "placement_map",
    "placement_tolerance", "sensitivity_study", "sobol_indices", "to_c_header",
]

# --- issue 5: mechanics and read-out (helper-owned block) ---
from magcilia.design import DesignMetrics, design_metrics
from magcilia.mechanics import (
    AIR,
    WATER,
    BentShape,
    Flow,
    Fluid,
    bend,
    bend_sweep,
    drag_coefficient,
)
from magcilia.readout import Readout, ReadoutFlag, ReadoutResult

__all__ += [
    "AIR", "WATER", "BentShape", "DesignMetrics", "Flow", "Fluid", "Readout", "ReadoutFlag",
    "ReadoutResult", "bend", "bend_sweep", "design_metrics", "drag_coefficient",
]
