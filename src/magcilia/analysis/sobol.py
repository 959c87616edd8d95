"""Global sensitivity: first- and total-order Sobol indices over the calibration bounds with
SALib (Saltelli/Sobol sampling, Jansen/Saltelli estimators, bootstrap confidence intervals) and
magcilia's batch evaluation (:func:`magcilia.model.tilt_output_batch`)."""

from __future__ import annotations

import functools
import logging
import math
import time
from collections.abc import Callable, Mapping, Sequence
from dataclasses import dataclass
from typing import Any

import numpy as np
from numpy.typing import ArrayLike, NDArray

from magcilia import _validate as v
from magcilia._display import Display, Item, Table, dataframe, rows_table, si
from magcilia._errors import MagciliaError, require
from magcilia.analysis.measures import (
    MEASURES,
    check_angles,
    data_angles,
    offset_cost,
    rms_change,
    shape_change,
)
from magcilia.device.parameters import PARAMETERS as REGISTRY
from magcilia.device.parameters import SWEEPABLE, check_ranges, default_bounds
from magcilia.device.setup import Setup
from magcilia.execution import run_tasks
from magcilia.io.recordings import Measurement
from magcilia.model.batch import tilt_output_batch

logger = logging.getLogger(__name__)

F64 = NDArray[np.float64]


# -- global: Sobol indices -----------------------------------------------------------------------
@dataclass(frozen=True, eq=False, repr=False)
class SobolResult(Display):
    """First- and total-order Sobol indices with bootstrap confidence intervals (immutable).

    Attributes
    ----------
    names : tuple of str
        Input names.
    S1, S1_conf, ST, ST_conf : ndarray, shape (p,)
        First-order and total indices and the half-widths of their confidence intervals.
    bounds : dict of str to (float, float)
        Sampled ranges (SI).
    n_base : int
        Base sample size N (a power of 2).
    n_evaluations : int
        Model evaluations, N · (p + 2).
    measure : str
        ``"rms"`` (RMS change vs the reference curve) or ``"cost"`` (calibration cost), or
        ``"shape"`` (offset-free change), or ``"function"`` for a plain function.
    conf_level : float
        Confidence level of the intervals.
    elapsed : float
        Wall time, s.
    """

    names: tuple[str, ...]
    S1: F64
    S1_conf: F64
    ST: F64
    ST_conf: F64
    bounds: dict[str, tuple[float, float]]
    n_base: int
    n_evaluations: int
    measure: str
    conf_level: float = 0.95
    elapsed: float = 0.0
    output_mean: float = math.nan
    output_std: float = math.nan

    def table(self) -> list[dict[str, Any]]:
        """Rows per input: name, S1 ± conf, ST ± conf."""
        return [
            {"parameter": n, "S1": float(a), "S1_conf": float(b),
             "ST": float(c), "ST_conf": float(d)}
            for n, a, b, c, d in zip(self.names, self.S1, self.S1_conf, self.ST, self.ST_conf,
                                     strict=True)
        ]

    def report(self) -> str:
        """Plain-text table."""
        lines = [(f"Sobol indices ({self.measure}; N = {self.n_base}, {self.n_evaluations} "
                 f"evaluations, {self.conf_level:.0%} intervals)"),
                 f"{'parameter':<18} {'S1':>8} {'±':>7} {'ST':>8} {'±':>7}"]
        lines += [f"{r['parameter']:<18} {r['S1']:8.3f} {r['S1_conf']:7.3f} {r['ST']:8.3f} "
                  f"{r['ST_conf']:7.3f}" for r in self.table()]
        return "\n".join(lines)

    def to_dict(self) -> dict[str, Any]:
        """JSON-ready content."""
        return {
            "measure": self.measure, "n_base": self.n_base, "n_evaluations": self.n_evaluations,
            "conf_level": self.conf_level, "elapsed_s": self.elapsed,
            "bounds": {k: list(b) for k, b in self.bounds.items()}, "table": self.table(),
            "output_mean": self.output_mean, "output_std": self.output_std,
        }

    # -- display --------------------------------------------------------------------------------
    def _display_items(self) -> list[Item]:
        order = np.argsort(self.ST)[::-1]
        top = ", ".join(f"{self.names[i]} {self.ST[i]:.2f}" for i in order[:3])
        return [("measure", self.measure), ("ST", top), ("N", str(self.n_base)),
                ("evaluations", str(self.n_evaluations)), ("elapsed", si(self.elapsed, "s")),
                ("confidence", f"{self.conf_level:.0%}")]

    def _display_table(self) -> Table | None:
        return rows_table(self.table(), 3)

    def to_dataframe(self) -> Any:
        """The indices as a ``pandas.DataFrame``, one row per parameter: ``parameter``, ``S1``,
        ``S1_conf``, ``ST``, ``ST_conf`` (dimensionless; conf: half-width of the interval)."""
        return dataframe({"parameter": list(self.names), "S1": self.S1,
                          "S1_conf": self.S1_conf, "ST": self.ST, "ST_conf": self.ST_conf})


def _seeds(rng: int | np.random.Generator | None) -> tuple[int, int]:
    # SALib's analyze ignores a seed of 0 (``if seed:``): draw two non-zero seeds
    gen = np.random.default_rng(rng)
    a, b = gen.integers(1, 2**31 - 1, size=2)
    return int(a), int(b)


def sobol_analysis(
    func: Callable[[F64], ArrayLike],
    bounds: Mapping[str, tuple[float, float]],
    n_base: int = 1024,
    *,
    integer: Sequence[str] = (),
    rng: int | np.random.Generator | None = None,
    conf_level: float = 0.95,
    num_resamples: int = 100,
    chunk: int = 32768,
    measure: str = "function",
    workers: int | None = None,
    scheduler: str | None = None,
    timeout: float = 10.0,
    progress: bool = False,
) -> SobolResult:
    """Sobol indices of any vectorised function over a box (the routine behind
    :func:`sobol_indices`).

    Parameters
    ----------
    func : callable
        ``func(X)`` with X of shape (m, p) (columns in ``bounds`` order) returning (m,) outputs.
    bounds : mapping of str to (low, high)
        Ranges of the p inputs (uniform).
    n_base : int
        Base sample size N, a power of 2; the function is evaluated N · (p + 2) times.
    integer : sequence of str
        Inputs that take whole values: sampled uniformly on [low − 0.5, high + 0.5] and rounded,
        so each whole value in [low, high] is equally likely.
    rng : int, Generator or None
        Seeds the scrambled Sobol sequence and the bootstrap; None (default) draws fresh
        entropy, an int gives the same indices every run.
    conf_level : float
        Level of the bootstrap confidence intervals.
    num_resamples : int
        Bootstrap resamples.
    chunk : int
        Samples per call of ``func`` (bounds memory).
    measure : str
        Label stored in the result.
    workers, scheduler, timeout : optional
        Given either of them, the evaluations run through the execution layer
        (:func:`magcilia.execution.run_tasks`) in chunks of at most ``chunk`` samples (at least
        four per worker): ``workers`` processes on this machine, or a Dask ``scheduler``
        address (``"local"``: a LocalCluster). ``func`` must then be picklable (a top-level
        function or a ``functools.partial`` of one). The indices equal the serial run's: each
        sample's output depends on that sample alone.
    progress : bool
        A progress bar over the chunks on stderr (with ``workers`` or ``scheduler``).

    Returns
    -------
    SobolResult
    """
    t0 = time.perf_counter()
    names = tuple(bounds)
    if len(names) < 1:
        raise v.fail("bounds", "no inputs", "at least one (low, high) range")
    box: dict[str, tuple[float, float]] = {}
    for name in names:
        try:
            lo, hi = (float(b) for b in bounds[name])
        except (TypeError, ValueError):
            raise v.fail(f"bounds[{name!r}]", bounds[name],
                         "a (low, high) pair of numbers") from None
        if not (math.isfinite(lo) and math.isfinite(hi)) or lo >= hi:
            raise v.fail(f"bounds[{name!r}]", (lo, hi), "a finite (low, high) pair with low < high")
        box[name] = (lo, hi)
    for name in integer:
        if name not in box:
            raise v.fail("integer input", name, "a key of bounds")
    n_base = v.integer("n_base", n_base, 2)
    if n_base & (n_base - 1):
        raise v.fail("n_base", n_base, "a power of 2 (Sobol sequences need one), e.g. 1024")
    chunk = v.integer("chunk", chunk, 1)
    if not 0.0 < conf_level < 1.0:
        raise v.fail("conf_level", conf_level, "between 0 and 1")
    salib_sample = require("SALib.sample.sobol", package="SALib", extra="sensitivity",
                           purpose="Sobol indices")
    salib_analyze = require("SALib.analyze.sobol", package="SALib", extra="sensitivity",
                            purpose="Sobol indices")
    ranges = [[lo - 0.5, hi + 0.5] if n in integer else [lo, hi] for n, (lo, hi) in box.items()]
    problem = {"num_vars": len(names), "names": list(names), "bounds": ranges}
    seed_sample, seed_boot = _seeds(rng)
    X = np.asarray(salib_sample.sample(problem, n_base, calc_second_order=False,  # type: ignore[attr-defined]
                                       seed=seed_sample), dtype=np.float64)
    for j, name in enumerate(names):
        if name in integer:
            X[:, j] = np.clip(np.rint(X[:, j]), box[name][0], box[name][1])
    Y = np.empty(X.shape[0])
    logger.info("Sobol: %d evaluations of %d parameters (N = %d)", X.shape[0], len(names), n_base)
    if workers is None and scheduler is None:
        for start in range(0, X.shape[0], chunk):
            stop = min(start + chunk, X.shape[0])
            Y[start:stop] = np.asarray(func(X[start:stop]), dtype=np.float64).reshape(-1)
    else:
        Y[:] = _evaluate_in_chunks(func, X, chunk, workers, scheduler, timeout, progress)
    if not np.isfinite(Y).all():
        bad = X[int(np.argmax(~np.isfinite(Y)))]
        raise MagciliaError(
            "bounds must keep the model finite; it is not at "
            + ", ".join(f"{n}={x:.6g}" for n, x in zip(names, bad, strict=True))
        )
    if np.ptp(Y) == 0:
        raise MagciliaError("the output does not vary over the bounds, so Sobol indices are "
                            "undefined; widen the bounds")
    logger.info("Sobol: model evaluated in %.3g s; analysing", time.perf_counter() - t0)
    res = salib_analyze.analyze(problem, Y, calc_second_order=False,  # type: ignore[attr-defined]
                                num_resamples=num_resamples, conf_level=conf_level,
                                print_to_console=False, seed=seed_boot)
    return SobolResult(
        names=names, S1=np.asarray(res["S1"]), S1_conf=np.asarray(res["S1_conf"]),
        ST=np.asarray(res["ST"]), ST_conf=np.asarray(res["ST_conf"]), bounds=box,
        n_base=n_base, n_evaluations=int(X.shape[0]), measure=measure, conf_level=conf_level,
        elapsed=time.perf_counter() - t0, output_mean=float(Y.mean()), output_std=float(Y.std()),
    )


def _apply(func: Callable[[F64], ArrayLike], X: F64) -> F64:
    """One chunk of a sweep (a task of the execution layer): ``func(X)`` as float64, shape
    (m,)."""
    return np.asarray(func(X), dtype=np.float64).reshape(-1)


def _evaluate_in_chunks(func: Callable[[F64], ArrayLike], X: F64, chunk: int,
                        workers: int | None, scheduler: str | None, timeout: float,
                        progress: bool) -> F64:
    """``func`` over the rows of ``X`` (m, p) through :func:`magcilia.execution.run_tasks`, in
    chunks of at most ``chunk`` rows and at least four chunks per worker; the outputs (m,) in
    row order. A chunk that fails (after its retry) is a one-line error."""
    parts = 4 * (workers or (8 if scheduler is not None else 2))
    size = max(1, min(chunk, math.ceil(X.shape[0] / parts)))
    tasks = [(f"{start}", X[start:start + size]) for start in range(0, X.shape[0], size)]
    results = run_tasks(functools.partial(_apply, func), tasks, workers=workers,
                        scheduler=scheduler, timeout=timeout, progress=progress,
                        label="model evaluations")
    for r in results:
        if r.error:
            raise MagciliaError(f"a chunk of the sweep failed (rows {r.key}.., on {r.worker}): "
                                f"{r.error}")
    return np.concatenate([r.value for r in results])


def _sweep_measure(setup: Setup, names: Sequence[str], angles: F64, measure: str, target: F64,
                   X: F64) -> F64:
    """The scalar output of each parameter set (rows of X, columns ``names``) of
    :func:`sobol_indices` (top level, so that sweeps can run in other processes)."""
    curves = tilt_output_batch(setup, {n: X[:, j] for j, n in enumerate(names)}, angles)
    if measure == "cost":
        return offset_cost(curves, target)
    if measure == "shape":
        return shape_change(curves, target)
    return rms_change(curves, target)


def sobol_indices(
    setup: Setup,
    bounds: Mapping[str, tuple[float, float]] | None = None,
    n_base: int = 1024,
    angles: ArrayLike | None = None,
    measure: str = "rms",
    data: Measurement | None = None,
    rng: int | np.random.Generator | None = None,
    *,
    conf_level: float = 0.95,
    num_resamples: int = 100,
    workers: int | None = None,
    scheduler: str | None = None,
    timeout: float = 10.0,
    progress: bool = False,
) -> SobolResult:
    """Global Sobol sensitivity of the output curve to the calibration parameters.

    Each sample is a full parameter set drawn over ``bounds``; its scalar output is the RMS change
    of the output curve over ``angles`` relative to ``setup``'s own curve (``measure="rms"``), or
    the calibration cost against ``data`` with the offset solved (``measure="cost"``). Evaluation
    goes through :func:`magcilia.model.tilt_output_batch` (no per-sample checks: the bounds must
    keep the sensing element outside the cilium — :data:`~magcilia.calibration.DEFAULT_BOUNDS`
    do).

    Parameters
    ----------
    setup : Setup
        Reference setup; supplies the parameters not in ``bounds`` and the reference curve.
    bounds : mapping of str to (low, high), optional
        Ranges (SI) of any of height, base_radius, tip_radius, x, y, z, n_loops,
        dipoles_per_loop, magnetization_scale; default the calibration bounds
        (:data:`magcilia.calibration.DEFAULT_BOUNDS`). ``n_loops`` and ``dipoles_per_loop`` are
        sampled continuously and rounded (each whole value equally likely).
    n_base : int
        Base sample size N (power of 2); N · (p + 2) model evaluations (p inputs).
    angles : array-like, shape (a,), optional
        Tilt angles, rad (default the paper's 33). With ``measure="cost"`` the data's angles.
    measure : {"rms", "shape", "cost"}
        Scalar output per sample: RMS change vs ``setup``'s curve, the offset-free RMS change
        (:func:`shape_change`), or the calibration cost
        against ``data`` (pass ``measure="cost"`` explicitly; data alone do not switch it).
    data : Measurement, optional
        Required for ``measure="cost"``.
    rng : int, Generator or None
        Seed (sampling and bootstrap); None (default) draws fresh entropy.
    conf_level, num_resamples : float, int
        Bootstrap confidence intervals.
    workers, scheduler, timeout, progress : optional
        Run the model evaluations in chunks through the execution layer (worker processes, or
        a Dask cluster; see :func:`sobol_analysis`); the indices equal the serial run's.

    Returns
    -------
    SobolResult
    """
    if not isinstance(setup, Setup):
        raise v.fail("setup", type(setup).__name__, "a magcilia Setup")
    v.choice("measure", measure, MEASURES)
    box = default_bounds() if bounds is None else dict(bounds)
    for name in box:
        v.choice("bounds key", name, SWEEPABLE)
    check_ranges(box)
    names = list(box)
    if measure == "cost":
        d_ang = data_angles(data)
        if data is None or d_ang is None:
            raise v.fail("data", None, "a Measurement when measure='cost'")
        ang, target = d_ang, np.asarray(data.volts)
    else:
        ang = check_angles(angles)
        target = setup.output(ang)

    evaluate = functools.partial(_sweep_measure, setup, tuple(names), ang, measure,
                                 np.asarray(target, dtype=np.float64))
    return sobol_analysis(evaluate, box, n_base,
                          integer=[n for n in names if REGISTRY[n].domain == "integer"],
                          rng=rng, conf_level=conf_level, num_resamples=num_resamples,
                          measure=measure, workers=workers, scheduler=scheduler,
                          timeout=timeout, progress=progress)
