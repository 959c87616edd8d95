"""The results of an array's read-out: :class:`Crosstalk`, :class:`ArrayEstimate` (one set of
readings, the full covariance) and :class:`ArrayEstimates` (n sets at once, on the read-out
protocol: ``value`` and ``sigma`` (n, C, 2), ``flags`` (n, C), ``unit`` ``"N"``). SI."""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Any

import numpy as np
from numpy.typing import NDArray

from magcilia._display import Display, Item, Table, dataframe, number, rows_table, si
from magcilia.readout.protocol import Flag, flag_names

F64 = NDArray[np.float64]

#: the array read-out's former flag enum: the one :class:`~magcilia.readout.protocol.Flag`
#: (its bits changed value: SATURATED 1 → 4, BEYOND_SPAN 2 → 64 (ABOVE_SPAN), NOT_CONVERGED
#: 4 → 512)
ArrayFlag = Flag
"""The array read-out's flags: the one :class:`~magcilia.readout.protocol.Flag` set, under its
former name (SATURATED is 4, ABOVE_SPAN (BEYOND_SPAN) 64, NOT_CONVERGED 512 now)."""
#: the bits an array read-out raises: SATURATED (a reading this cilium's load moves by ≥ 1 σ
#: over its span was saturated and left out), ABOVE_SPAN (alias BEYOND_SPAN: the magnitude lies
#: beyond the span, the table's last cubic continued), NOT_CONVERGED (the fit stopped at its
#: iteration limit; its last estimate is kept), MISSING (a reading is NaN: left out)
ARRAY_FLAGS = Flag.SATURATED | Flag.ABOVE_SPAN | Flag.NOT_CONVERGED | Flag.MISSING


@dataclass(frozen=True, eq=False, repr=False)
class Crosstalk(Display):
    """Each sensor axis's response to a unit horizontal load on each cilium at rest (SI).

    Attributes
    ----------
    names : tuple of str
        Cilium names (C).
    sensor_names : tuple of str
        Sensor names (S).
    matrix : ndarray, shape (3 S, 2 C)
        T/N: row 3 s + i is sensor s's axis i (its own axes), column 2 c (2 c + 1) a load on
        cilium c along the board's x (y).
    response : ndarray, shape (S, C)
        Spectral norm of each 3 × 2 block, T/N.
    site : ndarray, shape (C,)
        Each cilium's site: the sensor nearest its base.
    ratio : ndarray, shape (C,)
        Crosstalk ratio: largest response of another sensor over the site's (dimensionless).
    """

    names: tuple[str, ...]
    sensor_names: tuple[str, ...]
    matrix: F64
    response: F64
    site: NDArray[np.int64]
    ratio: F64

    def table(self) -> list[dict[str, Any]]:
        """One row per cilium (SI): its site, on-site response and crosstalk ratio, and the
        sensor that sees it most besides."""
        rows = []
        for c, name in enumerate(self.names):
            others = self.response[:, c].copy()
            others[self.site[c]] = -1.0
            worst = int(np.argmax(others)) if others.size > 1 else int(self.site[c])
            rows.append({"cilium": name, "site": self.sensor_names[self.site[c]],
                         "response_T_per_N": float(self.response[self.site[c], c]),
                         "worst_other": self.sensor_names[worst],
                         "worst_other_T_per_N": float(max(others[worst], 0.0)),
                         "ratio": float(self.ratio[c])})
        return rows

    def to_dict(self) -> dict[str, Any]:
        """JSON-ready content (SI)."""
        return {"names": list(self.names), "sensor_names": list(self.sensor_names),
                "matrix_T_per_N": self.matrix.tolist(), "response_T_per_N": self.response.tolist(),
                "site": self.site.tolist(), "ratio": self.ratio.tolist()}

    def report(self) -> str:
        """The table in display units (gauss per mN)."""
        lines = [(f"crosstalk of {len(self.names)} cilia over {len(self.sensor_names)} sensors: "
                 f"ratio median {number(float(np.median(self.ratio)))}, largest "
                 f"{number(float(self.ratio.max()))} ({self.names[int(np.argmax(self.ratio))]})"),
                 (f"{'cilium':<8} {'site':<24} {'G/mN':>10} {'worst other':<24} {'G/mN':>10} "
                 f"{'ratio':>8}")]
        for r in self.table():
            lines.append(f"{r['cilium']:<8} {r['site'][:24]:<24} "
                         f"{r['response_T_per_N'] * 10.0:>10.4g} {r['worst_other'][:24]:<24} "
                         f"{r['worst_other_T_per_N'] * 10.0:>10.4g} {r['ratio']:>8.3g}")
        return "\n".join(lines)

    def to_dataframe(self) -> Any:
        """One row per cilium, SI columns (:meth:`table`)."""
        rows = self.table()
        return dataframe({key: [r[key] for r in rows] for key in rows[0]})

    def _display_items(self) -> list[Item]:
        return [("cilia", str(len(self.names))), ("sensors", str(len(self.sensor_names))),
                ("median ratio", number(float(np.median(self.ratio)))),
                ("largest", (f"{number(float(self.ratio.max()))} "
                            f"({self.names[int(np.argmax(self.ratio))]})"))]

    def _display_table(self) -> Table | None:
        return rows_table(self.table())


@dataclass(frozen=True, eq=False, repr=False)
class ArrayEstimate(Display):
    """Every cilium's horizontal force vector from one set of readings (SI): what
    :meth:`ArrayReadout.read <magcilia.ArrayReadout.read>` gives for one sample (3S,) or (S, 3);
    several samples give :class:`ArrayEstimates`.

    Attributes
    ----------
    names : tuple of str
        Cilium names (C).
    force : ndarray, shape (C, 2)
        (Fx, Fy), N, board frame.
    sigma : ndarray, shape (C, 2)
        1-σ of Fx, Fy, N.
    magnitude, sigma_magnitude : ndarray, shape (C,)
        |F| and its 1-σ, N.
    direction, sigma_direction : ndarray, shape (C,)
        atan2(Fy, Fx) and its 1-σ, rad (σ infinite for a zero estimate).
    covariance : ndarray, shape (2 C, 2 C)
        Of (Fx1, Fy1, Fx2, …), N²: the noise's plus the force scale's (:attr:`covariance_scale`).
    flags : ndarray of uint16, shape (C,)
        :class:`~magcilia.readout.protocol.Flag` bits (:data:`ARRAY_FLAGS`).
    span : ndarray, shape (C,)
        Each cilium's span, N.
    iterations : int
        Least-squares iterations (:func:`magcilia.fitting.fit_batch`).
    converged : bool
        Whether the last step fell below the tolerance.
    chi2 : float
        Σ of the squared whitened residuals at the solution (expect about the readings less the
        unknowns under the noise model).
    readings_used : int
        Readings in the fit (not saturated).
    covariance_scale : ndarray, shape (2 C, 2 C)
        The force scale's share of the covariance, N²: each cilium's Young's modulus's relative
        1 σ along its force, fully correlated between the cilia of one modulus (systematic:
        :func:`magcilia.readout.scale.array_scale_covariance`); zeros for moduli taken as exact.
    scale_note : str
        Where the force scale comes from (:meth:`magcilia.Modulus.note` of each distinct
        modulus).
    """

    names: tuple[str, ...]
    force: F64
    sigma: F64
    magnitude: F64
    sigma_magnitude: F64
    direction: F64
    sigma_direction: F64
    covariance: F64
    flags: NDArray[np.uint16]
    span: F64
    iterations: int
    converged: bool
    chi2: float
    readings_used: int
    covariance_scale: F64
    scale_note: str

    #: SI unit of :attr:`value` (the read-out protocol)
    unit = "N"

    @property
    def value(self) -> F64:
        """(Fx, Fy) per cilium, N, (C, 2): :attr:`force` (the read-out protocol's name)."""
        return self.force

    @property
    def sigma_scale(self) -> F64:
        """The force scale's 1 σ of each cilium's force, N, (C,) (``|F| · σ_E/E``)."""
        d = np.clip(np.diag(self.covariance_scale), 0.0, None).reshape(-1, 2)
        return np.asarray(np.sqrt(d.sum(axis=1)), dtype=np.float64)

    @property
    def sigma_noise(self) -> F64:
        """The sensors' noise's 1 σ of Fx, Fy, N, (C, 2): :attr:`sigma` without the force
        scale's share (what readings simulated with the model's own modulus can test)."""
        d = np.clip(np.diag(self.covariance - self.covariance_scale), 0.0, None)
        return np.asarray(np.sqrt(d.reshape(-1, 2)), dtype=np.float64)

    def table(self) -> list[dict[str, Any]]:
        """One row per cilium (SI)."""
        return [{"cilium": n, "Fx_N": float(f[0]), "Fy_N": float(f[1]),
                 "sigma_Fx_N": float(s[0]), "sigma_Fy_N": float(s[1]), "force_N": float(m),
                 "sigma_force_N": float(sm), "direction_rad": float(d),
                 "sigma_direction_rad": float(sd),
                 "flags": int(fl), "flag_names": "|".join(flag_names(int(fl))) or "ok"}
                for n, f, s, m, sm, d, sd, fl in zip(
                    self.names, self.force, self.sigma, self.magnitude, self.sigma_magnitude,
                    self.direction, self.sigma_direction, self.flags, strict=True)]

    def to_dict(self) -> dict[str, Any]:
        """JSON-ready content (SI)."""
        return {"cilia": self.table(), "span_N": self.span.tolist(),
                "covariance_N2": self.covariance.tolist(), "iterations": self.iterations,
                "converged": self.converged, "chi2": self.chi2,
                "readings_used": self.readings_used,
                "covariance_scale_N2": self.covariance_scale.tolist(),
                "scale_note": self.scale_note}

    def to_dataframe(self) -> Any:
        """One row per cilium, SI columns (:meth:`table`)."""
        rows = self.table()
        return dataframe({key: [r[key] for r in rows] for key in rows[0]})

    def report(self) -> str:
        """A table in display units (mN, degrees)."""
        flagged = int(np.count_nonzero(self.flags))
        lines = [(f"force vectors of {len(self.names)} cilia: {self.iterations} iterations"
                 f"{'' if self.converged else ' (not converged)'}, chi2 {self.chi2:.4g} over "
                 f"{self.readings_used} readings, {flagged} flagged"),
                 (f"{'cilium':<8} {'Fx mN':>10} {'Fy mN':>10} {'|F| mN':>10} {'σ mN':>9} "
                 f"{'dir deg':>8} {'σ deg':>7}  flags")]
        for r in self.table():
            lines.append(f"{r['cilium']:<8} {r['Fx_N'] * 1e3:>10.4g} {r['Fy_N'] * 1e3:>10.4g} "
                         f"{r['force_N'] * 1e3:>10.4g} {r['sigma_force_N'] * 1e3:>9.3g} "
                         f"{math.degrees(r['direction_rad']):>8.1f} "
                         f"{math.degrees(r['sigma_direction_rad']):>7.3g}  {r['flag_names']}")
        if self.scale_note:
            lines.append(self.scale_note)
        return "\n".join(lines)

    def _display_items(self) -> list[Item]:
        return [("cilia", str(len(self.names))),
                ("largest", si(float(self.magnitude.max()), "N")),
                ("median σ", si(float(np.median(self.sigma_magnitude)), "N")),
                ("flagged", str(int(np.count_nonzero(self.flags)))),
                ("iterations", str(self.iterations))]

    def _display_table(self) -> Table | None:
        return rows_table(self.table())


@dataclass(frozen=True, eq=False, repr=False)
class ArrayEstimates(Display):
    """Every cilium's horizontal force vector from n sets of readings at once (SI): what
    :meth:`ArrayReadout.read <magcilia.ArrayReadout.read>` gives for samples (n, 3S); sample i
    is the :class:`ArrayEstimate` of its readings alone, less the cross-cilium covariance.

    Attributes
    ----------
    names : tuple of str
        Cilium names (C).
    force, sigma : ndarray, shape (n, C, 2)
        (Fx, Fy) and their 1 σ (noise and force scale), N, board frame.
    magnitude, sigma_magnitude, direction, sigma_direction : ndarray, shape (n, C)
        |F| (N), atan2(Fy, Fx) (rad) and their 1 σ (σ of the direction infinite at zero).
    covariance, covariance_scale : ndarray, shape (n, C, 2, 2)
        Each cilium's covariance of (Fx, Fy), N², and the force scale's share of it (the
        blocks on the diagonal of :attr:`ArrayEstimate.covariance`).
    flags : ndarray of uint16, shape (n, C)
        :class:`~magcilia.readout.protocol.Flag` bits (:data:`ARRAY_FLAGS`).
    span : ndarray, shape (C,)
        Each cilium's span, N.
    iterations, readings_used : ndarray of int, shape (n,)
        Least-squares iterations and readings in the fit, per sample.
    converged : ndarray of bool, shape (n,)
    chi2 : ndarray, shape (n,)
        Σ of the squared whitened residuals per sample.
    scale_note : str
        Where the force scale comes from.
    """

    names: tuple[str, ...]
    force: F64
    sigma: F64
    magnitude: F64
    sigma_magnitude: F64
    direction: F64
    sigma_direction: F64
    covariance: F64
    covariance_scale: F64
    flags: NDArray[np.uint16]
    span: F64
    iterations: NDArray[np.int64]
    converged: NDArray[np.bool_]
    chi2: F64
    readings_used: NDArray[np.int64]
    scale_note: str

    #: SI unit of :attr:`value` (the read-out protocol)
    unit = "N"

    def __len__(self) -> int:
        return int(self.force.shape[0])

    @property
    def value(self) -> F64:
        """(Fx, Fy) per sample and cilium, N, (n, C, 2): :attr:`force`."""
        return self.force

    @property
    def sigma_noise(self) -> F64:
        """The sensors' noise's 1 σ of Fx, Fy, N, (n, C, 2) (:attr:`sigma` without the force
        scale's share)."""
        d = np.diagonal(self.covariance - self.covariance_scale, axis1=-2, axis2=-1)
        return np.asarray(np.sqrt(np.clip(d, 0.0, None)), dtype=np.float64)

    def to_dict(self) -> dict[str, Any]:
        """JSON-ready content (SI)."""
        return {"names": list(self.names), "force_N": self.force.tolist(),
                "sigma_N": self.sigma.tolist(), "magnitude_N": self.magnitude.tolist(),
                "sigma_magnitude_N": self.sigma_magnitude.tolist(),
                "direction_rad": self.direction.tolist(),
                "sigma_direction_rad": self.sigma_direction.tolist(),
                "covariance_N2": self.covariance.tolist(),
                "covariance_scale_N2": self.covariance_scale.tolist(),
                "flags": self.flags.tolist(), "span_N": self.span.tolist(),
                "iterations": self.iterations.tolist(), "converged": self.converged.tolist(),
                "chi2": self.chi2.tolist(), "readings_used": self.readings_used.tolist(),
                "scale_note": self.scale_note}

    def to_dataframe(self) -> Any:
        """One row per sample and cilium (SI): ``sample``, ``cilium``, ``Fx_N``, ``Fy_N``,
        their σ, ``force_N``, ``direction_rad``, their σ and ``flags``."""
        n, c = self.flags.shape
        return dataframe({
            "sample": np.repeat(np.arange(n), c), "cilium": list(self.names) * n,
            "Fx_N": self.force[..., 0].reshape(-1), "Fy_N": self.force[..., 1].reshape(-1),
            "sigma_Fx_N": self.sigma[..., 0].reshape(-1),
            "sigma_Fy_N": self.sigma[..., 1].reshape(-1),
            "force_N": self.magnitude.reshape(-1),
            "sigma_force_N": self.sigma_magnitude.reshape(-1),
            "direction_rad": self.direction.reshape(-1),
            "sigma_direction_rad": self.sigma_direction.reshape(-1),
            "flags": self.flags.reshape(-1)})

    def report(self) -> str:
        """One line: samples, cilia, convergence, the largest force and the median σ."""
        n = len(self)
        text = (f"force vectors of {len(self.names)} cilia in {n} sample{'s' * (n != 1)}: "
                f"{int(self.converged.sum())} converged, "
                f"{int(np.count_nonzero(self.flags))} estimates flagged")
        if self.magnitude.size:
            text += (f"; |F| up to {si(float(np.nanmax(self.magnitude)), 'N')}, median σ "
                     f"{si(float(np.nanmedian(self.sigma_magnitude)), 'N')}")
        return text + (f"; {self.scale_note}" if self.scale_note else "")

    def _display_items(self) -> list[Item]:
        return [("samples", str(len(self))), ("cilia", str(len(self.names))),
                ("flagged", str(int(np.count_nonzero(self.flags)))),
                ("converged", f"{int(self.converged.sum())}/{len(self)}")]
