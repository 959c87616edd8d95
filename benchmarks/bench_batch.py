"""Batch calibration and the execution layer (issue 16): throughput with 2 workers against 1, the
Dask overhead per task, and the effect of one BLAS thread per worker.

* **throughput**: ``calibrate_batch`` of N synthetic recordings (Table I's cilium, 33 angles,
  200 samples each, seeds 0..N-1; the default search: 256 starts, no figures), with
  ``workers=1`` (in this process) and ``workers=2`` (the local process pool) and a Dask
  ``LocalCluster`` of 2 processes (``scheduler="local"``); the pool's and cluster's start
  included. Anchor: workers=1; the ratio is the speed-up (goal ≥ 1.8 on 2 cores).
* **overhead per task**: M trivial tasks (``abs``) through a running LocalCluster of 2 workers
  (a fresh Client per call, as ``run_tasks`` does) and through the local pool, against the same
  tasks in this process; (t − t_in_process) / M (goal ≤ 5 ms for Dask).
* **threadpoolctl**: 2 workers of BLAS-bound tasks (a 400 × 400 symmetric eigenproblem each)
  and the batch calibration, with one BLAS thread per worker (the default) and without the
  limit (``MAGCILIA_WORKER_THREADS=none``: each worker's OpenBLAS starts a thread per core).

Run: python benchmarks/bench_batch.py [--quick]
"""

from __future__ import annotations

import argparse
import os
import shutil
import tempfile
import time
from pathlib import Path

import numpy as np

import magcilia as mc
from magcilia.acquire.synthetic import synthetic_recording
from magcilia.batch import calibrate_batch
from magcilia.execution import THREADS_ENV, run_tasks

ANGLES = np.radians(np.linspace(0.0, 85.0, 33))


def write_recordings(folder: Path, n: int) -> str:
    folder.mkdir(parents=True, exist_ok=True)
    for i in range(n):
        rec = synthetic_recording(mc.Setup.paper(), ANGLES, samples_per_angle=200, rng=i)
        (folder / f"hair{i:03d}.csv").write_text("angle_deg,voltage_V\n" + "".join(
            f"{a:.17g},{v:.17g}\n" for a, v in zip(rec.angle_deg, rec.voltage, strict=True)))
    return str(folder / "*.csv")


def timed_batch(pattern: str, out: Path, **kwargs: object) -> tuple[float, object]:
    shutil.rmtree(out, ignore_errors=True)
    t0 = time.perf_counter()
    result = calibrate_batch(pattern, out, figures=False, progress=False, **kwargs)  # type: ignore[arg-type]
    return time.perf_counter() - t0, result


def blas_task(seed: int) -> float:
    """A BLAS-bound task: the eigenvalues of a 400 x 400 symmetric matrix."""
    a = np.random.default_rng(seed).standard_normal((400, 400))
    return float(np.linalg.eigvalsh(a + a.T)[-1])


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    parser.add_argument("--quick", action="store_true", help="fewer recordings and tasks")
    args = parser.parse_args()
    n_rec = 24 if args.quick else 120
    n_trivial = 500 if args.quick else 2000
    tmp = Path(tempfile.mkdtemp(prefix="bench-batch-"))
    print(f"bench_batch: {os.cpu_count()} cores (figures measured under load unless the machine "
          "is quiet)")
    try:
        pattern = write_recordings(tmp / "rec", n_rec)
        # warm the numba cache on disk so that no worker compiles
        timed_batch(pattern.replace("*", "hair000"), tmp / "warm", workers=1)

        t0 = time.perf_counter()
        run_tasks(abs, [("a", -1), ("b", -2)], workers=2, progress=False)
        t_start = time.perf_counter() - t0  # spawning two workers that import magcilia
        t1, r1 = timed_batch(pattern, tmp / "w1", workers=1)
        t2, r2 = timed_batch(pattern, tmp / "w2", workers=2)
        td, rd = timed_batch(pattern, tmp / "dask", workers=2, scheduler="local")
        same = all(a["cost"] == b["cost"] == c["cost"] for a, b, c in
                   zip(r1.rows, r2.rows, rd.rows, strict=True))  # type: ignore[attr-defined]
        print(f"\nthroughput: {n_rec} recordings (33 angles, 256 starts), pool start included")
        print(f"  workers=1 (in process)     {t1:7.2f} s  {n_rec / t1:6.2f} recordings/s")
        print(f"  workers=2 (process pool)   {t2:7.2f} s  {n_rec / t2:6.2f} recordings/s  "
              f"speed-up {t1 / t2:.2f}x (goal >= 1.8)")
        print(f"  LocalCluster, 2 processes  {td:7.2f} s  {n_rec / td:6.2f} recordings/s  "
              f"speed-up {t1 / td:.2f}x")
        print(f"  the pool's start alone (2 trivial tasks): {t_start:.2f} s; workers=2 without "
              f"it: speed-up {t1 / (t2 - t_start):.2f}x")
        print(f"  identical costs on the three backends: {same}")

        tasks = [(str(i), -i) for i in range(n_trivial)]
        t0 = time.perf_counter()
        run_tasks(abs, tasks, workers=1, progress=False)
        t_in = time.perf_counter() - t0
        t0 = time.perf_counter()
        run_tasks(abs, tasks, workers=2, progress=False)
        t_pool = time.perf_counter() - t0
        import logging

        from distributed import LocalCluster

        with LocalCluster(n_workers=2, threads_per_worker=1, processes=True,
                          dashboard_address=None, silence_logs=logging.ERROR) as cluster:
            run_tasks(abs, tasks[:10], scheduler=cluster.scheduler_address, progress=False)
            t0 = time.perf_counter()
            run_tasks(abs, tasks, scheduler=cluster.scheduler_address, progress=False)
            t_dask = time.perf_counter() - t0
        print(f"\noverhead per task: {n_trivial} trivial tasks")
        print(f"  in process                 {t_in * 1e3 / n_trivial:8.3f} ms/task")
        print(f"  local pool (2, with start) {t_pool * 1e3 / n_trivial:8.3f} ms/task  overhead "
              f"{(t_pool - t_in) * 1e3 / n_trivial:.3f} ms")
        print(f"  Dask LocalCluster (2)      {t_dask * 1e3 / n_trivial:8.3f} ms/task  overhead "
              f"{(t_dask - t_in) * 1e3 / n_trivial:.3f} ms (goal <= 5 ms)")

        blas = [(str(i), i) for i in range(16 if args.quick else 40)]
        times = {}
        for label, value in (("limit 1 thread/worker", "1"), ("no limit", "none")):
            os.environ[THREADS_ENV] = value
            t0 = time.perf_counter()
            run_tasks(blas_task, blas, workers=2, progress=False)
            t_blas = time.perf_counter() - t0
            t_cal, _ = timed_batch(pattern, tmp / "tp", workers=2)
            times[label] = (t_blas, t_cal)
        os.environ.pop(THREADS_ENV, None)
        t0 = time.perf_counter()
        run_tasks(blas_task, blas, workers=1, progress=False)
        t_serial = time.perf_counter() - t0
        print(f"\nthreadpoolctl: 2 workers, {len(blas)} eigenproblems (400 x 400) / the "
              f"{n_rec}-recording batch")
        for label, (t_blas, t_cal) in times.items():
            print(f"  {label:<22} {t_blas:7.2f} s / {t_cal:7.2f} s")
        print(f"  in process (serial)    {t_serial:7.2f} s (eigenproblems)")
    finally:
        shutil.rmtree(tmp, ignore_errors=True)


if __name__ == "__main__":
    main()
