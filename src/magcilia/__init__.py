"""magcilia: magnetic cilia force and flow sensors.

Field models (the paper's distributed dipoles and an exact reference), the AMR sensor, calibration,
sensitivity analysis, firmware approximations, large-deflection bending and read-out. SI units in
the whole API (m, rad, T, V, A/m, A·m², N, Pa).

The public names are grouped below by topic; each comes from the room (subpackage) that holds it:
``model`` (the field model), ``device`` (what the sensor is), ``mechanics`` (bending), ``io``
(files), ``calibration``, ``analysis`` (sensitivity), ``approximation``, ``readout``.
"""

from __future__ import annotations

import logging
from typing import TYPE_CHECKING

from magcilia._errors import LayoutWarning, MagciliaError, MagciliaWarning, MissingDependencyError
from magcilia._lazy import attach
from magcilia._version import __version__

if TYPE_CHECKING:
    # -- sensitivity -----------------------------------------------------------------------------
    from magcilia.analysis import (
        OATResult,
        PlacementTolerance,
        SensitivityStudy,
        SobolResult,
        oat_sweep,
        placement_map,
        placement_tolerance,
        sensitivity_study,
        sobol_indices,
    )

    # -- ring-down: the modulus and damping ratio of a flicked cilium -----------------------------
    from magcilia.analysis.ringdown import ringdown
    from magcilia.analysis.ringdown_result import RingdownResult

    # -- firmware approximations -----------------------------------------------------------------
    from magcilia.approximation import LookupTable, PiecewiseLinear, lookup_table, piecewise_linear

    # -- many recordings at once, on one machine or a Dask cluster ---------------------------------
    from magcilia.batch import BatchResult, calibrate_batch

    # -- calibration -------------------------------------------------------------------------------
    from magcilia.calibration import CalibrationResult, ParameterCovariance, calibrate

    # -- design: metrics and optimisation ----------------------------------------------------------
    from magcilia.design import (
        CalibrationFreeError,
        CoilSelfTest,
        DesignMetrics,
        DesignOptimum,
        Metric,
        Tolerances,
        calibration_free_error,
        design_metrics,
        optimise_design,
    )

    # -- the device and its field --------------------------------------------------------------
    from magcilia.device import (
        MAGNETOMETERS,
        Actuation,
        CiliaArray,
        Cilium,
        Magnetometer,
        Material,
        Modulus,
        Sensor,
        SensorCheck,
        SensorFlag,
        Setup,
        TemperatureModel,
        TemperatureProfile,
    )

    # -- files -----------------------------------------------------------------------------------
    from magcilia.io import (
        Measurement,
        export,
        load_array,
        load_setup,
        presets,
        read_measurements,
        save_array,
        save_setup,
        to_c_header,
    )

    # -- bending -----------------------------------------------------------------------------------
    from magcilia.live import LiveReadout
    from magcilia.mechanics import (
        AIR,
        GLYCEROL,
        WATER,
        BentShape,
        Flow,
        Fluid,
        FrequencyResponse,
        Modes,
        SpatialBentShape,
        TransientResponse,
        bend,
        bend_sweep,
        drag_coefficient,
        frequency_response,
        modes,
        simulate_response,
    )
    from magcilia.model import Centreline, SpatialCentreline, exact_field

    # -- read-out ----------------------------------------------------------------------------------
    # (and arrays of cilia: CiliaArray above, their crosstalk, inverse and metrics)
    from magcilia.readout import (
        ActuatedReadout,
        ArrayEstimate,
        ArrayEstimates,
        ArrayFlag,
        ArrayMetrics,
        ArrayReadout,
        BiaxialReadout,
        Crosstalk,
        DynamicReadout,
        Flag,
        ForceFlag,
        ForceVectorResult,
        Readout,
        ReadoutFlag,
        ReadoutResult,
        Recalibration,
        Recalibrator,
        SensorReadout,
        Tare,
        ThermalReadout,
        ThermalResult,
        array_metrics,
        field_for_loads,
    )

__all__ = [
    "AIR",
    "GLYCEROL",
    "MAGNETOMETERS",
    "WATER",
    "ActuatedReadout",
    "Actuation",
    "ArrayEstimate",
    "ArrayEstimates",
    "ArrayFlag",
    "ArrayMetrics",
    "ArrayReadout",
    "BatchResult",
    "BentShape",
    "BiaxialReadout",
    "CalibrationFreeError",
    "CalibrationResult",
    "Centreline",
    "CiliaArray",
    "Cilium",
    "CoilSelfTest",
    "Crosstalk",
    "DesignMetrics",
    "DesignOptimum",
    "DynamicReadout",
    "Flag",
    "Flow",
    "Fluid",
    "ForceFlag",
    "ForceVectorResult",
    "FrequencyResponse",
    "LayoutWarning",
    "LiveReadout",
    "LookupTable",
    "MagciliaError",
    "MagciliaWarning",
    "Magnetometer",
    "Material",
    "Measurement",
    "Metric",
    "MissingDependencyError",
    "Modes",
    "Modulus",
    "OATResult",
    "ParameterCovariance",
    "PiecewiseLinear",
    "PlacementTolerance",
    "Readout",
    "ReadoutFlag",
    "ReadoutResult",
    "Recalibration",
    "Recalibrator",
    "RingdownResult",
    "SensitivityStudy",
    "Sensor",
    "SensorCheck",
    "SensorFlag",
    "SensorReadout",
    "Setup",
    "SobolResult",
    "SpatialBentShape",
    "SpatialCentreline",
    "Tare",
    "TemperatureModel",
    "TemperatureProfile",
    "ThermalReadout",
    "ThermalResult",
    "Tolerances",
    "TransientResponse",
    "__version__",
    "array_metrics",
    "bend",
    "bend_sweep",
    "calibrate",
    "calibrate_batch",
    "calibration_free_error",
    "design_metrics",
    "drag_coefficient",
    "exact_field",
    "export",
    "field_for_loads",
    "frequency_response",
    "load_array",
    "load_setup",
    "lookup_table",
    "modes",
    "oat_sweep",
    "optimise_design",
    "piecewise_linear",
    "placement_map",
    "placement_tolerance",
    "presets",
    "read_measurements",
    "ringdown",
    "save_array",
    "save_setup",
    "sensitivity_study",
    "simulate_response",
    "sobol_indices",
    "to_c_header",
]

# the library logs to "magcilia" (and its modules' child loggers) but never configures logging:
# the application does (the CLI's -v/-q); without one, nothing is printed
logging.getLogger("magcilia").addHandler(logging.NullHandler())

__getattr__, __dir__ = attach(__name__)
