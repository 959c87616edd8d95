"""Reading recordings: ``mc.read_measurements`` against pandas' C reader (issue 17, item 4).

Writes recordings of 1e6 and 1e7 samples (``--quick``: 1e5 and 1e6) to a temporary folder, as
the bundled example is written (``angle_deg,voltage_V,time_s``; 33 angles from −40 to 40 deg,
the paper setup's output plus 20 µV of noise, sampled at 1 kHz), as CSV, as TDMS in one segment
(as another program writes one) and as magcilia records one (``RecordingWriter``: a segment per
half-second chunk at 1 kHz, with its CRC-32 checksums), then reduces each to per-angle means,
standard errors and counts:

* **ours**: ``mc.read_measurements(path)`` (every check of a recording included: the quality
  checks, the TDMS structure, the chunks' checksums of magcilia's own recordings);
* **anchor** (the strongest ordinary use): CSV ``pandas.read_csv(engine="c", usecols=...,
  dtype=float64)``, TDMS ``nptdms.TdmsFile.read``; then one ``np.unique(return_inverse=True)``
  and ``np.bincount`` for the counts, the means and the squared deviations from them.

Time: both interleaved in this process (pandas imported and warm), min and median of the runs.
Peak memory: each reduction alone in a fresh child process that reports its own peak RSS
(``ru_maxrss``), min and median of the runs; the child's peak just after importing NumPy, pandas
and magcilia is printed as the baseline. Targets: 1e7 CSV rows in <= 10 s and <= 1.5 GB peak,
1e6 rows well under 1 s; the checks of a recording (issue 25) cost little: with them, 1e7 CSV rows
in <= 1.2x the time and <= 2x the peak memory of the read without them, 1e7 TDMS samples in
<= 2x the time (run the same script on the tree before them to compare).

Run: python benchmarks/bench_recordings.py [--quick]
"""

from __future__ import annotations

import os

for _var in ("OMP_NUM_THREADS", "OPENBLAS_NUM_THREADS", "MKL_NUM_THREADS"):
    os.environ[_var] = "1"  # single thread, before NumPy loads BLAS

import argparse
import resource
import statistics
import subprocess
import sys
import tempfile
import time
from collections.abc import Callable
from pathlib import Path

import numpy as np
import pandas as pd

import magcilia as mc

ANGLES_DEG = np.linspace(-40.0, 40.0, 33)
RATE_HZ = 1000.0
NOISE_V = 2e-5


def columns(samples: int) -> dict[str, np.ndarray]:
    """A recording's columns: angle (deg), output (V) and time (s), shapes (samples,)."""
    per = -(-samples // ANGLES_DEG.size)
    angle = np.repeat(ANGLES_DEG, per)[:samples]
    clean = mc.Setup.paper().output(np.radians(ANGLES_DEG))
    volts = (np.repeat(clean, per)[:samples]
             + np.random.default_rng(0).normal(0.0, NOISE_V, samples))
    return {"angle_deg": angle, "voltage_V": volts, "time_s": np.arange(samples) / RATE_HZ}


def write_csv(path: Path, cols: dict[str, np.ndarray]) -> None:
    """The columns as the example recording is written (4 decimals of a degree, 8 digits of V)."""
    with path.open("w") as f:
        f.write("angle_deg,voltage_V,time_s\n")
        for i in range(0, cols["angle_deg"].size, 1_000_000):
            part = zip(*(cols[k][i:i + 1_000_000].tolist() for k in cols), strict=True)
            f.write("".join(f"{a:.4f},{v:.7e},{t:.3f}\n" for a, v, t in part))


def write_tdms(path: Path, cols: dict[str, np.ndarray]) -> None:
    import nptdms

    with nptdms.TdmsWriter(path) as writer:
        writer.write_segment([nptdms.ChannelObject("recording", k, a) for k, a in cols.items()])


def write_own(path: Path, cols: dict[str, np.ndarray]) -> None:
    """As ``magcilia record`` writes at 1 kHz: 500-sample chunks, one segment each."""
    from magcilia.io import RecordingWriter

    with RecordingWriter(path, metadata={"source": "bench", "rate_Hz": RATE_HZ},
                         chunk=round(0.5 * RATE_HZ)) as rec:
        for i in range(0, cols["time_s"].size, 100_000):
            part = slice(i, i + 100_000)
            rec.write(cols["time_s"][part], cols["voltage_V"][part],
                      angle_deg=cols["angle_deg"][part])


def reduce_anchor(angle: np.ndarray, volts: np.ndarray) -> tuple[np.ndarray, ...]:
    """Per-angle means, standard errors and counts: one np.unique, then np.bincount."""
    distinct, group = np.unique(angle, return_inverse=True)
    count = np.bincount(group)
    mean = np.bincount(group, volts) / count
    var = np.bincount(group, (volts - mean[group]) ** 2) / (count - 1)
    return distinct, mean, np.sqrt(var / count), count


def anchor(path: Path) -> tuple[np.ndarray, ...]:
    if path.suffix == ".csv":
        frame = pd.read_csv(path, engine="c", usecols=["angle_deg", "voltage_V"],
                            dtype={"angle_deg": np.float64, "voltage_V": np.float64})
        return reduce_anchor(frame["angle_deg"].to_numpy(), frame["voltage_V"].to_numpy())
    import nptdms

    group = nptdms.TdmsFile.read(path)["recording"]
    return reduce_anchor(group["angle_deg"][:], group["voltage_V"][:])


METHODS: dict[str, Callable[[Path], object]] = {"ours": mc.read_measurements, "anchor": anchor}


def child(method: str, path: str) -> None:
    """Run one reduction (or none) and print this process's peak RSS in MB: ``VmHWM`` on Linux
    (``ru_maxrss`` would include the parent's peak, which a child started by fork and exec
    inherits), ``ru_maxrss`` elsewhere."""
    if method != "none":
        METHODS[method](Path(path))
    status = Path("/proc/self/status")
    if status.exists():
        kb = next(int(line.split()[1]) for line in status.read_text().splitlines()
                  if line.startswith("VmHWM:"))
    else:  # ru_maxrss: bytes on macOS, KiB elsewhere
        kb = resource.getrusage(resource.RUSAGE_SELF).ru_maxrss // (
            1024 if sys.platform == "darwin" else 1)
    print(kb / 1024)


def peak_mb(method: str, path: Path) -> float:
    out = subprocess.run([sys.executable, __file__, "--child", method, str(path)],
                         check=True, capture_output=True, text=True).stdout
    return float(out.split()[-1])


def compare(path: Path, runs: int, label: str) -> None:
    """Time (interleaved, here) and peak memory (children) of ours and the anchor on one file."""
    ours = mc.read_measurements(path)
    ref = anchor(path)
    np.testing.assert_allclose(ours.angles_deg, ref[0], atol=1e-9)
    np.testing.assert_allclose(ours.volts, ref[1], rtol=1e-12)
    np.testing.assert_allclose(ours.sem, ref[2], rtol=1e-9)
    assert ours.counts.tolist() == ref[3].tolist()
    times: dict[str, list[float]] = {name: [] for name in METHODS}
    for _ in range(runs):
        for name, run in METHODS.items():
            t0 = time.perf_counter()
            run(path)
            times[name].append(time.perf_counter() - t0)
    peaks = {name: [peak_mb(name, path) for _ in range(runs)] for name in METHODS}
    print(f"  {label:26s} {path.stat().st_size / 1e6:7.1f} MB file")
    for name, label in (("ours", "mc.read_measurements"), ("anchor", "anchor")):
        t, m = times[name], peaks[name]
        print(f"    {label:22s} {min(t):8.3f} {statistics.median(t):8.3f} s   "
              f"{min(m):7.0f} {statistics.median(m):7.0f} MB peak")
    print(f"    {'ratio anchor/ours':22s} {min(times['anchor']) / min(times['ours']):8.2f} "
          f"{statistics.median(times['anchor']) / statistics.median(times['ours']):8.2f}     "
          f"{min(peaks['anchor']) / min(peaks['ours']):7.2f} "
          f"{statistics.median(peaks['anchor']) / statistics.median(peaks['ours']):7.2f}")


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--quick", action="store_true", help="1e5 and 1e6 samples, 3 runs")
    parser.add_argument("--child", nargs=2, metavar=("METHOD", "PATH"), help=argparse.SUPPRESS)
    args = parser.parse_args()
    if args.child:
        child(*args.child)
        return
    sizes, runs = ((100_000, 1_000_000), 3) if args.quick else ((1_000_000, 10_000_000), 5)
    print(f"recordings: read and reduce to per-angle means (min, median of {runs} runs; peak RSS "
          f"of a child process doing only that; baseline after imports: "
          f"{peak_mb('none', Path()):.0f} MB)")
    print(f"  {'':27s} {'min':>8s} {'median':>8s}     {'min':>7s} {'median':>7s}")
    with tempfile.TemporaryDirectory() as tmp:
        for samples in sizes:
            print(f"{samples:.0e} samples, {ANGLES_DEG.size} angles")
            cols = columns(samples)
            for label, name, write in (("CSV", ".csv", write_csv),
                                       ("TDMS, one segment", ".tdms", write_tdms),
                                       ("TDMS, magcilia's own", "-own.tdms", write_own)):
                path = Path(tmp) / f"r{samples}{name}"
                write(path, cols)
                compare(path, runs, label)
                path.unlink()


if __name__ == "__main__":
    main()
