"""``magcilia batch calibrate``: the folder and table, resuming, and its one-line errors."""

from __future__ import annotations

import importlib.util
import json
import socket
from pathlib import Path

import pandas as pd
import pytest

from magcilia.cli import main

_spec = importlib.util.spec_from_file_location(
    "magcilia_batch_conftest", Path(__file__).parents[1] / "batch" / "conftest.py")
assert _spec is not None and _spec.loader is not None
_conftest = importlib.util.module_from_spec(_spec)
_spec.loader.exec_module(_conftest)
write_recordings = _conftest.write_recordings

FAST = ["--starts", "8", "--no-figures", "--workers", "1", "--quiet"]


def test_batch_calibrate_writes_and_resumes(tmp_path: Path,
                                            capsys: pytest.CaptureFixture[str]) -> None:
    write_recordings(tmp_path / "rec", 3)
    (tmp_path / "rec" / "empty.csv").write_text("")
    out = tmp_path / "out"
    args = ["batch", "calibrate", str(tmp_path / "rec" / "*.csv"), "--out", str(out), *FAST]
    assert main(args) == 0
    captured = capsys.readouterr()
    assert "4 recordings: 3 calibrated, 1 failed; 4 computed now" in captured.out
    assert "height" in captured.out and " mm " in captured.out
    assert "1 of 4 recordings failed" in captured.err
    table = pd.read_csv(out / "results.csv", keep_default_na=False, na_values=[""])
    assert table["recording"].tolist() == ["empty", "hair000", "hair001", "hair002"]
    assert table["error"][0] and table["error"][1:].isna().all()
    assert (table["height"][1:] > 1e-3).all() and (table["height"][1:] < 1e-2).all()  # metres
    assert (out / "results.parquet").is_file() and (out / "summary.md").is_file()
    assert main([*args, "--json"]) == 0
    doc = json.loads(capsys.readouterr().out)
    assert doc["computed"] == ["empty"] and len(doc["skipped"]) == 3
    assert 1.0 < doc["statistics"]["height_mm"]["median"] < 10.0
    assert main([*args, "--json", "--si"]) == 0
    assert doc["statistics"]["height_mm"]["median"] == pytest.approx(
        json.loads(capsys.readouterr().out)["statistics"]["height_m"]["median"] * 1e3)


@pytest.mark.parametrize(("setup", "extra", "message"), [
    ("none", [], "no recording matches"),
    ("dup", [], "two recordings are named 'hair000'"),
    ("foreign", [], "holds another batch (its bias differ); pass --force"),
    ("scheduler", [], "cannot reach the Dask scheduler at tcp://127.0.0.1:"),
])
def test_batch_errors_are_one_line(tmp_path: Path, capsys: pytest.CaptureFixture[str],
                                   setup: str, extra: list[str], message: str) -> None:
    pattern = str(tmp_path / "rec" / "*.csv")
    out = tmp_path / "out"
    more: list[str] = []
    if setup == "dup":
        write_recordings(tmp_path / "rec" / "a", 1)
        write_recordings(tmp_path / "rec" / "b", 1)
        pattern = str(tmp_path / "rec" / "**" / "*.csv")
    elif setup in ("foreign", "scheduler"):
        write_recordings(tmp_path / "rec", 1)
    if setup == "foreign":
        assert main(["batch", "calibrate", pattern, "--out", str(out), *FAST]) == 0
        capsys.readouterr()
        more = ["--bias", "none"]
    if setup == "scheduler":
        pytest.importorskip("distributed")
        with socket.socket() as s:
            s.bind(("127.0.0.1", 0))
            port = s.getsockname()[1]
        more = ["--scheduler", f"tcp://127.0.0.1:{port}", "--timeout", "0.5"]
    code = main(["batch", "calibrate", pattern, "--out", str(out), *FAST, *more, *extra])
    err = capsys.readouterr().err
    assert code == 2
    assert err.startswith("magcilia: error: ") and err.count("\n") == 1
    assert message in err
    if setup != "foreign":
        assert not out.exists()
