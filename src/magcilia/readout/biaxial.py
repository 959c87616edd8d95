"""Biaxial read-out: the horizontal tip force vector (Fx, Fy) from several field channels.

The read-out sees the bent cilium's field through *channels* (:mod:`.channel`): one sensitive
axis at one point each, with its noise; a 3-axis :class:`~magcilia.device.magnetometer.Magnetometer`
is three channels at one point, two single-axis elements (HMC1021Z turned 90°, or side by side)
are two.

:class:`BiaxialReadout` builds, once, the model reading of every channel on a polar grid of
(F, φ) (:mod:`.vector_model`: one bend sweep over [0, span·(1 + edge)], the planar shapes observed
on circles) and its bicubic Hermite interpolant (:mod:`.polar_table`), which gives each channel's
reading and its derivatives anywhere in the disc |F| ≤ F_max. :meth:`BiaxialReadout.read`
estimates (Fx, Fy) per reading by a coarse grid search (χ² at the grid's nodes, one matrix product
per block of readings) and the one batched least squares (:func:`magcilia.fitting.fit_batch`, the
table's analytic Jacobian) in Cartesian (Fx, Fy), and gives the covariance from the channels'
noise through the Jacobian (:class:`~magcilia.readout.force_vector.ForceVectorResult`).

On the read-out protocol (:mod:`magcilia.readout.protocol`): ``inputs`` are the channels' names
(``NAME.x``, ``NAME.y``, ``NAME.z`` for a 3-axis sensor NAME), ``rest`` (c,) T, ``read(samples)``
of shape (n, c) gives ``value`` and ``sigma`` (n, 2) = [Fx, Fy], ``flags`` (n,), ``unit`` ``"N"``;
``tare(baseline)`` a copy holding one :class:`~magcilia.readout.tare.Tare` (unit T).

The F = 0 row of the grid is the mean over φ (the rings' trace, :mod:`.vector_model`).

σ includes the force scale: the Young's modulus's uncertainty (a force vector scales with E at a
fixed shape; :mod:`magcilia.readout.scale`), systematic and kept apart in
:attr:`ForceVectorResult.covariance_scale`. What σ omits: the interpolation error of the grid
(measured at construction, :attr:`BiaxialReadout.table_error`), the uncertainty of the setup's
parameters (calibration), the ring trace above, and any force component the read-out does not
model (vertical loads, flow).

All SI: N, rad, T, m.
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from dataclasses import dataclass
from typing import Any

import numpy as np
from numpy.typing import ArrayLike, NDArray

from magcilia import _validate as v
from magcilia._display import Display, Item, scaled
from magcilia.device.actuation import Actuation
from magcilia.device.sensor import beyond_range
from magcilia.device.setup import Setup
from magcilia.fitting import fit_batch
from magcilia.mechanics import require_tip_radius
from magcilia.readout.channel import Channel, ChannelLike, channels
from magcilia.readout.force_vector import (
    NO_DIRECTION,
    NO_VECTOR,
    VECTOR_FLAGS,
    ForceFlag,
    ForceVectorResult,
    polar_sigmas,
)
from magcilia.readout.inverse import EDGE_TOLERANCE
from magcilia.readout.polar_table import (
    CoarseGrid,
    evaluate,
    hermite_coefficients,
    onto_disc_rows,
    whitened,
)
from magcilia.readout.protocol import FLAG_DTYPE, Flag, tare_flags
from magcilia.readout.scale import vector_rate, vector_scale_covariance
from magcilia.readout.tare import (
    ChannelTare,
    Tare,
)
from magcilia.readout.vector_model import (
    actuated_polar_model,
    actuated_scale_rates,
    polar_model,
)

F64 = NDArray[np.float64]

#: readings per block of :meth:`BiaxialReadout.read` (the coarse search's χ² table stays small)
BLOCK = 16384
#: Δχ² within which a second, distinct minimum makes a reading AMBIGUOUS
AMBIGUITY_CHI2 = 4.0
#: a force smaller than this many σ (largest axis of its error ellipse) has no direction
NEAR_ZERO_SIGMAS = 3.0
#: rings (magnitudes) and directions of the coarse search's grid (the table's nodes, thinned)
COARSE = (12, 32)
#: least-squares iterations at most
MAX_ITERATIONS = 40
#: the fit has converged when a step lowers χ² by less than this fraction of it …
FIT_FTOL = 1e-14
#: … or moves (Fx, Fy) by less than this fraction of the box 2 F_max (~1e-10 of the span)
FIT_XTOL = 5e-11
#: … or changes χ² by less than this, up or down (whitened: a point this close to the minimum
#: lies ~√FIT_ATOL σ from it)
FIT_ATOL = 1e-12
#: the normal matrix's condition number above which the two components are not both determined
CONDITION_LIMIT = 1e10


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
    _coarse: CoarseGrid
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
            fields = polar_model(setup, chans, dense_f, dense_phi)  # (2nF−1, 2nφ, c)
        else:
            fields, direct = actuated_polar_model(setup, chans, dense_f, dense_phi, actuation)
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
        object.__setattr__(self, "_coef", hermite_coefficients(forces, table))
        object.__setattr__(self, "_rate_grid", None)
        if actuation is not None and setup.youngs_modulus_uncertainty:
            object.__setattr__(self, "_rate_grid", actuated_scale_rates(
                setup, chans, actuation, f_max, self._coef))
        step = max(1, (n_f - 1) // COARSE[0])
        every = max(1, n_phi // COARSE[1])
        object.__setattr__(self, "_coarse", CoarseGrid.build(forces[::step], azimuths[::every],
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
            good = (est[5] & FLAG_DTYPE(NO_VECTOR)) == 0
            err = np.hypot(est[0] - truth[..., 0].reshape(-1), est[1] - truth[..., 1].reshape(-1))
            object.__setattr__(self, "table_error",
                               float(np.max(err[good])) if good.any() else math.nan)
        else:
            object.__setattr__(self, "table_error", math.nan)

    # -- the read-out protocol (:class:`~magcilia.readout.protocol.SensorReadout`) --------------
    @property
    def inputs(self) -> tuple[str, ...]:
        """What one sample holds, in order: the channels' names (a 3-axis sensor NAME gives
        ``NAME.x``, ``NAME.y``, ``NAME.z``)."""
        return tuple(c.name for c in self.channels)

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
        ≤ the grid's end (b,): the table's interpolant (:func:`.polar_table.evaluate`)."""
        return evaluate(self._coef, float(self.forces[1]), fx, fy, derivatives)
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
            bad = np.flatnonzero(flags & FLAG_DTYPE(NO_VECTOR))
            if bad.size:
                why = ("the channels do not determine both components"
                       if flags[bad[0]] & Flag.UNDETERMINED else
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
        flags |= saturated.astype(FLAG_DTYPE) * FLAG_DTYPE(Flag.SATURATED)
        flags |= missing.astype(FLAG_DTYPE) * FLAG_DTYPE(Flag.MISSING)
        flags |= FLAG_DTYPE(tare_flags(self.baseline))  # a tare taken under load
        fx, fy, chi2 = outs[0], outs[1], outs[2]
        mag = np.hypot(fx, fy)
        direction = np.arctan2(fy, fx)
        with np.errstate(invalid="ignore"):  # near zero: against the noise's ellipse alone
            tr = cov[:, 0, 0] + cov[:, 1, 1]
            det = cov[:, 0, 0] * cov[:, 1, 1] - cov[:, 0, 1] ** 2
            major = np.sqrt(np.clip(0.5 * tr + np.sqrt(np.clip(0.25 * tr * tr - det, 0, None)),
                                    0.0, None))
        near = (mag < NEAR_ZERO_SIGMAS * major) & ((flags & FLAG_DTYPE(NO_VECTOR)) == 0)
        flags |= near.astype(FLAG_DTYPE) * FLAG_DTYPE(Flag.NEAR_ZERO)
        cov_scale = self._scale_covariance(fx, fy)
        if cov_scale.any():
            cov = cov + np.nan_to_num(cov_scale)
        s_mag, s_dir = polar_sigmas(cov, mag, direction)
        no_vec = (flags & FLAG_DTYPE(NO_VECTOR)) != 0
        no_dir = (flags & FLAG_DTYPE(NO_DIRECTION)) != 0
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
        flags[none] |= FLAG_DTYPE(Flag.OUTSIDE_SPAN)
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
        flags |= undetermined.astype(FLAG_DTYPE) * FLAG_DTYPE(Flag.UNDETERMINED)
        flags |= (~conv1).astype(FLAG_DTYPE) * FLAG_DTYPE(Flag.NOT_CONVERGED)
        # ambiguity: a distinct second minimum about as good
        dist = np.hypot(fx2 - fx1, fy2 - fy1)
        size = np.sqrt(np.clip(inv[:, 0, 0] + inv[:, 1, 1], 0.0, None))
        amb = (has2 & (chi_2 - chi1 < AMBIGUITY_CHI2)
               & (dist > np.maximum(3.0 * size, 0.02 * self.span)))
        flags |= amb.astype(FLAG_DTYPE) * FLAG_DTYPE(Flag.AMBIGUOUS)
        mag = np.hypot(fx1, fy1)
        f_max = self.forces[-1]
        outside = mag >= f_max * (1.0 - 1e-9)
        flags |= outside.astype(FLAG_DTYPE) * FLAG_DTYPE(Flag.OUTSIDE_SPAN
                                                         | Flag.ABOVE_SPAN)
        # on the edge the fit may crawl along it to its iteration limit: moot without an estimate
        flags[outside] &= ~FLAG_DTYPE(Flag.NOT_CONVERGED)
        beyond = (mag > self.span) & ~outside
        flags |= beyond.astype(FLAG_DTYPE) * FLAG_DTYPE(Flag.EXTRAPOLATED
                                                        | Flag.ABOVE_SPAN)
        # without a fit, nothing else about it is meaningful
        flags[undetermined] = FLAG_DTYPE(Flag.UNDETERMINED)
        flags[none] = FLAG_DTYPE(Flag.OUTSIDE_SPAN)
        return fx1, fy1, chi1, inv, iters1, flags

    def _refine(self, y: F64, w: F64, fx: F64, fy: F64
                ) -> tuple[F64, F64, F64, F64, F64, NDArray[np.bool_]]:
        """Least squares in (Fx, Fy) from the starts, all readings at once (the one batched
        Levenberg–Marquardt, :func:`magcilia.fitting.fit_batch`, with the table's analytic
        Jacobian): Fx, Fy, χ², the normal matrix JᵀWJ (b, 2, 2) at the end, iterations and
        convergence (b,). The model lives in the disc |F| ≤ F_max: trial points beyond it are
        projected radially onto its edge."""
        h_f, edge = float(self.forces[1]), float(self.forces[-1]) * (1.0 - 1e-12)
        root_w = np.sqrt(w)

        def residuals(x: F64, which: NDArray[np.intp]) -> tuple[F64, F64]:
            return whitened(self._coef, h_f, x, y, root_w, which)

        def disc(x: F64, _which: NDArray[np.intp]) -> F64:
            return onto_disc_rows(x, edge)

        f_max = float(self.forces[-1])
        fit = fit_batch(residuals, np.stack([fx, fy], -1), [-f_max, -f_max], [f_max, f_max],
                        jacobian=True, maxiter=MAX_ITERATIONS, ftol=FIT_FTOL,
                        xtol=FIT_XTOL, atol=FIT_ATOL, damping=1e-3, project=disc)
        # jacobian=True: JᵀJ of the whitened residuals (JᵀWJ) at the estimate itself
        return (fit.x[:, 0].copy(), fit.x[:, 1].copy(), np.array(fit.cost), np.array(fit.jtj),
                fit.iterations.astype(np.float64), np.array(fit.converged))

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


__all__ = ["NO_DIRECTION", "NO_VECTOR", "VECTOR_FLAGS", "BiaxialReadout", "Channel",
           "ChannelTare", "Flag", "ForceFlag", "ForceVectorResult", "Tare", "channels",
           "polar_sigmas"]
