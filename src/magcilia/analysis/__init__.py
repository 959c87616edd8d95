"""Sensitivity analysis of the model (the paper's Sec. IV.C and beyond).

* :mod:`.measures`: RMS change, offset-free change and calibration cost of output curves;
* :mod:`.oat`: one parameter at a time (figs. 9–12), the x–y placement map, the whole study;
* :mod:`.sobol`: global Sobol indices (SALib) over the calibration bounds;
* :mod:`.tolerance`: how precisely the placement must be known for a target angle accuracy;
* :mod:`.identifiability_table`: what each rig-free calibration (coil, size, ring-down) and the
  paper's rig determine, from the Fisher information (docs/coil-calibration.md).
"""

from __future__ import annotations

from typing import TYPE_CHECKING

from magcilia._lazy import attach

if TYPE_CHECKING:
    from magcilia.analysis.identifiability_table import (
        IdentifiabilityTable,
        identifiability_table,
    )
    from magcilia.analysis.measures import (
        DEFAULT_ANGLES,
        MEASURES,
        check_angles,
        offset_cost,
        rms_change,
        shape_change,
    )
    from magcilia.analysis.oat import (
        STUDY_PARAMETERS,
        SWEEP_PARAMETERS,
        OATResult,
        PlacementMap,
        SensitivityStudy,
        default_spans,
        oat_sweep,
        placement_map,
        sensitivity_study,
    )
    from magcilia.analysis.sobol import SobolResult, sobol_analysis, sobol_indices
    from magcilia.analysis.tolerance import PlacementTolerance, placement_tolerance

__all__ = [
    "DEFAULT_ANGLES",
    "MEASURES",
    "STUDY_PARAMETERS",
    "SWEEP_PARAMETERS",
    "IdentifiabilityTable",
    "OATResult",
    "PlacementMap",
    "PlacementTolerance",
    "SensitivityStudy",
    "SobolResult",
    "check_angles",
    "default_spans",
    "identifiability_table",
    "oat_sweep",
    "offset_cost",
    "placement_map",
    "placement_tolerance",
    "rms_change",
    "sensitivity_study",
    "shape_change",
    "sobol_analysis",
    "sobol_indices",
]

__getattr__, __dir__ = attach(__name__)
