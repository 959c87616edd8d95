"""Moved to :mod:`magcilia.fitting` (issue 26: one least-squares core): the batched
Levenberg–Marquardt is :func:`magcilia.fitting.fit_batch`, its result
:class:`magcilia.fitting.BatchFit` (``x`` and ``cost`` as before, and more). The old names stay
for this release."""

from __future__ import annotations

from magcilia.fitting import BatchFit as LocalFits
from magcilia.fitting import fit_batch as levenberg_marquardt

__all__ = ["LocalFits", "levenberg_marquardt"]
