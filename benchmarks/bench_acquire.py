"""Sustained acquisition + recording, one process (issue 10).

A simulated source paced by the wall clock (``realtime=True``, the way a device delivers) feeds
the background reader's ring buffer; the main thread writes every sample into a crash-safe TDMS
recording (a flushed segment per chunk). Reported per rate: samples written per second of wall
time and the overruns (samples the buffer had to overwrite because the writer fell behind).
Target: >= 1e6 samples/s sustained with zero overruns. Also: the recording writer alone, and the
simulated source alone, to show where the time goes.

Run: python benchmarks/bench_acquire.py [--quick]
"""

from __future__ import annotations

import os

for _var in ("OMP_NUM_THREADS", "OPENBLAS_NUM_THREADS", "MKL_NUM_THREADS"):
    os.environ[_var] = "1"

import argparse
import tempfile
import time
from pathlib import Path

import numpy as np

import magcilia as mc
from magcilia.acquire import SimulatedSource, record_stream
from magcilia.io import RecordingWriter, read_samples


def sustained(rate: float, seconds: float, folder: Path) -> bool:
    source = SimulatedSource(mc.Setup.paper(), 0.3, rate=rate, realtime=True, rng=0)
    path = folder / f"stream-{rate:.0e}.tdms"
    result = record_stream(source, path, seconds, chunk=65536, buffer_seconds=2.0)
    n_file = read_samples(path, required=("voltage_V",))["voltage_V"].size
    kept_up = result.overruns == 0 and n_file == round(rate * seconds)
    print(f"  paced at {rate:9.3g} Hz for {seconds:g} s: {n_file} samples in the file, "
          f"{result.overruns} overruns ({result.rate:.4g} samples/s over the wall time, start "
          f"included)   {'kept up' if kept_up else 'FELL BEHIND'}")
    path.unlink()
    return kept_up


def writer_alone(samples: int, folder: Path) -> None:
    t = np.arange(65536) / 1e6
    volts = np.random.default_rng(0).standard_normal(65536)
    path = folder / "writer.tdms"
    t0 = time.perf_counter()
    with RecordingWriter(path, chunk=65536) as rec:
        for _ in range(samples // 65536):
            rec.write(t, volts)
    elapsed = time.perf_counter() - t0
    size = path.stat().st_size
    print(f"  recording writer alone (65536-sample chunks, flushed): "
          f"{rec.samples / elapsed:.4g} samples/s, {size / elapsed / 1e6:.0f} MB/s")
    path.unlink()


def source_alone(samples: int) -> None:
    source = SimulatedSource(mc.Setup.paper(), 0.3, rate=1e6, rng=0)
    t0 = time.perf_counter()
    with source:
        for _ in range(samples // 65536):
            source.read(65536)
    print(f"  simulated source alone (not paced): "
          f"{source.counters.samples / (time.perf_counter() - t0):.4g} samples/s")


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--quick", action="store_true", help="short smoke run")
    args = parser.parse_args()
    seconds = 2.0 if args.quick else 10.0
    print("acquisition + recording benchmark (one process: reader thread + writer)")
    with tempfile.TemporaryDirectory() as tmp:
        folder = Path(tmp)
        source_alone(2_000_000 if args.quick else 20_000_000)
        writer_alone(2_000_000 if args.quick else 20_000_000, folder)
        kept = [rate for rate in ((1e6, 2e6) if args.quick else (1e6, 2e6, 4e6))
                if sustained(rate, seconds, folder)]
    best = f"{max(kept):.3g} samples/s" if kept else "none"
    print(f"highest paced rate sustained with zero overruns: {best} "
          "(target: >= 1e6 samples/s with zero overruns)")


if __name__ == "__main__":
    main()
