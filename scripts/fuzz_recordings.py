"""Fuzz the recording readers: read N mutated recordings and count the outcomes.

Each recording is read by ``magcilia.read_measurements`` in a worker process (warnings are
errors, as in the test suite); a worker that dies is a crash of the reading process and the case
it was on is counted as one. Outcomes: ``ok`` (read), ``MagciliaError`` (one line naming the
file), ``bad message`` (a MagciliaError of several lines or without the file name), ``other``
(any other exception: a bug) and ``crash``. The corpus is ``tests/fuzz/corpus.py`` (seeded: the
same seed and library versions give the same files).

With ``--values`` each recording read is also compared with its seed (``corpus.check_case``):
``same`` (the values written), ``noted`` (other values, and the measurement says something is
off), ``silent`` (other values, nothing said: what must not happen) or ``refused``; for TDMS the
changes are split by where the mutations fell (``structure``: lead-ins, metadata, lengths;
``data``: the change comes from bytes of raw data changed in place, which a format without
checksums cannot tell from a measurement: the raw-data changes alone, applied to the seed, read
the same).

Run: python scripts/fuzz_recordings.py -n 10000 [--seed 0] [--jobs 4] [--format mat] [--values]
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
from typing import Any

from _fuzz_pool import load_corpus, run_workers

FORMATS = {"csv": (".csv",), "mat": (".mat",), "tdms": (".tdms",)}


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


def value_outcome(corpus: types.ModuleType, path: Path, case: Any) -> tuple[str, str]:
    """Read one case and compare it with its seed: (outcome[:structure|:data], detail)."""
    try:
        with warnings.catch_warnings():
            warnings.simplefilter("error")
            kind, detail = corpus.check_case(path, case.index, case.seed_name)
    except Exception as exc:  # noqa: BLE001 (counted: the point of the exercise)
        return "other", f"{type(exc).__name__}: {str(exc)[:200]}".replace("\n", "\\n")
    if kind in ("noted", "silent") and case.suffix == ".tdms":
        kind += ":structure" if corpus.touches_structure(case, path.parent) else ":data"
    return kind, detail.replace("\n", "\\n").replace("\t", " ")


def worker(seed: int, start: int, stop: int, suffixes: tuple[str, ...] | None,
           values: bool = False) -> None:
    """Read cases ``start``…``stop − 1`` and print ``index<TAB>outcome<TAB>detail`` lines."""
    corpus = load_corpus("corpus.py")
    with tempfile.TemporaryDirectory(prefix="magcilia-fuzz-") as tmp:
        for case in corpus.cases(stop - start, seed, suffixes, start=start):
            path = case.write(Path(tmp))
            kind, detail = (value_outcome(corpus, path, case) if values
                            else outcome(corpus, path, case.index))
            path.unlink()
            print(f"{case.index}\t{kind}\t{case.seed_name}\t{detail}", flush=True)


def run(n: int, seed: int, jobs: int, suffixes: tuple[str, ...] | None,
        values: bool = False) -> int:
    """Fuzz ``n`` cases in ``jobs`` workers; print counts per outcome. Returns the exit code
    (1 for any crash, other exception, bad message or, with ``values``, silent change)."""
    counts: collections.Counter[str] = collections.Counter()
    per_seed: dict[str, collections.Counter[str]] = collections.defaultdict(collections.Counter)
    examples: dict[str, list[str]] = collections.defaultdict(list)
    isolated = 0  # MATLAB reader crashes turned into one line
    t0 = time.monotonic()
    extra = ["--suffixes", ",".join(suffixes or ())] + (["--values"] if values else [])
    for index, kind, name, detail in run_workers(__file__, n, seed, jobs, extra):
        if kind == "crash":
            counts["crash"] += 1
            examples["crash"].append(f"case {index}: {detail}")
            continue
        counts[kind] += 1
        per_seed[name][kind] += 1
        isolated += "MATLAB reader crashed" in detail
        if kind not in ("ok", "same") and (kind not in ("MagciliaError", "refused")
                                           or len(examples[kind]) < 3):
            examples[kind].append(f"case {index} ({name}): {detail}")
    print(f"{sum(counts.values())} mutated recordings, seed {seed}, "
          f"{time.monotonic() - t0:.0f} s")
    kinds = (("refused", "same", "noted:structure", "noted:data", "noted", "silent:structure",
              "silent:data", "silent") if values else ("ok", "MagciliaError", "bad message"))
    for kind in (*kinds, "other", "crash"):
        if kind in counts or kind in ("other", "crash") or not values:
            print(f"  {kind:16s} {counts[kind]}")
    print(f"  (of the MagciliaErrors, {isolated} are the MATLAB reader's child process "
          "crashing, isolated from this one)")
    print("per seed recording:")
    for name, cnt in sorted(per_seed.items()):
        print(f"  {name:14s} " + ", ".join(f"{k} {c}" for k, c in sorted(cnt.items())))
    for kind, lines in examples.items():
        for text in lines[:10]:
            print(f"  [{kind}] {text}")
    silent = sum(c for k, c in counts.items() if k.startswith("silent"))
    return 1 if counts["other"] or counts["crash"] or counts["bad message"] or silent else 0


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("-n", type=int, default=10_000, help="number of mutated recordings")
    parser.add_argument("--seed", type=int, default=0, help="corpus seed")
    parser.add_argument("--jobs", type=int, default=os.cpu_count() or 1, help="worker processes")
    parser.add_argument("--format", choices=sorted(FORMATS), action="append",
                        help="only this format (repeatable; default all)")
    parser.add_argument("--values", action="store_true",
                        help="also compare what is read with what was written")
    parser.add_argument("--worker", action="store_true", help=argparse.SUPPRESS)
    parser.add_argument("--start", type=int, default=0, help=argparse.SUPPRESS)
    parser.add_argument("--stop", type=int, default=0, help=argparse.SUPPRESS)
    parser.add_argument("--suffixes", default="", help=argparse.SUPPRESS)
    args = parser.parse_args(argv)
    if args.worker:
        worker(args.seed, args.start, args.stop,
               tuple(args.suffixes.split(",")) if args.suffixes else None, args.values)
        return 0
    suffixes = tuple(s for f in args.format for s in FORMATS[f]) if args.format else None
    return run(args.n, args.seed, max(1, args.jobs), suffixes, args.values)


if __name__ == "__main__":
    sys.exit(main())
