"""The force-vector read-out's result: :class:`ForceVectorResult` (SI: N, rad).

On the read-out protocol (:mod:`magcilia.readout.protocol`): for readings of shape (n, c) its
``value`` is (n, 2) = [Fx, Fy], ``sigma`` the 1 σ of each component (n, 2), ``flags`` (n,) bits of
the one :class:`~magcilia.readout.protocol.Flag` set, ``unit`` ``"N"``; besides, the magnitude and
direction with their σ, the covariance (noise and force scale apart), χ² and counts.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Any

import numpy as np
from numpy.typing import NDArray

from magcilia._display import Display, Item, Table, column, dataframe, scaled
from magcilia.readout.protocol import Flag, flag_counts, flag_names

F64 = NDArray[np.float64]

#: the force vector's former flag enum: the one :class:`~magcilia.readout.protocol.Flag` (the
#: same bits as before)
ForceFlag = Flag
"""The force-vector read-out's flags: the one :class:`~magcilia.readout.protocol.Flag` set, under
its former name (its bits kept their values)."""
#: the bits a force-vector read-out raises. OUTSIDE_SPAN and UNDETERMINED leave a reading without
#: an estimate (NaN, :data:`NO_VECTOR`); NEAR_ZERO and AMBIGUOUS leave it without a direction
#: (``direction`` NaN, ``sigma_direction`` inf). AMBIGUOUS: a second, distinct minimum about as
#: good; Fx, Fy and the magnitude are the better minimum's (a mirror image, e.g. φ and −φ, has
#: the same magnitude; other pairs need not).
VECTOR_FLAGS = (Flag.OUTSIDE_SPAN | Flag.SATURATED | Flag.EXTRAPOLATED | Flag.ABOVE_SPAN
                | Flag.AMBIGUOUS | Flag.UNDETERMINED | Flag.NOT_CONVERGED | Flag.NEAR_ZERO
                | Flag.MISSING)
#: the flags that leave a reading without an estimate (all values and sigmas NaN)
NO_VECTOR = Flag.OUTSIDE_SPAN | Flag.UNDETERMINED
#: the flags that leave a reading without a direction
NO_DIRECTION = NO_VECTOR | Flag.NEAR_ZERO | Flag.AMBIGUOUS


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
        :class:`~magcilia.readout.protocol.Flag` bits (:data:`VECTOR_FLAGS`).
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

    # -- the read-out protocol (:class:`~magcilia.readout.protocol.ReadoutValues`) -------------
    unit = "N"

    @property
    def value(self) -> F64:
        """(Fx, Fy), N, shape (..., 2): :attr:`vector`."""
        return self.vector

    @property
    def sigma(self) -> F64:
        """1 σ of (Fx, Fy), N, shape (..., 2): (:attr:`sigma_fx`, :attr:`sigma_fy`)."""
        return np.stack([self.sigma_fx, self.sigma_fy], axis=-1)

    @property
    def vector(self) -> F64:
        """(Fx, Fy), N, shape (..., 2)."""
        return np.stack([self.fx, self.fy], axis=-1)

    def counts(self) -> dict[str, int]:
        """Readings per flag name (lower case), and ``"readings"``, ``"estimated"``, ``"ok"``."""
        # the bits a force vector raises, and any other set (e.g. by a view)
        return {"readings": int(self.flags.size), "estimated": int(self.estimated.sum()),
                "ok": int(self.ok.sum()), **flag_counts(self.flags, VECTOR_FLAGS)}

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
        return dataframe(self._columns())

    def to_xarray(self, time_s: Any = None) -> Any:
        """The columns of :meth:`to_dataframe` as an ``xarray.Dataset`` along ``sample`` (one
        per reading), each with its ``units`` attribute (SI; ``time_s``, s, the coordinate
        where given, one per reading). Needs xarray (the ``export`` extra)."""
        from magcilia import _validate as v
        from magcilia.io.export_xarray import dataset

        columns: dict[str, Any] = self._columns()
        units = {k: k.rsplit("_", 1)[1].replace("N2", "N^2") for k in columns if "_" in k}
        units["chi2"] = "1"
        if time_s is not None:
            times = np.asarray(time_s, dtype=np.float64).reshape(-1)
            if times.size != self.flags.size:
                raise v.fail("time_s", f"{times.size} times", f"one time per reading "
                                                              f"({self.flags.size})")
            columns["time_s"], units["time_s"] = times, "s"
        return dataset(columns, units, dim="sample", coords=("time_s",),
                       attrs={"scale_note": self.scale_note})

    def _columns(self) -> dict[str, NDArray[Any]]:
        """:meth:`to_dataframe`'s columns, each flattened to shape (n,)."""
        flat = {
            column("fx", "N"): self.fx, column("fy", "N"): self.fy,
            column("magnitude", "N"): self.magnitude,
            column("direction", "rad"): self.direction,
            column("sigma_fx", "N"): self.sigma_fx, column("sigma_fy", "N"): self.sigma_fy,
            column("sigma_magnitude", "N"): self.sigma_magnitude,
            column("sigma_direction", "rad"): self.sigma_direction,
            column("cov_xy", "N2"): self.covariance[..., 0, 1],
            "chi2": self.chi2, "flags": self.flags}
        return {k: np.asarray(a).reshape(-1) for k, a in flat.items()}

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
                         "|".join(flag_names(int(f))) or "ok"))
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
