"""Plan a coil calibration: which applied uniform fields to read (issue 29, item 1).

:func:`plan_coil` offers candidate fields (:func:`coil_candidates`: directions on a sphere grid ×
magnitudes, each kept only where the total field at the element stays within the sensor's range
and below the AMR's flip field), takes their rows (:func:`~magcilia.calibration.coil_rows.
coil_jacobian`: the cilium bent by the field, plus the field seen directly), and chooses the
``budget`` readings by D-optimality (:func:`~magcilia.calibration.doptimal.d_optimal`, the
per-axis offsets as nuisances, priors as ``1/σ²``), next to a naive sequence of the same budget
(equally spaced fields along the sensor's x axis, one Helmholtz pair swept). Before any search,
the information of every candidate read at once is checked (:func:`~magcilia.calibration.
identifiability.identify`): a combination that no sequence here determines is refused, named, with
what would determine it.
"""

from __future__ import annotations

import math
from collections.abc import Callable, Sequence
from dataclasses import dataclass
from typing import Any

import numpy as np
from numpy.typing import ArrayLike, NDArray

from magcilia import _validate as v
from magcilia._display import Display, Item, Table
from magcilia._errors import MagciliaError
from magcilia.calibration.coil_rows import (
    MEASURES,
    coil_jacobian,
    coil_totals,
    nominal,
    parameters_for,
    sphere_directions,
)
from magcilia.calibration.doptimal import RESTARTS, Design, d_optimal, evaluate_design
from magcilia.calibration.identifiability import (
    experiment_information,
    identify,
    prior_information,
    sigma_text,
)
from magcilia.calibration.plan import OFFSET_PRIOR
from magcilia.calibration.plan_size import check_plan_size
from magcilia.device.sensor import DEFAULT_BANDWIDTH, SensorFlag, beyond_range
from magcilia.device.setup import Setup

F64 = NDArray[np.float64]

#: what a coil plan fits by default (the modulus needs a ring-down or a load: add it with a
#: prior); the sensitivity only for the AMR output (:func:`coil_fit`)
COIL_FIT = ("height", "base_radius", "x", "y", "z", "magnetization_scale", "sensitivity")


def coil_fit(measure: str) -> tuple[str, ...]:
    """:data:`COIL_FIT` for a measure (a 3-axis part has no fitted scale)."""
    return tuple(n for n in COIL_FIT if n in parameters_for(measure))
#: the candidate magnitudes, fractions of the largest field the sensor allows
MAGNITUDES = (0.25, 0.5, 0.75, 1.0)
#: the 3-axis part of ``--measure field`` (±8 gauss, 0.4 mG RMS at 100 Hz)
DEFAULT_PART = "MMC5983MA"


def field_limit(setup: Setup, measure: str, part: str = DEFAULT_PART) -> float:
    """The largest applied field a candidate may have, T: the AMR's linear range (it holds for
    the total field; its flip field is higher) or the 3-axis part's full scale per axis."""
    if measure == "output":
        return float(min(setup.sensor.field_range, setup.sensor.flip_field))
    from magcilia.device.magnetometer import Magnetometer

    return float(min(Magnetometer.preset(part).field_range))


def default_noise(setup: Setup, measure: str, part: str = DEFAULT_PART) -> float:
    """σ of one reading: the AMR output's noise over the default band (one raw sample at 1 kHz),
    V, or the 3-axis part's RMS noise per axis, T."""
    if measure == "output":
        return float(setup.sensor.output_noise_rms(*DEFAULT_BANDWIDTH))
    from magcilia.device.magnetometer import Magnetometer

    return float(max(Magnetometer.preset(part).noise))


def usable(setup: Setup, total: F64, measure: str, part: str = DEFAULT_PART) -> NDArray[np.bool_]:
    """Which total fields (c, 3), T, at the element give a good reading: within the AMR's range
    (B_x and |B|) and below its flip field, or within the part's full scale on every axis."""
    if measure == "output":
        bad = (SensorFlag.BEYOND_RANGE | SensorFlag.TOTAL_BEYOND_RANGE
               | SensorFlag.FLIPPED_RISK)
        return np.asarray((setup.sensor.check(total) & np.uint8(bad)) == 0)
    from magcilia.device.magnetometer import Magnetometer

    m = Magnetometer.preset(part)
    return np.asarray(~np.any(beyond_range(total, np.asarray(m.field_range),
                                           np.asarray(m.resolution)), axis=1))


def coil_candidates(setup: Setup, measure: str = "output", *,
                    magnitudes: Sequence[float] | None = None,
                    directions: ArrayLike | None = None, part: str = DEFAULT_PART
                    ) -> tuple[F64, F64]:
    """Candidate applied fields and the total field each gives at the element.

    Parameters
    ----------
    setup : Setup
    measure : {"output", "field"}
    magnitudes : sequence of float, optional
        Field magnitudes, T (default :data:`MAGNITUDES` × :func:`field_limit`).
    directions : array-like, shape (d, 3), optional
        Unit directions (default :func:`~magcilia.calibration.coil_rows.sphere_directions`,
        30° × 45°).
    part : str
        The 3-axis part of ``"field"``.

    Returns
    -------
    fields, totals : ndarray, shape (c, 3)
        The usable candidates (:func:`usable`; zero field first), T.
    """
    measure = v.choice("measure", measure, MEASURES)
    limit = field_limit(setup, measure, part)
    mags = (np.array(MAGNITUDES) * limit if magnitudes is None
            else v.finite_array("magnitudes", magnitudes, ndim=1, unit="T"))
    if mags.size < 1 or np.any(mags <= 0):
        raise v.fail("magnitudes", mags.tolist(), "positive field magnitudes, T")
    dirs = (sphere_directions() if directions is None
            else v.finite_array("directions", directions, unit=""))
    dirs = dirs / np.linalg.norm(dirs, axis=1, keepdims=True)
    fields = np.concatenate([np.zeros((1, 3)), *(dirs * m for m in mags)])
    totals = coil_totals(setup, fields)
    keep = usable(setup, totals, measure, part)
    if keep.sum() < 2:
        raise v.fail("magnitudes", (mags / 1e-4).round(3).tolist(),
                     "fields that keep the element within the sensor's range (gauss)")
    return fields[keep], totals[keep]


@dataclass(frozen=True, repr=False, eq=False)
class CoilPlan(Display):
    """A planned coil calibration and a naive sequence of the same budget.

    Attributes
    ----------
    setup : Setup
    measure : str
        ``"output"`` (V) or ``"field"`` (T per component).
    noise : float
        σ of one reading (V, or T per component).
    fields : ndarray, shape (c, 3)
        The candidate applied fields, T.
    design, naive : Design
        The D-optimal plan (``chosen`` index :attr:`fields`) and the naive sequence's figures.
    naive_fields : ndarray, shape (N, 3)
        The naive sequence: equally spaced fields along x over ± the largest candidate, T.
    """

    setup: Setup
    measure: str
    noise: float
    fields: F64
    design: Design
    naive: Design
    naive_fields: F64

    def conditions(self) -> list[tuple[tuple[float, ...], int]]:
        """The planned readings as (applied field (3,) T, repeats), by magnitude."""
        out = [(tuple(float(c) for c in self.fields[i]), int(self.design.counts[i]))
               for i in np.flatnonzero(self.design.counts)]
        return sorted(out, key=lambda t: (float(np.linalg.norm(t[0])), t[0]))

    def to_dict(self) -> dict[str, Any]:
        """JSON-ready, SI."""
        return {"units": "SI", "stimulus": "coil", "measure": self.measure, "noise": self.noise,
                "budget": self.design.budget,
                "conditions": [{"field": list(b), "repeats": n} for b, n in self.conditions()],
                "plan": self.design.to_dict(), "naive": self.naive.to_dict(),
                "naive_fields": self.naive_fields.tolist()}

    def report(self, si: bool = False) -> str:
        """The plan against the naive sweep (rank, σ of each parameter) and the readings: fields
        in gauss (T with ``si``)."""
        d, r = self.design, self.naive
        f, unit = (1.0, "T") if si else (1e-4, "G")
        noise = (f"{self.noise * 1e3:.3g} mV" if self.measure == "output" and not si
                 else f"{self.noise:.3g} {'V' if self.measure == 'output' else 'T'}"
                 if si else f"{self.noise / 1e-4:.3g} G")
        lines = [(f"Coil calibration plan: {d.budget} readings, measure {self.measure} (noise "
                  f"{noise} per reading)"),
                 f"  {'':<28}{'naive (x sweep)':>16}{'plan':>16}",
                 (f"  {'rank':<28}{f'{r.rank}/{len(r.interest)}':>16}"
                  f"{f'{d.rank}/{len(d.interest)}':>16}")]
        for i, n in enumerate(d.names):
            if n in d.interest:
                size = abs(nominal(self.setup, n))
                lines.append(f"  {f'σ {n}':<28}{_shown(n, float(r.stderr[i]), si, size):>16}"
                             f"{_shown(n, float(d.stderr[i]), si, size):>16}")
        lines.append(f"  planned fields ({unit}: Bx, By, Bz ×repeats):")
        for b, k in self.conditions():
            lines.append("    (" + ", ".join(f"{round(c / f, 9) + 0.0:+.3g}" for c in b) + ")"
                         + (f" ×{k}" if k > 1 else ""))
        lines.append(f"  naive: {d.budget} fields along x from {self.naive_fields[0, 0] / f:.3g} "
                     f"to {self.naive_fields[-1, 0] / f:.3g} {unit}")
        return "\n".join(lines)

    def _display_items(self) -> list[Item]:
        return [("N", str(self.design.budget)), ("measure", self.measure),
                *self.design._display_items()[1:]]

    def _display_table(self) -> Table:
        d, r = self.design, self.naive
        return (["", "naive", "plan"],
                [["rank", str(r.rank), str(d.rank)],
                 *[[f"σ {n}", _shown(n, float(r.stderr[i]), False, abs(nominal(self.setup, n))),
                    _shown(n, float(d.stderr[i]), False, abs(nominal(self.setup, n)))]
                   for i, n in enumerate(d.names) if n in d.interest]])


def _shown(name: str, value: float, si: bool, size: float) -> str:
    if not math.isfinite(value):
        return "undetermined"
    return f"{value:.3g}" if si else sigma_text(name, value, 3, size)


def plan_coil(setup: Setup, budget: int, *, measure: str = "output",
              parameters: Sequence[str] | None = None, prior_sd: dict[str, float] | None = None,
              noise: float | None = None, magnitudes: Sequence[float] | None = None,
              part: str = DEFAULT_PART,
              progress: Callable[[int, int], None] | None = None) -> CoilPlan:
    """Plan a coil calibration of ``setup``: the D-optimal ``budget`` applied fields among
    :func:`coil_candidates`, next to a naive x sweep of the same budget.

    Parameters
    ----------
    setup : Setup
        The expected cilium (SI; a positive tip radius).
    budget : int
        Readings N (each of ``"field"`` gives three components).
    measure : {"output", "field"}
        The AMR output or a 3-axis part (``part``).
    parameters : sequence of str, optional
        Fitted parameters, among :func:`~magcilia.calibration.coil_rows.parameters_for` the
        measure (default :func:`coil_fit`); the rest are held at the setup's values.
    prior_sd : dict of str to float, optional
        Prior σ (SI) of some of them (a size measurement, a ring-down's modulus).
    noise : float, optional
        σ of one reading (default :func:`default_noise`).
    magnitudes : sequence of float, optional
        Candidate field magnitudes, T.
    part : str
        The 3-axis part of ``"field"`` (its range and noise).
    progress : callable(done, total), optional

    Returns
    -------
    CoilPlan

    Raises
    ------
    MagciliaError
        A budget below the parameters without a prior, a plan too large
        (:func:`~magcilia.calibration.plan_size.check_plan_size`), or parameters that no
        sequence of these fields determines: the combination, named, and what would determine it.
    """
    measure = v.choice("measure", measure, MEASURES)
    names = coil_fit(measure) if parameters is None else tuple(parameters)
    for n in names:
        if n not in parameters_for(measure):
            raise v.fail("parameters", n, "names among " + ", ".join(parameters_for(measure)))
    prior_sd = dict(prior_sd or {})
    budget = v.integer("budget", budget, 1)
    informative = len(names) - sum(1 for n in names if n in prior_sd)
    if budget < informative:
        raise v.fail("budget", budget, f"at least {informative} readings to determine "
                                       f"{informative} parameters ({', '.join(names)})")
    noise = default_noise(setup, measure, part) if noise is None else noise
    noise = v.positive("noise", noise, "V" if measure == "output" else "T", "noise σ")
    r = 1 if measure == "output" else 3
    fields, _ = coil_candidates(setup, measure, magnitudes=magnitudes, part=part)
    check_plan_size(budget, fields.shape[0], len(names) + r, RESTARTS)  # before the rows
    J = coil_jacobian(setup, fields, measure=measure, parameters=names)
    priors = prior_information(names, prior_sd)
    every = identify(experiment_information(J, noise), names, setup, prior_sd)
    if every.undetermined:
        raise MagciliaError(f"--stimulus coil: no sequence of the {len(fields)} candidate fields "
                            f"determines {every.undetermined[0]}; add {every.remedies[0]}")
    full = np.concatenate([J, np.broadcast_to(np.eye(r), (J.shape[0], r, r))], axis=2) / noise
    labels = tuple(f"offset[B{'xyz'[k]}]" if r == 3 else "offset" for k in range(r))
    prec = np.concatenate([np.diag(priors), np.zeros(r)])
    signal = float(np.max(np.abs(J[:, :, :]) * np.array([max(abs(x), 1e-3) for x in
                                                           _values(setup, names)])))
    prec[len(names):] = 1.0 / (OFFSET_PRIOR * max(signal, noise)) ** 2
    all_names = (*names, *labels)
    design = d_optimal(full, budget, names=all_names, interest=names, prior_precision=prec,
                       progress=progress)
    top = _x_span(fields)
    naive_fields = np.zeros((budget, 3))
    naive_fields[:, 0] = np.linspace(-top, top, budget)
    Jn = coil_jacobian(setup, naive_fields, measure=measure, parameters=names)
    fulln = np.concatenate([Jn, np.broadcast_to(np.eye(r), (budget, r, r))], axis=2) / noise
    naive = evaluate_design(fulln, np.arange(budget), names=all_names, interest=names,
                            prior_precision=prec)
    return CoilPlan(setup=setup, measure=measure, noise=float(noise), fields=fields,
                    design=design, naive=naive, naive_fields=naive_fields)


def _x_span(fields: F64) -> float:
    """The largest field along +x and along −x among the candidates (the smaller of the two), T:
    the span of the naive sweep."""
    mag = np.linalg.norm(fields, axis=1)
    along = np.abs(fields[:, 0]) >= mag * (1 - 1e-9)
    plus = fields[along & (fields[:, 0] > 0), 0]
    minus = -fields[along & (fields[:, 0] < 0), 0]
    if plus.size and minus.size:
        return float(min(plus.max(), minus.max()))
    return float(np.max(mag))


def _values(setup: Setup, names: Sequence[str]) -> list[float]:
    return [nominal(setup, n) for n in names]


__all__ = [
    "COIL_FIT",
    "DEFAULT_PART",
    "MAGNITUDES",
    "CoilPlan",
    "coil_candidates",
    "coil_fit",
    "default_noise",
    "field_limit",
    "plan_coil",
    "usable",
]
