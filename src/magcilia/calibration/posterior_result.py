"""A sampled posterior and its summary (:class:`Posterior`), what
:func:`~magcilia.calibration.posterior.sample_posterior` returns, and the display units of a
parameter name."""

from __future__ import annotations

from dataclasses import dataclass
from typing import Any

import numpy as np
from numpy.typing import NDArray

from magcilia import _validate as v
from magcilia._display import Display, Item, Table, column, dataframe, number
from magcilia.calibration.parameters import ParameterKey

F64 = NDArray[np.float64]

#: credible levels of the equal-tailed intervals a :class:`Posterior` reports
LEVELS = (0.68, 0.95)


class SamplingWarning(UserWarning):
    """The sampler stopped before its target (time limit) or a mode's covariance was degenerate."""


@dataclass(frozen=True, repr=False, eq=False)
class Posterior(Display):
    """Samples of a posterior and their summary (SI).

    Attributes
    ----------
    names : tuple of str
        Parameter names, length p (registry names such as ``"height"`` show in display units).
    samples : ndarray, shape (s, p)
        Posterior samples, SI, modes mixed in proportion to their weights.
    log_prob : ndarray, shape (s,)
        Log probability of each sample.
    mean, sd : ndarray, shape (p,)
        Posterior mean and standard deviation.
    intervals : dict of float to ndarray, shape (p, 2)
        Equal-tailed credible intervals by level (:data:`LEVELS`: 0.68 and 0.95).
    ess : ndarray, shape (p,)
        Effective sample size of each parameter (see the module docstring).
    autocorr_time : ndarray, shape (p,)
        Integrated autocorrelation time (steps) of each parameter, the largest over the modes.
    acceptance : float
        Mean acceptance fraction of the walkers.
    modes : ndarray, shape (k, p)
        The modes (SI), by decreasing weight.
    weights : ndarray, shape (k,)
        Their weights (sum 1; Laplace evidence).
    mode_log_prob : ndarray, shape (k,)
        Log probability at each mode.
    walkers, steps : int
        Walkers per mode and steps run in all (over the modes).
    seconds : float
        Wall-clock time of the sampling.
    target : int
        The ``n_effective`` asked for; ``converged`` says whether it was reached.
    long_enough : bool
        Whether every mode's chain reached the stopping rule's whole length (at least
        :data:`~magcilia.calibration.posterior.TAU_FACTOR` τ after the burn-in, where τ itself can
        be trusted); False where the time limit cut a chain short, whatever its ESS.
    """

    names: tuple[str, ...]
    samples: F64
    log_prob: F64
    mean: F64
    sd: F64
    intervals: dict[float, F64]
    ess: F64
    autocorr_time: F64
    acceptance: float
    modes: F64
    weights: F64
    mode_log_prob: F64
    walkers: int
    steps: int
    seconds: float
    target: int
    long_enough: bool = True

    @property
    def converged(self) -> bool:
        """Whether the smallest ESS reached the target on chains long enough to trust τ
        (:attr:`long_enough`)."""
        return bool(np.min(self.ess) >= self.target) and self.long_enough

    def interval(self, level: float = 0.68) -> F64:
        """Equal-tailed credible interval at ``level`` (0 < level < 1), SI, shape (p, 2)."""
        level = float(level)
        if level in self.intervals:
            return self.intervals[level]
        if not 0.0 < level < 1.0:
            raise v.fail("level", level, "a credible level between 0 and 1, e.g. 0.68")
        return intervals(self.samples, level)

    def covariance(self) -> F64:
        """Sample covariance of the parameters, SI, shape (p, p)."""
        return np.atleast_2d(np.cov(self.samples, rowvar=False))

    def draws(self, count: int) -> F64:
        """``count`` samples evenly spaced through :attr:`samples` (all if fewer), shape
        (min(count, s), p): a thinned subset for propagating the posterior through a model."""
        count = v.integer("count", count, 1)
        if count >= self.samples.shape[0]:
            return self.samples
        index = np.linspace(0, self.samples.shape[0] - 1, count).round().astype(int)
        return self.samples[index]

    def to_dict(self) -> dict[str, Any]:
        """JSON-ready summary, SI (``"units": "SI"``); the samples are in :meth:`to_dataframe`."""
        return {
            "units": "SI",
            "names": list(self.names),
            "mean": dict(zip(self.names, self.mean.tolist(), strict=True)),
            "sd": dict(zip(self.names, self.sd.tolist(), strict=True)),
            "intervals": {f"{round(100 * lv)}": dict(zip(self.names, iv.tolist(), strict=True))
                          for lv, iv in self.intervals.items()},
            "ess": dict(zip(self.names, self.ess.tolist(), strict=True)),
            "autocorr_time": dict(zip(self.names, self.autocorr_time.tolist(), strict=True)),
            "acceptance": self.acceptance,
            "modes": [{"weight": float(w), "log_prob": float(lp),
                       "values": dict(zip(self.names, m.tolist(), strict=True))}
                      for m, w, lp in zip(self.modes, self.weights, self.mode_log_prob,
                                          strict=True)],
            "samples": int(self.samples.shape[0]), "walkers": self.walkers, "steps": self.steps,
            "seconds": self.seconds, "target": self.target, "long_enough": self.long_enough,
            "converged": self.converged,
        }

    def report(self) -> str:
        """The marginal posteriors in display units: mean ± sd, the 68 % and 95 % intervals and
        the ESS of each parameter, then the modes and their weights."""
        lines = [f"Posterior: {self.samples.shape[0]} samples, {self.walkers} walkers × "
                 f"{self.steps} steps in {self.seconds:.1f} s, acceptance {self.acceptance:.2f}, "
                 f"ESS ≥ {number(float(np.min(self.ess)), 4)}"
                 + ("" if self.converged else
                    f" (target {self.target} NOT reached)" if np.min(self.ess) < self.target
                    else " (chains cut short by the time limit: τ NOT yet trustworthy)")]
        head = f"  {'parameter':<18}{'mean ± sd':>24}{'68 % interval':>26}{'95 % interval':>26}"
        lines += [head + f"{'ESS':>8}"]
        for i, name in enumerate(self.names):
            f, unit = _display(name)
            lo68, hi68 = self.intervals[0.68][i] / f
            lo95, hi95 = self.intervals[0.95][i] / f
            mean = f"{number(self.mean[i] / f, 5)} ± {number(self.sd[i] / f, 2)} {unit}"
            lines.append(f"  {name:<18}{mean:>24}"
                         f"{f'[{number(lo68, 4)}, {number(hi68, 4)}] {unit}':>26}"
                         f"{f'[{number(lo95, 4)}, {number(hi95, 4)}] {unit}':>26}"
                         f"{number(float(self.ess[i]), 4):>8}")
        if len(self.weights) > 1:
            lines.append(f"  {len(self.weights)} modes (Laplace evidence weights):")
            for m, w in zip(self.modes, self.weights, strict=True):
                where = ", ".join(f"{n}={_text(n, float(x))}" for n, x in zip(self.names, m,
                                                                              strict=True))
                lines.append(f"    weight {w:.3f}: {where}")
        return "\n".join(lines)

    def _display_items(self) -> list[Item]:
        items = [("samples", str(self.samples.shape[0])),
                 ("ESS", number(float(np.min(self.ess)), 4)),
                 ("modes", str(len(self.weights)))]
        items += [(n, f"{_text(n, float(m))} ± {_text(n, float(s), 2)}")
                  for n, m, s in zip(self.names, self.mean, self.sd, strict=True)]
        return items

    def _display_table(self) -> Table:
        rows = []
        for i, n in enumerate(self.names):
            lo, hi = self.intervals[0.95][i]
            rows.append([n, _text(n, float(self.mean[i])), _text(n, float(self.sd[i]), 2),
                         f"[{_text(n, float(lo))}, {_text(n, float(hi))}]",
                         number(float(self.ess[i]), 4)])
        return ["parameter", "mean", "sd", "95 % interval", "ESS"], rows

    def to_dataframe(self) -> Any:
        """The samples as a ``pandas.DataFrame``: one SI column per parameter, the unit as suffix
        (``height_m``, ``offset_V``), and ``log_prob``."""
        cols: dict[str, Any] = {column(n, _si_unit(n)): self.samples[:, i]
                                for i, n in enumerate(self.names)}
        cols["log_prob"] = self.log_prob
        return dataframe(cols)


# -- units of a name ------------------------------------------------------------------------------

def _key(name: str | ParameterKey) -> ParameterKey:
    """The structural name: a key as given, a registry name as its own key (a label is never
    parsed: a name outside the registry has no unit)."""
    return name if isinstance(name, ParameterKey) else ParameterKey(name)


def display_unit(name: str | ParameterKey) -> tuple[float, str]:
    """SI value of one display unit and its symbol for a parameter (``(1e-3, "mm")`` for
    height; a :class:`~magcilia.calibration.parameters.ParameterKey` by its name and axis;
    ``(1.0, "")`` for a name outside the registry)."""
    return _key(name).display()


_display = display_unit


def _si_unit(name: str | ParameterKey) -> str:
    return _key(name).unit


def _text(name: str | ParameterKey, value: float, digits: int = 4) -> str:
    f, unit = _display(name)
    return f"{number(value / f, digits)} {unit}".rstrip()


def intervals(S: F64, level: float) -> F64:
    """Equal-tailed credible intervals at ``level`` of the samples ``S`` (s, p), shape (p, 2)."""
    tail = 50.0 * (1.0 - level)
    return np.stack([np.percentile(S, tail, axis=0), np.percentile(S, 100.0 - tail, axis=0)],
                    axis=1)
