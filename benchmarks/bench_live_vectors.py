"""Live read-out of force vectors in real time: the 16-cilium array of examples/array.toml at
50 Hz and a 3-axis sensor (MMC5983MA at the element of the force-sensor preset) at its 100 Hz.

Each runs ``magcilia live``'s read-out (the simulated source pushing the cilia in changing
directions, the tare at the start) for ``--seconds`` in real time. Reported: the read-out's time
per window (the protocol's ``read`` of one chunk, divided by its windows: the array inverse
solves every window), the pipeline latency (sample in -> value out, median and p99 over the run)
and the samples lost (overruns). Target: the time per window well under the window (20 ms at
50 Hz), 0 overruns, latency median within a window plus a chunk.

Run: python benchmarks/bench_live_vectors.py [--seconds 10] [--quick]
"""

from __future__ import annotations

import os

for _var in ("OMP_NUM_THREADS", "OPENBLAS_NUM_THREADS", "MKL_NUM_THREADS"):
    os.environ[_var] = "1"

import argparse
import time
from pathlib import Path
from typing import Any

import numpy as np

from magcilia.cli._live import build_live

ROOT = Path(__file__).resolve().parents[1]
OPTIONS: dict[str, Any] = {
    "source_spec": "sim", "quantity": "force", "span_text": None, "calibration_path": None,
    "fluid": "water", "source_rate": None, "channel": "output", "set_reset": None,
    "no_tare": False, "tracking": 30.0, "seed": 0, "tip_radius": None, "modulus": None,
    "sensor_noise": None}


def run(name: str, seconds: float, **kw: Any) -> None:
    live = build_live(**OPTIONS, **kw)
    view = live.sensor.view
    spent: list[float] = []
    windows: list[int] = []
    read = view.read

    def timed(samples: Any, /, **options: Any) -> Any:
        t = time.perf_counter()
        out = read(samples, **options)
        spent.append(time.perf_counter() - t)
        windows.append(len(samples))
        return out

    object.__setattr__(view, "read", timed)  # (the view is frozen: time its calls)
    with live:
        cursor = live.history.total
        time.sleep(seconds)
        samples, _, lost = live.history.since(cursor)
        status = live.status
    per = np.array(spent) / np.maximum(np.array(windows), 1)
    lat = samples.latency[np.isfinite(samples.latency)] * 1e3
    print(f"{name}: {len(samples)} read-outs at {live.rate:g} Hz over {seconds:g} s; time per "
          f"window median {np.median(per) * 1e3:.2f} ms, p99 {np.quantile(per, 0.99) * 1e3:.2f} "
          f"ms ({np.mean(windows):.1f} windows per read); latency median {np.median(lat):.1f} "
          f"ms, p99 {np.quantile(lat, 0.99):.1f} ms; overruns {status.overruns}, dropped "
          f"{status.counters.dropped}, lost by the view {lost}")


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--seconds", type=float, default=10.0)
    parser.add_argument("--quick", action="store_true", help="2 s per sensor (a smoke run)")
    args = parser.parse_args()
    if args.quick:
        args.seconds = min(args.seconds, 2.0)
    run("array (16 cilia)", args.seconds, setup_arg=str(ROOT / "examples" / "array.toml"),
        sensor_name=None, rate=50.0)
    run("3-axis sensor", args.seconds, setup_arg="force-sensor", sensor_name="MMC5983MA",
        rate=None)


if __name__ == "__main__":
    main()
