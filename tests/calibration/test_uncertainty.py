"""Reported standard errors against the cost profile they summarise."""

from __future__ import annotations

import math

import numpy as np
import pytest

import magcilia as mc
from magcilia.acquire.synthetic import synthetic_recording
from magcilia.io.recordings import measurement_from_samples

ANGLES = np.radians(np.linspace(0.0, 85.0, 33))
TRUTH = mc.Setup.paper().replace(y=0.0)
P = TRUTH.params()


def _profile_halfwidth(data: mc.Measurement, bounds: dict, fit: mc.CalibrationResult,
                       name: str, start: float) -> float:
    """Half the width of the interval where the cost, re-minimised over the other parameters,
    stays within σ² (= cost / dof) of the optimum: the profile's 1-σ half-width (inf if the
    profile stays below within ``start`` × 2^10)."""
    dof = len(data) - len(fit.uncertainty.correlation_names)
    s2 = fit.cost / dof
    best = fit.values[name]

    def rise(step: float) -> float:
        value = best + step
        lo, hi = mc.calibration.DEFAULT_BOUNDS[name]
        if not lo <= value <= hi:
            return math.inf
        held = {**bounds, name: (value, value)}
        refit = mc.calibrate(data, initial=fit.setup.replace(**{name: value}), bounds=held,
                             starts=4, rng=0)
        return (refit.cost - fit.cost) / s2

    widths = []
    for sign in (-1.0, 1.0):
        low, high = 0.0, start
        while rise(sign * high) < 1.0:
            low, high = high, 2.0 * high
            if high > start * 2**10:
                return math.inf
        for _ in range(20):
            mid = 0.5 * (low + high)
            low, high = (mid, high) if rise(sign * mid) < 1.0 else (low, mid)
        widths.append(0.5 * (low + high))
    return float(np.mean(widths))


def _data(seed: int) -> mc.Measurement:
    rec = synthetic_recording(TRUTH, ANGLES, samples_per_angle=400, rng=seed)
    return measurement_from_samples(rec.angle_deg, rec.voltage)


def test_determined_y_matches_its_profile() -> None:
    # geometry held: y is determined (the fit lands at |y| ~ 0.16 mm, away from the symmetric 0)
    bounds = {n: (P[n], P[n]) for n in ("height", "base_radius", "z", "n_loops",
                                        "dipoles_per_loop")}
    data = _data(3)
    fit = mc.calibrate(data, initial=TRUTH, bounds=bounds, rng=0, starts=32)
    se = fit.stderr["y"]
    assert math.isfinite(se)
    assert se == pytest.approx(_profile_halfwidth(data, bounds, fit, "y", se), rel=0.3)


def test_y_near_zero_is_not_reported_as_known() -> None:
    # with z free the fit lands at y ~ 1e-8 m, where d output / d y ~ 0 (B_x is even in y) and
    # the y column is tiny and nearly parallel to the offset's: its standard error must not
    # collapse (a pseudo-inverse of the unscaled JᵀJ dropped that column and reported 2.5e-10 m)
    bounds = {n: (P[n], P[n]) for n in ("height", "base_radius", "n_loops", "dipoles_per_loop")}
    data = _data(2)
    fit = mc.calibrate(data, initial=TRUTH, bounds=bounds, rng=0, starts=64)
    assert abs(fit.values["y"]) < 1e-6
    width = _profile_halfwidth(data, bounds, fit, "y", 1e-5)
    assert width > 1e-4  # the data leave y loose by a tenth of a millimetre or more
    assert fit.stderr["y"] >= 0.5 * width
    assert any("y is not determined" in w for w in fit.warnings)
