"""Serial protocol throughput: parsing and the whole serial path.

Measures, in one run and on one thread (the emulator's writer is a second thread of the same
process, sharing the GIL):
  * ``FrameParser.feed`` on a large pre-encoded byte stream of 32- and 64-sample frames (one
    channel), fed in 4 KiB pieces as a port delivers them and in one piece: samples/s
    (target >= 1e6 on one core);
  * end to end: ``DeviceEmulator`` (samples from a ``SimulatedSource``, encoded, written to a
    pseudo-terminal as fast as the reader takes them) -> pyserial -> ``SerialSource.read``:
    samples/s, for 32- and 64-sample frames.

Run: python benchmarks/bench_serial.py [--quick]
"""

from __future__ import annotations

import os

for _var in ("OMP_NUM_THREADS", "OPENBLAS_NUM_THREADS", "MKL_NUM_THREADS", "NUMBA_NUM_THREADS"):
    os.environ[_var] = "1"  # single thread, before NumPy loads BLAS

import argparse
import math
import time

import numpy as np

import magcilia as mc
from magcilia.acquire.emulator import VOLTS_PER_COUNT, DeviceEmulator
from magcilia.acquire.protocol import FrameParser, encode_frame
from magcilia.acquire.serial import SerialSource
from magcilia.acquire.simulated import SimulatedSource

TARGET = 1e6
PIECE = 4096


def byte_stream(samples: int, per_frame: int) -> bytes:
    """``samples`` samples of one channel as frames of ``per_frame``, encoded."""
    counts = np.random.default_rng(0).integers(-2**23, 2**23, samples, dtype=np.int32)
    return b"".join(
        encode_frame(counts[i:i + per_frame], sequence=k, first=i, rate=1000.0,
                     volts_per_count=VOLTS_PER_COUNT)
        for k, i in enumerate(range(0, samples, per_frame)))


def parse_rate(data: bytes, samples: int, piece: int | None, repeat: int) -> float:
    """Samples/s of the best of ``repeat`` parses (in pieces of ``piece`` bytes, or whole)."""
    best = math.inf
    for _ in range(repeat):
        parser = FrameParser()
        t0 = time.perf_counter()
        if piece is None:
            got = sum(f.n for f in parser.feed(data))
        else:
            got = sum(f.n for i in range(0, len(data), piece)
                      for f in parser.feed(data[i:i + piece]))
        best = min(best, time.perf_counter() - t0)
        if parser.corrupt or got != samples:
            raise SystemExit(f"parsed {got} of {samples} samples, {parser.corrupt} corrupt")
    return samples / best


def end_to_end(samples: int, per_frame: int) -> tuple[float, str]:
    """Samples/s through the emulator and the serial source; the source's counters."""
    setup = mc.Setup.paper()
    sim = SimulatedSource(setup, 0.3, rate=1e5, rng=0)
    with (DeviceEmulator(sim, samples_per_frame=per_frame, realtime=False) as device,
          SerialSource(device.port) as source):
        source.read(10 * per_frame)  # warm up
        t0 = time.perf_counter()
        source.read(samples)
        wall = time.perf_counter() - t0
    return samples / wall, source.counters.report()


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--quick", action="store_true", help="smaller streams, fewer repeats")
    args = parser.parse_args()
    samples = 192_000 if args.quick else 1_920_000
    repeat = 3 if args.quick else 5
    print(f"FrameParser.feed, one channel, {samples} samples pre-encoded "
          f"[target >= {TARGET:.0e} samples/s]")
    for per_frame in (32, 64):
        data = byte_stream(samples, per_frame)
        pieces = parse_rate(data, samples, PIECE, repeat)
        whole = parse_rate(data, samples, None, repeat)
        print(f"  {per_frame:2d} samples/frame ({len(data) / samples:.2f} bytes/sample): "
              f"{pieces:.3g} samples/s in {PIECE}-byte pieces, {whole:.3g} in one piece; "
              f"ratio to target {pieces / TARGET:.3g}x")
    e2e = 100_000 if args.quick else 1_000_000
    print(f"end to end: DeviceEmulator -> pseudo-terminal -> pyserial -> SerialSource.read, "
          f"{e2e} samples (SimulatedSource at 100 kHz, not paced)")
    for per_frame in (32, 64):
        rate, counters = end_to_end(e2e, per_frame)
        print(f"  {per_frame:2d} samples/frame: {rate:.3g} samples/s ({counters})")


if __name__ == "__main__":
    main()
