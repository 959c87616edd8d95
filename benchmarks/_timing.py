"""Timing shared by the benchmarks (run as scripts: ``python benchmarks/bench_*.py``)."""

from __future__ import annotations

import time
from collections.abc import Callable


def interleaved(runs: dict[str, Callable[[], object]], repeat: int) -> dict[str, list[float]]:
    """Wall times (s) of each callable, ``repeat`` rounds, the callables interleaved."""
    times: dict[str, list[float]] = {name: [] for name in runs}
    for _ in range(repeat):
        for name, run in runs.items():
            t0 = time.perf_counter()
            run()
            times[name].append(time.perf_counter() - t0)
    return times


def numpy_reference(fn: Callable[[], object]) -> Callable[[], object]:
    """``fn`` run with magcilia's compiled kernels switched off (its NumPy reference paths: the
    model's and read-outs' kernels, and the fitter's step)."""
    from magcilia.fitting import compiled as fitting_compiled
    from magcilia.model import compiled

    def run() -> object:
        compiled.ENABLED = fitting_compiled.ENABLED = False
        try:
            return fn()
        finally:
            compiled.ENABLED = fitting_compiled.ENABLED = True

    return run
