"""Biaxial read-out: the horizontal tip force vector (Fx, Fy) from several field channels.

A horizontal tip force of magnitude F at azimuth φ bends the cilium in the vertical plane at φ:
the planar shape of :func:`magcilia.bend_sweep` (direction π/2, toward +x) turned by φ about the
vertical axis through the base (:meth:`magcilia.SpatialCentreline.from_planar`). The read-out
sees that shape's field through *channels*: one sensitive axis at one point each, with its noise
(:class:`Channel`); a 3-axis :class:`~magcilia.device.magnetometer.Magnetometer` is three
channels at one point, two single-axis elements (HMC1021Z turned 90°, or side by side) are two.

:class:`BiaxialReadout` builds, once, the model reading of every channel on a polar grid of
(F, φ): one bend sweep over [0, span·(1 + edge)] gives the planar shapes; the field of shape F
turned by φ at a point p is ``R(φ) · G_F(R(−φ)(p − b) + b)`` with ``G_F`` the planar shape's
field and ``b`` the base centre (exact: the turned world), so the grid needs only the dipoles of
the planar shapes, observed on circles. A bicubic Hermite interpolant (cubic-spline derivatives
along F, spectral ones along the periodic φ) gives each channel's reading and its derivatives
anywhere in the disc |F| ≤ F_max. :meth:`BiaxialReadout.read` estimates (Fx, Fy) per reading by
a coarse grid search (χ² at the grid's nodes, one matrix product per block of readings) and a
Levenberg–Marquardt refinement in Cartesian (Fx, Fy), vectorised over readings, and gives the
covariance from the channels' noise through the Jacobian.

The model's dipole rings turn with the bending direction (the convention of
:mod:`magcilia.model.azimuth`), so even the unloaded cilium's field depends on φ by a trace
(~1e-6 of the field for the paper's k = 5): the F = 0 row of the grid is the mean over φ, so
that the model is a smooth function of (Fx, Fy) through zero.

σ includes the force scale: the Young's modulus's uncertainty (a force vector scales with E at a
fixed shape; :mod:`magcilia.readout.scale`), systematic and kept apart in
:attr:`ForceVectorResult.covariance_scale`. What σ omits: the interpolation error of the grid
(measured at construction, :attr:`BiaxialReadout.table_error`), the uncertainty of the setup's
parameters (calibration), the ring trace above, and any force component the read-out does not
model (vertical loads, flow).

All SI: N, rad, T, m.
"""

from __future__ import annotations

import enum
import math
from collections.abc import Sequence
from dataclasses import dataclass
from typing import Any

import numpy as np
from numpy.typing import ArrayLike, NDArray

from magcilia import _validate as v
from magcilia._display import Display, Item, Table, column, dataframe, scaled
from magcilia._errors import MagciliaError
from magcilia.device.actuation import Actuation
from magcilia.device.magnetometer import Magnetometer
from magcilia.device.sensor import DEFAULT_BANDWIDTH, Sensor, beyond_range
from magcilia.device.setup import Setup
from magcilia.mechanics import bend, bend_sweep, require_tip_radius
from magcilia.model.azimuth import turn_about_z
from magcilia.model.centreline import SpatialCentreline
from magcilia.model.kernels import pose_field
from magcilia.readout.inverse import EDGE_TOLERANCE
from magcilia.readout.scale import (
    VECTOR_RATE_GRID,
    least_squares_rate,
    per_ln_modulus,
    to_polar,
    vector_rate,
    vector_scale_covariance,
)
from magcilia.readout.tare import (
    ChannelTare,  # noqa: F401  (the former name, kept)
    Tare,
)

F64 = NDArray[np.float64]

#: readings per block of :meth:`BiaxialReadout.read` (the coarse search's χ² table stays small)
BLOCK = 4096
#: Δχ² within which a second, distinct minimum makes a reading AMBIGUOUS
AMBIGUITY_CHI2 = 4.0
#: a force smaller than this many σ (largest axis of its error ellipse) has no direction
NEAR_ZERO_SIGMAS = 3.0
#: rings (magnitudes) and directions of the coarse search's grid (the table's nodes, thinned)
COARSE = (12, 32)
#: Levenberg–Marquardt iterations at most
MAX_ITERATIONS = 40
#: the normal matrix's condition number above which the two components are not both determined
CONDITION_LIMIT = 1e10


class ForceFlag(enum.IntFlag):
    """Bit flags of a force-vector reading (combine with ``|``; 0 is a good reading). The bits
    that mean the same as :class:`~magcilia.ReadoutFlag`'s have its values.

    OUTSIDE_SPAN and UNDETERMINED leave a reading without an estimate (NaN, :data:`NO_VECTOR`);
    NEAR_ZERO and AMBIGUOUS leave it without a direction (``direction`` NaN, ``sigma_direction``
    inf).
    """

    OK = 0
    #: no estimate: beyond the grid's reach (span and edge), or no finite unsaturated channel
    OUTSIDE_SPAN = 1
    #: a channel beyond its range (±field_range): left out of the estimate
    SATURATED = 4
    #: beyond the span but within the edge tolerance: the model continued past the span
    EXTRAPOLATED = 8
    #: the force's magnitude lies beyond the span
    ABOVE_SPAN = 64
    #: a second, distinct minimum within :data:`AMBIGUITY_CHI2` of the best: the direction is not
    #: determined by these readings (NaN); Fx, Fy and the magnitude are the better minimum's (a
    #: mirror image, e.g. φ and −φ, has the same magnitude; other pairs need not)
    AMBIGUOUS = 128
    #: the channels do not determine both components (fewer than two informative channels, or
    #: channels that see only one projection of the force): no estimate
    UNDETERMINED = 256
    #: the refinement stopped before converging (its last estimate is kept)
    NOT_CONVERGED = 512
    #: the force is within :data:`NEAR_ZERO_SIGMAS` σ of zero: its direction is undefined
    NEAR_ZERO = 1024
    #: a channel's reading is NaN: left out of the estimate
    MISSING = 2048


#: the flags that leave a reading without an estimate (all values and sigmas NaN)
NO_VECTOR = ForceFlag.OUTSIDE_SPAN | ForceFlag.UNDETERMINED
#: the flags that leave a reading without a direction
NO_DIRECTION = NO_VECTOR | ForceFlag.NEAR_ZERO | ForceFlag.AMBIGUOUS


# -- channels -------------------------------------------------------------------------------------


@dataclass(frozen=True, repr=False)
class Channel(Display):
    """One sensitive axis at one point: what one single-axis reading sees (all SI).

    Parameters
    ----------
    position : (3,) floats
        Sensing point, m, in the board frame (the paper's element is the origin, +z up).
    axis : (3,) floats
        Sensitive direction in the board frame (normalised here): the reading is ``axis · B``.
    sigma : float
        RMS noise of one reading, T (> 0).
    field_range : float
        Linear range ±field_range, T; readings beyond it are SATURATED (default: none).
    name : str
        For reports and errors.
    resolution : float
        One LSB of a digital part's reading, T (0: analog); a reading within half an LSB of the
        range is saturated (:func:`~magcilia.device.sensor.beyond_range`).

    Examples
    --------
    >>> c = Channel((0.0, 0.0, 0.0), (0.0, 2.0, 0.0), 1e-7, name="y")
    >>> c.axis
    (0.0, 1.0, 0.0)
    """

    position: Any
    axis: Any
    sigma: float
    field_range: float = math.inf
    name: str = "channel"
    resolution: float = 0.0

    def __post_init__(self) -> None:
        pos = v.vector3("position", self.position)
        axis = v.vector3("axis", self.axis, unit="")
        norm = float(np.linalg.norm(axis))
        if norm == 0.0:
            raise v.fail("axis", tuple(axis), "a non-zero direction (x, y, z)")
        object.__setattr__(self, "position", tuple(float(p) for p in pos))
        object.__setattr__(self, "axis", tuple(float(a) for a in axis / norm))
        object.__setattr__(self, "sigma", v.positive("sigma", self.sigma, "T", "noise"))
        rng = v.real("field_range", self.field_range, "T") if math.isfinite(
            float(self.field_range)) else math.inf
        if not rng > 0.0:
            raise v.fail("field_range", self.field_range, "a positive field in T (or inf)")
        object.__setattr__(self, "field_range", rng)
        object.__setattr__(self, "resolution",
                           v.non_negative("resolution", self.resolution, "T", "field"))

    @classmethod
    def of_magnetometer(cls, sensor: Magnetometer) -> tuple[Channel, Channel, Channel]:
        """The three channels of a 3-axis sensor: its axes (rotation columns), per-axis noise
        and range, named ``NAME.x``, ``.y``, ``.z``."""
        if not isinstance(sensor, Magnetometer):
            raise v.fail("sensor", type(sensor).__name__, "a magcilia Magnetometer")
        rot = np.asarray(sensor.rotation)
        return tuple(cls(sensor.position, rot[:, i], float(sensor.noise[i]),  # type: ignore[return-value]
                         float(sensor.field_range[i]), f"{sensor.name}.{'xyz'[i]}",
                         float(sensor.resolution[i]))
                     for i in range(3))

    @classmethod
    def of_sensor(cls, sensor: Sensor, position: ArrayLike = (0.0, 0.0, 0.0),
                  axis: ArrayLike = (1.0, 0.0, 0.0),
                  bandwidth: tuple[float, float] = DEFAULT_BANDWIDTH,
                  name: str = "HMC1021Z") -> Channel:
        """A single-axis AMR element (:class:`~magcilia.Sensor`) at ``position`` (m) with its
        sensitive axis along ``axis`` (the paper's element: the origin, +x): σ is the sensor's
        noise over ``bandwidth`` (Hz), in T; the range its ``field_range``."""
        if not isinstance(sensor, Sensor):
            raise v.fail("sensor", type(sensor).__name__, "a magcilia.Sensor")
        sigma = sensor.noise_rms(*bandwidth)
        return cls(position, axis, sigma, sensor.field_range, name)

    def to_dict(self) -> dict[str, Any]:
        """JSON-ready content (SI)."""
        return {"name": self.name, "position": list(self.position), "axis": list(self.axis),
                "sigma": self.sigma,
                "field_range": self.field_range if math.isfinite(self.field_range) else None,
                "resolution": self.resolution, "units": "SI"}

    def report(self) -> str:
        """One line: name, position (mm), axis, noise and range (gauss)."""
        rng = "no range" if not math.isfinite(self.field_range) else \
            f"range ±{self.field_range / 1e-4:.4g} G"
        return (f"{self.name}: at (" + ", ".join(f"{p * 1e3:.4g}" for p in self.position)
                + ") mm, axis (" + ", ".join(f"{a:.3g}" for a in self.axis)
                + f"), noise {self.sigma / 1e-4:.3g} G RMS, {rng}")

    def _display_items(self) -> list[Item]:
        return [("", self.name),
                ("at", "(" + ", ".join(f"{p * 1e3:.4g}" for p in self.position) + ") mm"),
                ("axis", "(" + ", ".join(f"{a:.3g}" for a in self.axis) + ")"),
                ("noise", scaled(self.sigma, 1e-4, "G"))]


ChannelLike = Channel | Magnetometer


def channels(sensors: ChannelLike | Sequence[ChannelLike]) -> tuple[Channel, ...]:
    """The channels of one sensor or a sequence of them (a Magnetometer gives three)."""
    items = [sensors] if isinstance(sensors, (Channel, Magnetometer)) else list(sensors)
    out: list[Channel] = []
    for i, item in enumerate(items):
        if isinstance(item, Magnetometer):
            out.extend(Channel.of_magnetometer(item))
        elif isinstance(item, Channel):
            out.append(item)
        else:
            raise v.fail(f"sensors[{i}]", type(item).__name__,
                         "a Magnetometer or a Channel (Channel.of_sensor for an HMC1021Z)")
    if not out:
        raise v.fail("sensors", "an empty list", "at least one Magnetometer or Channel")
    return tuple(out)


# -- the tare --------------------------------------------------------------------------------------


# -- the result ------------------------------------------------------------------------------------


@dataclass(frozen=True, eq=False, repr=False)
class ForceVectorResult(Display):
    """Force-vector estimates from :meth:`BiaxialReadout.read` (arrays have the readings' shape
    ``(...)``; SI).

    Attributes
    ----------
    fx, fy : ndarray
        Horizontal force components, N (NaN where a flag of :data:`NO_VECTOR` is set).
    magnitude, direction : ndarray
        |F|, N, and its azimuth, rad in (−π, π] from +x toward +y (NaN where a flag of
        :data:`NO_DIRECTION` is set: near zero, ambiguous or no estimate).
    sigma_fx, sigma_fy, sigma_magnitude, sigma_direction : ndarray
        1-σ uncertainties from the channels' noise (and a tare's standard error) through the
        Jacobian at the estimate, and the force scale (:attr:`covariance_scale`), N and rad;
        ``sigma_direction`` is inf where the direction is undefined (NEAR_ZERO, AMBIGUOUS).
    covariance : ndarray, shape (..., 2, 2)
        Covariance of (Fx, Fy), N²: the noise's (:attr:`covariance_noise`) plus the force
        scale's.
    covariance_scale : ndarray, shape (..., 2, 2)
        The force scale's share of it, N²: the Young's modulus's relative 1 σ along
        ∂F/∂ln E (the force itself without an actuation: the magnitude's σ grows by
        ``|F| · σ_E/E``, the direction's not; :mod:`magcilia.readout.scale`). Systematic: one
        error shared by every reading (fully correlated). Zeros for a modulus taken as exact.
    chi2 : ndarray
        χ² of the fit (Σ over the channels used of (residual/σ)²): ~ (channels − 2) for a
        reading the model explains.
    flags : ndarray of uint16
        :class:`ForceFlag` bits.
    span : float
        The read-out's span (largest magnitude), N.
    table_error : float
        Largest force error (N, vector) of the interpolation grid at its mid-points.
    scale_note : str
        Where the force scale comes from (:meth:`magcilia.Modulus.note`).
    """

    fx: F64
    fy: F64
    magnitude: F64
    direction: F64
    sigma_fx: F64
    sigma_fy: F64
    sigma_magnitude: F64
    sigma_direction: F64
    covariance: F64
    chi2: F64
    flags: NDArray[np.uint16]
    span: float
    table_error: float
    covariance_scale: F64
    scale_note: str = ""

    @property
    def covariance_noise(self) -> F64:
        """The noise's covariance of (Fx, Fy) alone, N², (..., 2, 2): :attr:`covariance` less
        the force scale's."""
        return np.asarray(self.covariance - self.covariance_scale, dtype=np.float64)

    @property
    def sigma_scale(self) -> F64:
        """The force scale's 1 σ, N, (...): the length of the modulus's error vector (``|F| ·
        σ_E/E`` without an actuation)."""
        return np.sqrt(np.clip(np.trace(self.covariance_scale, axis1=-2, axis2=-1), 0.0, None))

    @property
    def estimated(self) -> NDArray[np.bool_]:
        """True where the reading has a force estimate (no flag of :data:`NO_VECTOR`)."""
        return np.asarray(self.flags & np.uint16(NO_VECTOR) == 0)

    @property
    def ok(self) -> NDArray[np.bool_]:
        """True where no flag is set."""
        return np.asarray(self.flags == 0)

    @property
    def vector(self) -> F64:
        """(Fx, Fy), N, shape (..., 2)."""
        return np.stack([self.fx, self.fy], axis=-1)

    def counts(self) -> dict[str, int]:
        """Readings per flag name (lower case), and ``"readings"``, ``"estimated"``, ``"ok"``."""
        flags = self.flags.reshape(-1)
        out = {"readings": int(flags.size), "estimated": int(self.estimated.sum()),
               "ok": int(self.ok.sum())}
        for f in ForceFlag:
            if f:
                out[str(f.name).lower()] = int(np.count_nonzero(flags & np.uint16(f)))
        return out

    def to_dict(self) -> dict[str, Any]:
        """JSON-ready content (SI; the JSON writer turns NaN and inf into null: the flags say
        which, NaN without an estimate, inf ``sigma_direction`` without a direction)."""
        return {"fx": self.fx.tolist(), "fy": self.fy.tolist(),
                "magnitude": self.magnitude.tolist(), "direction": self.direction.tolist(),
                "sigma_fx": self.sigma_fx.tolist(), "sigma_fy": self.sigma_fy.tolist(),
                "sigma_magnitude": self.sigma_magnitude.tolist(),
                "sigma_direction": self.sigma_direction.tolist(),
                "covariance": self.covariance.tolist(), "chi2": self.chi2.tolist(),
                "covariance_scale": self.covariance_scale.tolist(),
                "flags": self.flags.tolist(), "span": self.span,
                "table_error": self.table_error, "scale_note": self.scale_note, "units": "SI"}

    def report(self) -> str:
        """One line: counts, magnitude range (mN), median σ of magnitude (mN) and direction
        (deg) of the readings with a direction."""
        c = self.counts()
        flagged = ", ".join(f"{c[k]} {k.replace('_', ' ')}" for k in
                            ("outside_span", "undetermined", "ambiguous", "near_zero",
                             "saturated", "missing", "not_converged", "extrapolated") if c[k])
        text = f"{c['estimated']}/{c['readings']} force vectors estimated"
        text += f" ({flagged})" if flagged else ""
        good = self.estimated
        if good.any():
            mag = self.magnitude[good]
            text += (f"; |F| {mag.min() * 1e3:.4g}…{mag.max() * 1e3:.4g} mN, median 1-σ "
                     f"{np.median(self.sigma_magnitude[good]) * 1e3:.3g} mN")
            has = np.isfinite(self.direction)
            if has.any():
                text += (f", direction median 1-σ "
                         f"{math.degrees(float(np.median(self.sigma_direction[has]))):.3g} deg")
        else:
            text += "; no valid estimate"
        if self.scale_note:
            text += f"; {self.scale_note}"
        return text

    def to_dataframe(self) -> Any:
        """One row per reading, SI, unit-suffixed columns: ``fx_N``, ``fy_N``, ``magnitude_N``,
        ``direction_rad``, their ``sigma_*``, ``cov_xy_N2``, ``chi2`` and ``flags``."""
        flat = {
            column("fx", "N"): self.fx, column("fy", "N"): self.fy,
            column("magnitude", "N"): self.magnitude,
            column("direction", "rad"): self.direction,
            column("sigma_fx", "N"): self.sigma_fx, column("sigma_fy", "N"): self.sigma_fy,
            column("sigma_magnitude", "N"): self.sigma_magnitude,
            column("sigma_direction", "rad"): self.sigma_direction,
            column("cov_xy", "N2"): self.covariance[..., 0, 1],
            "chi2": self.chi2, "flags": self.flags}
        return dataframe({k: np.asarray(a).reshape(-1) for k, a in flat.items()})

    def _display_items(self) -> list[Item]:
        c = self.counts()
        items: list[Item] = [("estimated", f"{c['estimated']}/{c['readings']}")]
        items += [(k.replace("_", " "), str(c[k])) for k in
                  ("undetermined", "ambiguous", "near_zero", "outside_span", "saturated") if c[k]]
        good = self.estimated
        if good.any():
            items.append(("median σ|F|",
                          scaled(float(np.median(self.sigma_magnitude[good])), 1e-3, "mN")))
        return items

    def _display_table(self) -> Table:
        rows = []
        for fx, fy, m, d, s, f in zip(*(a.reshape(-1)[:50] for a in (
                self.fx, self.fy, self.magnitude, self.direction, self.sigma_magnitude,
                self.flags)), strict=True):
            rows.append((f"{fx * 1e3:.4g}", f"{fy * 1e3:.4g}", f"{m * 1e3:.4g}",
                         f"{math.degrees(d):.4g}", f"{s * 1e3:.3g}",
                         ForceFlag(int(f)).name or "ok"))
        return (("Fx (mN)", "Fy (mN)", "|F| (mN)", "direction (deg)", "σ|F| (mN)", "flags"),
                rows)


def polar_sigmas(cov: F64, magnitude: F64, direction: F64) -> tuple[F64, F64]:
    """1 σ of the magnitude (N) and of the direction (rad) of force vectors of ``magnitude``
    (N) and ``direction`` (rad), shape (b,), with the covariance ``cov`` of (Fx, Fy), N²,
    (b, 2, 2): its variance along the force, and across it over the magnitude."""
    c, s = np.cos(direction), np.sin(direction)
    var_r = c * c * cov[:, 0, 0] + 2 * c * s * cov[:, 0, 1] + s * s * cov[:, 1, 1]
    var_t = s * s * cov[:, 0, 0] - 2 * c * s * cov[:, 0, 1] + c * c * cov[:, 1, 1]
    s_mag = np.sqrt(np.clip(var_r, 0.0, None))
    with np.errstate(divide="ignore", invalid="ignore"):
        s_dir = np.sqrt(np.clip(var_t, 0.0, None)) / magnitude
    return s_mag, s_dir


# -- the read-out ----------------------------------------------------------------------------------


_HERMITE = np.array([[1.0, 0.0, 0.0, 0.0], [0.0, 0.0, 1.0, 0.0],
                     [-3.0, 3.0, -2.0, -1.0], [2.0, -2.0, 1.0, 1.0]])


def _coefficients(f: F64, f_u: F64, f_w: F64, f_uw: F64) -> F64:
    """Bicubic Hermite coefficients a[k, l] (of u^k w^l) per cell: (nF − 1, nφ, c, 4, 4), from
    values and derivatives scaled to unit cells at the nodes (nF, nφ, c), φ periodic."""
    def corners(a: F64) -> tuple[F64, F64, F64, F64]:
        nxt = np.roll(a, -1, axis=1)
        return a[:-1], nxt[:-1], a[1:], nxt[1:]

    f00, f01, f10, f11 = corners(f)
    u00, u01, u10, u11 = corners(f_u)
    w00, w01, w10, w11 = corners(f_w)
    x00, x01, x10, x11 = corners(f_uw)
    g = np.stack([np.stack([f00, f01, w00, w01], -1), np.stack([f10, f11, w10, w11], -1),
                  np.stack([u00, u01, x00, x01], -1), np.stack([u10, u11, x10, x11], -1)], -2)
    return np.einsum("ki,...ij,lj->...kl", _HERMITE, g, _HERMITE)


@dataclass(frozen=True, eq=False, init=False, repr=False)
class BiaxialReadout(Display):
    """Read-out of the horizontal tip force vector (Fx, Fy) from several channels (immutable).

    Parameters
    ----------
    setup : Setup
        The cilium and its placement (``tip_radius > 0`` for a tip force); its dipole layout
        resolved by the layout rule at the channels' points
        (:meth:`~magcilia.Setup.resolve_layout`); ``.setup`` is the setup used.
    sensors : Magnetometer, Channel or a sequence of them
        What is read: a 3-axis sensor gives three channels (its axes), a :class:`Channel` one;
        readings are given in this order.
    span : float
        Largest force magnitude, N (> 0).
    table_size : (int, int)
        Grid nodes in magnitude (≥ 9) and in direction (≥ 16) of the model table.
    edge_tolerance : float, optional
        How far beyond the span magnitudes are still estimated (flag EXTRAPOLATED), N;
        default :data:`~magcilia.readout.inverse.EDGE_TOLERANCE` of the span.
    actuation : Actuation, optional
        A known, constant actuation field acting while the readings are taken (compensation):
        the grid is built from the cilium bent by each force *and* the actuation, and every
        channel also sees the actuation's direct field at its point. A uniform field along z
        keeps the problem symmetric about the vertical axis (one bend sweep, turned, as
        without); any other field needs one 3-D bend per grid node (~15 ms each: a
        ``table_size`` of (17, 32) takes ~30 s). A direct field that puts a channel beyond its
        range is refused.

    Attributes
    ----------
    channels : tuple of Channel
        The channels, in reading order.
    forces, azimuths : ndarray, shapes (nF,), (nφ,)
        The grid, N and rad.
    table : ndarray, shape (nF, nφ, c)
        Each channel's model reading on the grid, T (the F = 0 row is the mean over φ).
    rest : ndarray, shape (c,)
        The model reading at rest, T.
    table_error : float
        Largest force error (N, vector) of the interpolant at the grid's mid-points (magnitude
        and direction midway between nodes), read back without noise.
    baseline : Tare or None
        The tare (:meth:`tare`).
    actuation : Actuation or None
        As given.
    direct : ndarray, shape (c,)
        Each channel's reading of the actuation's direct field, T (zeros without one).

    Examples
    --------
    >>> import numpy as np, magcilia as mc
    >>> from magcilia.device.magnetometer import Magnetometer
    >>> s = mc.Setup.paper(tip_radius=5e-5, youngs_modulus=2e6)
    >>> m = Magnetometer(field_range=1e-3, resolution=1e-8, noise=1e-8, rate=100.0)
    >>> r = BiaxialReadout(s, m, span=1e-4, table_size=(33, 64))
    >>> shape = mc.bend(s, 5e-5)
    >>> b = s.field(shape, azimuth=np.radians(30.0))
    >>> np.round(r.estimate(m.to_sensor(b)) * 1e6, 2)
    array([[43.3, 25. ]])
    """

    setup: Setup
    channels: tuple[Channel, ...]
    span: float
    edge_tolerance: float
    forces: F64
    azimuths: F64
    table: F64
    rest: F64
    table_error: float
    baseline: Tare | None
    actuation: Actuation | None
    direct: F64
    _coef: F64
    _coarse: _Coarse
    _rate_grid: tuple[F64, F64, F64] | None

    def __init__(self, setup: Setup, sensors: ChannelLike | Sequence[ChannelLike],
                 span: float, table_size: tuple[int, int] = (65, 128),
                 edge_tolerance: float | None = None,
                 actuation: Actuation | None = None) -> None:
        if not isinstance(setup, Setup):
            raise v.fail("setup", type(setup).__name__, "a magcilia.Setup")
        chans = channels(sensors)
        # the layout rule at the channels' points
        setup = setup.resolve_layout(np.array([c.position for c in chans]),
                                     where="the sensors' points")
        span = v.positive("span", span, "N", "force")
        require_tip_radius(setup, "force")
        if np.size(table_size) != 2:
            raise v.fail("table_size", table_size, "a pair (magnitudes ≥ 9, directions ≥ 16)")
        n_f = v.integer("table_size[0]", table_size[0], 9)
        n_phi = v.integer("table_size[1]", table_size[1], 16)
        edge = EDGE_TOLERANCE * span if edge_tolerance is None else v.non_negative(
            "edge_tolerance", edge_tolerance, "N", "force")
        f_max = span + edge
        # a grid twice as dense: even nodes are the table, odd ones check it
        dense_f = np.linspace(0.0, f_max, 2 * n_f - 1)
        dense_phi = np.arange(2 * n_phi, dtype=np.float64) * (math.pi / n_phi)
        direct = np.zeros(len(chans))
        if actuation is None:
            fields = _model(setup, chans, dense_f, dense_phi)  # (2nF−1, 2nφ, c)
        else:
            fields, direct = _actuated_model(setup, chans, dense_f, dense_phi, actuation)
        table = fields[::2, ::2].copy()
        table[0] = table[0].mean(axis=0)
        forces, azimuths = dense_f[::2], dense_phi[::2]
        for name, value in (("setup", setup), ("channels", chans), ("span", span),
                            ("edge_tolerance", edge), ("forces", forces),
                            ("azimuths", azimuths), ("table", table),
                            ("rest", table[0, 0].copy()), ("baseline", None),
                            ("table_error", 0.0), ("actuation", actuation),
                            ("direct", direct)):
            object.__setattr__(self, name, value)
        object.__setattr__(self, "_coef", _build_coefficients(forces, table))
        object.__setattr__(self, "_rate_grid", None)
        if actuation is not None and setup.youngs_modulus_uncertainty:
            object.__setattr__(self, "_rate_grid", self._actuated_rates(f_max))
        step = max(1, (n_f - 1) // COARSE[0])
        every = max(1, n_phi // COARSE[1])
        object.__setattr__(self, "_coarse", _Coarse.build(forces[::step], azimuths[::every],
                                                          table[::step, ::every], span))
        for arr in (forces, azimuths, table, self.rest):
            arr.setflags(write=False)
        # the interpolant's error at the mid-points (noise-free read-back)
        mid_f, mid_phi = dense_f[1::2], dense_phi[1::2]
        truth = np.stack(np.broadcast_arrays(
            mid_f[:, None] * np.cos(mid_phi), mid_f[:, None] * np.sin(mid_phi)), -1)
        mids = fields[1::2, 1::2].reshape(-1, len(chans))
        if len(chans) >= 2:
            est = self._solve(mids, np.ones(mids.shape), self._tare_arrays())
            good = (est[5] & np.uint16(NO_VECTOR)) == 0
            err = np.hypot(est[0] - truth[..., 0].reshape(-1), est[1] - truth[..., 1].reshape(-1))
            object.__setattr__(self, "table_error",
                               float(np.max(err[good])) if good.any() else math.nan)
        else:
            object.__setattr__(self, "table_error", math.nan)

    # -- the model ------------------------------------------------------------------------------
    @property
    def sigma(self) -> F64:
        """Noise of one reading per channel, T, (c,): the tare's measured spread if tared, else
        the channels' stated noise."""
        if self.baseline is not None:
            return np.asarray(self.baseline.noise)
        return np.array([c.sigma for c in self.channels])

    @property
    def field_range(self) -> F64:
        """Range per channel, T, (c,)."""
        return np.array([c.field_range for c in self.channels])

    def model(self, fx: ArrayLike, fy: ArrayLike) -> F64:
        """The model reading of every channel for forces (Fx, Fy) (N, arrays that broadcast to
        ``(...)``, magnitude ≤ span + edge), T, shape (..., c): the grid's interpolant."""
        fx_arr, fy_arr = np.broadcast_arrays(np.asarray(fx, dtype=np.float64),
                                             np.asarray(fy, dtype=np.float64))
        shape = fx_arr.shape
        mag = np.hypot(fx_arr, fy_arr).reshape(-1)
        if np.any(~np.isfinite(mag)) or np.any(mag > self.forces[-1] * (1 + 1e-12)):
            bad = int(np.argmax(~np.isfinite(mag) | (mag > self.forces[-1])))
            raise v.fail("force", f"{mag[bad]:.6g} N", f"a finite magnitude ≤ "
                         f"{self.forces[-1]:.6g} N (the span and its edge)")
        val = self._evaluate(fx_arr.reshape(-1), fy_arr.reshape(-1), derivatives=False)[0]
        return val.reshape(*shape, len(self.channels))

    def _evaluate(self, fx: F64, fy: F64, derivatives: bool = True) -> tuple[F64, F64, F64]:
        """Model readings (b, c), T, and d/dFx, d/dFy (b, c), T/N, at forces with magnitude
        ≤ the grid's end (b,)."""
        h_f = float(self.forces[1])
        n_phi = self.azimuths.size
        h_phi = 2.0 * math.pi / n_phi
        mag = np.hypot(fx, fy)
        phi = np.arctan2(fy, fx) % (2.0 * math.pi)
        u = mag / h_f
        i = np.minimum(u.astype(np.intp), self.forces.size - 2)
        u -= i
        w = phi / h_phi
        j = np.minimum(w.astype(np.intp), n_phi - 1)
        w -= j
        coef = self._coef[i, j]  # (b, c, 4, 4)
        one = np.ones_like(u)
        uu = np.stack([one, u, u * u, u * u * u], -1)
        ww = np.stack([one, w, w * w, w * w * w], -1)
        cw = np.einsum("bckl,bl->bck", coef, ww)
        val = np.einsum("bck,bk->bc", cw, uu)
        if not derivatives:
            return val, val, val
        zero = np.zeros_like(u)
        du = np.stack([zero, one, 2 * u, 3 * u * u], -1) / h_f
        dw = np.stack([zero, one, 2 * w, 3 * w * w], -1) / h_phi
        d_f = np.einsum("bck,bk->bc", cw, du)
        # dB/dφ / F: in the first cell the u^0 terms of dB/dφ vanish (the F = 0 row is constant),
        # so divide the polynomial by u exactly there
        first = (i == 0)[:, None]
        safe = np.where(mag > 0.0, mag, 1.0)[:, None]
        uq = np.where(first, np.stack([zero, one, u, u * u], -1) / h_f, uu / safe)
        d_phi_over_f = np.einsum("bckl,bk,bl->bc", coef, uq, dw)
        c, s = (np.cos(phi)[:, None], np.sin(phi)[:, None])
        return val, c * d_f - s * d_phi_over_f, s * d_f + c * d_phi_over_f

    # -- estimation -----------------------------------------------------------------------------
    def _check_fields(self, fields: ArrayLike) -> F64:
        try:
            x = np.asarray(fields, dtype=np.float64)
        except (TypeError, ValueError):
            raise v.fail("fields", v.short(fields), "numbers, T") from None
        c = len(self.channels)
        if x.ndim == 0 or x.shape[-1] != c:
            raise v.fail("fields", f"an array of shape {x.shape}",
                         f"shape (..., {c}): one reading per channel "
                         f"({', '.join(ch.name for ch in self.channels)}), T")
        return x

    def estimate(self, fields: ArrayLike) -> F64:
        """Force vectors (Fx, Fy), N, shape (..., 2), from readings ``fields`` (T, shape
        (..., c), one per channel in order; a tare's correction is added first): the fast path,
        raising a one-line error for a reading without an estimate (NaN, saturated, beyond the
        span's reach, or undetermined by the channels). An AMBIGUOUS reading gets the better of
        its two minima and a NEAR_ZERO one its vector: :meth:`read` flags them."""
        x = self._check_fields(fields)
        flat = x.reshape(-1, x.shape[-1])
        if not np.isfinite(flat).all():
            r, ch = (int(k[0]) for k in np.nonzero(~np.isfinite(flat)))
            raise v.fail(f"fields[{r}, {ch}]", flat[r, ch], "a finite reading, T")
        over = np.abs(flat) > self.field_range
        if over.any():
            r, ch = (int(k[0]) for k in np.nonzero(over))
            raise v.fail(f"fields[{r}, {ch}]", f"{flat[r, ch]:.6g} T", f"within "
                         f"{self.channels[ch].name}'s range ±{self.field_range[ch]:.6g} T")
        out = np.empty((flat.shape[0], 2))
        tare = self._tare_arrays()
        for start in range(0, flat.shape[0], BLOCK):
            part = slice(start, start + BLOCK)
            fx, fy, _, _, _, flags = self._solve(flat[part] + tare[0], np.ones(
                flat[part].shape), tare)
            bad = np.flatnonzero(flags & np.uint16(NO_VECTOR))
            if bad.size:
                why = ("the channels do not determine both components"
                       if flags[bad[0]] & ForceFlag.UNDETERMINED else
                       f"beyond the span's reach {self.forces[-1]:.6g} N")
                raise v.fail(f"fields[{start + int(bad[0])}]", "a reading without an estimate",
                             f"a reading within the read-out's span ({why}; use read() for "
                             "flags)")
            out[part, 0], out[part, 1] = fx, fy
        return out.reshape(*x.shape[:-1], 2)

    def read(self, fields: ArrayLike, noise: ArrayLike | None = None) -> ForceVectorResult:
        """Estimates with covariance, 1-σ uncertainties and flags (never raises for a reading's
        values: NaN or saturated channels are left out and flagged).

        Parameters
        ----------
        fields : array-like, shape (..., c)
            One reading per channel (in order), T; a tare's correction is added first.
        noise : float or array-like, shape (c,), optional
            RMS noise of one reading per channel, T, measured (e.g. the spread of unloaded
            readings, or of averaged windows); replaces the tare's measured spread or the
            channels' stated noise (:attr:`sigma`) as the weights and for the covariance.
        """
        x = self._check_fields(fields)
        shape = x.shape[:-1]
        flat = x.reshape(-1, x.shape[-1])
        n = flat.shape[0]
        use = np.isfinite(flat)
        missing = ~use.all(axis=1)
        beyond = beyond_range(np.where(use, flat, 0.0), self.field_range,
                              [c.resolution for c in self.channels])
        saturated = beyond.any(axis=1)
        use &= ~beyond
        weight = use.astype(np.float64)
        tare = self._tare_arrays()
        if noise is not None:
            sig = np.broadcast_to(v.finite_array("noise", noise, unit="T"), self.sigma.shape)
            if np.any(sig <= 0.0):
                raise v.fail("noise", noise, "a positive RMS noise per channel, T")
            tare = (tare[0], np.array(sig, dtype=np.float64), tare[2])
        y = np.where(use, flat, 0.0) + tare[0]
        outs = [np.empty(n) for _ in range(4)]
        cov = np.empty((n, 2, 2))
        flags = np.empty(n, dtype=np.uint16)
        for start in range(0, n, BLOCK):
            part = slice(start, start + BLOCK)
            fx, fy, chi2, cv, _, fl = self._solve(y[part], weight[part], tare)
            outs[0][part], outs[1][part], outs[2][part] = fx, fy, chi2
            cov[part] = cv
            flags[part] = fl
        flags |= saturated.astype(np.uint16) * np.uint16(ForceFlag.SATURATED)
        flags |= missing.astype(np.uint16) * np.uint16(ForceFlag.MISSING)
        fx, fy, chi2 = outs[0], outs[1], outs[2]
        mag = np.hypot(fx, fy)
        direction = np.arctan2(fy, fx)
        with np.errstate(invalid="ignore"):  # near zero: against the noise's ellipse alone
            tr = cov[:, 0, 0] + cov[:, 1, 1]
            det = cov[:, 0, 0] * cov[:, 1, 1] - cov[:, 0, 1] ** 2
            major = np.sqrt(np.clip(0.5 * tr + np.sqrt(np.clip(0.25 * tr * tr - det, 0, None)),
                                    0.0, None))
        near = (mag < NEAR_ZERO_SIGMAS * major) & ((flags & np.uint16(NO_VECTOR)) == 0)
        flags |= near.astype(np.uint16) * np.uint16(ForceFlag.NEAR_ZERO)
        cov_scale = self._scale_covariance(fx, fy)
        if cov_scale.any():
            cov = cov + np.nan_to_num(cov_scale)
        s_mag, s_dir = polar_sigmas(cov, mag, direction)
        no_vec = (flags & np.uint16(NO_VECTOR)) != 0
        no_dir = (flags & np.uint16(NO_DIRECTION)) != 0
        for arr in (fx, fy, mag, s_mag, chi2):
            arr[no_vec] = np.nan
        cov[no_vec] = np.nan
        cov_scale[no_vec] = np.nan
        direction[no_dir] = np.nan
        s_dir[no_dir] = np.inf
        s_dir[no_vec] = np.nan
        sig_x = np.sqrt(cov[:, 0, 0])
        sig_y = np.sqrt(cov[:, 1, 1])
        return ForceVectorResult(
            fx=fx.reshape(shape), fy=fy.reshape(shape), magnitude=mag.reshape(shape),
            direction=direction.reshape(shape), sigma_fx=sig_x.reshape(shape),
            sigma_fy=sig_y.reshape(shape), sigma_magnitude=s_mag.reshape(shape),
            sigma_direction=s_dir.reshape(shape), covariance=cov.reshape(*shape, 2, 2),
            chi2=chi2.reshape(shape), flags=flags.reshape(shape), span=self.span,
            table_error=self.table_error, covariance_scale=cov_scale.reshape(*shape, 2, 2),
            scale_note=self.setup.modulus.note())

    def _scale_covariance(self, fx: F64, fy: F64) -> F64:
        """The force scale's covariance, N², (b, 2, 2), of estimates (b,)
        (:func:`magcilia.readout.scale.vector_rate`; zeros for a modulus taken as exact)."""
        relative = self.setup.youngs_modulus_uncertainty
        if not relative:
            return np.zeros((fx.size, 2, 2))
        return vector_scale_covariance(vector_rate(fx, fy, self._rate_grid), relative)

    def _actuated_rates(self, f_max: float) -> tuple[F64, F64, F64]:
        """The force's derivative with respect to ln E under the actuation, on a
        :data:`~magcilia.readout.scale.VECTOR_RATE_GRID` grid of magnitudes (0 … ``f_max``, N)
        and directions: (magnitudes, directions, components along and across the force
        (m, d, 2), N). The readings' derivative is a central difference of the model
        (:func:`_actuated_model`) in ln E (:func:`~magcilia.readout.scale.per_ln_modulus`),
        taken through the read-out's least squares with the channels' stated noise."""
        assert self.actuation is not None
        setup, chans = self.setup, self.channels
        mags = np.linspace(0.0, f_max, VECTOR_RATE_GRID[0])
        step = 2.0 * math.pi / VECTOR_RATE_GRID[1]
        dirs = np.arange(VECTOR_RATE_GRID[1], dtype=np.float64) * step
        actuation = self.actuation
        g = per_ln_modulus(lambda s: _actuated_model(s, chans, mags, dirs, actuation)[0],
                           setup).reshape(-1, len(chans))
        m, d = (a.reshape(-1) for a in np.meshgrid(mags, dirs, indexing="ij"))
        _, jx, jy = self._evaluate(m * np.cos(d), m * np.sin(d))
        weight = np.broadcast_to(1.0 / np.array([c.sigma for c in chans]) ** 2, g.shape)
        rates = to_polar(least_squares_rate(jx, jy, g, weight), d)
        return mags, dirs, rates.reshape(mags.size, dirs.size, 2)

    def _tare_arrays(self) -> tuple[F64, F64, F64]:
        """(correction, σ per reading, tare standard error), T, each (c,)."""
        if self.baseline is None:
            c = len(self.channels)
            return np.zeros(c), self.sigma, np.zeros(c)
        b = self.baseline
        return b.correction, np.asarray(b.noise), b.standard_error

    def _solve(self, y: F64, weight: F64, tare: tuple[F64, F64, F64]
               ) -> tuple[F64, F64, F64, F64, F64, NDArray[np.uint16]]:
        """Fit readings ``y`` (b, c), T (tare applied), with channel ``weight`` (b, c) in {0, 1}:
        Fx, Fy (b,), χ² (b,), covariance (b, 2, 2), iterations used (b,) and flags (b,)."""
        _, sigma, tare_se = tare  # σ > 0: checked where it is set
        w = weight / sigma**2  # (b, c)
        b = y.shape[0]
        flags = np.zeros(b, dtype=np.uint16)
        none = w.sum(axis=1) == 0.0
        flags[none] |= np.uint16(ForceFlag.OUTSIDE_SPAN)
        # coarse search on the grid's nodes: χ² = Σ w y² − 2 Σ w y Y + Σ w Y²
        coarse = self._coarse
        best, second = coarse.search(y, w)
        has2 = second >= 0
        two = np.flatnonzero(has2)  # readings with a second minimum: refine both
        start = np.concatenate([best, second[two]])
        f0, p0 = coarse.force[start], coarse.azimuth[start]
        fx, fy, chi2, normal, iters, conv = self._refine(
            np.concatenate([y, y[two]]), np.concatenate([w, w[two]]), f0 * np.cos(p0),
            f0 * np.sin(p0))

        def spread(arr: Any) -> Any:
            """Rows b… (the alternatives of the readings ``two``) after a copy of rows 0…b."""
            out = np.concatenate([arr[:b], arr[:b]])
            out[b + two] = arr[b:]
            return out

        fx, fy, chi2, normal, iters, conv = (spread(a) for a in (fx, fy, chi2, normal, iters,
                                                                  conv))
        # the better of the two minima is the estimate, the other the alternative
        better = has2 & (chi2[b:] < chi2[:b])

        def pick(a: Any, first: bool) -> Any:
            m = better.reshape(-1, *([1] * (a.ndim - 1)))
            return np.where(m, a[b:], a[:b]) if first else np.where(m, a[:b], a[b:])

        fx1, fy1, chi1 = pick(fx, True), pick(fy, True), pick(chi2, True)
        fx2, fy2, chi_2 = pick(fx, False), pick(fy, False), pick(chi2, False)
        a_mat, iters1, conv1 = pick(normal, True), pick(iters, True), pick(conv, True)
        # covariance: (JᵀWJ)⁻¹ plus the tare's shared error G S Gᵀ
        det = a_mat[:, 0, 0] * a_mat[:, 1, 1] - a_mat[:, 0, 1] ** 2
        tr = a_mat[:, 0, 0] + a_mat[:, 1, 1]
        undetermined = ~(det > tr * tr / CONDITION_LIMIT) & ~none
        safe = np.where(undetermined | none, 1.0, det)
        inv = np.empty_like(a_mat)
        inv[:, 0, 0] = a_mat[:, 1, 1] / safe
        inv[:, 1, 1] = a_mat[:, 0, 0] / safe
        inv[:, 0, 1] = inv[:, 1, 0] = -a_mat[:, 0, 1] / safe
        if np.any(tare_se > 0.0):
            _, jx, jy = self._evaluate(fx1, fy1)
            jac = np.stack([jx, jy], -1) * w[..., None]  # (b, c, 2): W J
            gain = np.einsum("bij,bcj->bic", inv, jac)  # (JᵀWJ)⁻¹ JᵀW
            inv = inv + np.einsum("bic,c,bjc->bij", gain, tare_se**2, gain)
        flags |= undetermined.astype(np.uint16) * np.uint16(ForceFlag.UNDETERMINED)
        flags |= (~conv1).astype(np.uint16) * np.uint16(ForceFlag.NOT_CONVERGED)
        # ambiguity: a distinct second minimum about as good
        dist = np.hypot(fx2 - fx1, fy2 - fy1)
        size = np.sqrt(np.clip(inv[:, 0, 0] + inv[:, 1, 1], 0.0, None))
        amb = (has2 & (chi_2 - chi1 < AMBIGUITY_CHI2)
               & (dist > np.maximum(3.0 * size, 0.02 * self.span)))
        flags |= amb.astype(np.uint16) * np.uint16(ForceFlag.AMBIGUOUS)
        mag = np.hypot(fx1, fy1)
        f_max = self.forces[-1]
        outside = mag >= f_max * (1.0 - 1e-9)
        flags |= outside.astype(np.uint16) * np.uint16(ForceFlag.OUTSIDE_SPAN
                                                         | ForceFlag.ABOVE_SPAN)
        beyond = (mag > self.span) & ~outside
        flags |= beyond.astype(np.uint16) * np.uint16(ForceFlag.EXTRAPOLATED
                                                        | ForceFlag.ABOVE_SPAN)
        # without a fit, nothing else about it is meaningful
        flags[undetermined] = np.uint16(ForceFlag.UNDETERMINED)
        flags[none] = np.uint16(ForceFlag.OUTSIDE_SPAN)
        return fx1, fy1, chi1, inv, iters1, flags

    def _refine(self, y: F64, w: F64, fx: F64, fy: F64
                ) -> tuple[F64, F64, F64, F64, F64, NDArray[np.bool_]]:
        """Levenberg–Marquardt in (Fx, Fy) from the starts, all readings at once (the active set
        shrinks as they converge): Fx, Fy, χ², the normal matrix JᵀWJ (b, 2, 2) at the end,
        iterations and convergence (b,)."""
        b = y.shape[0]
        f_max = self.forces[-1]
        fx, fy = fx.copy(), fy.copy()
        val, jx, jy = self._evaluate(fx, fy)
        res = y - val
        chi2 = np.einsum("bc,bc->b", w, res * res)
        lam = np.full(b, 1e-3)
        iters = np.zeros(b)
        conv = np.zeros(b, dtype=bool)
        normal = np.empty((b, 2, 2))
        tol = 1e-10 * self.span
        active = np.flatnonzero(w.any(axis=1))  # a reading without channels: no fit
        for _ in range(MAX_ITERATIONS):
            if not active.size:
                break
            wa, ra = w[active], res[active]
            jxa, jya = jx[active], jy[active]
            a11 = np.einsum("bc,bc->b", wa, jxa * jxa)
            a22 = np.einsum("bc,bc->b", wa, jya * jya)
            a12 = np.einsum("bc,bc->b", wa, jxa * jya)
            g1 = np.einsum("bc,bc->b", wa, jxa * ra)
            g2 = np.einsum("bc,bc->b", wa, jya * ra)
            normal[active, 0, 0], normal[active, 1, 1] = a11, a22
            normal[active, 0, 1] = normal[active, 1, 0] = a12
            la = lam[active]
            d11, d22 = a11 * (1 + la), a22 * (1 + la)
            scale = np.maximum(a11 + a22, 1e-300) * 1e-12
            d11, d22 = d11 + scale, d22 + scale
            det = d11 * d22 - a12 * a12
            dx = (d22 * g1 - a12 * g2) / det
            dy = (d11 * g2 - a12 * g1) / det
            tx, ty = fx[active] + dx, fy[active] + dy
            tm = np.hypot(tx, ty)
            shrink = np.where(tm > f_max, f_max * (1 - 1e-12) / np.maximum(tm, 1e-300), 1.0)
            tx, ty = tx * shrink, ty * shrink
            tv, tjx, tjy = self._evaluate(tx, ty)
            tres = y[active] - tv
            tchi = np.einsum("bc,bc->b", wa, tres * tres)
            old = chi2[active]
            ok = tchi <= old
            step = np.hypot(tx - fx[active], ty - fy[active])
            acc = active[ok]
            fx[acc], fy[acc] = tx[ok], ty[ok]
            val[acc], jx[acc], jy[acc], res[acc] = tv[ok], tjx[ok], tjy[ok], tres[ok]
            chi2[acc] = tchi[ok]
            lam[acc] *= 0.3
            lam[active[~ok]] *= 10.0
            iters[active] += 1
            done = (ok & ((step <= tol) | (old - tchi <= 1e-14 * old))) | (
                ~ok & (step <= tol))
            done |= lam[active] > 1e12
            conv[active[done]] = (lam[active[done]] <= 1e12) | (step[done] <= tol)
            active = active[~done]
        if active.size:
            conv[active] = False
        # the normal matrix at the final point
        a11 = np.einsum("bc,bc->b", w, jx * jx)
        a22 = np.einsum("bc,bc->b", w, jy * jy)
        a12 = np.einsum("bc,bc->b", w, jx * jy)
        normal[:, 0, 0], normal[:, 1, 1] = a11, a22
        normal[:, 0, 1] = normal[:, 1, 0] = a12
        return fx, fy, chi2, normal, iters, conv

    # -- tare -----------------------------------------------------------------------------------
    def tare(self, baseline: ArrayLike) -> BiaxialReadout:
        """A copy whose zero is the mean of unloaded readings ``baseline`` (T, shape (..., c), at
        least 2 finite per channel; NaN skipped): every reading gets ``rest − mean`` added per
        channel, the baseline's spread replaces the channels' stated noise, and its standard
        error (shared by all readings) enters the covariance."""
        x = self._check_fields(baseline).reshape(-1, len(self.channels))
        tare = Tare.from_readings(x, self.rest, unit="T",
                                  names=tuple(c.name for c in self.channels))
        new = object.__new__(BiaxialReadout)
        for f in self.__dataclass_fields__:
            object.__setattr__(new, f, getattr(self, f))
        object.__setattr__(new, "baseline", tare)
        return new

    # -- protocol -------------------------------------------------------------------------------
    def to_dict(self) -> dict[str, Any]:
        """JSON-ready description (SI)."""
        return {"span": self.span, "edge_tolerance": self.edge_tolerance,
                "table_size": [int(self.forces.size), int(self.azimuths.size)],
                "table_error": self.table_error, "rest": self.rest.tolist(),
                "channels": [c.to_dict() for c in self.channels],
                "tare": None if self.baseline is None else self.baseline.to_dict(),
                **({} if self.actuation is None else {
                    "actuation": self.actuation.to_dict(), "direct": self.direct.tolist()}),
                "units": "SI"}

    def report(self) -> str:
        """One line: span, channels, the grid and its error."""
        err = ("not measured (one channel: the direction is undetermined)"
               if not math.isfinite(self.table_error)
               else f"≤ {self.table_error * 1e3:.2g} mN")
        text = (f"force-vector read-out over |F| ≤ {self.span * 1e3:.4g} mN (extrapolated to "
                f"{self.forces[-1] * 1e3:.4g} mN) from {len(self.channels)} channel(s) "
                f"({', '.join(c.name for c in self.channels)}); grid {self.forces.size} × "
                f"{self.azimuths.size}, table error {err}")
        if len(self.channels) < 2:
            text += ("; one channel sees one projection only: no force vector (add a channel: a "
                     "3-axis sensor or a second element turned 90°; or read the magnitude along "
                     "a known direction with Readout)")
        if self.baseline is not None:
            text += f"; {self.baseline.report()}"
        if self.actuation is not None:
            text += (f"; compensating {self.actuation.describe()} (direct field per channel "
                     + ", ".join(f"{d / 1e-4:.4g}" for d in self.direct) + " G)")
        return text

    def _display_items(self) -> list[Item]:
        return [("span", scaled(self.span, 1e-3, "mN")), ("channels", str(len(self.channels))),
                ("grid", f"{self.forces.size}×{self.azimuths.size}"),
                ("table error", scaled(self.table_error, 1e-3, "mN")
                 if math.isfinite(self.table_error) else "—"),
                ("tared", "yes" if self.baseline is not None else "no")]


@dataclass(frozen=True, eq=False)
class _Coarse:
    """The coarse search's candidates (the grid's nodes, thinned): magnitudes and azimuths (K,),
    readings (K, c), the rest (F = 0) first and once, then ring after ring of equal magnitude;
    the first ring's node indices, and which nodes lie far from which (K, K)."""

    force: F64
    azimuth: F64
    reading: F64
    square: F64
    ring: NDArray[np.intp]
    far: NDArray[np.bool_]

    @classmethod
    def build(cls, forces: F64, azimuths: F64, table: F64, span: float) -> _Coarse:
        n_r, n_p = forces.size - 1, azimuths.size
        f = np.concatenate([[0.0], np.repeat(forces[1:], n_p)])
        p = np.concatenate([[0.0], np.tile(azimuths, n_r)])
        y = np.concatenate([table[:1, 0], table[1:].reshape(-1, table.shape[-1])])
        idx = 1 + np.arange(n_r * n_p).reshape(n_r, n_p)
        x, yv = f * np.cos(p), f * np.sin(p)
        far = np.hypot(x[:, None] - x[None, :], yv[:, None] - yv[None, :]) > 0.1 * span
        return cls(f, p, y, (y * y).T.copy(), idx[0].copy(), far)

    def search(self, y: F64, w: F64) -> tuple[NDArray[np.intp], NDArray[np.intp]]:
        """For readings ``y`` (b, c) with weights ``w`` (b, c): the best node and the best local
        minimum of χ² at least a tenth of the span from it (−1 where there is none), (b,)."""
        chi = w @ self.square - 2.0 * (w * y) @ self.reading.T  # χ² − Σ w y² (b, K)
        best = np.argmin(chi, axis=1)
        g = chi[:, 1:].reshape(chi.shape[0], -1, self.ring.size)  # (b, rings, φ)
        loc = np.empty(g.shape, dtype=bool)  # ≤ its four neighbours (slices: no gathers)
        np.less_equal(g[..., 1:], g[..., :-1], out=loc[..., 1:])
        np.less_equal(g[..., :1], g[..., -1:], out=loc[..., :1])
        loc[..., :-1] &= g[..., :-1] <= g[..., 1:]
        loc[..., -1:] &= g[..., -1:] <= g[..., :1]
        loc[:, 1:] &= g[:, 1:] <= g[:, :-1]
        loc[:, :-1] &= g[:, :-1] <= g[:, 1:]
        loc[:, 0] &= g[:, 0] <= chi[:, :1]
        local = np.concatenate([(chi[:, 0] <= g[:, 0].min(axis=1))[:, None],
                                loc.reshape(chi.shape[0], -1)], axis=1)
        local &= self.far[best]
        masked = np.where(local, chi, np.inf)
        second = np.argmin(masked, axis=1)
        found = np.isfinite(masked[np.arange(chi.shape[0]), second])
        return best, np.where(found, second, -1)


def _build_coefficients(forces: F64, table: F64) -> F64:
    """Bicubic Hermite coefficients of the table (nF, nφ, c): derivatives along F from a cubic
    spline (not-a-knot), along the periodic φ spectrally (FFT), in unit-cell scale."""
    from scipy.interpolate import CubicSpline

    n_phi = table.shape[1]
    h_f = float(forces[1] - forces[0])
    h_phi = 2.0 * math.pi / n_phi
    d_f = CubicSpline(forces, table, axis=0).derivative()(forces)
    k = np.fft.fftfreq(n_phi, d=1.0 / n_phi)
    if n_phi % 2 == 0:
        k[n_phi // 2] = 0.0

    def d_phi(a: F64) -> F64:
        return np.real(np.fft.ifft(1j * k[None, :, None] * np.fft.fft(a, axis=1), axis=1))

    f_u = d_f * h_f
    f_w = d_phi(table) * h_phi
    f_uw = d_phi(d_f) * h_f * h_phi
    f_w[0] = 0.0  # the rest row is the same for every φ
    coef = _coefficients(table, f_u, f_w, f_uw)
    coef = np.ascontiguousarray(coef)
    coef.setflags(write=False)
    return coef


def _model(setup: Setup, chans: tuple[Channel, ...], forces: F64, azimuths: F64) -> F64:
    """Each channel's reading (T) for horizontal tip forces ``forces`` (nF,) toward ``azimuths``
    (nφ,): (nF, nφ, c). The planar shapes' dipoles observed at the channels' points turned by
    −φ about the vertical axis through the base, the field turned back by +φ."""
    return _model_shapes(setup, chans, forces, azimuths, bend_sweep(setup, forces=forces))


def _model_shapes(setup: Setup, chans: tuple[Channel, ...], forces: F64, azimuths: F64,
                  shapes: Any) -> F64:
    """:func:`_model` of the planar ``shapes`` (a Centreline of nF shapes in the x–z plane)."""
    base = setup.base_centre
    points = np.array([c.position for c in chans])
    unique, which = np.unique(points, axis=0, return_inverse=True)
    which = np.asarray(which).reshape(-1)
    rel = unique - base  # (P, 3)
    obs = turn_about_z(rel[None], azimuths[:, None], inverse=True) + base  # R(−φ)(p − b) + b
    flat = obs.reshape(-1, 3)
    try:
        setup.check_outside(flat, shapes)
    except MagciliaError:
        for i, p in enumerate(unique):
            try:
                setup.check_outside(obs[:, i], shapes)
            except MagciliaError:
                names = ", ".join(c.name for c, w in zip(chans, which, strict=True) if w == i)
                raise v.fail("sensors", f"{names} at ({', '.join(f'{x * 1e3:.4g}' for x in p)})"
                             " mm", f"sensors outside the cilium bent by up to "
                             f"{forces[-1]:.4g} N in any direction (move the sensor or lower "
                             "the span)") from None
        raise
    pos, mom = setup.dipoles(shapes)
    with np.errstate(divide="ignore", invalid="ignore", over="ignore"):
        b = pose_field(flat, pos, mom).reshape(forces.size, azimuths.size, -1, 3)
    if not np.isfinite(b).all():
        raise v.fail("sensors", "a point on a dipole of the model", "sensors away from the "
                     "model's dipoles")
    board = turn_about_z(b, azimuths[None, :, None])  # R(φ) B
    axes = np.array([c.axis for c in chans])  # (c, 3)
    return np.einsum("fpcx,cx->fpc", board[:, :, which], axes)


def _actuated_model(setup: Setup, chans: tuple[Channel, ...], forces: F64, azimuths: F64,
                    actuation: Actuation) -> tuple[F64, F64]:
    """:func:`_model` while ``actuation`` acts: each channel's reading (T), (nF, nφ, c), of the
    cilium bent by the force and the actuation plus the actuation's direct field, and the direct
    field's reading per channel (c,). A uniform field along z keeps the axial symmetry (the
    planar sweep under it, turned); any other needs a 3-D bend per (F, φ)."""
    if not isinstance(actuation, Actuation):
        raise v.fail("actuation", type(actuation).__name__,
                     "a magcilia Actuation (Actuation.uniform(b), Actuation.magpylib(source))")
    points = np.array([c.position for c in chans])
    axes = np.array([c.axis for c in chans])
    direct_b = actuation.field(points)  # (c, 3)
    if not np.all(np.isfinite(direct_b)):
        raise v.fail("actuation", "a field that is not finite at a channel",
                     "a source away from the sensors")
    direct = np.einsum("cx,cx->c", direct_b, axes)
    rng = np.array([c.field_range for c in chans])
    beyond = np.flatnonzero(np.abs(direct) > rng)
    if beyond.size:
        i = int(beyond[0])
        raise v.fail("actuation", f"a direct field of {direct[i] / 1e-4:.4g} G on "
                     f"{chans[i].name}", f"within its range ±{rng[i] / 1e-4:.4g} G (lower the "
                     "field or its scale, or pick a wider range)")
    uniform = actuation.uniform_field if actuation.is_uniform else None
    if uniform is not None and uniform[0] == 0.0 and uniform[1] == 0.0:
        # symmetric about the vertical axis: the planar sweep under the field, turned
        bent = _model_shapes(setup, chans, forces, azimuths,
                             bend_sweep(setup, forces=forces, actuation=actuation))
        return bent + direct, direct
    shapes = [bend(setup, float(f), azimuth=float(p), actuation=actuation)
              for f in forces for p in azimuths]
    spatial = SpatialCentreline(shapes[0].s, *(np.concatenate([
        getattr(sh if isinstance(sh, SpatialCentreline) else SpatialCentreline.from_planar(sh),
                name) for sh in shapes]) for name in ("points", "tangents", "normals")))
    unique, which = np.unique(points, axis=0, return_inverse=True)
    which = np.asarray(which).reshape(-1)
    try:
        b = setup.field_at(unique, spatial)  # (a, P, 3)
    except MagciliaError:
        raise v.fail("sensors", "a point inside the bent cilium", f"sensors outside the "
                     f"cilium bent by up to {forces[-1]:.4g} N and the actuation") from None
    b = b.reshape(forces.size, azimuths.size, -1, 3)[:, :, which]
    return np.einsum("fpcx,cx->fpc", b, axes) + direct, direct
