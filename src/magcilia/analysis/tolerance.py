"""Placement tolerance: how precisely the cilium's position must be known for a target angle
accuracy.

The read-out inverts the calibrated curve V(θ) of the *nominal* placement. If the real placement
is off by δx_i, the reading at tilt θ is V(θ) + (∂V/∂x_i) δx_i and the inferred angle is off by
``δθ = (∂V/∂x_i) δx_i / (∂V/∂θ)`` (first order). For a target accuracy Δθ, coordinate i alone may
therefore be off by at most ``Δθ · |∂V/∂θ| / |∂V/∂x_i|`` at that angle; the tolerance is the
smallest of these over the angle range (the worst angle). The sensor noise over the read-out
bandwidth sets the noise-limited angle resolution ``σ_V / |∂V/∂θ|`` (worst over the range); the
tolerance that remains once that noise is spent (in quadrature) is reported too.

This puts numbers on the paper's worry (Sec. V) that small placement errors make the model fail.
SI units: m, rad, V.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Any

import numpy as np
from numpy.typing import ArrayLike, NDArray

from magcilia import _validate as v
from magcilia._display import Display, Item, Table, dataframe, rows_table, scaled, si
from magcilia.analysis.measures import check_angles
from magcilia.device.parameters import PARAMETERS, SWEEPABLE
from magcilia.device.sensor import DEFAULT_BANDWIDTH
from magcilia.device.setup import Setup
from magcilia.model.batch import tilt_output_batch

F64 = NDArray[np.float64]
#: what a tolerance can be asked for: the lengths among the sweepable parameters
COORDINATES = tuple(n for n in SWEEPABLE if PARAMETERS[n].dimension == "length")


@dataclass(frozen=True, eq=False, repr=False)
class PlacementTolerance(Display):
    """Per-coordinate position tolerance for a target angle accuracy (immutable).

    Attributes
    ----------
    coordinates : tuple of str
        The coordinates studied (default x, y, z: the paper's placement).
    tolerance : ndarray, shape (c,)
        Position error, m, that alone causes ``angle_accuracy`` of angle error at the worst angle
        (inf if the output does not depend on the coordinate, e.g. y at y = 0 by symmetry).
    worst_angle : ndarray, shape (c,)
        The tilt angle, rad, where that happens.
    tolerance_with_noise : ndarray, shape (c,)
        As ``tolerance`` with the budget reduced by the noise-limited resolution in quadrature,
        ``sqrt(Δθ² − σ_θ(θ)²)`` per angle (0 where the noise alone exceeds Δθ).
    angle_accuracy : float
        Target Δθ, rad.
    noise_rms : float
        Output noise over the bandwidth, V rms.
    bandwidth : (float, float)
        Read-out band, Hz.
    noise_angle : float
        Noise-limited angle resolution (1 σ), rad, worst over the range.
    angles : ndarray, shape (a,)
        Tilt angles, rad.
    slope : ndarray, shape (a,)
        ∂V/∂θ, V/rad.
    sensitivities : ndarray, shape (c, a)
        ∂V/∂(coordinate), V/m.
    """

    coordinates: tuple[str, ...]
    tolerance: F64
    worst_angle: F64
    tolerance_with_noise: F64
    angle_accuracy: float
    noise_rms: float
    bandwidth: tuple[float, float]
    noise_angle: float
    angles: F64
    slope: F64
    sensitivities: F64

    def table(self) -> list[dict[str, Any]]:
        """Rows: coordinate, tolerance (µm), worst angle (deg), tolerance after noise (µm)."""
        return [
            {"coordinate": c, "tolerance_um": float(t) * 1e6,
             "worst_angle_deg": math.degrees(float(w)),
             "tolerance_with_noise_um": float(tn) * 1e6}
            for c, t, w, tn in zip(self.coordinates, self.tolerance, self.worst_angle,
                                   self.tolerance_with_noise, strict=True)
        ]

    def report(self) -> str:
        """Plain-text summary ("x must be known to ±… µm")."""
        lines = [
            (f"placement tolerance for {math.degrees(self.angle_accuracy):.3g} deg angle accuracy "
            f"over {math.degrees(self.angles[0]):.3g}..{math.degrees(self.angles[-1]):.3g} deg"),
            (f"noise {self.noise_rms * 1e6:.3g} uV rms over "
            f"{self.bandwidth[0]:g}..{self.bandwidth[1]:g} Hz"
            f" -> noise-limited angle resolution {math.degrees(self.noise_angle):.3g} deg (1 sigma,"
            " worst angle)"),
        ]
        for r in self.table():
            tol, tol_n = r["tolerance_um"], r["tolerance_with_noise_um"]
            if math.isinf(tol):
                lines.append(f"{r['coordinate']}: no first-order effect on the angle")
                continue
            lines.append(f"{r['coordinate']} must be known to ±{tol:.3g} um (worst at "
                         f"{r['worst_angle_deg']:.3g} deg; ±{tol_n:.3g} um once the noise is "
                         "spent)")
        return "\n".join(lines)

    def to_dict(self) -> dict[str, Any]:
        """JSON-ready content (SI plus the display table)."""
        return {
            "angle_accuracy_rad": self.angle_accuracy, "noise_rms_V": self.noise_rms,
            "bandwidth_Hz": list(self.bandwidth), "noise_angle_rad": self.noise_angle,
            "coordinates": list(self.coordinates), "tolerance_m": self.tolerance.tolist(),
            "worst_angle_rad": self.worst_angle.tolist(),
            "tolerance_with_noise_m": self.tolerance_with_noise.tolist(), "table": self.table(),
        }

    # -- display --------------------------------------------------------------------------------
    def _display_items(self) -> list[Item]:
        tol = [(c, f"±{si(t, 'm')}") for c, t in zip(self.coordinates, self.tolerance,
                                                     strict=True)]
        return [("accuracy", scaled(self.angle_accuracy, math.pi / 180.0, "deg")), *tol,
                ("noise", si(self.noise_rms, "V")),
                ("noise angle", scaled(self.noise_angle, math.pi / 180.0, "deg"))]

    def _display_table(self) -> Table | None:
        return rows_table(self.table())

    def to_dataframe(self) -> Any:
        """One row per coordinate as a ``pandas.DataFrame``, SI: ``coordinate``,
        ``tolerance_m``, ``worst_angle_rad``, ``tolerance_with_noise_m`` (inf: no first-order
        effect)."""
        return dataframe({"coordinate": list(self.coordinates), "tolerance_m": self.tolerance,
                          "worst_angle_rad": self.worst_angle,
                          "tolerance_with_noise_m": self.tolerance_with_noise})


def placement_tolerance(
    setup: Setup,
    angle_accuracy: float = math.radians(1.0),
    angles: ArrayLike | None = None,
    bandwidth: tuple[float, float] = DEFAULT_BANDWIDTH,
    coordinates: tuple[str, ...] = ("x", "y", "z"),
    step: float = 1e-6,
) -> PlacementTolerance:
    """How precisely each placement coordinate must be known for a target angle accuracy.

    Parameters
    ----------
    setup : Setup
        The calibrated setup (the nominal placement).
    angle_accuracy : float
        Target angle accuracy Δθ, rad (default 1°).
    angles : array-like, shape (a,), optional
        Tilt angles over which the worst case is taken, rad (default 0..85° in 33 steps).
    bandwidth : (float, float)
        Read-out band [f_low, f_high], Hz, for the sensor noise (white + 1/f).
    coordinates : tuple of str
        Any of x, y, z, height, base_radius, tip_radius.
    step : float
        Central-difference step for ∂V/∂x_i, m (and step / 1 mm rad for ∂V/∂θ).

    Returns
    -------
    PlacementTolerance
    """
    if not isinstance(setup, Setup):
        raise v.fail("setup", type(setup).__name__, "a magcilia Setup")
    dtheta = v.positive("angle_accuracy", angle_accuracy, "rad", "angle")
    ang = check_angles(angles)
    step = v.positive("step", step, "m", "step")
    coords = tuple(v.choice("coordinate", c, COORDINATES) for c in coordinates)
    if not coords:
        raise v.fail("coordinates", "()", "at least one of " + ", ".join(COORDINATES))
    try:
        f_lo, f_hi = (float(b) for b in bandwidth)
    except (TypeError, ValueError):
        raise v.fail("bandwidth", bandwidth, "a (f_low, f_high) pair in Hz") from None
    sensor = setup.sensor
    noise_v = sensor.output_noise_rms(f_lo, f_hi)
    h_t = step / 1e-3  # rad: the same relative step as step/1 mm of position
    slope = (setup.output(ang + h_t) - setup.output(ang - h_t)) / (2.0 * h_t)
    nominal = setup.params()
    rows = []
    for c in coords:
        x0 = float(nominal[c])
        vals = np.array([x0 + step, x0 - step])
        if PARAMETERS[c].domain != "real" and x0 - step < 0:
            vals[1] = x0  # one-sided at a zero tip radius
        out = tilt_output_batch(setup, {c: vals}, ang)
        rows.append((out[0] - out[1]) / (vals[0] - vals[1]))
    sens = np.asarray(rows)
    # round-off of the difference (e.g. y at y = 0, where V is even in y) is no dependence
    floor = 1e-9 * float(np.abs(setup.output(ang)).max()) / 1e-3
    sens = np.where(np.abs(sens) > floor, sens, 0.0)
    abs_slope = np.abs(slope)
    with np.errstate(divide="ignore", invalid="ignore"):
        per_angle = np.where(np.abs(sens) > 0, dtheta * abs_slope / np.abs(sens), np.inf)
        noise_theta = np.where(abs_slope > 0, noise_v / abs_slope, np.inf)
    budget = np.sqrt(np.clip(dtheta**2 - noise_theta**2, 0.0, None))
    with np.errstate(divide="ignore", invalid="ignore"):
        per_angle_noise = np.where(np.abs(sens) > 0, budget * abs_slope / np.abs(sens), np.inf)
    worst = np.argmin(per_angle, axis=1)
    return PlacementTolerance(
        coordinates=coords, tolerance=per_angle.min(axis=1), worst_angle=ang[worst],
        tolerance_with_noise=per_angle_noise.min(axis=1), angle_accuracy=dtheta,
        noise_rms=noise_v, bandwidth=(f_lo, f_hi), noise_angle=float(noise_theta.max()),
        angles=ang, slope=slope, sensitivities=sens,
    )
