"""Calibration design: which measurements pin the parameters down (issue 14, item 5).

:func:`plan_calibration` builds the candidates of a tilt-table calibration of a
:class:`~magcilia.device.setup.Setup` (tilt angles × azimuths, the AMR output or the three field
components, each experiment's offsets as nuisances), chooses the conditions by D-optimality
(:func:`~magcilia.calibration.doptimal.d_optimal`: the design search, with
:func:`~magcilia.calibration.doptimal.evaluate_design`, lives in
:mod:`magcilia.calibration.doptimal`) and compares the plan with the paper's single path at the
same budget (:class:`CalibrationPlan`).
"""

from __future__ import annotations

import math
from collections.abc import Callable, Sequence
from dataclasses import dataclass
from typing import Any

import numpy as np
from numpy.typing import ArrayLike, NDArray

from magcilia import _validate as v
from magcilia._display import Display, Item, Table, number
from magcilia.calibration.doptimal import (
    MAX_EXCHANGES,
    NULL_COMPONENT,
    RANK_TOLERANCE,
    RESTARTS,
    TOLERANCE,
    Design,
    condition_text,
    d_optimal,
    evaluate_design,
    value_text,
)
from magcilia.calibration.plan_size import check_plan_size
from magcilia.device.parameters import MEASURANDS, PARAMETERS, Quantity
from magcilia.device.sensor import DEFAULT_BANDWIDTH
from magcilia.device.setup import Setup

F64 = NDArray[np.float64]

#: the physical parameters a tilt-table calibration fits (the offsets are nuisances)
PLAN_PARAMETERS = ("height", "base_radius", "x", "y", "z")
#: what a condition measures: the AMR output, or the three components of a 3-axis magnetometer
SENSORS = ("output", "field")
#: prior σ of a nuisance offset, in units of the largest signal one condition's rows can move: a
#: weak prior that keeps the information of an experiment not (yet) in the design invertible
OFFSET_PRIOR = 1e3


# -- a tilt-table calibration of a setup ----------------------------------------------------------

@dataclass(frozen=True, repr=False, eq=False)
class CalibrationPlan(Display):
    """A planned tilt-table calibration and the paper's single path at the same budget.

    Attributes
    ----------
    setup : Setup
        The setup the sensitivities are taken at (the expected cilium).
    sensor : str
        ``"output"`` (the AMR output, V) or ``"field"`` (three field components, T).
    noise : float
        Noise σ of one reading: V for ``"output"``, T for each component of ``"field"``.
    angles, azimuths : ndarray, shape (c,)
        Tilt angle and tilt azimuth (rad) of each candidate.
    design : Design
        The D-optimal plan (its ``chosen`` index the candidates).
    reference : Design
        The paper's design: ``budget`` equally spaced angles over the candidates' angle range on
        the first azimuth (:attr:`reference_angles`), same sensor.
    reference_angles : ndarray, shape (N,)
        Its angles, rad.
    """

    setup: Setup
    sensor: str
    noise: float
    angles: F64
    azimuths: F64
    design: Design
    reference: Design
    reference_angles: F64

    def conditions(self) -> list[tuple[float, float, int]]:
        """The planned conditions as (angle rad, azimuth rad, repeats), by azimuth then angle."""
        out = [(float(self.angles[i]), float(self.azimuths[i]), int(self.design.counts[i]))
               for i in np.flatnonzero(self.design.counts)]
        return sorted(out, key=lambda t: (t[1], t[0]))

    def to_dict(self) -> dict[str, Any]:
        """JSON-ready, SI: the conditions, both designs and the noise."""
        return {"units": "SI", "sensor": self.sensor, "noise": self.noise,
                "budget": self.design.budget,
                "conditions": [{"angle": a, "azimuth": phi, "repeats": n}
                               for a, phi, n in self.conditions()],
                "plan": self.design.to_dict(), "paper": self.reference.to_dict(),
                "paper_angles": self.reference_angles.tolist()}

    def report(self, si: bool = False) -> str:
        """The comparison with the paper's sweep (rank, condition number, the expected standard
        error of each parameter), what no design here determines, and the planned readings; in
        display units (mm, deg, mV or gauss), SI with ``si``."""
        d, r = self.design, self.reference
        angle = MEASURANDS["angle"]
        noise_unit = PARAMETERS["offset" if self.sensor == "output" else "field_range"]

        def unit(q: Quantity) -> tuple[str, float]:
            return (q.unit, 1.0) if si else (q.display, q.display_factor)

        def shown(value: float, name: str) -> str:
            f = unit(PARAMETERS[name])[1]
            return "undetermined" if not math.isfinite(value) else f"{value / f:.3g}"

        a_unit, a_factor = unit(angle)
        n_unit, n_factor = unit(noise_unit)
        lines = [f"Calibration plan: {d.budget} readings, sensor {self.sensor} (noise "
                 f"{self.noise / n_factor:.3g} {n_unit} per reading"
                 + (", 3 components)" if self.sensor == "field" else ")"),
                 f"  {'':<24}{'paper (1 path)':>16}{'plan':>16}",
                 (f"  {'rank':<24}{f'{r.rank}/{len(r.interest)}':>16}"
                  f"{f'{d.rank}/{len(d.interest)}':>16}"),
                 (f"  {'condition number':<24}{condition_text(r.condition):>16}"
                  f"{condition_text(d.condition):>16}")]
        for i, n in enumerate(d.names):
            if n in d.interest:
                lines.append(f"  {f'σ {n} ({unit(PARAMETERS[n])[0]})':<24}"
                             f"{shown(float(r.stderr[i]), n):>16}"
                             f"{shown(float(d.stderr[i]), n):>16}")
        lost = [n for i, n in enumerate(d.names)
                if n in d.interest and not math.isfinite(d.stderr[i])]
        if lost:
            why = (" (at one sensing point the field does not change when the whole cilium and "
                   "its placement scale together, B ∝ M·V/r³)"
                   if set(lost) == set(PLAN_PARAMETERS) else "")
            lines.append(f"  undetermined by any design here: {', '.join(lost)}{why}: add a "
                         "prior, e.g. --prior height=3.26:0.1")
        lines.append(f"  planned readings (azimuth: angles in {a_unit}, ×repeats):")
        conditions = self.conditions()
        for phi in sorted({c[1] for c in conditions}):
            text = ", ".join(f"{a / a_factor:.4g}" + (f"×{n}" if n > 1 else "")
                             for a, az, n in conditions if az == phi)
            lines.append(f"    {phi / a_factor:.4g}: {text}")
        paper = ", ".join(f"{float(a) / a_factor:.4g}" for a in self.reference_angles)
        lines.append(f"  paper: {d.budget} equally spaced angles at azimuth "
                     f"{float(self.azimuths[0]) / a_factor:.4g}: {paper}")
        return "\n".join(lines)

    def _display_items(self) -> list[Item]:
        return [("N", str(self.design.budget)), ("sensor", self.sensor),
                ("conditions", str(int(np.count_nonzero(self.design.counts)))),
                *self.design._display_items()[1:]]

    def _display_table(self) -> Table:
        d, r = self.design, self.reference
        return (["", "paper", "plan"],
                [["rank", str(r.rank), str(d.rank)],
                 ["condition", number(r.condition), number(d.condition)],
                 *[[f"σ {n}", value_text(n, float(r.stderr[i])), value_text(n, float(d.stderr[i]))]
                   for i, n in enumerate(d.names) if n in d.interest]])


def tilt_jacobian(setup: Setup, angles: ArrayLike, azimuths: ArrayLike, *,
                  sensor: str = "output",
                  parameters: Sequence[str] = PLAN_PARAMETERS) -> F64:
    """Sensitivity of each tilt condition's observable(s) to the parameters, by central finite
    differences of :meth:`Setup.output` / :meth:`Setup.field`.

    Parameters
    ----------
    setup : Setup
        Where the derivatives are taken (SI).
    angles, azimuths : array-like, shape (c,)
        Tilt angle and tilt azimuth of each candidate, rad.
    sensor : {"output", "field"}
        The AMR output (one row, V per SI unit) or the three field components (three rows, T per
        SI unit).
    parameters : sequence of str
        Setup parameters to differentiate (continuous registry names).

    Returns
    -------
    ndarray, shape (c, r, q)
        ``r`` = 1 (output) or 3 (field); ``q`` = len(parameters). Offsets are not included.
    """
    sensor = v.choice("sensor", sensor, SENSORS)
    a = v.finite_array("angles", angles, ndim=1)
    phi = v.finite_array("azimuths", azimuths, ndim=1)
    if phi.size != a.size:
        raise v.fail("azimuths", f"{phi.size} values", f"one azimuth per angle ({a.size})")
    params = setup.params()
    r = 1 if sensor == "output" else 3
    out = np.empty((a.size, r, len(parameters)))

    def observe(s: Setup) -> F64:
        res = np.empty((a.size, r))
        for az in np.unique(phi):
            sel = phi == az
            if sensor == "output":
                res[sel, 0] = s.output(a[sel], azimuth=float(az))
            else:
                res[sel] = s.field(a[sel], azimuth=float(az))
        return res

    for j, name in enumerate(parameters):
        if name not in params or PARAMETERS[name].domain == "integer":
            raise v.fail("parameters", name, "continuous setup parameters such as "
                                             + ", ".join(PLAN_PARAMETERS))
        h = 1e-4 * max(abs(params[name]), 1e-3 if PARAMETERS[name].unit == "m" else 1.0)
        up = observe(setup.replace(**{name: params[name] + h}))
        down = observe(setup.replace(**{name: params[name] - h}))
        out[:, :, j] = (up - down) / (2.0 * h)
    return out


def plan_calibration(setup: Setup, budget: int, *, sensor: str = "output",
                     azimuths: ArrayLike = (0.0, math.pi / 2),
                     angles: ArrayLike | None = None, noise: float | None = None,
                     parameters: Sequence[str] = PLAN_PARAMETERS,
                     prior_sd: dict[str, float] | None = None,
                     progress: Callable[[int, int], None] | None = None) -> CalibrationPlan:
    """Plan a tilt-table calibration of ``setup``: the D-optimal ``budget`` conditions among
    ``angles`` × ``azimuths``, next to the paper's ``budget`` equally spaced angles on one path.

    Each azimuth is one experiment with its own output offset (one per field component for
    ``"field"``), a nuisance parameter with a weak prior (:data:`OFFSET_PRIOR`), profiled out of
    the criterion (D_s-optimality on ``parameters``).

    Parameters
    ----------
    setup : Setup
        The expected cilium and placement (SI).
    budget : int
        Number of readings N (each reading of ``"field"`` gives three components).
    sensor : {"output", "field"}
        The single-axis AMR output or a 3-axis magnetometer.
    azimuths : array-like of float
        Tilt directions on offer, rad (default 0 and π/2).
    angles : array-like of float, optional
        Tilt angles on offer, rad (default 0 to 85 deg in 2.5 deg steps).
    noise : float, optional
        σ of one reading: V for ``"output"`` (default the sensor's noise over
        :data:`~magcilia.device.sensor.DEFAULT_BANDWIDTH`), T per component for ``"field"``
        (default 10 nT).
    parameters : sequence of str
        Parameters of interest (default height, base radius, x, y, z).
    prior_sd : dict of str to float, optional
        Prior σ (SI) of some parameters (manual measurements).
    progress : callable(done, total), optional
        Called as the search goes (:func:`d_optimal`).

    Returns
    -------
    CalibrationPlan

    Raises
    ------
    MagciliaError
        Bad arguments, or a plan beyond :data:`~magcilia.calibration.plan_size.MAX_WORK` or
        :data:`~magcilia.calibration.plan_size.MAX_INFORMATION`
        (:func:`~magcilia.calibration.plan_size.check_plan_size`), before any work.
    """
    sensor = v.choice("sensor", sensor, SENSORS)
    grid = (np.radians(np.arange(0.0, 85.0 + 1e-9, 2.5)) if angles is None
            else v.finite_array("angles", angles, ndim=1))
    phis = np.unique(v.finite_array("azimuths", azimuths, ndim=1))
    if grid.size < 1 or phis.size < 1:
        raise v.fail("angles", grid.tolist(), "at least one tilt angle and one azimuth")
    if noise is None:
        noise = (setup.sensor.output_noise_rms(*DEFAULT_BANDWIDTH) if sensor == "output"
                 else 10e-9)
    noise = v.positive("noise", noise, "V" if sensor == "output" else "T", "noise σ")
    parameters = tuple(parameters)
    q = len(parameters)
    budget = v.integer("budget", budget, 1)
    prior_sd = dict(prior_sd or {})
    informative = q - sum(1 for n in parameters if n in prior_sd)  # readings, whatever the rows
    if budget < informative:
        raise v.fail("budget", budget, f"at least {informative} conditions to determine "
                                       f"{informative} parameters ({', '.join(parameters)})")

    def candidates(a: F64, phi: F64, experiments: F64) -> tuple[F64, list[str]]:
        J = tilt_jacobian(setup, a, phi, sensor=sensor, parameters=parameters) / noise
        r = J.shape[1]
        off = np.zeros((a.size, r, experiments.size * r))
        labels = []
        for e, az in enumerate(experiments):
            for k in range(r):
                off[phi == az, k, e * r + k] = 1.0 / noise
                labels.append(f"offset[{math.degrees(az):g}deg"
                              + ("" if r == 1 else f",B{'xyz'[k]}") + "]")
        return np.concatenate([J, off], axis=2), labels

    r = 1 if sensor == "output" else 3
    check_plan_size(budget, grid.size * phis.size, q + r * phis.size, RESTARTS)  # no work yet
    a_all = np.tile(grid, phis.size)
    phi_all = np.repeat(phis, grid.size)
    J, labels = candidates(a_all, phi_all, phis)
    names = (*parameters, *labels)
    prec = np.zeros(len(names))
    for n, sd in prior_sd.items():
        if n not in parameters:
            raise v.fail("prior_sd", n, "parameters among " + ", ".join(parameters))
        prec[parameters.index(n)] = 1.0 / v.positive(f"prior_sd[{n}]", sd, "SI", "σ") ** 2
    # a weak prior on each offset: OFFSET_PRIOR × the largest signal of one reading
    signal = float(np.max(np.abs(J[:, :, :q] * np.array([
        max(abs(setup.params()[n]), 1e-3) for n in parameters])))) * noise
    prec[q:] = 1.0 / (OFFSET_PRIOR * max(signal, noise)) ** 2
    design = d_optimal(J, budget, names=names, interest=parameters, prior_precision=prec,
                       progress=progress)
    ref_angles = np.linspace(float(grid.min()), float(grid.max()), budget)
    J_ref, _ = candidates(ref_angles, np.full(budget, phis[0]), phis)
    reference = evaluate_design(J_ref, np.arange(budget), names=names, interest=parameters,
                                prior_precision=prec)
    return CalibrationPlan(setup=setup, sensor=sensor, noise=float(noise), angles=a_all,
                           azimuths=phi_all, design=design, reference=reference,
                           reference_angles=ref_angles)


__all__ = ["MAX_EXCHANGES", "NULL_COMPONENT", "OFFSET_PRIOR", "PLAN_PARAMETERS", "RANK_TOLERANCE",
           "RESTARTS", "SENSORS", "TOLERANCE", "CalibrationPlan", "Design", "d_optimal",
           "evaluate_design", "plan_calibration", "tilt_jacobian"]
