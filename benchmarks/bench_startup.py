"""Start-up: ``import magcilia``, ``magcilia --help`` and a first ``magcilia calibrate``, each in a
fresh process, against ``import numpy`` (issue 27 item 3).

Each command runs as a new Python process (this interpreter, the tree under test first on
``PYTHONPATH``), the commands interleaved round by round, and its wall time from spawn to exit is
taken; printed are min and median of the rounds and the ratios of the medians to ``import
numpy``'s. The CLI runs as its console script does (``from magcilia.cli import run; run()``).
``calibrate`` fits the bundled example recording and writes its whole folder (setup, result,
report and the two figures) into a new folder each round, once as the command runs (the figures
drawn by its helper process, :mod:`magcilia.report.figure_process`) and once with them drawn
in-process (``MAGCILIA_FIGURE_PROCESS=0``); numba's disk cache and the tree's bytecode are
filled by one untimed run first (a first run ever compiles: that cost is ``bench_field``'s
"first call"; an installed package has its bytecode).

Targets: ``import magcilia`` and ``magcilia --help`` <= 2x ``import numpy``; a first
``magcilia calibrate`` of the example with its figures <= 1 s.

Run: python benchmarks/bench_startup.py [--quick] [--rounds N]
"""

from __future__ import annotations

import argparse
import os
import platform
import resource
import statistics
import subprocess
import sys
import tempfile
import time
from pathlib import Path

SRC = Path(__file__).resolve().parents[1] / "src"
EXAMPLE = SRC / "magcilia" / "data" / "example_recording.csv"
CLI = "from magcilia.cli import run; run()"


def commands(out: Path) -> dict[str, list[str]]:
    """name -> argv of each timed command (``calibrate`` gets ``{round}`` in its folder)."""
    py = sys.executable
    return {
        "python -c pass": [py, "-c", "pass"],
        "import numpy": [py, "-c", "import numpy"],
        "import magcilia": [py, "-c", "import magcilia"],
        "magcilia --help": [py, "-c", CLI, "--help"],
        "magcilia calibrate": [py, "-c", CLI, "-q", "calibrate", str(EXAMPLE), "--out",
                               str(out / "fit-{round}")],
        # the figures always in the command's own process, and always in its helper process
        "  figures in-process": ["env", "MAGCILIA_FIGURE_PROCESS=0", py, "-c", CLI, "-q",
                                 "calibrate", str(EXAMPLE), "--out", str(out / "in-{round}")],
        "  figures in helper": ["env", "MAGCILIA_FIGURE_PROCESS=1", py, "-c", CLI, "-q",
                                "calibrate", str(EXAMPLE), "--out", str(out / "fork-{round}")],
    }


def run_once(argv: list[str], env: dict[str, str]) -> tuple[float, float]:
    """Wall time and CPU time (user + system, its helper process included) in s of one
    process from spawn to exit; its failure ends the benchmark."""
    cpu0 = resource.getrusage(resource.RUSAGE_CHILDREN)
    t0 = time.perf_counter()
    done = subprocess.run(argv, env=env, stdout=subprocess.DEVNULL, stderr=subprocess.PIPE,
                          text=True, check=False)
    elapsed = time.perf_counter() - t0
    cpu1 = resource.getrusage(resource.RUSAGE_CHILDREN)
    if done.returncode != 0:
        raise SystemExit(f"{' '.join(argv)} failed ({done.returncode}): {done.stderr.strip()}")
    return elapsed, cpu1.ru_utime + cpu1.ru_stime - cpu0.ru_utime - cpu0.ru_stime


def machine() -> str:
    """CPU model, cores and Python, for the figures' context."""
    model = platform.processor() or platform.machine()
    try:
        for line in Path("/proc/cpuinfo").read_text().splitlines():
            if line.startswith("model name"):
                model = line.split(":", 1)[1].strip()
                break
    except OSError:
        pass
    return f"{model}, {os.cpu_count()} cores, Python {platform.python_version()}"


def load() -> str:
    try:
        return "load average {:.2f} {:.2f} {:.2f}".format(*os.getloadavg())
    except OSError:
        return "load average unknown"


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--quick", action="store_true", help="3 rounds (a smoke run)")
    parser.add_argument("--rounds", type=int, default=None, help="rounds (default 11)")
    args = parser.parse_args()
    rounds = args.rounds or (3 if args.quick else 11)
    env = {**os.environ, "PYTHONPATH": os.pathsep.join(
        [str(SRC), *filter(None, [os.environ.get("PYTHONPATH")])])}
    env.pop("MPLBACKEND", None)  # (the figures choose Agg themselves)
    # the tree's bytecode written by the untimed run and used, as an installed package has it
    # (PYTHONDONTWRITEBYTECODE=1 would have each command compile magcilia's sources: ~0.1 s)
    env.pop("PYTHONDONTWRITEBYTECODE", None)
    print(f"start-up: fresh processes, interleaved, {rounds} rounds (min, median)")
    print(f"  {machine()}; {load()} before")
    with tempfile.TemporaryDirectory() as tmp:
        out = Path(tmp)
        argvs = commands(out)
        warm = [a.replace("{round}", "warm-up") for a in argvs["magcilia calibrate"]]
        run_once(warm, env)  # numba's disk cache filled (a compile, if any, is not timed)
        times: dict[str, list[float]] = {name: [] for name in argvs}
        cpu: dict[str, list[float]] = {name: [] for name in argvs}
        for r in range(rounds):
            for name, argv in argvs.items():
                wall, used = run_once([a.replace("{round}", str(r)) for a in argv], env)
                times[name].append(wall)
                cpu[name].append(used)
    base = statistics.median(times["import numpy"])
    print(f"  {'':20s} {'min':>7s} {'median':>7s}     {'ratio':>5s}               CPU median")
    for name, t in times.items():
        median = statistics.median(t)
        print(f"  {name:20s} {min(t):7.3f} {median:7.3f} s   {median / base:5.2f}x import numpy  "
              f"{statistics.median(cpu[name]):6.3f} s")
    print(f"  {load()} after")
    ratio_import = statistics.median(times["import magcilia"]) / base
    ratio_help = statistics.median(times["magcilia --help"]) / base
    first = statistics.median(times["magcilia calibrate"])
    print(f"targets: import magcilia {ratio_import:.2f}x and --help {ratio_help:.2f}x import numpy "
          f"(<= 2x); first calibrate {first:.2f} s (<= 1 s)")


if __name__ == "__main__":
    main()
