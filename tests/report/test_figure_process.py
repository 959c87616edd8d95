"""Figures drawn by the helper process (``magcilia.report.figure_process``): the same files as
in-process, failures as one line with no folder left, and the in-process fallback (which every
in-process CLI test of ``calibrate`` runs: a test process has threads and matplotlib).

The child is forked only from a fresh single-threaded process without matplotlib, so each check
runs in a new interpreter (this tree first on the path)."""

from __future__ import annotations

import json
import os
import subprocess
import sys
import time
from pathlib import Path

import numpy as np
import pytest

import magcilia
from magcilia.report import figure_process

SRC = Path(magcilia.__file__).resolve().parents[1]
EXAMPLE = SRC / "magcilia" / "data" / "example_recording.csv"

needs_fork = pytest.mark.skipif(os.name != "posix" or sys.platform == "darwin",
                                reason="the helper process is forked on POSIX but macOS")
#: the helper process wherever forking is safe (unset, it also asks for two CPUs)
FORK = {figure_process.ENVIRONMENT: "1"}


def _run(code: str, **env: str) -> subprocess.CompletedProcess[str]:
    environment = {**os.environ, **env, "PYTHONPATH": os.pathsep.join(
        [str(SRC), *filter(None, [os.environ.get("PYTHONPATH")])])}
    return subprocess.run([sys.executable, "-c", code], capture_output=True, text=True,
                          env=environment, timeout=300, check=False)


_CALIBRATE = """
import json, sys
import magcilia.report.figure_process as fp
forked = []
submit = fp.FigureWriter.submit
def spy(self, task, *args):
    forked.append(self.forked)
    return submit(self, task, *args)
fp.FigureWriter.submit = spy
{patch}
from magcilia.cli import main
code = main(["-q", "calibrate", sys.argv[1], "--out", sys.argv[2]])
print(json.dumps([code, forked]))
"""


def _calibrate(out: Path, patch: str = "", **env: str) -> tuple[int, list[bool], str]:
    done = _run(_CALIBRATE.format(patch=patch).replace("sys.argv[1]", repr(str(EXAMPLE)))
                .replace("sys.argv[2]", repr(str(out))), **FORK, **env)
    assert done.stdout, done.stderr
    code, forked = json.loads(done.stdout.splitlines()[-1])
    return code, forked, done.stderr


@needs_fork
def test_calibrate_draws_its_figures_in_the_helper_process(tmp_path: Path) -> None:
    from PIL import Image

    code, forked, _ = _calibrate(tmp_path / "out")
    assert code == 0 and forked == [True, True]
    names = sorted(p.name for p in (tmp_path / "out").iterdir())
    assert names == ["fit.png", "fitted_setup.toml", "report.md", "residuals.png", "result.json"]
    # the same pixels as drawn in-process from the same result
    from magcilia.calibration import CalibrationResult
    from magcilia.report.calibration import draw_figure, fit_figure

    result = CalibrationResult.load(tmp_path / "out" / "result.json")
    draw_figure(fit_figure, result, [tmp_path / "here.png"], "screen")
    ours = np.asarray(Image.open(tmp_path / "out" / "fit.png"))
    here = np.asarray(Image.open(tmp_path / "here.png"))
    assert ours.shape == here.shape and ours.shape[0] > 500
    assert np.mean(np.any(ours != here, axis=-1)) < 0.01  # (result.json rounds nothing; the
    # title's numbers and the fonts are the same: equal but for antialiasing noise, if any)


@needs_fork
def test_a_failure_in_the_helper_is_one_line_and_leaves_no_folder(tmp_path: Path) -> None:
    patch = ("import magcilia.report.calibration as rc\n"
             "def boom(*args, **kwargs):\n    raise OSError(28, 'No space left on device')\n"
             "rc.save_figure = boom")
    code, forked, err = _calibrate(tmp_path / "out", patch)
    assert code == 2 and forked == [True, True]
    assert err.count("\n") == 1 and err.startswith("magcilia: error: ")
    assert "No space left on device" in err
    assert list(tmp_path.iterdir()) == []  # no folder, no staging remnant


@needs_fork
def test_the_writer_runs_tasks_and_reports_the_first_failure(tmp_path: Path) -> None:
    code = f"""
import os
from magcilia._errors import MagciliaError
from magcilia.report.figure_process import figure_writer
with figure_writer() as writer:
    assert writer.forked
    writer.submit(os.mkdir, {str(tmp_path / "a")!r})
    writer.submit(os.mkdir, {str(tmp_path / "a")!r})  # exists: fails in the child
    writer.submit(os.mkdir, {str(tmp_path / "b")!r})
    try:
        writer.wait()
    except MagciliaError as exc:
        print("error:", exc)
"""
    done = _run(code, **FORK)
    assert done.returncode == 0, done.stderr
    assert done.stdout.startswith("error: [Errno 17] File exists")
    assert sorted(p.name for p in tmp_path.iterdir()) == ["a", "b"]
    assert done.stderr == ""  # the child prints nothing


def test_in_process_without_the_conditions() -> None:
    """Here (a test process: threads, or matplotlib already imported) the writer draws in
    process, and its tasks run at once."""
    import matplotlib  # noqa: F401 (one of the conditions)

    ran: list[int] = []
    with figure_process.figure_writer() as writer:
        assert not writer.forked
        writer.submit(ran.append, 1)
        assert ran == [1]
        writer.wait()


@needs_fork
def test_a_task_that_does_not_pickle_runs_in_process(tmp_path: Path) -> None:
    code = f"""
import os
from magcilia.report.figure_process import figure_writer
with figure_writer() as writer:
    assert writer.forked
    writer.submit(lambda path: os.mkdir(path), {str(tmp_path / "here")!r})
    assert os.path.isdir({str(tmp_path / "here")!r})  # (run at once)
    writer.submit(os.mkdir, {str(tmp_path / "there")!r})
    writer.wait()
"""
    done = _run(code, **FORK)
    assert done.returncode == 0, done.stderr
    assert sorted(p.name for p in tmp_path.iterdir()) == ["here", "there"]


@needs_fork
def test_a_killed_command_leaves_no_helper_behind() -> None:
    """SIGKILL of the command (no clean-up runs in it) ends its helper too: the helper sees the
    pipe end and exits, so nothing keeps the command's stdout and stderr open. (It had kept a
    copy of the parent's end of the pipe, waited for tasks forever, and a caller reading the
    killed command's stderr waited with it.)"""
    code = (
        "import os, signal\n"
        "from magcilia.report.figure_process import figure_writer\n"
        "with figure_writer() as writer:\n"
        "    assert writer.forked\n"
        "    print(writer._process.pid, flush=True)\n"
        "    os.kill(os.getpid(), signal.SIGKILL)\n")
    environment = {**os.environ, **FORK, "PYTHONPATH": os.pathsep.join(
        [str(SRC), *filter(None, [os.environ.get("PYTHONPATH")])])}
    proc = subprocess.Popen([sys.executable, "-c", code], stdout=subprocess.PIPE,
                            stderr=subprocess.PIPE, text=True, env=environment)
    out, err = proc.communicate(timeout=60)  # EOF only once the helper, too, has let go
    assert proc.returncode == -9, err
    helper = int(out.split()[0])
    assert not _alive(helper, seconds=10.0)  # gone (init reaps the orphan)


def _alive(pid: int, seconds: float) -> bool:
    """Whether process ``pid`` still exists after waiting up to ``seconds`` for it to go."""
    for _ in range(int(seconds / 0.05)):
        try:
            os.kill(pid, 0)
        except ProcessLookupError:
            return False
        time.sleep(0.05)
    return True


_WORKERS = """
import os, time
import magcilia.report.figure_process as fp
fp._cpus = lambda: {workers}
from magcilia._errors import MagciliaError
from magcilia.report.figure_process import figure_writer
"""


def _writer_code(workers: int, body: str) -> str:
    """A script that opens a writer whose helper sees ``workers`` CPUs, then runs ``body``
    (tasks defined in it pickle by name: the helper is forked after them)."""
    return _WORKERS.format(workers=workers) + body


_AFTER = """
def after(other, mine, tries):
    for _ in range(tries):  # (0.05 s each: a failure, not a hang, when run one after the other)
        if os.path.exists(other):
            os.mkdir(mine)
            return
        time.sleep(0.05)
    raise RuntimeError("ran alone")
"""


@needs_fork
@pytest.mark.parametrize("workers", [1, 2])
def test_tasks_run_side_by_side_where_there_are_cpus(tmp_path: Path, workers: int) -> None:
    """With two CPUs the tasks run at once (the first waits for a directory only the second
    makes: one after the other, it gives up), and the failures come in the order of the tasks;
    on one CPU they run one after the other in the helper itself (the first gives up after
    0.5 s, never seeing the directory)."""
    tries = 10 if workers == 1 else 1200
    a, b, none = (str(tmp_path / name) for name in ("a", "b", "none"))
    code = _writer_code(workers, _AFTER + f"""
with figure_writer() as writer:
    assert writer.forked
    writer.submit(after, {b!r}, {a!r}, {tries})
    writer.submit(os.mkdir, {b!r})
    writer.submit(os.mkdir, {b!r})  # exists
    writer.submit(os.rmdir, {none!r})  # fails too
    try:
        writer.wait()
    except MagciliaError as exc:
        print("error:", exc)
""")
    done = _run(code, **FORK)
    assert done.returncode == 0, done.stderr
    assert done.stderr == ""  # the helper and its workers print nothing
    if workers == 1:
        assert done.stdout.startswith("error: ran alone"), done.stdout
        assert sorted(p.name for p in tmp_path.iterdir()) == ["b"]
    else:
        assert done.stdout.startswith("error: [Errno 17] File exists"), done.stdout
        assert sorted(p.name for p in tmp_path.iterdir()) == ["a", "b"]


@needs_fork
def test_a_worker_that_dies_is_a_failed_task() -> None:
    code = _writer_code(2, """
import signal
with figure_writer() as writer:
    writer.submit(os.kill, 0, 0)  # (fine)
    writer.submit(os.abort)
    try:
        writer.wait()
    except MagciliaError as exc:
        print("error:", exc)
""")
    done = _run(code, **FORK)
    assert done.returncode == 0, done.stderr
    assert done.stdout.startswith("error: a figure worker ended without a reply"), done.stdout
    assert "MAGCILIA_FIGURE_PROCESS=0" in done.stdout


@needs_fork
@pytest.mark.parametrize("end", ["killed", "error"])
def test_the_workers_end_with_the_command(tmp_path: Path, end: str) -> None:
    """A command killed (SIGKILL) or ending in an error while a worker draws leaves no helper
    and no worker behind."""
    pid_file = tmp_path / "worker.pid"
    finish = ("os.kill(os.getpid(), 9)" if end == "killed"
              else "raise MagciliaError('stop')")
    code = _writer_code(2, f"""
def busy(path):
    with open(path + ".tmp", "w") as f:
        f.write(str(os.getpid()))
    os.rename(path + ".tmp", path)
    time.sleep(120)
with figure_writer() as writer:
    print(writer._process.pid, flush=True)
    writer.submit(busy, {str(pid_file)!r})
    for _ in range(1200):
        if os.path.exists({str(pid_file)!r}):
            break
        time.sleep(0.05)
    {finish}
""")
    environment = {**os.environ, **FORK, "PYTHONPATH": os.pathsep.join(
        [str(SRC), *filter(None, [os.environ.get("PYTHONPATH")])])}
    proc = subprocess.Popen([sys.executable, "-c", code], stdout=subprocess.PIPE,
                            stderr=subprocess.PIPE, text=True, env=environment)
    out, err = proc.communicate(timeout=60)  # EOF only once the helper and workers let go
    assert proc.returncode == (-9 if end == "killed" else 1), err
    helper, worker = int(out.split()[0]), int(pid_file.read_text())
    assert not _alive(helper, seconds=10.0)
    assert not _alive(worker, seconds=10.0)
