"""Nothing left behind, nothing foreign removed (``magcilia._atomic``): the partial file of a
killed ``--out FILE`` and the scratch folder of a killed worker are removed by the next run
that writes there (a live run's are kept), ``--force`` replaces only the command's own files
and refuses a folder holding anything else, in one line naming it."""

from __future__ import annotations

import os
import signal
import subprocess
import sys
import time
from pathlib import Path

import numpy as np
import pytest

from magcilia import _atomic
from magcilia._atomic import (
    clear_output,
    foreign_entry,
    partial_file,
    remove_leftovers,
    scratch_directory,
    staged_directory,
    temporary_name,
    write_text,
)
from magcilia._errors import MagciliaError

posix_only = pytest.mark.skipif(sys.platform == "win32", reason="POSIX locks and signals")


def temporaries(folder: Path) -> list[str]:
    return sorted(p.name for p in folder.iterdir() if _atomic.is_temporary(p.name))


def tree(folder: Path) -> dict[str, bytes]:
    """Every file under ``folder`` by relative path, with its bytes."""
    return {str(p.relative_to(folder)): p.read_bytes() for p in sorted(folder.rglob("*"))
            if p.is_file()}


# -- names ------------------------------------------------------------------------------------

def test_temporary_names_keep_the_suffix_and_are_recognised(tmp_path: Path) -> None:
    part = temporary_name(tmp_path / "ro.csv", "partial")
    assert part.parent == tmp_path
    assert part.name.startswith(f".ro.magcilia-partial-{os.getpid()}-")
    assert part.suffix == ".csv"
    staging = temporary_name(tmp_path / "out", "staging")
    assert staging.name.startswith(f".out.magcilia-staging-{os.getpid()}-")
    for name in (part.name, staging.name, ".a.tar.magcilia-partial-1-0123abcd.gz"):
        assert _atomic.is_temporary(name)
    for name in ("ro.csv", ".ro-k2j3h4g5.csv", ".out.magcilia-other-1-00",
                 "x.magcilia-partial-1-0"):
        assert not _atomic.is_temporary(name)


# -- partial files ----------------------------------------------------------------------------

KILLED_WRITER = """
import os, sys
from magcilia._atomic import partial_file
with partial_file(sys.argv[1]) as part:
    part.path.write_bytes(b"half" * 1000)
    print(part.path.name, flush=True)
    os.kill(os.getpid(), 9)
"""


@posix_only
def test_a_killed_write_leaves_a_partial_file_the_next_write_removes(tmp_path: Path) -> None:
    target = tmp_path / "ro.csv"
    target.write_text("earlier")
    child = subprocess.run([sys.executable, "-c", KILLED_WRITER, str(target)],
                           capture_output=True, text=True, check=False)
    assert child.returncode == -signal.SIGKILL
    left = tmp_path / child.stdout.strip()
    assert left.is_file() and left.stat().st_size == 4000
    assert target.read_text() == "earlier"  # never touched
    stranger = tmp_path / ".ro-k2j3h4g5.csv"  # an old-style or someone else's hidden file
    stranger.write_text("mine")
    write_text(tmp_path / "other.txt", "next run")  # any atomic write into the folder
    assert temporaries(tmp_path) == []
    assert stranger.read_text() == "mine" and target.read_text() == "earlier"


@posix_only
def test_a_live_partial_file_is_kept_even_when_old(tmp_path: Path) -> None:
    with partial_file(tmp_path / "ro.csv") as part:
        part.path.write_text("being written")
        old = time.time() - 3600
        os.utime(part.path, (old, old))
        assert remove_leftovers(tmp_path) == []  # locked by this (live) writer
        assert part.path.exists()
    assert temporaries(tmp_path) == []  # not published: removed on leaving


@posix_only
def test_an_unlocked_partial_file_of_a_live_pid_waits_until_stale(tmp_path: Path) -> None:
    young = tmp_path / f".ro.magcilia-partial-{os.getpid()}-0123abcd.csv"
    young.write_text("x")
    assert remove_leftovers(tmp_path) == []  # its process id lives, it is new: kept
    old = time.time() - 2 * _atomic.STALE_AFTER
    os.utime(young, (old, old))
    assert remove_leftovers(tmp_path) == [young]


def test_publish_early_then_keep_writing(tmp_path: Path) -> None:
    """The convention for a stream that replaces a file once its first part is safe: the file
    is published and the writer goes on writing it under the target's name."""
    target = tmp_path / "rec.tdms"
    target.write_text("old recording")
    with partial_file(target) as part, part.path.open("w") as fh:
        fh.write("first chunk\n")
        fh.flush()
        assert target.read_text() == "old recording"
        part.publish()
        fh.write("second chunk\n")
    assert target.read_text() == "first chunk\nsecond chunk\n"
    assert temporaries(tmp_path) == []


def test_an_error_discards_the_partial_file(tmp_path: Path) -> None:
    target = tmp_path / "ro.csv"
    target.write_text("earlier")

    def write_and_fail() -> None:
        with partial_file(target) as part:
            part.path.write_text("half")
            raise RuntimeError("disk full")

    with pytest.raises(RuntimeError, match="disk full"):
        write_and_fail()
    assert target.read_text() == "earlier" and temporaries(tmp_path) == []


KILLED_SCRATCH = """
import os
from magcilia._atomic import scratch_directory
with scratch_directory("batch") as tmp:
    (tmp / "fit.png").write_bytes(b"x" * 100)
    print(tmp.name, flush=True)
    os.kill(os.getpid(), 9)
"""


@posix_only
def test_a_killed_scratch_folder_is_removed_by_the_next(tmp_path: Path,
                                                        monkeypatch: pytest.MonkeyPatch) -> None:
    env = {**os.environ, "TMPDIR": str(tmp_path)}
    child = subprocess.run([sys.executable, "-c", KILLED_SCRATCH], capture_output=True,
                           text=True, env=env, check=False)
    assert child.returncode == -signal.SIGKILL
    assert (tmp_path / child.stdout.strip() / "fit.png").is_file()
    monkeypatch.setattr("tempfile.tempdir", str(tmp_path))
    with scratch_directory("batch") as tmp:
        assert tmp.parent == tmp_path and temporaries(tmp_path) == [tmp.name]
        assert oct(tmp.stat().st_mode & 0o777) == oct(0o700)
    assert list(tmp_path.iterdir()) == []


# -- nothing foreign removed ------------------------------------------------------------------

def batch_like(folder: Path) -> None:
    """A folder as a batch writes it: its own files and one sub-folder per recording."""
    folder.mkdir()
    (folder / "manifest.json").write_text("{}")
    (folder / "results.csv").write_text("a\n")
    for name in ("hair000", "hair001"):
        (folder / name).mkdir()
        (folder / name / "result.json").write_text("{}")
        (folder / name / "batch.json").write_text("{}")


NAMES = ("manifest.json", "results.csv", "summary.md")
INNER = ("result.json", "batch.json", "report.md")


@pytest.mark.parametrize(("where", "shown"), [
    ("notes.txt", "notes.txt"),
    ("hair001/raw.bin", "hair001/raw.bin"),
    ("empty/", "empty/"),
    ("hair000/sub/", "hair000/sub"),
])
def test_a_foreign_entry_is_named_and_nothing_is_removed(tmp_path: Path, where: str,
                                                         shown: str) -> None:
    out = tmp_path / "out"
    batch_like(out)
    path = out / where.rstrip("/")
    if where.endswith("/"):
        path.mkdir()
    else:
        path.write_bytes(b"\x00raw data\xff")
    before = tree(out)
    assert foreign_entry(out, NAMES, INNER) == shown
    with pytest.raises(MagciliaError) as err:
        clear_output(out, NAMES, INNER, out="out")
    assert str(err.value) == (f"out holds {shown!r}, which this command does not write; it "
                              "replaces only its own earlier output (--force too): move that "
                              "away, or choose another --out")
    assert tree(out) == before and (out / "hair000").is_dir()


def test_clear_output_removes_only_its_own(tmp_path: Path) -> None:
    out = tmp_path / "out"
    batch_like(out)
    (out / temporary_name(out / "hair002", "staging").name).mkdir()  # this process's: live
    dead = out / ".results.magcilia-partial-999999999-0123abcd.csv"  # a killed run's
    dead.write_text("half")
    assert foreign_entry(out, NAMES, INNER) is None
    clear_output(out, NAMES, INNER)
    assert [p.name for p in out.iterdir()] == temporaries(out)  # only the live run's is left
    assert not dead.exists()


def test_force_refuses_a_nested_foreign_file(tmp_path: Path) -> None:
    out = tmp_path / "out"
    batch_like(out)
    (out / "hair000" / "notes.txt").write_text("mine")
    before = tree(out)
    with pytest.raises(MagciliaError, match=r"holds 'hair000/notes\.txt'"), \
            staged_directory(out, force=True, names=NAMES, folders=INNER):
        pass
    assert tree(out) == before
    (out / "hair000" / "notes.txt").unlink()
    with staged_directory(out, force=True, names=NAMES, folders=INNER) as tmp:
        (tmp / "results.csv").write_text("new\n")
    assert tree(out) == {"results.csv": b"new\n"}


# -- the command: readout --out killed --------------------------------------------------------

@posix_only
def test_a_killed_readout_leaves_a_partial_file_the_next_run_removes(tmp_path: Path) -> None:
    n = 200_000
    t = np.arange(n) / 1000.0
    np.savetxt(tmp_path / "rec.csv", np.c_[t, 0.01 * np.sin(t)], delimiter=",",
               header="time_s,voltage_V", comments="", fmt="%.6g")
    out = tmp_path / "res" / "ro.csv"
    args = [sys.executable, "-m", "magcilia", "readout", "paper", str(tmp_path / "rec.csv"),
            "--quantity", "angle", "--span", "0:40", "--out", str(out), "--quiet"]
    proc = subprocess.Popen(args, stdout=subprocess.DEVNULL, stderr=subprocess.PIPE)
    deadline = time.monotonic() + 120
    while not (out.parent.is_dir() and temporaries(out.parent)) and proc.poll() is None:
        assert time.monotonic() < deadline
        time.sleep(0.005)
    proc.kill()
    _, err = proc.communicate(timeout=60)
    if proc.returncode == 0:
        pytest.skip("the read-out finished before it could be killed")
    assert proc.returncode == -signal.SIGKILL, err.decode()
    assert not out.exists()
    assert [p.name for p in out.parent.iterdir()] == temporaries(out.parent) != []
    done = subprocess.run(args, capture_output=True, check=False)
    assert done.returncode == 0, done.stderr.decode()
    assert [p.name for p in out.parent.iterdir()] == ["ro.csv"]
    assert len(out.read_text().splitlines()) == n + 1
