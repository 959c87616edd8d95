"""Many recordings or many models at once, through the execution layer
(:mod:`magcilia.execution`): batch calibration (:func:`calibrate_batch`, :mod:`.calibration`)
and what it gives (:class:`BatchResult`, its table and statistics, :mod:`.results`)."""

from __future__ import annotations

from typing import TYPE_CHECKING

from magcilia._lazy import attach

if TYPE_CHECKING:
    from magcilia.batch.calibration import calibrate_batch, calibrate_recording
    from magcilia.batch.results import COLUMNS, OUTLIER_Z, BatchResult, batch_statistics, robust_z

__all__ = [
    "COLUMNS",
    "OUTLIER_Z",
    "BatchResult",
    "batch_statistics",
    "calibrate_batch",
    "calibrate_recording",
    "robust_z",
]

__getattr__, __dir__ = attach(__name__)
