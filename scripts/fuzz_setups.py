"""Fuzz the setup-file reader and the checked model: load N mutated setup files, count outcomes.

Each file goes through ``check_file`` of ``tests/fuzz/setup_corpus.py`` in a worker process
(warnings are errors, as in the test suite): ``magcilia.load_setup``, then ``output([0, 0.5])``,
then ``save_setup`` and ``load_setup`` again. A worker that dies is a crash of that process and
the case it was on is counted as one. Outcomes: ``loaded`` (finite output, saved and read back),
``refused`` (a one-line MagciliaError naming the file), ``model refused`` (loaded; the output
raised a one-line MagciliaError), ``save refused`` (loaded; save_setup refused it in one line),
``bad`` (a NaN output, a message of several lines or without the file name, a save/load
mismatch), ``traceback`` (any other exception: a bug) and ``crash``. The corpus is seeded: the
same seed and library versions give the same files.

Run: python scripts/fuzz_setups.py -n 5000 [--seed 0] [--jobs 4]
(the long mode of the test suite is the same: MAGCILIA_FUZZ=long pytest tests/fuzz).
"""

from __future__ import annotations

import argparse
import collections
import os
import sys
import tempfile
import time
import types
import warnings
from pathlib import Path

from _fuzz_pool import load_corpus, run_workers

KINDS = ("loaded", "refused", "model refused", "save refused", "bad", "traceback", "crash")


def outcome(corpus: types.ModuleType, path: Path) -> tuple[str, str]:
    """Check one case: (outcome, detail)."""
    try:
        with warnings.catch_warnings():
            warnings.simplefilter("error")
            return corpus.check_file(path), ""
    except AssertionError as exc:
        return "bad", str(exc)[:300].replace("\n", "\\n")
    except Exception as exc:  # noqa: BLE001 (counted: the point of the exercise)
        return "traceback", f"{type(exc).__name__}: {str(exc)[:200]}".replace("\n", "\\n")


def worker(seed: int, start: int, stop: int) -> None:
    """Check cases ``start``…``stop − 1``; print ``index<TAB>outcome<TAB>seed<TAB>detail``."""
    corpus = load_corpus("setup_corpus.py")
    with tempfile.TemporaryDirectory(prefix="magcilia-fuzz-") as tmp:
        for case in corpus.cases(stop - start, seed, start=start):
            path = case.write(Path(tmp))
            kind, detail = outcome(corpus, path)
            path.unlink()
            mutations = "+".join(case.mutations)
            print(f"{case.index}\t{kind}\t{case.seed_name}:{mutations}\t{detail}", flush=True)


def run(n: int, seed: int, jobs: int) -> int:
    """Fuzz ``n`` cases in ``jobs`` workers; print counts per outcome. Returns the exit code."""
    counts: collections.Counter[str] = collections.Counter()
    per_mutation: dict[str, collections.Counter[str]] = collections.defaultdict(
        collections.Counter)
    examples: dict[str, list[str]] = collections.defaultdict(list)
    t0 = time.monotonic()
    for index, kind, name, detail in run_workers(__file__, n, seed, jobs, None):
        if kind == "crash":
            counts["crash"] += 1
            examples["crash"].append(f"case {index}: {detail}")
            continue
        counts[kind] += 1
        for mutation in set(name.split(":", 1)[1].split("+")):
            per_mutation[mutation][kind] += 1
        if kind not in ("loaded", "refused") or len(examples[kind]) < 3:
            examples[kind].append(f"case {index} ({name}): {detail}")
    print(f"{sum(counts.values())} mutated setup files, seed {seed}, "
          f"{time.monotonic() - t0:.0f} s")
    for kind in KINDS:
        print(f"  {kind:14s} {counts[kind]}")
    print("per mutation (a case counts once for each mutation applied):")
    for name, cnt in sorted(per_mutation.items()):
        print(f"  {name:14s} " + ", ".join(f"{k} {c}" for k, c in sorted(cnt.items())))
    for kind, lines in examples.items():
        for text in lines[:10]:
            print(f"  [{kind}] {text}")
    return 1 if counts["bad"] or counts["traceback"] or counts["crash"] else 0


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("-n", type=int, default=5_000, help="number of mutated setup files")
    parser.add_argument("--seed", type=int, default=0, help="corpus seed")
    parser.add_argument("--jobs", type=int, default=os.cpu_count() or 1, help="worker processes")
    parser.add_argument("--worker", action="store_true", help=argparse.SUPPRESS)
    parser.add_argument("--start", type=int, default=0, help=argparse.SUPPRESS)
    parser.add_argument("--stop", type=int, default=0, help=argparse.SUPPRESS)
    args = parser.parse_args(argv)
    if args.worker:
        worker(args.seed, args.start, args.stop)
        return 0
    return run(args.n, args.seed, max(1, args.jobs))


if __name__ == "__main__":
    sys.exit(main())
