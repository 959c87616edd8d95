"""How the ``magcilia`` console script ends (``magcilia.cli.run``): at once when the command is
done, its output flushed and the exit handlers run, without the interpreter's tear-down of the
modules; as usual where another thread still runs. Each check runs the entry point in a new
interpreter (this tree first on the path)."""

from __future__ import annotations

import os
import subprocess
import sys
from pathlib import Path

import magcilia

SRC = Path(magcilia.__file__).resolve().parents[1]

_SCRIPT = """
import atexit, sys, tempfile, threading, time
folder = tempfile.TemporaryDirectory()  # (removed by a finalizer at exit)
print(folder.name, flush=True)
atexit.register(lambda: open({marks!r} + "/atexit", "w").close())
class Torn:
    def __del__(self, _open=open):  # (runs only in the interpreter's tear-down)
        _open({marks!r} + "/torn-down", "w").close()
kept = Torn()
if {thread}:
    def late():
        time.sleep(0.3)
        open({marks!r} + "/thread", "w").close()
    threading.Thread(target=late).start()
sys.argv = ["magcilia", *{argv!r}]
from magcilia.cli import run
run()
"""


def _run(tmp_path: Path, argv: list[str], thread: bool = False
         ) -> tuple[subprocess.CompletedProcess[str], set[str]]:
    marks = tmp_path / "marks"
    marks.mkdir()
    code = _SCRIPT.format(marks=str(marks), thread=thread, argv=argv)
    environment = {**os.environ, "PYTHONPATH": os.pathsep.join(
        [str(SRC), *filter(None, [os.environ.get("PYTHONPATH")])])}
    done = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True,
                          env=environment, timeout=120, check=False)
    folder = Path(done.stdout.splitlines()[0])
    assert not folder.exists()  # the finalizer ran
    return done, {p.name for p in marks.iterdir()}


def test_a_finished_command_ends_at_once_with_its_output_and_exit_handlers(tmp_path: Path
                                                                           ) -> None:
    done, marks = _run(tmp_path, ["field", "--help"])
    assert done.returncode == 0, done.stderr
    assert done.stdout.splitlines()[1].startswith("Usage: magcilia field")
    assert done.stdout.rstrip().endswith("Show this message and exit.")  # all of it
    assert marks == {"atexit"}  # the handlers ran, the modules were not torn down


def test_an_error_keeps_its_code_and_line(tmp_path: Path) -> None:
    done, marks = _run(tmp_path, ["calibrate", str(tmp_path / "none.csv"), "--out",
                                  str(tmp_path / "out")])
    assert done.returncode == 2
    assert done.stderr.count("\n") == 1 and done.stderr.startswith("magcilia: error: ")
    assert marks == {"atexit"}


def test_a_thread_still_running_ends_as_usual(tmp_path: Path) -> None:
    done, marks = _run(tmp_path, ["--version"], thread=True)
    assert done.returncode == 0, done.stderr
    assert magcilia.__version__ in done.stdout
    assert marks == {"atexit", "thread", "torn-down"}  # waited for, then the usual exit
