"""The field model: plain values in, arrays out.

* :mod:`.kernels`: bare vectorised point-dipole kernels (arrays in, arrays out, no checks);
* :mod:`.compiled`: the same kernels compiled with numba (loaded on first use, cached on disk;
  the NumPy ones are the reference and the fallback);
* :mod:`.body`: the body of revolution (radius, slice volumes, ring radii), once for all;
* :mod:`.layout`: the paper's n slices × k dipoles layout, straight or along a centreline;
* :mod:`.spec`: :class:`ModelSpec`, what the model needs of a sensor (``Setup.spec`` builds it);
* :mod:`.centreline`: poses (rigid tilt and bent shapes) as plain arrays;
* :mod:`.pose`: one spec's field and output for a batch of poses, with the inside checks;
* :mod:`.batch`: many parameter sets at once (optimisers, Sobol), unchecked: :class:`TiltBatch`;
* :mod:`.exact`: the exact reference, a stack of magpylib cylinders.

Nothing here imports the device objects above it: functions take a :class:`ModelSpec` or any
object with a ``spec`` attribute (a :class:`magcilia.Setup`).
"""

from __future__ import annotations

from typing import TYPE_CHECKING

from magcilia._lazy import attach

if TYPE_CHECKING:
    from magcilia.model.batch import TiltBatch, tilt_field_batch, tilt_output_batch
    from magcilia.model.centreline import Centreline, SpatialCentreline
    from magcilia.model.exact import exact_body, exact_field, single_dipole_field
    from magcilia.model.kernels import dipole_field, dipole_field_batch, pose_field, tilt_fields
    from magcilia.model.layout import pose_dipoles, ring_layout
    from magcilia.model.pose import Pose
    from magcilia.model.spec import ModelSpec, SupportsSpec, as_spec

__all__ = [
    "Centreline",
    "ModelSpec",
    "Pose",
    "SpatialCentreline",
    "SupportsSpec",
    "TiltBatch",
    "as_spec",
    "dipole_field",
    "dipole_field_batch",
    "exact_body",
    "exact_field",
    "pose_dipoles",
    "pose_field",
    "ring_layout",
    "single_dipole_field",
    "tilt_field_batch",
    "tilt_fields",
    "tilt_output_batch",
]

__getattr__, __dir__ = attach(__name__)
