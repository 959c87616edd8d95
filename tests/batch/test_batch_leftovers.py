"""A batch removes nothing it did not write: ``--force`` refuses a folder holding a foreign file
and leaves it byte for byte; a batch whose every recording fails exits with status 2 and one
line; its search effort is bounded before any work. (A SIGKILL of ``magcilia batch calibrate``:
tests/test_execution.py.)"""

from __future__ import annotations

from pathlib import Path

import pytest

from magcilia._atomic import is_temporary
from magcilia._errors import MagciliaError
from magcilia.batch import calibrate_batch
from magcilia.calibration.search import MAX_RESTARTS, MAX_STARTS
from magcilia.cli import main

from .conftest import write_recordings  # type: ignore[import-not-found]

FAST = {"starts": 16, "figures": False, "progress": False}


def tree(folder: Path) -> dict[str, bytes]:
    return {str(p.relative_to(folder)): p.read_bytes() for p in sorted(folder.rglob("*"))
            if p.is_file()}


def temporaries(folder: Path) -> list[Path]:
    return [p for p in folder.rglob("*") if is_temporary(p.name)]


@pytest.fixture
def batch(tmp_path: Path) -> tuple[str, Path]:
    """Two recordings calibrated into tmp_path/out."""
    write_recordings(tmp_path / "rec", 2)
    pattern = str(tmp_path / "rec" / "*.csv")
    calibrate_batch(pattern, tmp_path / "out", workers=1, **FAST)
    return pattern, tmp_path / "out"


@pytest.mark.parametrize("foreign", ["notes.txt", "hair001/raw.bin", "raw/scan.tif"])
@pytest.mark.parametrize("other_options", [True, False], ids=["other-options", "same-options"])
def test_force_refuses_a_folder_holding_a_foreign_file(batch: tuple[str, Path], foreign: str,
                                                       other_options: bool) -> None:
    pattern, out = batch
    path = out / foreign
    path.parent.mkdir(exist_ok=True)
    path.write_bytes(b"\x00the user's data\xff")
    before = tree(out)
    with pytest.raises(MagciliaError, match=rf"holds '{foreign}', which this command does not "
                                            r"write; it replaces only its own"):
        calibrate_batch(pattern, out, workers=1, force=True,
                        **({**FAST, "starts": 8} if other_options else FAST))
    assert tree(out) == before


def test_force_starts_over_removing_only_its_own(batch: tuple[str, Path]) -> None:
    pattern, out = batch
    dead = out / ".hair000.magcilia-staging-999999999-0badc0de"  # a killed run's
    dead.mkdir()
    (dead / "fit.png").write_bytes(b"half")
    redone = calibrate_batch(pattern, out, workers=1, force=True, **{**FAST, "starts": 8})
    assert redone.computed == ("hair000", "hair001") and not temporaries(out)


def test_a_recording_folder_to_redo_must_hold_only_its_files(batch: tuple[str, Path]) -> None:
    pattern, out = batch
    (out / "hair001" / "result.json").unlink()  # to be redone
    (out / "hair001" / "notes.txt").write_text("mine")
    before = tree(out)
    with pytest.raises(MagciliaError, match=r"hair001 holds 'notes\.txt'"):
        calibrate_batch(pattern, out, workers=1, **FAST)
    assert tree(out) == before


def test_every_recording_failing_exits_2(tmp_path: Path,
                                        capsys: pytest.CaptureFixture[str]) -> None:
    for name in ("a", "b"):
        (tmp_path / f"{name}.csv").write_text("time_s,something\n0,1\n")
    args = ["batch", "calibrate", str(tmp_path / "*.csv"), "--out", str(tmp_path / "out"),
            "--workers", "1", "--starts", "8", "--no-figures", "--quiet"]
    assert main(args) == 2
    captured = capsys.readouterr()
    assert captured.err.count("\n") == 1
    assert captured.err.startswith("magcilia: error: all 2 recordings failed, none calibrated "
                                   "(the first, a: ")
    assert "2 failed" in captured.out  # the summary still says what happened
    assert (tmp_path / "out" / "results.csv").is_file()  # each error in the table
    write_recordings(tmp_path / "good", 1)
    assert main([*args[:2], str(tmp_path / "*.csv"), str(tmp_path / "good" / "*.csv"),
                 *args[3:], "--out", str(tmp_path / "out2")]) == 0  # one good: exit 0
    assert "2 of 3 recordings failed" in capsys.readouterr().err


@pytest.mark.parametrize(("option", "limit"), [("--restarts", MAX_RESTARTS),
                                               ("--starts", MAX_STARTS)])
def test_search_effort_is_bounded_before_any_work(tmp_path: Path, option: str, limit: int,
                                                  capsys: pytest.CaptureFixture[str]) -> None:
    write_recordings(tmp_path / "rec", 1)
    args = ["batch", "calibrate", str(tmp_path / "rec" / "*.csv"), "--out",
            str(tmp_path / "out"), "--quiet"]
    assert main([*args, option, str(limit + 1)]) == 2
    err = capsys.readouterr().err
    assert err.count("\n") == 1 and f"at most {limit}" in err
    assert not (tmp_path / "out").exists()
