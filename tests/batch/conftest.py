"""Batch fixtures: seeded synthetic recordings (the bundled generator, few samples per angle) and
one Dask LocalCluster of two worker processes per module that asks for it."""

from __future__ import annotations

import logging
from collections.abc import Iterator
from pathlib import Path
from typing import Any

import numpy as np
import pytest

import magcilia as mc
from magcilia.acquire.synthetic import synthetic_recording

ANGLES = np.radians(np.linspace(0.0, 85.0, 12))


def write_recordings(folder: Path, n: int, *, first_seed: int = 0,
                     prefix: str = "hair") -> list[Path]:
    """``n`` CSV recordings of Table I's cilium, 12 angles x 3 samples, seeds first_seed.. ."""
    folder.mkdir(parents=True, exist_ok=True)
    paths = []
    for i in range(n):
        rec = synthetic_recording(mc.Setup.paper(), ANGLES, samples_per_angle=3,
                                  rng=first_seed + i)
        path = folder / f"{prefix}{i:03d}.csv"
        path.write_text("angle_deg,voltage_V\n" + "".join(
            f"{a:.17g},{v:.17g}\n" for a, v in zip(rec.angle_deg, rec.voltage, strict=True)))
        paths.append(path)
    return paths


@pytest.fixture(scope="module")
def cluster() -> Iterator[Any]:
    distributed = pytest.importorskip("distributed")
    with distributed.LocalCluster(n_workers=2, threads_per_worker=1, processes=True,
                                  dashboard_address=":0", silence_logs=logging.CRITICAL) as c:
        yield c
