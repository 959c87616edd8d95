"""Many recordings or many models at once, through the execution layer
(:mod:`magcilia.execution`): batch calibration (:func:`calibrate_batch`)."""

from magcilia.batch.calibration import (
    COLUMNS,
    OUTLIER_Z,
    BatchResult,
    batch_statistics,
    calibrate_batch,
    calibrate_recording,
    robust_z,
)

__all__ = [
    "COLUMNS",
    "OUTLIER_Z",
    "BatchResult",
    "batch_statistics",
    "calibrate_batch",
    "calibrate_recording",
    "robust_z",
]
