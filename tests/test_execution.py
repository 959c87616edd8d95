"""The execution layer (magcilia.execution): the same results in this process, in a local pool of
processes and after a worker is killed; errors kept as results; one retry; one-line errors."""

from __future__ import annotations

import math
import multiprocessing
import os
import re
import shutil
import signal
import socket
import subprocess
import sys
import threading
import time
from pathlib import Path

import pytest

from magcilia._atomic import is_temporary
from magcilia._errors import MagciliaError
from magcilia.cli import main
from magcilia.execution import (
    WATCHDOG_INTERVAL,
    TaskResult,
    one_line,
    resolve_scheduler,
    run_tasks,
)
from magcilia.io import example_path

TASKS = [(f"t{i}", float(i) - 2.0) for i in range(8)]  # two negative: math.sqrt fails


def _values(results: list[TaskResult]) -> list[tuple[str, object, str, int]]:
    return [(r.key, r.value, r.error, r.attempts) for r in results]


def test_serial_keeps_order_errors_and_retries() -> None:
    results = run_tasks(math.sqrt, TASKS, workers=1, progress=False)
    assert [r.key for r in results] == [k for k, _ in TASKS]
    assert [r.value for r in results[2:]] == [math.sqrt(x) for _, x in TASKS[2:]]
    for r in results[:2]:
        assert (r.value, r.error, r.attempts, r.ok) == (
            None, "ValueError: math domain error", 2, False)
    assert all(r.attempts == 1 and r.ok and r.worker == "in-process" for r in results[2:])
    assert run_tasks(math.sqrt, {"x": -1.0}, workers=1, retries=0, progress=False)[0].attempts == 1


def test_pool_equals_serial_and_calls_back_once_per_task() -> None:
    seen: list[str] = []
    pooled = run_tasks(math.sqrt, dict(TASKS), workers=2, progress=False,
                       on_result=lambda r: seen.append(r.key))
    assert _values(pooled) == _values(run_tasks(math.sqrt, TASKS, workers=1, progress=False))
    assert sorted(seen) == sorted(k for k, _ in TASKS)
    assert {r.worker.split("-")[0] for r in pooled} == {"local"}
    assert {r.worker for r in pooled} != {f"local-{os.getpid()}"}


def test_a_killed_worker_loses_and_duplicates_nothing() -> None:
    """SIGKILL one pool process as the first result arrives: the pool is started afresh for the
    unfinished tasks; every task has its one correct result and one callback."""
    tasks = [(f"s{i}", range(i * 1000, i * 1000 + 3_000_000)) for i in range(12)]
    seen: list[str] = []
    killed: list[int] = []

    def kill_one(result: TaskResult) -> None:
        seen.append(result.key)
        if not killed:
            child = multiprocessing.active_children()[0]
            os.kill(child.pid, signal.SIGKILL)  # type: ignore[arg-type]
            killed.append(child.pid)  # type: ignore[arg-type]

    results = run_tasks(sum, tasks, workers=2, progress=False, on_result=kill_one)
    assert killed
    assert [r.value for r in results] == [sum(r) for _, r in tasks]
    assert all(r.ok for r in results)
    assert sorted(seen) == sorted(k for k, _ in tasks)  # once each
    assert len({r.worker for r in results}) >= 3  # the fresh pool's processes ran some


def test_a_worker_that_always_dies_is_reported_failed() -> None:
    results = run_tasks(os._exit, [("a", 3), ("b", 4)], workers=2, progress=False)
    assert [r.ok for r in results] == [False, False]
    assert all(r.error.startswith("BrokenProcessPool: ") and "\n" not in r.error for r in results)


def test_unreachable_scheduler_is_a_one_line_error_within_the_timeout() -> None:
    """The given timeout (1 s) ends the attempt, not Dask's own connect timeout: that is set
    to an hour here, so a run that ignored ours would hang past the 120 s guard (a guard
    against a hang, not a speed check)."""
    pytest.importorskip("distributed")
    import dask

    with socket.socket() as s:  # a port nobody listens on
        s.bind(("127.0.0.1", 0))
        port = s.getsockname()[1]
    raised: list[BaseException] = []

    def attempt() -> None:
        try:
            run_tasks(math.sqrt, TASKS, scheduler=f"tcp://127.0.0.1:{port}", timeout=1.0,
                      progress=False)
        except Exception as exc:  # noqa: BLE001 (kept for the main thread to look at)
            raised.append(exc)

    with dask.config.set({"distributed.comm.timeouts.connect": "3600s"}):
        worker = threading.Thread(target=attempt, daemon=True)
        worker.start()
        worker.join(120)
    assert not worker.is_alive(), "the 1 s timeout was not honoured"
    (err,) = raised
    assert isinstance(err, MagciliaError)
    assert re.search(rf"cannot reach the Dask scheduler at tcp://127\.0\.0\.1:{port} within 1 s",
                     str(err)), err
    assert "\n" not in str(err)


def test_scheduler_from_the_environment(monkeypatch: pytest.MonkeyPatch) -> None:
    monkeypatch.setenv("MAGCILIA_SCHEDULER", "tcp://10.0.0.1:8786")
    assert resolve_scheduler(None) == "tcp://10.0.0.1:8786"
    assert resolve_scheduler("local") == "local"
    monkeypatch.delenv("MAGCILIA_SCHEDULER")
    assert resolve_scheduler(None) is None
    with pytest.raises(MagciliaError, match="scheduler must be a Dask scheduler address"):
        resolve_scheduler("nonsense")


@pytest.mark.parametrize(("tasks", "message"), [
    ([("a", 1), ("a", 2)], "task key must be unique"),
    ([(1, 1)], "task key 0 must be a str"),
    ([("a",)], r"tasks\[0\] must be a \(key, argument\) pair"),
])
def test_bad_tasks(tasks: list[tuple[object, ...]], message: str) -> None:
    with pytest.raises(MagciliaError, match=message):
        run_tasks(math.sqrt, tasks, workers=1, progress=False)  # type: ignore[arg-type]


def test_bad_workers() -> None:
    with pytest.raises(MagciliaError, match="workers must be an integer >= 1; got 0"):
        run_tasks(math.sqrt, TASKS, workers=0)


def test_no_tasks_no_work() -> None:
    assert run_tasks(math.sqrt, [], progress=False) == []


def test_one_line() -> None:
    assert one_line(ValueError("a\n  b")) == "ValueError: a b"
    assert one_line(KeyError()) == "KeyError"
    assert len(one_line(ValueError("x" * 2000))) == 500


def test_workers_hold_blas_and_openmp_to_one_thread() -> None:
    pytest.importorskip("threadpoolctl")
    probe = ("[max([i['num_threads'] for i in __import__('threadpoolctl').threadpool_info()] "
             "or [1]), __import__('os').environ['OMP_NUM_THREADS']]")
    results = run_tasks(eval, [("a", probe), ("b", probe)], workers=2, progress=False)
    assert [r.value for r in results] == [[1, "1"], [1, "1"]]


def test_a_failing_callback_stops_the_run() -> None:
    calls: list[str] = []

    def fail(result: TaskResult) -> None:
        calls.append(result.key)
        raise RuntimeError("disk full")

    tasks = [(f"s{i}", range(2_000_000)) for i in range(40)]
    with pytest.raises(RuntimeError, match="disk full"):
        run_tasks(sum, tasks, workers=2, progress=False, on_result=fail)
    assert calls == calls[:1]  # no result handed on after the failure


@pytest.mark.parametrize("method", sorted(set(multiprocessing.get_all_start_methods())
                                          & {"fork", "forkserver", "spawn"}))
def test_every_start_method_gives_the_serial_results(method: str,
                                                     monkeypatch: pytest.MonkeyPatch) -> None:
    from magcilia.execution import START_ENV, start_method

    monkeypatch.setenv(START_ENV, method)
    assert start_method() == method
    tasks = [(f"t{i}", float(i) - 2.0) for i in range(6)]
    pool = run_tasks(math.sqrt, tasks, workers=2, progress=False)
    serial = run_tasks(math.sqrt, tasks, workers=1, progress=False)
    assert [(r.value, r.error) for r in pool] == [(r.value, r.error) for r in serial]


def test_the_default_start_method_and_a_bad_one(monkeypatch: pytest.MonkeyPatch) -> None:
    import sys

    from magcilia.execution import START_ENV, start_method

    monkeypatch.delenv(START_ENV, raising=False)
    if sys.platform.startswith("linux") and sys.version_info < (3, 12):
        assert start_method() == "fork"  # the workers inherit imports and kernels: fast start
    else:
        assert start_method() in ("forkserver", "spawn")
    monkeypatch.setenv(START_ENV, "teleport")
    with pytest.raises(MagciliaError, match=r"^MAGCILIA_START_METHOD must be one of") as err:
        start_method()
    assert "\n" not in str(err.value)


# -- workers die with their parent ------------------------------------------------------------

ORPHANING = """
import multiprocessing, os, signal, sys, time
from magcilia import execution
if sys.argv[1] == "watchdog":  # as on a system without Linux's parent-death signal
    execution._parent_death_signal = lambda: False
os.environ[execution.START_ENV] = sys.argv[2]

def killed(result):
    print(" ".join(str(p.pid) for p in multiprocessing.active_children()), flush=True)
    os.kill(os.getpid(), signal.SIGKILL)

execution.run_tasks(time.sleep, [("a", 0.0), ("b", 60.0), ("c", 60.0)], workers=2,
                    progress=False, on_result=killed)
"""


def survivors(pids: list[int], within: float) -> list[int]:
    """The processes of ``pids`` still running (not ended, not a zombie) after ``within`` s."""
    psutil = pytest.importorskip("psutil")
    deadline = time.monotonic() + within
    while True:
        alive = []
        for pid in pids:
            try:
                if psutil.Process(pid).status() != psutil.STATUS_ZOMBIE:
                    alive.append(pid)
            except psutil.NoSuchProcess:
                pass
        if not alive or time.monotonic() > deadline:
            return alive
        time.sleep(0.05)


@pytest.mark.skipif(os.name != "posix", reason="SIGKILL")
@pytest.mark.parametrize(("how", "method"), [("prctl", "fork"), ("watchdog", "fork"),
                                             ("watchdog", "forkserver")])
def test_pool_workers_die_with_a_killed_parent(how: str, method: str, tmp_path: Path) -> None:
    if how == "prctl" and not sys.platform.startswith("linux"):
        pytest.skip("the parent-death signal is Linux's")
    if method not in multiprocessing.get_all_start_methods():
        pytest.skip(f"no {method} here")
    out = tmp_path / "stdout.txt"
    with out.open("wb") as fh:  # a file, not a pipe: surviving workers would hold a pipe open
        code = subprocess.run([sys.executable, "-c", ORPHANING, how, method], stdout=fh,
                              timeout=120, check=False).returncode
    workers = [int(p) for p in out.read_text().split()]
    try:
        assert code == -signal.SIGKILL
        assert len(workers) == 2
        # the parent-death signal acts at once; the watchdog within its interval
        alive = survivors(workers, within=5.0 if how == "prctl" else 10 * WATCHDOG_INTERVAL)
    finally:  # a failing test leaves no process behind either
        for pid in survivors(workers, within=0.0):
            os.kill(pid, signal.SIGKILL)
    assert alive == []


@pytest.mark.skipif(os.name != "posix", reason="SIGKILL")
def test_a_killed_batch_leaves_no_worker_and_no_temporary_file(
        tmp_path: Path, monkeypatch: pytest.MonkeyPatch) -> None:
    """`magcilia batch calibrate` killed mid-run: no pool worker survives it; the next run
    (``--force``, other options) leaves no temporary file in the batch or the temp folder."""
    psutil = pytest.importorskip("psutil")
    (tmp_path / "rec").mkdir()
    for i in range(4):
        shutil.copy(example_path(), tmp_path / "rec" / f"hair{i:03d}.csv")
    scratch = tmp_path / "tmp"
    scratch.mkdir()
    out = tmp_path / "out"
    args = ["batch", "calibrate", str(tmp_path / "rec" / "*.csv"), "--out", str(out),
            "--workers", "2", "--no-figures", "--quiet"]
    log = tmp_path / "stderr.txt"
    workers: list[int] = []
    with log.open("wb") as err:  # a file, not a pipe: surviving workers would hold a pipe open
        proc = subprocess.Popen([sys.executable, "-m", "magcilia", *args, "--restarts", "40"],
                                env={**os.environ, "TMPDIR": str(scratch)},
                                stdout=subprocess.DEVNULL, stderr=err)
    try:
        deadline = time.monotonic() + 120
        while len(workers) < 2 and proc.poll() is None:
            assert time.monotonic() < deadline
            time.sleep(0.05)
            workers = [c.pid for c in psutil.Process(proc.pid).children(recursive=True)]
        time.sleep(0.5)  # mid-run: the workers fitting
        proc.kill()
        assert proc.wait(timeout=60) == -signal.SIGKILL, log.read_text()
        assert len(workers) >= 2
        alive = survivors(workers, within=10.0)
    finally:  # a failing test leaves no process behind either
        for pid in survivors(workers, within=0.0):
            os.kill(pid, signal.SIGKILL)
    assert alive == []
    monkeypatch.setattr("tempfile.tempdir", str(scratch))
    assert main([*args, "--restarts", "1", "--starts", "16", "--force"]) == 0
    assert [p for p in out.rglob("*") if is_temporary(p.name)] == []
    assert list(scratch.iterdir()) == []
    assert sorted(p.name for p in out.iterdir() if p.is_dir()) == [
        f"hair{i:03d}" for i in range(4)]
