"""Batch calibration (magcilia.batch.calibrate_batch): a folder per recording, the results table,
resuming, the same numbers on every backend, and the errors a batch can meet."""

from __future__ import annotations

import json
import math
from pathlib import Path

import numpy as np
import pandas as pd
import pytest

import magcilia as mc
from magcilia._errors import MagciliaError
from magcilia.batch import COLUMNS, BatchResult, batch_statistics, calibrate_batch, robust_z
from magcilia.report.calibration import CALIBRATION_FILES

from .conftest import write_recordings  # type: ignore[import-not-found]

FAST = {"starts": 16, "figures": False, "progress": False}
#: the columns that say where and how long, not what was fitted
WHERE = ("seconds", "worker", "attempts")


def _fitted(result: BatchResult) -> list[dict[str, object]]:
    return [{k: v for k, v in r.items() if k not in WHERE} for r in result.rows]


def _same(a: BatchResult, b: BatchResult) -> None:
    """Bit for bit: every fitted value, standard error, cost and text equal (NaN equal NaN)."""
    for ra, rb in zip(_fitted(a), _fitted(b), strict=True):
        assert ra.keys() == rb.keys()
        for k in ra:
            x, y = ra[k], rb[k]
            assert x == y or (isinstance(x, float) and isinstance(y, float) and math.isnan(x)
                              and math.isnan(y)), (ra["recording"], k, x, y)


@pytest.fixture(scope="module")
def recordings(tmp_path_factory: pytest.TempPathFactory) -> Path:
    folder = tmp_path_factory.mktemp("recordings")
    write_recordings(folder, 6)
    (folder / "broken.csv").write_text("time_s,something\n0,1\n")
    return folder


@pytest.fixture(scope="module")
def reference(recordings: Path, tmp_path_factory: pytest.TempPathFactory) -> BatchResult:
    """The batch in this process, one recording after the other."""
    return calibrate_batch(str(recordings / "*.csv"), tmp_path_factory.mktemp("ref") / "out",
                           workers=1, **FAST)


def test_folder_table_and_summary(reference: BatchResult, recordings: Path) -> None:
    out = Path(reference.out)
    assert [r["recording"] for r in reference.rows] == ["broken", *(f"hair{i:03d}"
                                                                     for i in range(6))]
    assert reference.failed == ("broken",)
    broken = reference.rows[0]
    assert broken["error"].startswith("MagciliaError: ") and "angle_deg" in broken["error"]
    assert math.isnan(broken["height"]) and broken["attempts"] == 2  # retried once
    table = pd.read_csv(out / "results.csv", keep_default_na=False, na_values=[""])
    assert list(table.columns) == list(COLUMNS)
    assert {"recording", "cost", "error", "height", "base_radius", "x", "y", "z"} <= set(
        table.columns)
    parquet = pd.read_parquet(out / "results.parquet")
    pyarrow = pytest.importorskip("pyarrow.parquet")
    schema = pyarrow.read_schema(out / "results.parquet")
    assert schema.field("height").metadata == {b"unit": b"m"}
    for frame in (table, parquet):
        assert frame["recording"].tolist() == [r["recording"] for r in reference.rows]
        np.testing.assert_array_equal(frame["height"].to_numpy(),
                                      [r["height"] for r in reference.rows])
    # each recording's folder is what `magcilia calibrate --out` writes (less the figures)
    for i in range(6):
        folder = out / f"hair{i:03d}"
        doc = json.loads((folder / "result.json").read_text())
        assert doc["units"] == "SI"
        assert doc["values"]["height"] == reference.rows[i + 1]["height"]
        assert mc.load_setup(folder / "fitted_setup.toml").cilium.height == pytest.approx(
            doc["values"]["height"], rel=1e-11)
    assert sorted(p.name for p in (out / "broken").iterdir()) == ["batch.json"]
    # the same fit as calibrate alone, seed for seed
    alone = mc.calibrate(mc.read_measurements(recordings / "hair003.csv"),
                         mc.Setup.paper_initial(), rng=0, starts=16)
    assert alone.setup.cilium.height == reference.rows[4]["height"]
    assert alone.cost == reference.rows[4]["cost"]
    summary = (out / "summary.md").read_text()
    assert "7 recordings: 6 calibrated, 1 failed" in summary and "median" in summary


def test_local_pool_and_dask_equal_serial_bit_for_bit(recordings: Path, reference: BatchResult,
                                                     cluster: object, tmp_path: Path) -> None:
    pooled = calibrate_batch(str(recordings / "*.csv"), tmp_path / "pool", workers=2, **FAST)
    dask = calibrate_batch(str(recordings / "*.csv"), tmp_path / "dask",
                           scheduler=cluster.scheduler_address, **FAST)  # type: ignore[attr-defined]
    _same(pooled, reference)
    _same(dask, reference)
    assert {r["worker"] for r in dask.rows} <= set(cluster.scheduler_info["workers"])  # type: ignore[attr-defined]
    assert (tmp_path / "dask" / "results.csv").read_text().count("\n") == 8


def test_a_killed_dask_worker_loses_and_duplicates_nothing(
        recordings: Path, reference: BatchResult, cluster: object, tmp_path: Path) -> None:
    """SIGKILL one worker process while the batch runs (as the first recording's folder
    appears): its tasks run again elsewhere; the table is complete, each recording once, and
    equal to the serial run's."""
    import os
    import signal
    import threading
    import time

    client_module = pytest.importorskip("distributed")
    with client_module.Client(cluster.scheduler_address) as client:  # type: ignore[attr-defined]
        pids = client.run(os.getpid)
    out = tmp_path / "killed"
    killed: list[int] = []

    def killer() -> None:
        deadline = time.monotonic() + 60
        while time.monotonic() < deadline and not list(out.glob("*/batch.json")):
            time.sleep(0.005)
        pid = min(pids.values())
        os.kill(pid, signal.SIGKILL)
        killed.append(pid)

    thread = threading.Thread(target=killer)
    thread.start()
    # with figures each recording takes long enough that the kill lands mid-batch
    result = calibrate_batch(str(recordings / "*.csv"), out, progress=False, starts=16,
                             scheduler=cluster.scheduler_address)  # type: ignore[attr-defined]
    thread.join()
    assert killed
    _same(result, reference)
    table = pd.read_csv(out / "results.csv", keep_default_na=False, na_values=[""])
    assert table["recording"].tolist() == [r["recording"] for r in reference.rows]
    for name in table["recording"][1:]:
        assert sorted(p.name for p in (out / name).iterdir()) == sorted(
            [*CALIBRATION_FILES, "batch.json"])
    assert not [p for p in out.iterdir() if p.name.startswith(".")]  # no staging left over


def test_a_hundred_recordings_resume(tmp_path: Path) -> None:
    """100 recordings: the table complete; a rerun computes nothing; after deleting three result
    files exactly those three run again, and the table is the same."""
    write_recordings(tmp_path / "rec", 100, first_seed=100)
    pattern = str(tmp_path / "rec" / "*.csv")
    first = calibrate_batch(pattern, tmp_path / "out", workers=2, **FAST)
    assert len(first.rows) == 100 and not first.failed and len(first.computed) == 100
    table = pd.read_csv(tmp_path / "out" / "results.csv")
    assert len(table) == 100 and table["error"].isna().all() and table["height"].notna().all()
    again = calibrate_batch(pattern, tmp_path / "out", **FAST)
    assert again.computed == () and len(again.skipped) == 100
    _same(again, first)
    for name in ("hair007", "hair050", "hair099"):
        (tmp_path / "out" / name / "result.json").unlink()
    third = calibrate_batch(pattern, tmp_path / "out", workers=1, **FAST)
    assert third.computed == ("hair007", "hair050", "hair099")
    _same(third, first)
    # a glob over the parent folder does not take the batch's own CSV files for recordings
    parent = calibrate_batch(str(tmp_path / "**" / "*.csv"), tmp_path / "out", **FAST)
    assert parent.computed == () and len(parent.rows) == 100
    # a changed recording runs again too
    path = tmp_path / "rec" / "hair010.csv"
    path.write_text(path.read_text())
    assert calibrate_batch(pattern, tmp_path / "out", workers=1, **FAST).computed == ("hair010",)


def test_empty_glob(tmp_path: Path) -> None:
    with pytest.raises(MagciliaError, match=r"no recording matches .*\*\.csv; check the pattern"):
        calibrate_batch(str(tmp_path / "*.csv"), tmp_path / "out", **FAST)
    assert not (tmp_path / "out").exists()


def test_two_recordings_of_one_name(tmp_path: Path) -> None:
    write_recordings(tmp_path / "a", 1)
    write_recordings(tmp_path / "b", 1)
    with pytest.raises(MagciliaError, match="two recordings are named 'hair000'"):
        calibrate_batch(str(tmp_path / "*" / "*.csv"), tmp_path / "out", **FAST)
    assert not (tmp_path / "out").exists()


def test_foreign_output_folder(tmp_path: Path) -> None:
    write_recordings(tmp_path / "rec", 2)
    pattern = str(tmp_path / "rec" / "*.csv")
    calibrate_batch(pattern, tmp_path / "out", workers=1, **FAST)
    before = (tmp_path / "out" / "results.csv").read_text()
    with pytest.raises(MagciliaError, match=r"holds another batch \(its bias, figures differ\); "
                                            "pass --force"):
        calibrate_batch(pattern, tmp_path / "out", workers=1, **{**FAST, "figures": True},
                        bias="none")
    assert (tmp_path / "out" / "results.csv").read_text() == before
    other = tmp_path / "other"
    other.mkdir()
    (other / "notes.txt").write_text("mine")
    with pytest.raises(MagciliaError, match="is not a batch folder"):
        calibrate_batch(pattern, other, **FAST)
    redone = calibrate_batch(pattern, tmp_path / "out", workers=1, force=True, bias="none",
                             **FAST)
    assert redone.computed == ("hair000", "hair001")


def test_unreachable_scheduler_writes_nothing(tmp_path: Path) -> None:
    pytest.importorskip("distributed")
    write_recordings(tmp_path / "rec", 1)
    with pytest.raises(MagciliaError, match="cannot reach the Dask scheduler"):
        calibrate_batch(str(tmp_path / "rec" / "*.csv"), tmp_path / "out",
                        scheduler="tcp://127.0.0.1:9", timeout=0.5, **FAST)
    assert not (tmp_path / "out").exists()


def test_robust_outliers() -> None:
    z = robust_z([1.0, 1.1, 0.9, 1.0, 1.05, 5.0])
    assert z[-1] > 3.5 and (np.abs(z[:-1]) < 3.5).all()
    assert (robust_z([2.0, 2.0, 2.0, 9.0]) == 0).all()  # MAD 0: nothing flagged
    rows = [{"recording": f"r{i}", "error": "", "cost": 1.0, "height": h, "base_radius": 1.0,
             "x": 0.0, "y": 0.0, "z": 0.0} for i, h in enumerate([3.0, 3.1, 2.9, 3.0, 9.0])]
    rows.append({"recording": "bad", "error": "X: y", "cost": math.nan, "height": math.nan,
                 "base_radius": math.nan, "x": math.nan, "y": math.nan, "z": math.nan})
    stats, outliers = batch_statistics(rows)
    assert stats["height"]["n"] == 5 and stats["height"]["median"] == 3.0
    assert stats["height"]["iqr"] == pytest.approx(0.1) and stats["height"]["max"] == 9.0
    assert [(o["recording"], o["parameter"]) for o in outliers] == [("r4", "height")]


def test_outliers_only_among_the_values_the_data_determine(reference: BatchResult) -> None:
    """Issue 24: recordings of one sensor give any height on an equally good fit (the scale
    symmetry leaves it undetermined): the outlier test skips it and says so, and flags a
    determined value only when its own standard errors say it differs."""
    fitted = [r for r in reference.rows if not r["error"]]
    assert all(not math.isfinite(r["height_stderr"]) for r in fitted)
    assert np.ptp([r["height"] for r in fitted]) > 0.5e-3  # a spread that says nothing
    assert not any(o["parameter"] == "height" for o in reference.outliers)
    assert reference.statistics["height"]["checked"] == 0.0
    assert reference.statistics["height"]["determined"] == 0
    summary = (Path(reference.out) / "summary.md").read_text()
    assert "not checked (undetermined in too many recordings" in summary
    assert "height (6 of 6 undetermined or held)" in summary

    def row(i: int, height: float, h_se: float, x: float, x_se: float) -> dict[str, object]:
        return {"recording": f"r{i}", "error": "", "cost": 1.0, "height": height,
                "height_stderr": h_se, "base_radius": 1.0, "base_radius_stderr": 0.1,
                "x": x, "x_stderr": x_se, "y": 0.0, "y_stderr": 0.1, "z": 0.0, "z_stderr": 0.1}

    # the three recordings: heights 2.03-3.04 mm, undetermined; x determined
    rows = [row(0, 2.03e-3, math.inf, 1.0, 0.01), row(1, 2.5e-3, math.inf, 1.01, 0.01),
            row(2, 3.04e-3, math.nan, 0.99, 0.01), row(3, 2.9e-3, math.inf, 1.0, 0.01),
            row(4, 9.0e-3, math.inf, 1.02, 0.01), row(5, 2.2e-3, math.inf, 1.5, 0.01),
            row(6, 2.4e-3, math.inf, 1.5, 1.0)]
    stats, outliers = batch_statistics(rows)
    assert stats["height"]["checked"] == 0.0 and stats["x"]["checked"] == 1.0
    # r5 lies 50 of its standard errors from the median: flagged; r6 as far by z-score, but
    # its own standard error (1.0) covers the distance: not flagged
    assert [(o["recording"], o["parameter"]) for o in outliers] == [("r5", "x")]
