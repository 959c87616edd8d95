"""The identifiability table of rig-free calibration (issue 29, item 1): what each calibration
determines, from the Fisher information, for two cilia on two sensors.

Calibrations (rows): the coil alone; coil + size (a height prior ±0.15 mm); coil + size +
ring-down (a modulus prior with the σ that :func:`magcilia.ringdown` gives for a simulated flick
of the cilium, its size known to ±0.15 mm); the paper's tilt rig (33 equally spaced angles 0–85°
on one path, the reference); rig + coil. The coil sequence is the D-optimal one of
:func:`~magcilia.calibration.coil_plan.plan_coil` with the same 33 readings (planned with both
priors). Each reading is the mean of 2 s of samples as the paper's (2000 at 1 kHz for the AMR, 200
at the part's 100 Hz for the MMC5983MA), white noise taken as averaging down. Cilia: the paper's
(examples/paper.toml, its dipole model, with a 0.02 mm tip radius: a field's couple on its sharp
cone is singular) and the force-sensor's (examples/force-sensor.toml). Parameters:
:data:`~magcilia.calibration.coil_rows.CALIBRATION_PARAMETERS`, all free in every row (the
sensitivity only for the AMR: the 3-axis part is taken as calibrated, "n/a").

``python -m magcilia plan --identifiability --markdown`` prints what docs/coil-calibration.md
holds (scripts/identifiability_table.py --write puts it there; a test checks it is current).
"""

from __future__ import annotations

import math
from collections.abc import Callable
from dataclasses import dataclass
from typing import Any

import numpy as np
from numpy.typing import NDArray

from magcilia._display import Display, Item
from magcilia.calibration.coil_plan import default_noise, plan_coil
from magcilia.calibration.coil_rows import (
    CALIBRATION_PARAMETERS,
    calibration_rows,
    parameters_for,
)
from magcilia.calibration.identifiability import (
    Identifiability,
    experiment_information,
    identify,
    sigma_text,
)
from magcilia.device.setup import Setup

F64 = NDArray[np.float64]

#: readings of the rig (the paper's 33 angles) and of the coil sequence
BUDGET = 33
#: the paper's angles, rad: equally spaced 0–85° on one path (azimuth 0)
RIG_ANGLES = np.radians(np.linspace(0.0, 85.0, BUDGET))
#: σ of the size measurement, m (a height prior)
HEIGHT_SIGMA = 0.15e-3
#: tip radius given to the paper's sharp cone for the coil rows, m
PAPER_TIP_RADIUS = 0.02e-3
#: each reading averages this long, s (the paper's 2000 samples at 1 kHz)
AVERAGE = 2.0
CILIA = {"paper": "paper.toml", "force-sensor": "force-sensor.toml"}
SENSORS = {"HMC1021Z": "output", "MMC5983MA": "field"}
CALIBRATIONS = ("coil only", "coil + size", "coil + size + ring-down", "paper's tilt rig",
                "rig + coil")


def cilium(name: str) -> Setup:
    """The table's setup of a cilium (:data:`CILIA`; the paper's with
    :data:`PAPER_TIP_RADIUS`)."""
    from magcilia.io import presets

    setup = presets.setup(name)
    if setup.params()["tip_radius"] <= 0:
        setup = setup.replace(tip_radius=PAPER_TIP_RADIUS)
    return setup


def ringdown_sigma(setup: Setup, rng: int = 0) -> float:
    """σ of the modulus that :func:`magcilia.ringdown` gives for a simulated flick of ``setup``'s
    cilium in air (the first mode of :func:`magcilia.modes` ringing down for 2 s at 10 kHz with
    the sensor's own noise, the output swing of a 10° tilt), its height known to
    :data:`HEIGHT_SIGMA`, Pa."""
    from magcilia.analysis.ringdown import ringdown
    from magcilia.analysis.ringdown_fit import damped_sinusoid
    from magcilia.mechanics.modal import modes

    rate = 10_000.0
    m = modes(setup, "air")
    fn, zeta = float(m.frequencies[0]), float(m.damping_ratios[0])
    rest, held = setup.output(np.radians([0.0, 10.0]))
    t = np.arange(int(2.0 * rate)) / rate
    y = rest + damped_sinusoid(t, fn * math.sqrt(1 - zeta**2), zeta * 2 * math.pi * fn,
                               held - rest)
    y = y + setup.sensor.noise(t.size, rate, rng=rng)
    res = ringdown(y, rate, setup=setup, fluid="air", size_sigma={"height": HEIGHT_SIGMA})
    return float(res.youngs_modulus_sigma)


@dataclass(frozen=True, repr=False, eq=False)
class IdentifiabilityTable(Display):
    """What each calibration determines, per cilium and sensor.

    Attributes
    ----------
    rows : tuple of (cilium, sensor, calibration, Identifiability)
    modulus_sigma : dict of str to float
        The ring-down's σ of the modulus per cilium, Pa.
    """

    rows: tuple[tuple[str, str, str, Identifiability], ...]
    modulus_sigma: dict[str, float]

    def to_dict(self) -> dict[str, Any]:
        """JSON-ready, SI."""
        return {"units": "SI", "modulus_sigma": self.modulus_sigma,
                "rows": [{"cilium": c, "sensor": s, "calibration": k, **r.to_dict()}
                         for c, s, k, r in self.rows]}

    def markdown(self) -> str:
        """One Markdown table per cilium and sensor, then the undetermined combinations; a σ
        larger than the value itself reads "> 100 %" (weakly determined: its digits would
        only echo the near-singular information)."""
        out: list[str] = []
        cols = CALIBRATION_PARAMETERS
        head = ("| calibration | rank | " + " | ".join(f"σ {n}" for n in cols) + " |")
        for c in CILIA:
            for s in SENSORS:
                out += ["", f"**{c} cilium, {s}**", "", head,
                        "|" + "---|" * (len(cols) + 2)]
                notes = []
                for cc, ss, k, r in self.rows:
                    if (cc, ss) != (c, s):
                        continue
                    label = f"**{k}** (reference)" if k == "paper's tilt rig" else k
                    shown = {n: ("> 100 %" if math.isfinite(x) and x > u
                                 else sigma_text(n, float(x), size=float(u)))
                             for n, x, u in zip(r.names, r.stderr, r.units, strict=True)}
                    out.append(f"| {label} | {r.rank}/{len(r.names)} | "
                               + " | ".join(shown.get(n, "n/a") for n in cols) + " |")
                    notes += [f"- {k}: undetermined: {u}; determined by {f}"
                              for u, f in zip(r.undetermined, r.remedies, strict=True)]
                out += ["", *notes]
        return "\n".join(out).strip() + "\n"

    def report(self) -> str:
        """The Markdown tables (they read as text too)."""
        return self.markdown()

    def _display_items(self) -> list[Item]:
        return [("rows", str(len(self.rows)))]


def identifiability_table(progress: Callable[[str], None] | None = None
                          ) -> IdentifiabilityTable:
    """Compute the table (about a minute on one core): every calibration of
    :data:`CALIBRATIONS` for every cilium of :data:`CILIA` on every sensor of :data:`SENSORS`."""
    rows: list[tuple[str, str, str, Identifiability]] = []
    sig_e: dict[str, float] = {}
    for c in CILIA:
        setup = cilium(c)
        sig_e[c] = ringdown_sigma(setup)
        size = {"height": HEIGHT_SIGMA}
        full = {**size, "youngs_modulus": sig_e[c]}
        for s, measure in SENSORS.items():
            if progress is not None:
                progress(f"identifiability: {c} cilium, {s}")
            names = parameters_for(measure)
            rate = 1000.0 if measure == "output" else 100.0
            noise = default_noise(setup, measure) / math.sqrt(AVERAGE * rate)
            plan = plan_coil(setup, BUDGET, measure=measure, parameters=names, prior_sd=full,
                             noise=noise)
            fields = plan.fields[plan.design.chosen]
            coil_rows, rig_rows = calibration_rows(setup, fields=fields, angles=RIG_ANGLES,
                                                   measure=measure)
            assert coil_rows is not None
            assert rig_rows is not None
            coil = experiment_information(coil_rows, noise)
            rig = experiment_information(rig_rows, noise)
            cases = {"coil only": (coil, {}), "coil + size": (coil, size),
                     "coil + size + ring-down": (coil, full),
                     "paper's tilt rig": (rig, {}), "rig + coil": (rig + coil, {})}
            for k in CALIBRATIONS:
                info, priors = cases[k]
                rows.append((c, s, k, identify(info, names, setup, priors)))
    return IdentifiabilityTable(rows=tuple(rows), modulus_sigma=sig_e)


__all__ = ["AVERAGE", "BUDGET", "CALIBRATIONS", "CILIA", "HEIGHT_SIGMA", "PAPER_TIP_RADIUS",
           "RIG_ANGLES", "SENSORS", "IdentifiabilityTable", "cilium",
           "identifiability_table", "ringdown_sigma"]
