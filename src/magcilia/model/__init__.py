"""The field model: the paper's distributed dipoles, bare kernels and the exact reference.

* :mod:`.kernels`: bare vectorised point-dipole kernels (arrays in, arrays out, no checks);
* :mod:`.layout`: the n slices × k dipoles layout and the fast batch evaluation;
* :mod:`.centreline`: poses (rigid tilt and bent shapes) as plain arrays;
* :mod:`.exact`: the exact reference, a stack of magpylib cylinders.
"""

from __future__ import annotations

from magcilia.model.centreline import Centreline
from magcilia.model.exact import exact_field, single_dipole_field
from magcilia.model.layout import (
    pose_dipoles,
    pose_field,
    ring_layout,
    tilt_field_batch,
    tilt_fields,
    tilt_output_batch,
)

__all__ = [
    "Centreline",
    "exact_field",
    "pose_dipoles",
    "pose_field",
    "ring_layout",
    "single_dipole_field",
    "tilt_field_batch",
    "tilt_fields",
    "tilt_output_batch",
]
