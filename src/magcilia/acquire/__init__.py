"""Acquisition: where recordings come from.

* :mod:`.synthetic`: simulated recordings of the paper's experiment (always labelled synthetic).
"""

from __future__ import annotations

from magcilia.acquire.synthetic import Recording, synthetic_recording

__all__ = ["Recording", "synthetic_recording"]
