"""Output files and folders are atomic (``magcilia._atomic``): one rename publishes a folder,
``--force`` replaces one in a step, an existing or unwritable ``--out`` fails before the work,
a failure or a crash at any moment leaves the target absent, old or new and complete (never
mixed), and the next run removes the staging folders that killed runs left.

The SIGKILL test runs ``magcilia demo`` and ``magcilia sensitivity`` as processes and kills them
at seeded random moments: 4 kills per command by default, 20 with ``MAGCILIA_FUZZ=long``.
"""

from __future__ import annotations

import json
import os
import random
import shutil
import signal
import subprocess
import sys
import time
import tomllib
from collections import Counter
from pathlib import Path
from typing import Any

import pytest

from magcilia import _atomic
from magcilia._atomic import remove_leftovers, staged_directory, write_files
from magcilia._errors import MagciliaError
from magcilia.cli import main
from magcilia.io import example_path
from magcilia.report.calibration import CALIBRATION_FILES

AB = ("a.txt", "b.txt")  # the files the tests' outputs hold
posix_only = pytest.mark.skipif(sys.platform == "win32", reason="POSIX renames, locks, signals")


def leftovers(folder: Path) -> list[str]:
    """Staging or trash folders in ``folder``."""
    return sorted(p.name for p in folder.iterdir() if ".magcilia-" in p.name)


def fill(folder: Path, text: str, names: tuple[str, ...] = ("a.txt", "b.txt")) -> None:
    for name in names:
        (folder / name).write_text(text)


def contents(folder: Path) -> dict[str, str]:
    return {p.name: p.read_text() for p in sorted(folder.iterdir())}


def _umask() -> int:
    mask = os.umask(0)
    os.umask(mask)
    return mask


def dead_pid() -> int:
    """The process id of a process that has ended."""
    child = subprocess.Popen([sys.executable, "-c", "pass"])
    child.wait()
    return child.pid


# --- the library: staged_directory -----------------------------------------------------------

def test_a_folder_is_published_with_one_rename(tmp_path: Path,
                                               monkeypatch: pytest.MonkeyPatch) -> None:
    out = tmp_path / "out"
    renames: list[tuple[str, str]] = []
    original = Path.rename

    def spy(self: Path, target: str | os.PathLike[str]) -> Path:
        renames.append((self.name, Path(target).name))
        return original(self, target)

    with staged_directory(out, names=AB) as tmp:
        assert tmp.parent == tmp_path and tmp.name.startswith(".out.magcilia-staging-")
        assert f"-{os.getpid()}-" in tmp.name
        fill(tmp, "new")
        assert not out.exists()
        monkeypatch.setattr(Path, "rename", spy)
    assert renames == [(tmp.name, "out")]
    assert contents(out) == {"a.txt": "new", "b.txt": "new"}
    assert leftovers(tmp_path) == []
    assert out.stat().st_mode & 0o777 == 0o777 & ~_umask()


def test_an_empty_folder_is_replaced_without_force(tmp_path: Path) -> None:
    (tmp_path / "out").mkdir()
    with staged_directory(tmp_path / "out", names=AB) as tmp:
        fill(tmp, "new")
    assert contents(tmp_path / "out") == {"a.txt": "new", "b.txt": "new"}


@posix_only
@pytest.mark.parametrize("exchange", [True, False], ids=["renameat2-exchange", "rename-aside"])
def test_force_replaces_the_whole_folder(tmp_path: Path, monkeypatch: pytest.MonkeyPatch,
                                         exchange: bool) -> None:
    out = tmp_path / "out"
    out.mkdir()
    fill(out, "old", ("a.txt", "stale.png"))
    if not exchange:
        monkeypatch.setattr(_atomic, "_exchange", lambda a, b: False)
    with pytest.raises(MagciliaError, match=r"^\S*out exists; pass --force to replace it"):
        staged_directory(out, names=AB).__enter__()
    with staged_directory(out, force=True, names=("a.txt", "b.txt", "stale.png")) as tmp:
        fill(tmp, "new")
        assert contents(out) == {"a.txt": "old", "stale.png": "old"}
    assert contents(out) == {"a.txt": "new", "b.txt": "new"}  # no stale file from the old run
    assert leftovers(tmp_path) == []


def test_exchange_is_used_on_linux(tmp_path: Path) -> None:
    if not sys.platform.startswith("linux"):
        pytest.skip("renameat2 is Linux only")
    a, b = tmp_path / "a", tmp_path / "b"
    a.mkdir()
    b.mkdir()
    (a / "in-a").touch()
    if not _atomic._exchange(a, b):
        pytest.skip("this file system has no RENAME_EXCHANGE")
    assert (b / "in-a").exists() and not (a / "in-a").exists()


def test_force_replaces_only_an_earlier_output(tmp_path: Path,
                                               monkeypatch: pytest.MonkeyPatch) -> None:
    out = tmp_path / "data"
    out.mkdir()
    fill(out, "precious", ("run.csv",))
    with pytest.raises(MagciliaError, match=r"holds 'run\.csv', which this command does not write"):
        staged_directory(out, force=True, names=("a.txt",)).__enter__()
    (out / "run.csv").unlink()
    (out / "sub").mkdir()
    with pytest.raises(MagciliaError, match="holds 'sub'"):
        staged_directory(out, force=True, names=("sub",)).__enter__()
    monkeypatch.chdir(out)
    for here in (".", ".."):
        with pytest.raises(MagciliaError, match="not the current folder or one above it"):
            staged_directory(here, force=True, names=AB).__enter__()
    assert (out / "sub").is_dir() and leftovers(tmp_path) == []


def test_a_file_in_the_way_is_an_error(tmp_path: Path) -> None:
    (tmp_path / "f").write_text("x")
    with pytest.raises(MagciliaError, match="f is a file, not a folder"):
        staged_directory(tmp_path / "f", force=True, names=AB).__enter__()
    with pytest.raises(MagciliaError, match=r"cannot write --out .*f is a file, not a folder"):
        staged_directory(tmp_path / "f" / "out", names=AB).__enter__()
    assert sorted(p.name for p in tmp_path.iterdir()) == ["f"]


@pytest.mark.parametrize("existing", [False, True], ids=["absent", "existing"])
def test_a_failure_mid_write_leaves_the_target_as_it_was(tmp_path: Path, existing: bool) -> None:
    out = tmp_path / "new" / "deeper" / "out"
    if existing:
        out.mkdir(parents=True)
        fill(out, "old")
    def write_and_fail() -> None:
        with staged_directory(out, force=True, names=AB) as tmp:
            (tmp / "a.txt").write_text("new")
            raise OSError("disk full")

    with pytest.raises(OSError, match="disk full"):
        write_and_fail()
    if existing:
        assert contents(out) == {"a.txt": "old", "b.txt": "old"}
        assert leftovers(out.parent) == []
    else:
        assert list(tmp_path.iterdir()) == []  # the parents it made are gone too


@posix_only
def test_a_failing_second_rename_restores_the_old_folder(tmp_path: Path,
                                                         monkeypatch: pytest.MonkeyPatch) -> None:
    out = tmp_path / "out"
    out.mkdir()
    fill(out, "old")
    monkeypatch.setattr(_atomic, "_exchange", lambda a, b: False)
    original = Path.rename

    def flaky(self: Path, target: str | os.PathLike[str]) -> Path:
        if ".magcilia-staging-" in self.name and Path(target) == out:
            raise OSError("I/O error")
        return original(self, target)

    monkeypatch.setattr(Path, "rename", flaky)
    with (pytest.raises(OSError, match="I/O error"),
          staged_directory(out, force=True, names=AB) as tmp):
        fill(tmp, "new")
    assert contents(out) == {"a.txt": "old", "b.txt": "old"}
    assert leftovers(tmp_path) == []


@posix_only
def test_stale_staging_folders_are_removed_live_ones_kept(tmp_path: Path) -> None:
    pid = dead_pid()
    with staged_directory(tmp_path / "out", names=AB) as live:  # a concurrent run, mid-work
        old = time.time() - 3600
        os.utime(live, (old, old))  # old, its process id alive, but locked: kept
        dead = tmp_path / f".out.magcilia-staging-{pid}-0badc0de"  # left by a killed run
        trash = tmp_path / f".other.magcilia-trash-{pid}-00ff"
        for folder in (dead, trash):
            folder.mkdir()
            fill(folder, "half")
        young = tmp_path / f".out.magcilia-staging-{os.getpid()}-0123"  # alive, just made: kept
        young.mkdir()
        stranger = tmp_path / ".out.something-else-1-23"
        stranger.mkdir()
        assert sorted(remove_leftovers(tmp_path)) == sorted([dead, trash])
        assert live.is_dir() and young.is_dir() and stranger.is_dir()
        fill(live, "new")
    assert contents(tmp_path / "out") == {"a.txt": "new", "b.txt": "new"}
    os.utime(young, (time.time() - 3600,) * 2)  # unlocked and old: its process id was reused
    with staged_directory(tmp_path / "out2", names=AB) as tmp:  # the next run removes it
        fill(tmp, "new")
    assert leftovers(tmp_path) == []
    assert stranger.is_dir()


# --- crashes at each step of the publication -------------------------------------------------

CRASH = """
import os, sys
from pathlib import Path
from magcilia import _atomic

out, step = Path(sys.argv[1]), sys.argv[2]
exchange, rename = _atomic._exchange, Path.rename

def crash_after_exchange(a, b):
    exchange(a, b)
    os._exit(9)

def crash_in_fallback(self, target):
    if step == "aside" and ".magcilia-staging-" in self.name and not out.exists():
        os._exit(9)  # the old folder is aside, the new not yet in
    result = rename(self, target)
    if step == "fallback-done" and ".magcilia-staging-" in self.name:
        os._exit(9)  # the new folder is in, the old one not yet removed
    return result

if step == "exchange":
    _atomic._exchange = crash_after_exchange
elif step in ("aside", "fallback-done"):
    _atomic._exchange = lambda a, b: False
    Path.rename = crash_in_fallback
with _atomic.staged_directory(out, force=True, names=("a.txt", "b.txt")) as tmp:
    (tmp / "a.txt").write_text("new")
    if step == "work":
        os._exit(9)
    (tmp / "b.txt").write_text("new")
"""


@posix_only
@pytest.mark.parametrize(
    ("step", "expected"),
    [("work", "old"), ("exchange", "new"), ("aside", None), ("fallback-done", "new")],
)
def test_a_crash_at_each_step_leaves_no_mixed_folder(tmp_path: Path, step: str,
                                                     expected: str | None) -> None:
    if step == "exchange" and not _atomic._exchange(tmp_path, tmp_path):
        pytest.skip("no RENAME_EXCHANGE here")
    out = tmp_path / "out"
    out.mkdir()
    fill(out, "old")
    code = subprocess.run([sys.executable, "-c", CRASH, str(out), step],
                          check=False).returncode
    assert code == 9
    if expected is None:
        assert not out.exists()
    else:
        assert contents(out) == {"a.txt": expected, "b.txt": expected}
    with staged_directory(out, force=True, names=AB) as tmp:  # the next run
        fill(tmp, "next")
    assert contents(out) == {"a.txt": "next", "b.txt": "next"}
    assert leftovers(tmp_path) == []


# --- the commands ----------------------------------------------------------------------------

def _no_work(*args: object, **kwargs: object) -> None:
    raise AssertionError("the work started")


COMMANDS = {
    "demo": (["demo", "--quiet"], "magcilia.cli.demo.calibrate_with_progress"),
    "calibrate": (["calibrate", str(example_path()), "--quiet"],
                  "magcilia.cli.calibrate.calibrate_with_progress"),
    "sensitivity": (["sensitivity", "--setup", "paper", "--quiet"],
                    "magcilia.cli.sensitivity.sensitivity_study"),
}


@pytest.mark.parametrize("command", list(COMMANDS))
def test_an_existing_out_is_refused_before_the_work(tmp_path: Path, command: str,
                                                    monkeypatch: pytest.MonkeyPatch,
                                                    capsys: pytest.CaptureFixture[str]) -> None:
    args, work = COMMANDS[command]
    monkeypatch.setattr(work, _no_work)
    out = tmp_path / "out"
    out.mkdir()
    (out / "report.md").write_text("old")
    assert main([*args, "--out", str(out)]) == 2
    err = capsys.readouterr().err
    assert err == (f"magcilia: error: {out} exists; pass --force to replace it, or choose another "
                   "--out\n")
    assert contents(out) == {"report.md": "old"} and leftovers(tmp_path) == []


@pytest.mark.parametrize("command", list(COMMANDS))
def test_an_unwritable_out_fails_before_the_work(tmp_path: Path, command: str,
                                                 monkeypatch: pytest.MonkeyPatch,
                                                 capsys: pytest.CaptureFixture[str]) -> None:
    args, work = COMMANDS[command]
    monkeypatch.setattr(work, _no_work)
    (tmp_path / "file").write_text("x")
    assert main([*args, "--out", str(tmp_path / "file" / "out")]) == 2
    err = capsys.readouterr().err
    assert err.count("\n") == 1 and "is a file, not a folder" in err
    if sys.platform != "win32" and os.geteuid() != 0:  # root writes anywhere
        locked = tmp_path / "locked"
        locked.mkdir(mode=0o500)
        assert main([*args, "--out", str(locked / "out")]) == 2
        err = capsys.readouterr().err
        assert err.count("\n") == 1 and "ermission denied" in err
    else:  # the same early check, the staging folder's mkdir made to fail
        mkdir = Path.mkdir

        def refuse(self: Path, *a: Any, **k: Any) -> None:
            if ".magcilia-staging-" in self.name:
                raise PermissionError(13, "Permission denied", str(self))
            mkdir(self, *a, **k)

        monkeypatch.setattr(Path, "mkdir", refuse)
        assert main([*args, "--out", str(tmp_path / "out")]) == 2
        err = capsys.readouterr().err
        assert err.count("\n") == 1 and "cannot write --out" in err
        assert "Permission denied" in err


def test_calibrate_force_replaces_an_earlier_output(tmp_path: Path,
                                                    capsys: pytest.CaptureFixture[str]) -> None:
    out = tmp_path / "fit"
    out.mkdir()
    (out / "fit.png").write_text("stale")  # an earlier, different output
    (out / "residuals.png").write_text("stale")
    args = ["calibrate", str(example_path()), "--setup", "paper", "--out", str(out), "--quiet",
            "--bound", "height=3.2613:3.2613", "--bound", "base_radius=0.1801:0.1801",
            "--bound", "n_loops=2:2", "--bound", "dipoles_per_loop=5:5", "--restarts", "1",
            "--force"]
    assert main(args) == 0
    capsys.readouterr()
    assert sorted(p.name for p in out.iterdir()) == sorted(CALIBRATION_FILES)
    assert (out / "fit.png").read_bytes().startswith(b"\x89PNG")
    assert leftovers(tmp_path) == []


def test_field_writes_no_file_when_the_plot_fails(tmp_path: Path,
                                                  capsys: pytest.CaptureFixture[str]) -> None:
    csv_path, js = tmp_path / "t.csv", tmp_path / "t.json"
    assert main(["field", "--setup", "paper", "--csv", str(csv_path), "--json-file", str(js),
                 "--plot", str(tmp_path / "f.xyz")]) == 2
    err = capsys.readouterr().err
    assert err.count("\n") == 1 and "--plot must be a figure file" in err
    (tmp_path / "file").write_text("x")
    csv_path.write_text("old")
    assert main(["field", "--setup", "paper", "--csv", str(csv_path), "--json-file", str(js),
                 "--plot", str(tmp_path / "file" / "f.png"), "--force"]) == 2
    err = capsys.readouterr().err
    assert err.count("\n") == 1 and "is a file, not a folder" in err
    assert csv_path.read_text() == "old" and not js.exists()
    assert sorted(p.name for p in tmp_path.iterdir()) == ["file", "t.csv"]


def test_write_files_writes_all_or_none(tmp_path: Path) -> None:
    (tmp_path / "blocker").write_text("x")
    with pytest.raises(MagciliaError):
        write_files({tmp_path / "a.txt": "a", tmp_path / "blocker" / "b.txt": b"b"})
    assert sorted(p.name for p in tmp_path.iterdir()) == ["blocker"]
    write_files({tmp_path / "a.txt": "a", tmp_path / "b.bin": b"b"})
    assert (tmp_path / "a.txt").read_text() == "a" and (tmp_path / "b.bin").read_bytes() == b"b"


# --- SIGKILL at random moments ---------------------------------------------------------------

def png_complete(data: bytes) -> bool:
    return data.startswith(b"\x89PNG\r\n\x1a\n") and data.endswith(b"IEND\xaeB`\x82")


def check_complete(out: Path, expected: set[str]) -> None:
    """Every expected file present (no other) and parseable."""
    assert {p.name for p in out.iterdir()} == expected, f"{out} is not complete"
    for path in out.iterdir():
        if path.suffix == ".json":
            json.loads(path.read_text())
        elif path.suffix == ".toml":
            tomllib.loads(path.read_text())
        elif path.suffix == ".png":
            assert png_complete(path.read_bytes()), path
        else:
            assert path.read_text().strip(), path


FUZZ = {
    "demo": (["demo", "--quiet"], set(CALIBRATION_FILES)),
    "sensitivity": (["sensitivity", "paper", "--points", "3", "--map-points", "3",
                     "--sobol-base", "0", "--quiet"],
                    {"fig09_xy.png", "fig10_z.png", "fig11_nk.png", "fig12_geometry.png",
                     "xy_map.png", "sensitivity.json", "summary.md"}),
}


def sigkill_fuzz(tmp_path: Path, command: str, kills: int, seed: int,
                 magcilia: Any) -> Counter[str]:
    """Run the command to completion (its duration T), then ``kills`` times killed at a seeded
    random moment in (0.1 T, 1.1 T), alternately onto an absent target and with --force onto a
    complete one; after each kill the target is absent or complete. A last complete run leaves no
    staging folder. Returns how the kills landed."""
    args, expected = FUZZ[command]
    out = tmp_path / "out"
    env = magcilia.env(MPLBACKEND="Agg")

    def start() -> subprocess.Popen[bytes]:
        return subprocess.Popen([*magcilia.argv, *args, "--out", str(out), "--force"],
                                stdout=subprocess.DEVNULL, stderr=subprocess.PIPE, env=env)

    began = time.perf_counter()
    proc = start()
    _, err = proc.communicate(timeout=120)
    assert proc.returncode == 0, err.decode()
    duration = time.perf_counter() - began
    check_complete(out, expected)
    reference = shutil.copytree(out, tmp_path / "reference")
    rng = random.Random(seed)
    outcomes: Counter[str] = Counter()
    for i in range(kills):
        if i % 2 == 0 and out.exists():
            shutil.rmtree(out)
        elif i % 2 == 1 and not out.exists():
            shutil.copytree(reference, out)
        delay = rng.uniform(0.1, 1.1) * duration
        onto = "replacing" if out.exists() else "new"
        proc = start()
        time.sleep(delay)
        proc.kill()
        _, err = proc.communicate(timeout=60)
        assert proc.returncode in (0, -signal.SIGKILL), err.decode()
        state = "complete" if out.exists() else "absent"
        if out.exists():
            check_complete(out, expected)
        ended = "finished" if proc.returncode == 0 else "killed"
        outcomes[f"{ended}, {onto}: {state}"] += 1
        outcomes[f"staging left: {bool(leftovers(tmp_path))}"] += 1
    proc = start()
    _, err = proc.communicate(timeout=120)
    assert proc.returncode == 0, err.decode()
    check_complete(out, expected)
    assert leftovers(tmp_path) == []
    print(f"{command}: T = {duration:.2f} s, {dict(sorted(outcomes.items()))}")
    return outcomes


@posix_only
@pytest.mark.parametrize("command", list(FUZZ))
def test_sigkill_at_random_moments(tmp_path: Path, command: str, magcilia_command: Any) -> None:
    sigkill_fuzz(tmp_path, command, kills=4, seed=12, magcilia=magcilia_command)


@posix_only
@pytest.mark.skipif(os.environ.get("MAGCILIA_FUZZ") != "long",
                    reason="20 SIGKILLs per command take minutes: set MAGCILIA_FUZZ=long")
@pytest.mark.parametrize("command", list(FUZZ))
def test_sigkill_at_random_moments_long(tmp_path: Path, command: str,
                                        magcilia_command: Any) -> None:
    sigkill_fuzz(tmp_path, command, kills=20, seed=2024, magcilia=magcilia_command)
