"""Arrays of cilia under loads: the forward map, crosstalk, the inverse and design metrics.

Loads. A horizontal force F = (Fx, Fy) (N) on cilium c's tip bends it in the vertical plane at
azimuth φ = atan2(Fy, Fx): the planar large-deflection shape of :func:`magcilia.bend` under
``|F|`` turned by φ about the vertical axis through its base
(:meth:`SpatialCentreline.from_planar`), its dipole rings kept fixed in the board frame
(:func:`magcilia.model.array.board_normals`; see :mod:`magcilia.model.array` for why).
:func:`loaded_poses` / :func:`field_for_loads` solve the elastica for each cilium (exact);
:class:`ArrayReadout` tabulates each kind of cilium's planar shape against |F| once (a cubic
spline through :func:`magcilia.bend_sweep` shapes on a uniform grid over ``[−span, span]``, the
shapes at −F being the mirror images, so that the model is smooth through zero load), and turns
it for every cilium and azimuth at the cost of a few array operations.

Crosstalk (:meth:`ArrayReadout.crosstalk`). The matrix J (3S × 2C, T/N): the response of each
sensor axis (on the sensor's own axes) to a unit horizontal load on each cilium at rest, along x
(column 2c) and y (column 2c + 1), by central differences of the model (step 1e-4 of the span).
A sensor's response to a cilium is the spectral norm of its 3 × 2 block (the largest field change
per newton over load directions). Cilium c's *site* is the sensor nearest its base
(horizontally); its crosstalk ratio is the largest response of any other sensor over the site's.

Inverse (:meth:`ArrayReadout.read`). All cilia's force vectors from all sensors at once:
minimise ``Σ ((y − f(F)) / σ)² + α Σ (F / span)²`` over the 2C components, y the readings
(T, on the sensors' axes), σ each axis's noise and quantisation (:attr:`CiliaArray.sigma`), f the
tabulated model. Levenberg–Marquardt (starting as Gauss–Newton) from the linear solution
``(JᵀWJ + α/span²)⁻¹ JᵀW (y − f(0))``, with the Jacobian by forward differences (step 1e-6 of
the span, all cilia in one kernel call; recomputed after large steps only, chord steps near the
solution). The Tikhonov weight α (``regularization``, dimensionless,
default 1e-6) acts as a prior of span/√α (1000 spans) on each component: it steadies the
solve and biases an estimate by about α / (α + (span · response / σ)²) of itself, ~1e-12 for a
cilium whose full-span load moves its readings by 1000 σ. Saturated readings are left out of the
fit (and flag the cilia they inform). Covariance: ``A⁻¹ JᵀWJ A⁻¹``, A = JᵀWJ + α/span², at
the solution (the sensors' white noise through the linearised model), plus the force scale's: each
force scales with its cilium's Young's modulus at a fixed shape, so the modulus's relative 1 σ
adds along the force, shared by the cilia of one modulus (:mod:`magcilia.readout.scale`); σ of
|F| and of the direction from it.

A problem is refused as singular (one-line error, at construction) when the readings are fewer
than the unknowns (3S < 2C), when a cilium's full-span load moves no reading by one σ in some
direction (its load does not reach any sensor), or when the loads of some cilia cannot be told
apart (the whitened, span-scaled matrix has a singular value below 1).

Neighbours. Two cilia that could touch when both are bent toward each other by their span's load
(the distance between their centrelines, point to point, less both radii, below zero anywhere)
are refused too: the array cannot measure beyond that contact; so is a sensor that a cilium
reaches under a load up to its span in some direction.
"""

from __future__ import annotations

import dataclasses
import enum
import math
from dataclasses import dataclass
from functools import lru_cache
from typing import Any

import numpy as np
from numpy.typing import ArrayLike, NDArray
from scipy.interpolate import CubicSpline

from magcilia import _validate as v
from magcilia._display import Display, Item, Table, dataframe, number, rows_table, si
from magcilia.device.array import CiliaArray
from magcilia.device.cilium import Cilium
from magcilia.device.magnetometer import Magnetometer
from magcilia.device.setup import Setup
from magcilia.mechanics import bend, bend_sweep
from magcilia.model.array import board_normals, segment_field
from magcilia.model.centreline import Centreline, SpatialCentreline
from magcilia.readout.scale import array_scale_covariance, scale_notes

F64 = NDArray[np.float64]

#: forward-difference step of the inverse's Jacobian, as a fraction of the span
JACOBIAN_STEP = 1e-6
#: the inverse recomputes its Jacobian after a step larger than this (a fraction of the span in
#: some component), else keeps the last one (chord steps: one model evaluation per iteration)
REFRESH_STEP = 1e-2
#: central-difference step of the crosstalk matrix, as a fraction of the span
CROSSTALK_STEP = 1e-4


class ArrayFlag(enum.IntFlag):
    """Bit flags of a cilium's estimate (0: a good estimate)."""

    OK = 0
    #: a reading this cilium's load moves by ≥ 1 σ over its span was saturated (left out)
    SATURATED = 1
    #: the estimate's magnitude lies beyond the span (the table's last cubic continued)
    BEYOND_SPAN = 2
    #: the iteration stopped before its step fell below the tolerance
    NOT_CONVERGED = 4


# -- the per-kind table of planar shapes against |F| --------------------------------------------

@dataclass(frozen=True, eq=False)
class LoadTable:
    """Planar slice frames of one kind of cilium against the force magnitude (plain values).

    Attributes
    ----------
    span : float
        Largest tabulated force, N (the grid is uniform over [−span, span]).
    step : float
        Grid step, N.
    coefficients : ndarray, shape (4, 2 g − 2, 3 n)
        The cubic spline's polynomial coefficients per interval (highest power first) of the
        slice mid-points' x (m), z (m) and tangent angle θ (rad), n slices each.
    error : ndarray, shape (3,)
        Largest difference between the spline and directly solved shapes at the mid-points of
        the positive half grid: x, z (m) and θ (rad).
    """

    span: float
    step: float
    coefficients: F64
    error: F64

    @property
    def slices(self) -> int:
        """Slices n."""
        return int(self.coefficients.shape[2] // 3)

    def frames(self, magnitude: F64) -> tuple[F64, F64, F64]:
        """x, z (m) and θ (rad) of the slice mid-points at force magnitudes (C,) N, each (C, n);
        beyond the span the last interval's cubic continues."""
        cells = self.coefficients.shape[1]
        idx = np.clip(((magnitude + self.span) / self.step).astype(np.int64), 0, cells - 1)
        u = (magnitude + self.span - idx * self.step)[:, None]
        c = self.coefficients[:, idx]
        out = ((c[0] * u + c[1]) * u + c[2]) * u + c[3]
        n = self.slices
        return out[:, :n], out[:, n:2 * n], out[:, 2 * n:]


def _slice_frames(shapes: Centreline, s_mid: F64) -> F64:
    """x, z, θ of the slice mid-points of planar shapes, (a, 3 n)."""
    pts, th = shapes.frames(s_mid)
    return np.concatenate([pts[..., 0], pts[..., 2], th], axis=1)


@lru_cache(maxsize=32)
def _load_table(cilium: Cilium, modulus: float, n_loops: int, span: float,
                size: int) -> LoadTable:
    setup = Setup(dataclasses.replace(cilium, youngs_modulus=modulus), n_loops=n_loops)
    s_mid = cilium.height * (np.arange(n_loops) + 0.5) / n_loops
    grid = np.linspace(0.0, span, size)
    shapes = bend_sweep(setup, forces=grid)
    assert isinstance(shapes, Centreline)  # for mypy: loads in the x–z plane give planar shapes
    frames = _slice_frames(shapes, s_mid)  # (size, 3n)
    n = n_loops
    mirror = frames[:0:-1].copy()  # −F: x and θ change sign, z does not
    mirror[:, :n] *= -1.0
    mirror[:, 2 * n:] *= -1.0
    both = np.concatenate([mirror, frames])
    forces = np.concatenate([-grid[:0:-1], grid])
    spline = CubicSpline(forces, both, axis=0)
    mids = 0.5 * (grid[:-1] + grid[1:])
    mid_shapes = bend_sweep(setup, forces=mids)
    assert isinstance(mid_shapes, Centreline)  # for mypy (as above)
    exact = _slice_frames(mid_shapes, s_mid)
    err = np.abs(spline(mids) - exact)
    error = np.array([err[:, :n].max(), err[:, n:2 * n].max(), err[:, 2 * n:].max()])
    coefficients = np.ascontiguousarray(spline.c)
    for arr in (coefficients, error):
        arr.setflags(write=False)
    return LoadTable(span=span, step=span / (size - 1), coefficients=coefficients, error=error)


# -- exact loaded shapes --------------------------------------------------------------------------

def _forces(array: CiliaArray, forces: ArrayLike) -> F64:
    f = v.finite_array("forces", forces, unit="N")
    if f.ndim != 2 or f.shape[0] != len(array) or f.shape[1] not in (2, 3):
        raise v.fail("forces", f"an array of shape {f.shape}",
                     f"shape ({len(array)}, 2) or ({len(array)}, 3): (Fx, Fy[, Fz]) per cilium, N")
    return f


def loaded_poses(array: CiliaArray, forces: ArrayLike) -> SpatialCentreline | list[Any]:
    """The cilia's shapes under tip forces, solved exactly (one :func:`magcilia.bend` each).

    Parameters
    ----------
    array : CiliaArray
    forces : array-like, shape (C, 2) or (C, 3)
        (Fx, Fy) or (Fx, Fy, Fz) per cilium, N, board frame: the force bends the cilium in the
        vertical plane at azimuth atan2(Fy, Fx), with direction atan2(|F_h|, Fz) from +z in that
        plane.

    Returns
    -------
    SpatialCentreline or list
        One shape per cilium, rings fixed in the board (:func:`magcilia.model.array.board_normals`):
        one SpatialCentreline of C shapes when the cilia share their length, else a list of C
        one-shape SpatialCentrelines. For :meth:`CiliaArray.field`.
    """
    f = _forces(array, forces)
    shapes = []
    for c, setup in enumerate(array.cilia):
        fh = math.hypot(f[c, 0], f[c, 1])
        fz = f[c, 2] if f.shape[1] == 3 else 0.0
        magnitude = math.hypot(fh, fz)
        planar = bend(setup, force=magnitude, direction=math.atan2(fh, fz)) if magnitude \
            else bend(setup)
        assert isinstance(planar, Centreline)  # for mypy: a load in the x–z plane
        phi = math.atan2(f[c, 1], f[c, 0]) if fh > 0.0 else 0.0
        spatial = SpatialCentreline.from_planar(planar, phi)
        shapes.append(SpatialCentreline(spatial.s, spatial.points, spatial.tangents,
                                        board_normals(spatial.tangents, spatial.normals)))
    if all(sh.s.size == shapes[0].s.size and np.array_equal(sh.s, shapes[0].s) for sh in shapes):
        return SpatialCentreline(shapes[0].s, np.concatenate([sh.points for sh in shapes]),
                                 np.concatenate([sh.tangents for sh in shapes]),
                                 np.concatenate([sh.normals for sh in shapes]))
    return shapes


def field_for_loads(array: CiliaArray, forces: ArrayLike) -> F64:
    """Field at every sensor (T, board frame, shape (S, 3)) with every cilium bent by its tip
    force ((C, 2) or (C, 3), N; :func:`loaded_poses`, exact elastica)."""
    return array.field(loaded_poses(array, forces))


# -- results ---------------------------------------------------------------------------------------

def _direction(deg: float) -> str:
    return f"{deg:.1f}°"


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
    """Every cilium's horizontal force vector from one set of readings (SI).

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
    flags : ndarray of uint8, shape (C,)
        :class:`ArrayFlag` bits.
    span : ndarray, shape (C,)
        Each cilium's span, N.
    iterations : int
        Levenberg–Marquardt iterations.
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
    flags: NDArray[np.uint8]
    span: F64
    iterations: int
    converged: bool
    chi2: float
    readings_used: int
    covariance_scale: F64
    scale_note: str

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
                 "flags": int(fl), "flag_names": ArrayFlag(int(fl)).name or "ok"}
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


# -- the read-out ----------------------------------------------------------------------------------

@dataclass(frozen=True, eq=False, init=False, repr=False)
class ArrayReadout(Display):
    """The forward map of an array under loads, its crosstalk and the inverse (immutable).

    Parameters
    ----------
    array : CiliaArray
    span : float or array-like, shape (C,)
        Largest horizontal tip force of each cilium, N (the tables cover [0, span]).
    table_size : int
        Tabulated loads over [0, span] (≥ 5; default 33); the table is checked against direct
        solves at its mid-points (:attr:`table_error`).
    regularization : float
        Tikhonov weight α on (F / span)² (dimensionless, ≥ 0; default 1e-6), see the module.
    max_iterations : int
        Levenberg–Marquardt iterations at most.
    tolerance : float
        Stop when a step changes the weighted sum of squares by less than this (default 1e-8:
        steps of about 1e-4 of the estimates' σ; the step is applied).

    Attributes
    ----------
    tables : tuple of LoadTable
        One per kind of cilium (same geometry, modulus and slices).
    kinds : ndarray, shape (C,)
        Each cilium's table.
    table_error : ndarray, shape (C,)
        The tables' error as a field at the sensors, T: the largest change of any sensor's field
        when every slice of cilium c is displaced by its table's largest errors (x, z, θ at the
        mid-points against direct solves, :attr:`LoadTable.error`) at once.
    rest : ndarray, shape (S, 3)
        The field at rest on the sensors' axes, T.
    jacobian : ndarray, shape (3 S, 2 C)
        The crosstalk matrix (T/N), see :meth:`crosstalk`.
    columns : tuple of ndarray
        Each cilium's slice mid-points as indices into the array layout's ``s_query``.

    Examples
    --------
    >>> import numpy as np
    >>> import magcilia as mc
    >>> from magcilia.device.magnetometer import Magnetometer
    >>> part = Magnetometer(field_range=5e-3, resolution=1.5e-7, noise=3e-7, rate=100.0)
    >>> setup = mc.Setup.paper(tip_radius=5e-5, youngs_modulus=1e6, position=(0, 0, 0))
    >>> array = mc.CiliaArray.grid(setup, 2, 2, pitch=2e-3, sensor=part)
    >>> readout = mc.ArrayReadout(array, span=2e-5)
    >>> forces = np.array([[1e-5, 0.0], [0.0, -5e-6], [3e-6, 3e-6], [0.0, 0.0]])
    >>> field = mc.field_for_loads(array, forces)  # the exact elastica, N -> T
    >>> est = readout.read(array.to_sensor(field))  # noise-free readings
    >>> bool(np.abs(est.force - forces).max() < 1e-6 * 2e-5)
    True
    """

    array: CiliaArray
    span: F64
    table_size: int
    regularization: float
    max_iterations: int
    tolerance: float
    tables: tuple[LoadTable, ...]
    kinds: NDArray[np.int64]
    table_error: F64
    rest: F64
    jacobian: F64
    columns: tuple[NDArray[np.int64], ...]

    def __init__(self, array: CiliaArray, span: float | ArrayLike, *, table_size: int = 33,
                 regularization: float = 1e-6, max_iterations: int = 30,
                 tolerance: float = 1e-8) -> None:
        if not isinstance(array, CiliaArray):
            raise v.fail("array", type(array).__name__, "a magcilia CiliaArray")
        spans = np.broadcast_to(np.asarray(span, dtype=np.float64), (len(array),)).copy() \
            if np.ndim(span) == 0 else v.finite_array("span", span, ndim=1, unit="N")
        if spans.shape != (len(array),) or not np.all(np.isfinite(spans)) or np.any(spans <= 0):
            raise v.fail("span", span, f"a positive force in N, or {len(array)} of them")
        size = v.integer("table_size", table_size, 5)
        alpha = float(regularization)
        if not math.isfinite(alpha) or alpha < 0.0:
            raise v.fail("regularization", regularization, "a number ≥ 0 (default 1e-6)")
        keys: dict[tuple[Any, ...], int] = {}
        kinds = np.empty(len(array), dtype=np.int64)
        tables: list[LoadTable] = []
        for c, setup in enumerate(array.cilia):
            if setup.cilium.tip_radius == 0.0:
                raise v.fail("tip_radius", 0.0, f"positive for cilium {array.names[c]}: a tip "
                             "force on a sharp cone has no finite bending (set tip_radius > 0)")
            key = (setup.cilium, setup.youngs_modulus, setup.n_loops, float(spans[c]))
            if key not in keys:
                keys[key] = len(tables)
                tables.append(_load_table(*key, size))
            kinds[c] = keys[key]
        set_ = object.__setattr__
        set_(self, "array", array)
        set_(self, "span", spans)
        set_(self, "table_size", size)
        set_(self, "regularization", alpha)
        set_(self, "max_iterations", v.integer("max_iterations", max_iterations, 1))
        set_(self, "tolerance", v.positive("tolerance", tolerance, "", "fraction"))
        set_(self, "tables", tuple(tables))
        set_(self, "kinds", kinds)
        lay = array.layout
        cols = []
        for setup in array.cilia:
            n = setup.n_loops
            cols.append(np.searchsorted(lay.s_query, setup.cilium.height * (np.arange(n) + 0.5)
                                        / n))
        set_(self, "columns", tuple(cols))
        zero = np.zeros((len(array), 2))
        rest = self._fields(zero[None])[0].sum(axis=0)
        set_(self, "rest", array.to_sensor(rest))
        set_(self, "jacobian", self._crosstalk_matrix())
        set_(self, "table_error", self._table_error())
        self._check_reach()
        self._check_singular()

    # -- the forward model ------------------------------------------------------------------------
    def _frames(self, force: F64) -> tuple[F64, F64, F64, F64]:
        """x, z, θ (C, q) of every cilium at force vectors (C, 2), and the azimuths (C,)."""
        lay = self.array.layout
        c_n, q = len(self.array), lay.s_query.size
        mag = np.hypot(force[:, 0], force[:, 1])
        phi = np.arctan2(force[:, 1], force[:, 0])
        x, z, th = np.zeros((c_n, q)), np.zeros((c_n, q)), np.zeros((c_n, q))
        cols = self.columns
        for kind, table in enumerate(self.tables):
            members = np.nonzero(self.kinds == kind)[0]
            fx, fz, fth = table.frames(mag[members])
            where = np.ix_(members, cols[members[0]])  # a kind shares its slices
            x[where], z[where], th[where] = fx, fz, fth
        return x, z, th, phi

    def _fields(self, forces: F64) -> F64:
        """Each cilium's field (board frame, T) at the sensors for ``b`` sets of force vectors
        (b, C, 2), N: shape (b, C, S, 3), one kernel call."""
        lay = self.array.layout
        parts_p, parts_m = [], []
        for f in forces:
            x, z, th, phi = self._frames(f)
            p, m = lay.planar_dipoles(x, z, th, phi)
            parts_p.append(p)
            parts_m.append(m)
        d = lay.size
        starts = np.concatenate([lay.starts[:-1] + i * d for i in range(len(forces))]
                                + [[len(forces) * d]]).astype(np.int64)
        out = segment_field(np.asarray(self.array.sensor_positions),
                            np.concatenate(parts_p), np.concatenate(parts_m), starts)
        return out.reshape(len(forces), len(self.array), -1, 3)

    def field(self, forces: ArrayLike) -> F64:
        """Field at every sensor (T, board frame, shape (S, 3)) with every cilium bent by its
        horizontal force ((C, 2), N), from the tables (:func:`field_for_loads` solves exactly)."""
        f = _forces(self.array, forces)
        if f.shape[1] == 3 and np.any(f[:, 2] != 0.0):
            raise v.fail("forces", "a vertical component", "horizontal forces (C, 2) for the "
                         "tables (field_for_loads solves loads with Fz)")
        f = f[:, :2]
        return np.asarray(self._fields(f[None])[0].sum(axis=0), dtype=np.float64)

    def _crosstalk_matrix(self) -> F64:
        c_n, h = len(self.array), CROSSTALK_STEP * self.span
        sets = np.zeros((4, c_n, 2))
        sets[0, :, 0], sets[1, :, 0], sets[2, :, 1], sets[3, :, 1] = h, -h, h, -h
        b = self.array.to_sensor(self._fields(sets))  # (4, C, S, 3)
        dx = (b[0] - b[1]) / (2.0 * h[:, None, None])
        dy = (b[2] - b[3]) / (2.0 * h[:, None, None])
        jac = np.stack([dx, dy], axis=-1)  # (C, S, 3, 2)
        return np.ascontiguousarray(jac.transpose(1, 2, 0, 3).reshape(3 * self.array.n_sensors,
                                                                      2 * c_n))

    def _table_error(self) -> F64:
        out = np.zeros(len(self.array))
        lay = self.array.layout
        pts = np.asarray(self.array.sensor_positions)
        for kind, table in enumerate(self.tables):
            members = np.nonzero(self.kinds == kind)[0]
            c = int(members[0])
            # the frames' errors as a field: every slice displaced by the table's largest
            # errors at once (x, z and θ), the change of the field at the sensors
            x, z, th, phi = self._frames(np.zeros((len(self.array), 2)))
            base_p, base_m = lay.planar_dipoles(x, z, th, phi)
            cols = self.columns
            x2, z2, th2 = x.copy(), z.copy(), th.copy()
            x2[c, cols[c]] += table.error[0]
            z2[c, cols[c]] += table.error[1]
            th2[c, cols[c]] += table.error[2]
            p2, m2 = lay.planar_dipoles(x2, z2, th2, phi)
            j0, j1 = int(lay.starts[c]), int(lay.starts[c + 1])
            seg = np.array([0, j1 - j0, 2 * (j1 - j0)], dtype=np.int64)
            b = segment_field(pts, np.concatenate([base_p[j0:j1], p2[j0:j1]]),
                              np.concatenate([base_m[j0:j1], m2[j0:j1]]), seg)
            out[members] = float(np.abs(b[1] - b[0]).max())
        out.setflags(write=False)
        return out

    # -- checks -----------------------------------------------------------------------------------
    def _check_reach(self) -> None:
        arr = self.array
        b = arr.bases
        reach = np.empty(len(arr))
        shapes = []
        solved: dict[int, tuple[F64, F64]] = {}  # one shape per kind (the kind holds the span)
        for c, setup in enumerate(arr.cilia):
            kind = int(self.kinds[c])
            if kind not in solved:
                s = np.linspace(0.0, setup.cilium.height, 65)
                solved[kind] = (bend(setup, force=float(self.span[c])).frames(s)[0],
                                setup.spec.radius(s))
            pts, radius = solved[kind]
            shapes.append((pts[0, :, 0], pts[0, :, 2] + b[c, 2], radius))
            reach[c] = float(np.max(pts[0, :, 0] + radius))
        self._check_sensor_reach()
        dist = np.hypot(b[:, None, 0] - b[None, :, 0], b[:, None, 1] - b[None, :, 1])
        close = np.argwhere(np.triu(dist < reach[:, None] + reach[None], 1))
        for i, j in close.tolist():
            xa, za, ra = shapes[i]
            xb, zb, rb = shapes[j]
            gap = np.hypot((dist[i, j] - xb)[None, :] - xa[:, None], zb[None, :] - za[:, None])
            gap -= ra[:, None] + rb[None, :]
            if gap.min() < 0.0:
                raise v.fail("span", f"{si(float(self.span[i]), 'N')} for cilia "
                             f"{arr.names[i]} and {arr.names[j]} ({dist[i, j] * 1e3:.4g} mm apart)",
                             "loads the cilia can take without touching: bent toward each "
                             "other by it they meet; use a larger pitch or a smaller span")

    def _check_sensor_reach(self) -> None:
        """No sensor within the region a cilium sweeps under loads up to its span in any
        direction: the closest approach of a cilium bent in the vertical plane through a point is
        when it bends toward the point, so each sensor is tested in that plane against the
        shapes at 9 loads from 0 to the span (point-to-segment distances less the radius)."""
        arr = self.array
        near = arr._within_reach  # (C, S)
        if not near.any():
            return
        pts = np.asarray(arr.sensor_positions)
        sweeps: dict[int, tuple[F64, F64, F64]] = {}
        for c in np.nonzero(near.any(axis=1))[0].tolist():
            setup, kind = arr.cilia[c], int(self.kinds[c])
            if kind not in sweeps:
                loads = np.linspace(0.0, float(self.span[c]), 9)
                s = np.linspace(0.0, setup.cilium.height, 129)
                shapes = bend_sweep(setup, forces=loads)
                sweeps[kind] = (shapes.frames(s)[0][..., [0, 2]], setup.spec.radius(s), loads)
            xz, radius, loads = sweeps[kind]  # (9, 129, 2), (129,), (9,)
            rel = pts[near[c]] - arr.bases[c]
            q = np.stack([np.hypot(rel[:, 0], rel[:, 1]), rel[:, 2]], axis=1)  # (o, 2)
            a, seg = xz[:, :-1], np.diff(xz, axis=1)  # (9, 128, 2)
            d = q[:, None, None, :] - a[None]
            t = np.clip(np.einsum("olmi,lmi->olm", d, seg) / np.einsum("lmi,lmi->lm", seg, seg),
                        0.0, 1.0)
            gap = np.linalg.norm(d - t[..., None] * seg[None], axis=-1) \
                - (radius[:-1] + t * np.diff(radius))
            if gap.min() <= 0.0:
                o, load, _ = np.unravel_index(int(np.argmin(gap)), gap.shape)
                s_idx = int(np.nonzero(near[c])[0][o])
                raise v.fail("sensors", f"sensor {s_idx + 1} at "
                             f"({', '.join(f'{x * 1e3:.4g}' for x in pts[s_idx])}) mm",
                             f"sensing points clear of the cilia under load; cilium "
                             f"{arr.names[c]} bent toward it by {si(float(loads[load]), 'N')} "
                             "reaches it: move the sensor or use a smaller span")

    def _check_singular(self) -> None:
        arr = self.array
        c_n, rows = len(arr), 3 * arr.n_sensors
        if rows < 2 * c_n:
            raise v.fail("sensors", f"{arr.n_sensors} sensors ({rows} readings)",
                         f"at least as many readings as unknowns: {2 * c_n} (Fx, Fy of "
                         f"{c_n} cilia); add sensors")
        jw = self.jacobian / arr.sigma.reshape(-1)[:, None] * np.repeat(self.span, 2)[None, :]
        for c in range(c_n):
            sv = np.linalg.svd(jw[:, 2 * c:2 * c + 2], compute_uv=False)
            if sv[-1] < 1.0:
                raise v.fail("array", f"cilium {arr.names[c]}",
                             f"cilia whose load reaches a sensor; a full-span load "
                             f"({si(float(self.span[c]), 'N')}) on {arr.names[c]} moves no "
                             f"reading by more than {sv[-1]:.3g} σ in its weakest direction: "
                             "move a sensor closer to it, or remove it")
        _, sv, vt = np.linalg.svd(jw, full_matrices=False)
        if sv[-1] < 1.0:
            weights = np.hypot(vt[-1, 0::2], vt[-1, 1::2])
            a, b = (arr.names[int(k)] for k in np.argsort(weights)[::-1][:2])
            raise v.fail("array", f"cilia {a} and {b}",
                         f"cilia whose loads the sensors can tell apart; the loads of {a} and "
                         f"{b} differ at the sensors by less than one σ per span (singular "
                         f"value {sv[-1]:.3g}): add or move sensors, or widen the span")

    # -- crosstalk --------------------------------------------------------------------------------
    def crosstalk(self) -> Crosstalk:
        """The crosstalk matrix, each sensor's response to each cilium and the ratios (see the
        module)."""
        arr = self.array
        s_n, c_n = arr.n_sensors, len(arr)
        blocks = self.jacobian.reshape(s_n, 3, c_n, 2).transpose(0, 2, 1, 3)
        response = np.asarray(np.linalg.svd(blocks, compute_uv=False)[..., 0], dtype=np.float64)
        pts, b = np.asarray(arr.sensor_positions), arr.bases
        horiz = np.hypot(pts[:, None, 0] - b[None, :, 0], pts[:, None, 1] - b[None, :, 1])
        site = np.argmin(horiz, axis=0).astype(np.int64)
        others = response.copy()
        others[site, np.arange(c_n)] = 0.0
        ratio = others.max(axis=0) / response[site, np.arange(c_n)]
        ratio = np.asarray(ratio, dtype=np.float64)
        for arr_ in (response, site, ratio):
            arr_.setflags(write=False)
        return Crosstalk(arr.names, tuple(s.name for s in arr.sensors), self.jacobian, response,
                         site, ratio)

    # -- inverse ----------------------------------------------------------------------------------
    def _model(self, force: F64, step: F64 | None) -> tuple[F64, F64 | None]:
        """Model readings (3S,) (T, the sensors' axes) at force vectors (C, 2) and, with a
        ``step`` (C,) N, the Jacobian (3S, 2C) T/N by forward differences (one kernel call)."""
        c_n = len(self.array)
        if step is None:
            b = self.array.to_sensor(self._fields(force[None]))
            return b[0].sum(axis=0).reshape(-1), None
        sets = np.repeat(force[None], 3, axis=0)
        sets[1, :, 0] += step
        sets[2, :, 1] += step
        b = self.array.to_sensor(self._fields(sets))  # (3, C, S, 3)
        f = b[0].sum(axis=0).reshape(-1)
        dx = (b[1] - b[0]) / step[:, None, None]
        dy = (b[2] - b[0]) / step[:, None, None]
        jac = np.stack([dx, dy], axis=-1).transpose(1, 2, 0, 3).reshape(f.size, 2 * c_n)
        return f, jac

    def read(self, readings: ArrayLike) -> ArrayEstimate:
        """Every cilium's horizontal force vector from one set of readings.

        Parameters
        ----------
        readings : array-like, shape (S, 3)
            Each sensor's reading on its own axes, T (:meth:`CiliaArray.readings`).

        Returns
        -------
        ArrayEstimate
        """
        arr = self.array
        y = v.finite_array("readings", readings, unit="T")
        if y.shape != (arr.n_sensors, 3):
            raise v.fail("readings", f"an array of shape {y.shape}", f"shape ({arr.n_sensors}, 3)")
        c_n = len(arr)
        sat = arr.saturated(y).reshape(-1)
        w = np.where(sat, 0.0, 1.0 / arr.sigma.reshape(-1))
        scale = np.repeat(self.span, 2)  # x = F / span
        alpha = self.regularization
        eye = alpha * np.eye(2 * c_n)
        y = y.reshape(-1)

        def normal(jac: F64, resid: F64) -> tuple[F64, F64]:
            jw = jac * w[:, None] * scale[None, :]
            return jw.T @ jw, jw.T @ (resid * w)

        jtj, g = normal(self.jacobian, y - self.rest.reshape(-1))
        x = np.linalg.solve(jtj + eye, g)
        step = JACOBIAN_STEP * self.span
        f, jac_ = self._model(x.reshape(c_n, 2) * self.span[:, None], step)
        jac: F64 = jac_  # type: ignore[assignment]
        resid = y - f
        cost = float(np.sum((resid * w) ** 2) + alpha * np.sum(x * x))
        mu, converged, iterations, refresh = 0.0, False, 0, False
        for it in range(1, self.max_iterations + 1):
            iterations = it
            jtj, g = normal(jac, resid)
            g = g - alpha * x
            a = jtj + eye
            while True:
                dx = np.linalg.solve(a + mu * np.diag(np.diag(a)), g)
                x_new = x + dx
                f_new, jac_new = self._model(x_new.reshape(c_n, 2) * self.span[:, None],
                                             step if refresh else None)
                resid_new = y - f_new
                cost_new = float(np.sum((resid_new * w) ** 2) + alpha * np.sum(x_new * x_new))
                if cost_new <= cost * (1.0 + 1e-12) or mu > 1e8:
                    break
                mu = max(1e-3, 10.0 * mu)
            x, f, resid, cost = x_new, f_new, resid_new, cost_new
            if jac_new is not None:
                jac = jac_new
            mu = 0.0 if mu < 1e-2 else mu / 10.0
            if float(dx @ a @ dx) < self.tolerance:
                converged = True
                break
            # a fresh Jacobian while the steps are large, else the last one (chord steps)
            refresh = float(np.max(np.abs(dx))) > REFRESH_STEP
        jtj, _ = normal(jac, resid)
        a_inv = np.linalg.inv(jtj + alpha * np.eye(2 * c_n))
        cov_x = a_inv @ jtj @ a_inv
        force = x.reshape(c_n, 2) * self.span[:, None]
        moduli = [setup.modulus for setup in arr.cilia]
        cov_scale = array_scale_covariance(force, moduli)
        cov = cov_x * np.outer(scale, scale) + cov_scale
        sigma = np.sqrt(np.diag(cov)).reshape(c_n, 2)
        mag = np.hypot(force[:, 0], force[:, 1])
        direction = np.arctan2(force[:, 1], force[:, 0])
        blocks = cov.reshape(c_n, 2, c_n, 2)[np.arange(c_n), :, np.arange(c_n), :]  # (C, 2, 2)
        with np.errstate(invalid="ignore", divide="ignore"):
            u = np.where(mag[:, None] > 0.0, force / np.where(mag > 0, mag, 1.0)[:, None],
                         np.array([1.0, 0.0]))
            perp = np.stack([-u[:, 1], u[:, 0]], axis=1)
            s_mag = np.sqrt(np.einsum("ci,cij,cj->c", u, blocks, u))
            s_dir = np.where(mag > 0.0, np.sqrt(np.einsum("ci,cij,cj->c", perp, blocks, perp))
                             / np.where(mag > 0, mag, 1.0), np.inf)
        flags = np.zeros(c_n, dtype=np.uint8)
        flags[mag > self.span * (1.0 + 1e-9)] |= np.uint8(ArrayFlag.BEYOND_SPAN)
        if sat.any():
            informed = np.abs(self.jacobian[sat] / arr.sigma.reshape(-1)[sat, None]) \
                * scale[None, :] >= 1.0
            hit = informed.reshape(-1, c_n, 2).any(axis=(0, 2))
            flags[hit] |= np.uint8(ArrayFlag.SATURATED)
        if not converged:
            flags |= np.uint8(ArrayFlag.NOT_CONVERGED)
        out = [force, sigma, mag, s_mag, direction, s_dir, cov, flags, cov_scale]
        for item in out:
            item.setflags(write=False)
        return ArrayEstimate(arr.names, force, sigma, mag, s_mag, direction, s_dir, cov, flags,
                             self.span.copy(), iterations, converged,
                             float(np.sum((resid * w) ** 2)), int(np.count_nonzero(w)),
                             cov_scale, scale_notes(moduli))

    def sigma_at_rest(self) -> F64:
        """1-σ force per site at rest in the worst direction, N, shape (C,): the square root of
        the largest eigenvalue of each cilium's 2 × 2 block of the inverse's covariance at zero
        load (the minimum detectable force at SNR 1)."""
        arr = self.array
        c_n = len(arr)
        scale = np.repeat(self.span, 2)
        jw = self.jacobian / arr.sigma.reshape(-1)[:, None] * scale[None, :]
        jtj = jw.T @ jw
        a_inv = np.linalg.inv(jtj + self.regularization * np.eye(2 * c_n))
        cov = (a_inv @ jtj @ a_inv) * np.outer(scale, scale)
        blocks = cov.reshape(c_n, 2, c_n, 2)[np.arange(c_n), :, np.arange(c_n), :]
        return np.asarray(np.sqrt(np.linalg.eigvalsh(blocks)[:, -1]), dtype=np.float64)

    # -- protocol ---------------------------------------------------------------------------------
    def to_dict(self) -> dict[str, Any]:
        """JSON-ready summary (SI): the spans, the tables' errors and the crosstalk."""
        return {"cilia": len(self.array), "sensors": self.array.n_sensors,
                "span_N": self.span.tolist(), "table_size": self.table_size,
                "regularization": self.regularization, "table_error_T": self.table_error.tolist(),
                "crosstalk": self.crosstalk().to_dict()}

    def report(self) -> str:
        """A few lines in display units."""
        ct = self.crosstalk()
        return (f"array read-out: {len(self.array)} cilia over {self.array.n_sensors} sensors, "
                f"span {si(float(self.span.max()), 'N')}, {len(self.tables)} table(s) of "
                f"{self.table_size} loads (error ≤ {si(float(self.table_error.max()), 'T')} at a "
                f"sensor); crosstalk ratio median {number(float(np.median(ct.ratio)))}, largest "
                f"{number(float(ct.ratio.max()))}; minimum detectable force median "
                f"{si(float(np.median(self.sigma_at_rest())), 'N')}")

    def _display_items(self) -> list[Item]:
        return [("cilia", str(len(self.array))), ("sensors", str(self.array.n_sensors)),
                ("span", si(float(self.span.max()), "N")),
                ("table error", si(float(self.table_error.max()), "T"))]


# -- design metrics vs pitch -----------------------------------------------------------------------

@dataclass(frozen=True, eq=False, repr=False)
class ArrayMetrics(Display):
    """Crosstalk and minimum detectable force of regular arrays against their pitch (SI).

    Attributes
    ----------
    pitches : ndarray, shape (P,)
        m.
    ratio : ndarray, shape (P, C)
        Crosstalk ratio of each cilium (:class:`Crosstalk`).
    minimum : ndarray, shape (P, C)
        Minimum detectable force per site, N (:meth:`ArrayReadout.sigma_at_rest`).
    isolated : float
        The minimum detectable force of one cilium alone over its sensor, N.
    names : tuple of str
        Cilium names.
    """

    pitches: F64
    ratio: F64
    minimum: F64
    isolated: float
    names: tuple[str, ...]

    def table(self) -> list[dict[str, Any]]:
        """One row per pitch (SI): the crosstalk ratio (median, largest) and the minimum
        detectable force (median, largest) over the sites."""
        return [{"pitch_m": float(p), "ratio_median": float(np.median(r)),
                 "ratio_max": float(r.max()), "minimum_median_N": float(np.median(m)),
                 "minimum_max_N": float(m.max()), "minimum_isolated_N": self.isolated}
                for p, r, m in zip(self.pitches, self.ratio, self.minimum, strict=True)]

    def to_dict(self) -> dict[str, Any]:
        """JSON-ready content (SI)."""
        return {"pitch_m": self.pitches.tolist(), "ratio": self.ratio.tolist(),
                "minimum_N": self.minimum.tolist(), "minimum_isolated_N": self.isolated,
                "names": list(self.names), "table": self.table()}

    def to_dataframe(self) -> Any:
        """One row per pitch, SI columns (:meth:`table`)."""
        rows = self.table()
        return dataframe({key: [r[key] for r in rows] for key in rows[0]})

    def report(self) -> str:
        """The table in display units (mm, mN)."""
        lines = [(f"array metrics vs pitch ({len(self.names)} cilia; one cilium alone: minimum "
                 f"detectable force {self.isolated * 1e3:.4g} mN)"),
                 (f"{'pitch mm':>9} {'ratio med':>10} {'ratio max':>10} {'min mN med':>11} "
                 f"{'min mN max':>11}")]
        for r in self.table():
            lines.append(f"{r['pitch_m'] * 1e3:>9.4g} {r['ratio_median']:>10.4g} "
                         f"{r['ratio_max']:>10.4g} {r['minimum_median_N'] * 1e3:>11.4g} "
                         f"{r['minimum_max_N'] * 1e3:>11.4g}")
        return "\n".join(lines)

    def _display_items(self) -> list[Item]:
        return [("pitches", f"{self.pitches.min() * 1e3:.3g}…{self.pitches.max() * 1e3:.3g} mm"),
                ("cilia", str(len(self.names))),
                ("largest ratio", number(float(self.ratio.max())))]

    def _display_table(self) -> Table | None:
        return rows_table(self.table())


def array_metrics(setup: Setup, pitches: ArrayLike, *, sensor: Magnetometer, span: float,
                  rows: int = 4, cols: int = 4, depth: float | None = None,
                  table_size: int = 17) -> ArrayMetrics:
    """Crosstalk ratio and minimum detectable force per site of rows × cols arrays of ``setup``
    with one ``sensor`` under each cilium (:meth:`CiliaArray.grid`), against the pitch.

    Parameters
    ----------
    setup : Setup
        The cilium.
    pitches : array-like, shape (P,)
        m (each large enough for the cilia not to touch at ``span``).
    sensor : Magnetometer
        The part under each cilium.
    span : float
        Largest horizontal tip force, N.
    rows, cols : int
        Array size (default 4 × 4).
    depth : float, optional
        Sensing points below the bases, m (see :meth:`CiliaArray.grid`).
    table_size : int
        Loads tabulated over the span (the metrics need the model at rest only).
    """
    p = v.finite_array("pitches", pitches, ndim=1, unit="m")
    if p.size == 0 or np.any(p <= 0.0):
        raise v.fail("pitches", pitches, "positive pitches in m")
    ratio, minimum = [], []
    names: tuple[str, ...] = ()
    for pitch in p.tolist():
        arr = CiliaArray.grid(setup, rows, cols, pitch, sensor=sensor, depth=depth)
        ro = ArrayReadout(arr, span, table_size=table_size)
        ratio.append(ro.crosstalk().ratio)
        minimum.append(ro.sigma_at_rest())
        names = arr.names
    alone = ArrayReadout(CiliaArray.grid(setup, 1, 1, float(p[0]), sensor=sensor, depth=depth),
                         span, table_size=table_size)
    out_r, out_m = np.array(ratio), np.array(minimum)
    for arr_ in (p, out_r, out_m):
        arr_.setflags(write=False)
    return ArrayMetrics(p, out_r, out_m, float(alone.sigma_at_rest()[0]), names)


__all__ = ["ArrayEstimate", "ArrayFlag", "ArrayMetrics", "ArrayReadout", "Crosstalk",
           "LoadTable", "array_metrics", "field_for_loads", "loaded_poses"]
