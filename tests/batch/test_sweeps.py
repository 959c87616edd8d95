"""Sweeps through the execution layer: Sobol indices from worker processes or a Dask cluster equal
the serial run's, bit for bit (each sample's output depends on that sample alone)."""

from __future__ import annotations

import json
from pathlib import Path

import numpy as np
import pytest

import magcilia as mc
from magcilia.cli import main

pytest.importorskip("SALib")
ANGLES = np.radians(np.linspace(0.0, 85.0, 12))


@pytest.fixture(scope="module")
def serial() -> mc.SobolResult:
    return mc.sobol_indices(mc.Setup.paper(), n_base=64, angles=ANGLES, rng=3)


def _same(a: mc.SobolResult, b: mc.SobolResult) -> None:
    for name in ("S1", "S1_conf", "ST", "ST_conf"):
        np.testing.assert_array_equal(getattr(a, name), getattr(b, name))
    assert (a.output_mean, a.output_std, a.n_evaluations) == (
        b.output_mean, b.output_std, b.n_evaluations)


def test_sobol_in_worker_processes_equals_serial(serial: mc.SobolResult) -> None:
    _same(mc.sobol_indices(mc.Setup.paper(), n_base=64, angles=ANGLES, rng=3, workers=2),
          serial)


def test_sobol_on_a_dask_cluster_equals_serial(serial: mc.SobolResult, cluster: object) -> None:
    _same(mc.sobol_indices(mc.Setup.paper(), n_base=64, angles=ANGLES, rng=3,
                           scheduler=cluster.scheduler_address),  # type: ignore[attr-defined]
          serial)


def test_sobol_analysis_chunks_fail_in_one_line() -> None:
    with pytest.raises(mc.MagciliaError, match=r"a chunk of the sweep failed \(rows 0\.\., on "
                                               r"in-process\): TypeError: "):
        mc.analysis.sobol_analysis(float, {"a": (-1.0, 1.0)}, 8, rng=0, workers=1)


def test_sensitivity_cli_workers_give_the_serial_indices(tmp_path: Path,
                                                         capsys: pytest.CaptureFixture[str]
                                                         ) -> None:
    docs = []
    for extra in ([], ["--workers", "2"]):
        out = tmp_path / f"out{len(extra)}"
        assert main(["sensitivity", "paper", "--out", str(out), "--points", "3",
                     "--map-points", "3", "--sobol-base", "16", "--json", "--quiet",
                     *extra]) == 0
        docs.append(json.loads(capsys.readouterr().out)["sobol"]["table"])
    assert docs[0] == docs[1]


def test_a_scheduler_without_workers_is_a_one_line_error() -> None:
    distributed = pytest.importorskip("distributed")
    from magcilia.execution import run_tasks

    with (distributed.LocalCluster(n_workers=0, processes=False, dashboard_address=":0") as c,
          pytest.raises(mc.MagciliaError, match="has no workers")):
        run_tasks(abs, [("a", -1)], scheduler=c.scheduler_address, timeout=0.5, progress=False)


def test_scheduler_local_starts_a_local_cluster_for_the_call() -> None:
    pytest.importorskip("distributed")
    import math

    from magcilia.execution import run_tasks

    tasks = [(f"t{i}", float(i) - 1.0) for i in range(6)]
    dask = run_tasks(math.sqrt, tasks, scheduler="local", workers=2, progress=False)
    serial = run_tasks(math.sqrt, tasks, workers=1, progress=False)
    assert [(r.value, r.error, r.attempts) for r in dask] == [
        (r.value, r.error, r.attempts) for r in serial]
    assert all(r.worker.startswith("tcp://") for r in dask)
