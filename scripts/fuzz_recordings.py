"""Fuzz the recording readers: read N mutated recordings and count the outcomes.

Each recording is read by ``magcilia.read_measurements`` in a worker process (warnings are
errors, as in the test suite); a worker that dies is a crash of the reading process and the case
it was on is counted as one. Outcomes: ``ok`` (read), ``MagciliaError`` (one line naming the
file), ``bad message`` (a MagciliaError of several lines or without the file name), ``other``
(any other exception: a bug) and ``crash``. The corpus is ``tests/fuzz/corpus.py`` (seeded: the
same seed and library versions give the same files).

Run: python scripts/fuzz_recordings.py -n 10000 [--seed 0] [--jobs 4] [--format mat]
(the long mode of the test suite is the same: MAGCILIA_FUZZ=long pytest tests/fuzz).
"""

from __future__ import annotations

import argparse
import collections
import importlib.util
import os
import subprocess
import sys
import tempfile
import time
import types
import warnings
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
FORMATS = {"csv": (".csv",), "mat": (".mat",), "tdms": (".tdms",)}


def load_corpus() -> types.ModuleType:
    """``tests/fuzz/corpus.py`` as a module (the tests folder is not a package)."""
    spec = importlib.util.spec_from_file_location("magcilia_fuzz_corpus",
                                                  ROOT / "tests" / "fuzz" / "corpus.py")
    if spec is None or spec.loader is None:
        raise ImportError("cannot load tests/fuzz/corpus.py")
    module = importlib.util.module_from_spec(spec)
    sys.modules[spec.name] = module
    spec.loader.exec_module(module)
    return module


def outcome(corpus: types.ModuleType, path: Path, index: int) -> tuple[str, str]:
    """Read one case: (outcome, detail)."""
    from magcilia import MagciliaError

    try:
        with warnings.catch_warnings():
            warnings.simplefilter("error")
            corpus.read_case(path, index)
    except MagciliaError as exc:
        text = str(exc)
        if "\n" in text or str(path) not in text:
            return "bad message", text[:300].replace("\n", "\\n")
        return "MagciliaError", text[len(str(path)):][:120]
    except Exception as exc:  # noqa: BLE001 (counted: the point of the exercise)
        return "other", f"{type(exc).__name__}: {str(exc)[:200]}".replace("\n", "\\n")
    return "ok", ""


def worker(seed: int, start: int, stop: int, suffixes: tuple[str, ...] | None) -> None:
    """Read cases ``start``…``stop − 1`` and print ``index<TAB>outcome<TAB>detail`` lines."""
    corpus = load_corpus()
    with tempfile.TemporaryDirectory(prefix="magcilia-fuzz-") as tmp:
        for case in corpus.cases(stop - start, seed, suffixes, start=start):
            path = case.write(Path(tmp))
            kind, detail = outcome(corpus, path, case.index)
            path.unlink()
            print(f"{case.index}\t{kind}\t{case.seed_name}\t{detail}", flush=True)


def run(n: int, seed: int, jobs: int, suffixes: tuple[str, ...] | None) -> int:
    """Fuzz ``n`` cases in ``jobs`` workers; print counts per outcome. Returns the exit code."""
    counts: collections.Counter[str] = collections.Counter()
    per_seed: dict[str, collections.Counter[str]] = collections.defaultdict(collections.Counter)
    examples: dict[str, list[str]] = collections.defaultdict(list)
    isolated = 0  # MATLAB reader crashes turned into one line
    step = 250
    todo = [(a, min(a + step, n)) for a in range(0, n, step)]
    active: list[tuple[subprocess.Popen[bytes], int, int, Path]] = []
    t0 = time.monotonic()
    with tempfile.TemporaryDirectory(prefix="magcilia-fuzz-log-") as logs:
        while todo or active:
            while todo and len(active) < jobs:
                a, b = todo.pop(0)
                log = Path(logs) / f"{a}-{b}.txt"
                argv = [sys.executable, __file__, "--worker", "--seed", str(seed), "--start",
                        str(a), "--stop", str(b), "--suffixes", ",".join(suffixes or ())]
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
                    counts[kind] += 1
                    per_seed[name][kind] += 1
                    isolated += "MATLAB reader crashed" in detail
                    if kind != "ok" and (kind != "MagciliaError" or len(examples[kind]) < 3):
                        examples[kind].append(f"case {index} ({name}): {detail}")
                if done < b:  # the worker died on case `done`
                    counts["crash"] += 1
                    examples["crash"].append(f"case {done}: worker exit code {proc.returncode}")
                    if done + 1 < b:
                        todo.insert(0, (done + 1, b))
                print(f"... {sum(counts.values())} of {n} cases, {time.monotonic() - t0:.0f} s",
                      file=sys.stderr, flush=True)
    print(f"{sum(counts.values())} mutated recordings, seed {seed}, "
          f"{time.monotonic() - t0:.0f} s")
    for kind in ("ok", "MagciliaError", "bad message", "other", "crash"):
        print(f"  {kind:14s} {counts[kind]}")
    print(f"  (of the MagciliaErrors, {isolated} are the MATLAB reader's child process "
          "crashing, isolated from this one)")
    print("per seed recording:")
    for name, cnt in sorted(per_seed.items()):
        print(f"  {name:14s} " + ", ".join(f"{k} {c}" for k, c in sorted(cnt.items())))
    for kind, lines in examples.items():
        for text in lines[:10]:
            print(f"  [{kind}] {text}")
    return 1 if counts["other"] or counts["crash"] or counts["bad message"] else 0


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("-n", type=int, default=10_000, help="number of mutated recordings")
    parser.add_argument("--seed", type=int, default=0, help="corpus seed")
    parser.add_argument("--jobs", type=int, default=os.cpu_count() or 1, help="worker processes")
    parser.add_argument("--format", choices=sorted(FORMATS), action="append",
                        help="only this format (repeatable; default all)")
    parser.add_argument("--worker", action="store_true", help=argparse.SUPPRESS)
    parser.add_argument("--start", type=int, default=0, help=argparse.SUPPRESS)
    parser.add_argument("--stop", type=int, default=0, help=argparse.SUPPRESS)
    parser.add_argument("--suffixes", default="", help=argparse.SUPPRESS)
    args = parser.parse_args(argv)
    if args.worker:
        worker(args.seed, args.start, args.stop,
               tuple(args.suffixes.split(",")) if args.suffixes else None)
        return 0
    suffixes = tuple(s for f in args.format for s in FORMATS[f]) if args.format else None
    return run(args.n, args.seed, max(1, args.jobs), suffixes)


if __name__ == "__main__":
    sys.exit(main())
