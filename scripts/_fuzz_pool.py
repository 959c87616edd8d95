"""What the fuzz scripts share: loading a corpus from ``tests/fuzz`` and running its cases in
worker processes that may crash.

A script runs itself with ``--worker --seed S --start A --stop B [extra]`` in up to ``jobs``
processes; each worker prints ``index<TAB>outcome<TAB>name<TAB>detail`` per case. A worker that
dies leaves its last case unprinted: that case is reported as a ``crash`` and the rest of its
range goes to a new worker.
"""

from __future__ import annotations

import importlib.util
import subprocess
import sys
import tempfile
import time
import types
from collections.abc import Iterator
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
#: cases per worker process
STEP = 250


def load_corpus(filename: str) -> types.ModuleType:
    """``tests/fuzz/FILENAME`` as a module (the tests folder is not a package)."""
    path = ROOT / "tests" / "fuzz" / filename
    spec = importlib.util.spec_from_file_location(f"magcilia_fuzz_{path.stem}", path)
    if spec is None or spec.loader is None:
        raise ImportError(f"cannot load tests/fuzz/{filename}")
    module = importlib.util.module_from_spec(spec)
    sys.modules[spec.name] = module
    spec.loader.exec_module(module)
    return module


def run_workers(script: str, n: int, seed: int, jobs: int,
                extra: list[str] | None = None) -> Iterator[tuple[str, str, str, str]]:
    """Run cases 0…n−1 of ``script``'s workers; yield (index, outcome, name, detail) per case,
    ``(index, "crash", "", "worker exit code C")`` for a case that killed its worker."""
    todo = [(a, min(a + STEP, n)) for a in range(0, n, STEP)]
    active: list[tuple[subprocess.Popen[bytes], int, int, Path]] = []
    seen = 0
    t0 = time.monotonic()
    with tempfile.TemporaryDirectory(prefix="magcilia-fuzz-log-") as logs:
        while todo or active:
            while todo and len(active) < jobs:
                a, b = todo.pop(0)
                log = Path(logs) / f"{a}-{b}.txt"
                argv = [sys.executable, script, "--worker", "--seed", str(seed), "--start",
                        str(a), "--stop", str(b), *(extra or [])]
                with log.open("wb") as out:
                    active.append((subprocess.Popen(argv, stdout=out), a, b, log))
            time.sleep(0.1)
            for item in [x for x in active if x[0].poll() is not None]:
                active.remove(item)
                proc, a, b, log = item
                done = a
                for line in log.read_text().splitlines():
                    index, kind, name, detail = line.split("\t", 3)
                    done = int(index) + 1
                    seen += 1
                    yield index, kind, name, detail
                if done < b:  # the worker died on case `done`
                    seen += 1
                    yield str(done), "crash", "", f"worker exit code {proc.returncode}"
                    if done + 1 < b:
                        todo.insert(0, (done + 1, b))
                print(f"... {seen} of {n} cases, {time.monotonic() - t0:.0f} s",
                      file=sys.stderr, flush=True)
