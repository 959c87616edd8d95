"""The read-out of an array of cilia: :class:`ArrayReadout` (forward map, crosstalk, inverse).

See :mod:`magcilia.readout.array` for the model, the crosstalk, the inverse and the checks. On the
read-out protocol (:mod:`magcilia.readout.protocol`): ``inputs`` are every sensor's three axes
(``NAME.x``, ``NAME.y``, ``NAME.z``) in the array's sensor order, ``rest`` (3 S,) T,
``read(samples)`` of shape (n, 3 S) gives :class:`~magcilia.readout.array_results.ArrayEstimates`
(``value`` and ``sigma`` (n, C, 2), ``flags`` (n, C), ``unit`` ``"N"``; n samples fitted at once
by :func:`magcilia.fitting.fit_batch`), one set (3 S,) or (S, 3) an
:class:`~magcilia.readout.array_results.ArrayEstimate`; ``tare(baseline)`` a copy holding one
:class:`~magcilia.readout.tare.Tare` (unit T).
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Any

import numpy as np
from numpy.typing import ArrayLike, NDArray

from magcilia import _validate as v
from magcilia._display import Display, Item, number, si
from magcilia.device.array import CiliaArray
from magcilia.device.stiffness import Modulus
from magcilia.model.array import segment_field
from magcilia.model.array_tabulated import TabulatedArray, table_field
from magcilia.readout.array_checks import check_reach, check_singular
from magcilia.readout.array_inverse import BOUND, FIT_XTOL, REFRESH_STEP, solve
from magcilia.readout.array_model import LoadTable, checked_forces, load_table
from magcilia.readout.array_results import ArrayEstimate, ArrayEstimates, Crosstalk
from magcilia.readout.array_stream import ArrayStream
from magcilia.readout.protocol import FLAG_DTYPE, Flag, tare_flags
from magcilia.readout.scale import array_scale_blocks, array_scale_covariance, scale_notes
from magcilia.readout.tare import Tare

F64 = NDArray[np.float64]

#: forward-difference step of the inverse's Jacobian, as a fraction of the span, before issue 27
#: (the inverse's Jacobian is analytic now: :mod:`magcilia.model.array_tabulated`); kept for
#: the names importable from :mod:`magcilia.readout.array`
JACOBIAN_STEP = 1e-6
#: central-difference step of the crosstalk matrix, as a fraction of the span
CROSSTALK_STEP = 1e-4
#: samples per block of :meth:`ArrayReadout.read` (the cached Jacobians stay small; each block
#: starts warm from the last frame of the one before)
BLOCK = 32
__all__ = ["BLOCK", "BOUND", "CROSSTALK_STEP", "FIT_XTOL", "JACOBIAN_STEP", "REFRESH_STEP",
           "ArrayReadout"]


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
        Least-squares iterations at most (per sample).
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
    rest : ndarray, shape (3 S,)
        The field at rest on the sensors' axes, T, sensor after sensor (x, y, z each): the
        reading of :attr:`inputs` at rest (the read-out protocol's shape; it was (S, 3)).
    baseline : Tare or None
        The tare (:meth:`tare`).
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
    baseline: Tare | None
    _scale: tuple[tuple[Modulus, ...], str]
    _model: tuple[TabulatedArray, TabulatedArray]

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
                tables.append(load_table(*key, size))
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
        moduli = tuple(setup.modulus for setup in array.cilia)  # the force scale, made once
        set_(self, "_scale", (moduli, scale_notes(moduli)))
        lay = array.layout
        cols = []
        for setup in array.cilia:
            n = setup.n_loops
            cols.append(np.searchsorted(lay.s_query, setup.cilium.height * (np.arange(n) + 0.5)
                                        / n))
        set_(self, "columns", tuple(cols))
        set_(self, "_model", self._tabulated())
        zero = np.zeros((len(array), 2))
        rest = self._fields(zero[None])[0].sum(axis=0)
        set_(self, "rest", array.to_sensor(rest).reshape(-1))
        set_(self, "baseline", None)
        set_(self, "jacobian", self._crosstalk_matrix())
        set_(self, "table_error", self._table_error())
        check_reach(self)
        check_singular(self)

    # -- the forward model ------------------------------------------------------------------------
    def _tabulated(self) -> tuple[TabulatedArray, TabulatedArray]:
        """The forward map as plain arrays for the fused kernel: on the sensors' axes and in
        the board frame."""
        arr, lay = self.array, self.array.layout
        n = max(t.slices for t in self.tables)
        coef = np.zeros((len(self.tables), 4, 2 * self.table_size - 2, 3 * n))
        for k, t in enumerate(self.tables):
            coef[k, :, :, :t.coefficients.shape[2]] = t.coefficients
        local = np.concatenate([np.searchsorted(self.columns[c], lay.slot[j0:j1])
                                for c, (j0, j1) in enumerate(zip(lay.starts[:-1], lay.starts[1:],
                                                                 strict=True))])
        parts = {"observers": np.asarray(arr.sensor_positions, dtype=np.float64),
                 "bases": lay.bases, "starts": lay.starts, "local": local.astype(np.int64),
                 "ring_cos": lay.ring_cos, "ring_sin": lay.ring_sin, "moment": lay.moment,
                 "kind": self.kinds, "slices": np.array([t.slices for t in self.tables],
                                                        dtype=np.int64)[self.kinds],
                 "coefficients": coef, "span": np.array([t.span for t in self.tables]),
                 "step": np.array([t.step for t in self.tables])}
        parts = {k: np.ascontiguousarray(a) for k, a in parts.items()}
        rot = np.ascontiguousarray(arr.rotations, dtype=np.float64)
        board = np.ascontiguousarray(np.broadcast_to(np.eye(3), rot.shape))
        return TabulatedArray(rotations=rot, **parts), TabulatedArray(rotations=board, **parts)

    def _frames(self, force: F64) -> tuple[F64, F64, F64, F64]:
        """x, z, θ (..., C, q) of every cilium at force vectors (..., C, 2), and the azimuths
        (..., C)."""
        lay = self.array.layout
        q = lay.s_query.size
        mag = np.hypot(force[..., 0], force[..., 1])
        phi = np.arctan2(force[..., 1], force[..., 0])
        x, z, th = (np.zeros((*mag.shape, q)) for _ in range(3))
        cols = self.columns
        for kind, table in enumerate(self.tables):
            members = np.nonzero(self.kinds == kind)[0]
            fx, fz, fth = (a.reshape(*mag.shape[:-1], members.size, -1)
                           for a in table.frames(mag[..., members].reshape(-1)))
            where = (..., members[:, None], cols[members[0]][None, :])  # a kind shares slices
            x[where], z[where], th[where] = fx, fz, fth
        return x, z, th, phi

    def _fields(self, forces: F64) -> F64:
        """Each cilium's field (board frame, T) at the sensors for ``b`` sets of force vectors
        (b, C, 2), N: shape (b, C, S, 3), one kernel call."""
        lay = self.array.layout
        n = len(forces)
        pos, mom = lay.planar_dipoles(*self._frames(forces))  # (b, D, 3)
        d = lay.size
        starts = np.concatenate([(lay.starts[:-1] + i * d) for i in range(n)]
                                + [[n * d]]).astype(np.int64)
        out = segment_field(np.asarray(self.array.sensor_positions), pos.reshape(-1, 3),
                            mom.reshape(-1, 3), starts)
        return out.reshape(n, len(self.array), -1, 3)

    def field(self, forces: ArrayLike) -> F64:
        """Field at every sensor (T, board frame, shape (S, 3)) with every cilium bent by its
        horizontal force ((C, 2), N), from the tables
        (:func:`~magcilia.readout.array_model.field_for_loads` solves exactly)."""
        f = checked_forces(self.array, forces)
        if f.shape[1] == 3 and np.any(f[:, 2] != 0.0):
            raise v.fail("forces", "a vertical component", "horizontal forces (C, 2) for the "
                         "tables (field_for_loads solves loads with Fz)")
        field, _ = table_field(self._model[1], f[None, :, :2])
        return field.reshape(-1, 3)

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

    # -- the read-out protocol (:class:`~magcilia.readout.protocol.SensorReadout`) ----------------
    @property
    def inputs(self) -> tuple[str, ...]:
        """What one sample holds, in order: every sensor's three axes, ``NAME.x``, ``NAME.y``,
        ``NAME.z``, in the array's sensor order (names made unique by their number where two
        sensors share one)."""
        names = [s.name for s in self.array.sensors]
        if len(set(names)) < len(names):
            names = [f"{n} {i + 1}" for i, n in enumerate(names)]
        return tuple(f"{n}.{axis}" for n in names for axis in "xyz")

    @property
    def sigma(self) -> F64:
        """Noise of one reading per input, T, (3 S,): the tare's measured spread if tared, else
        the sensors' noise and quantisation (:attr:`CiliaArray.sigma`)."""
        if self.baseline is not None:
            return np.asarray(self.baseline.noise, dtype=np.float64)
        return np.asarray(self.array.sigma.reshape(-1), dtype=np.float64)

    def tare(self, baseline: ArrayLike, /) -> ArrayReadout:
        """A copy whose zero is the mean of unloaded readings ``baseline`` (T, shape (n, 3 S) or
        (n, S, 3), at least 2 finite per input; NaN skipped): every reading gets ``rest − mean``
        added per input (a constant field offset, the earth's or a magnet's, cancels), the
        baseline's spread replaces the sensors' stated noise, and its standard error (shared by
        all readings) enters the covariance."""
        x = np.asarray(baseline, dtype=np.float64)
        c = self.rest.size
        if x.ndim >= 2 and x.shape[-2:] == (self.array.n_sensors, 3):
            x = x.reshape(*x.shape[:-2], c)
        if x.ndim == 0 or x.shape[-1] != c:
            raise v.fail("baseline", f"an array of shape {x.shape}",
                         f"shape (n, {c}): unloaded samples of every sensor axis, T")
        tare = Tare.from_readings(x.reshape(-1, c), self.rest, unit="T", names=self.inputs)
        new = object.__new__(ArrayReadout)
        for f in self.__dataclass_fields__:
            object.__setattr__(new, f, getattr(self, f))
        object.__setattr__(new, "baseline", tare)
        return new

    # -- inverse ----------------------------------------------------------------------------------
    def read(self, readings: ArrayLike, /, *, noise: ArrayLike | None = None,
             start: ArrayLike | None = None) -> ArrayEstimate | ArrayEstimates:
        """Every cilium's horizontal force vector from the sensors' readings.

        Parameters
        ----------
        readings : array-like
            Each sensor's reading on its own axes, T (:meth:`CiliaArray.readings`): one set,
            shape (3 S,) or (S, 3), gives an :class:`ArrayEstimate`; n sets, shape (n, 3 S)
            (the read-out protocol: :attr:`inputs` per row), give :class:`ArrayEstimates`, all
            fitted at once (with one sensor, (1, 3) is one sample of the protocol). A tare's
            correction is added first; NaN readings are left out (flag MISSING on the cilia
            they inform), saturated ones too (SATURATED).
        noise : float or array-like, shape (3 S,), optional
            RMS noise of one reading per input, T, measured; replaces the tare's spread or the
            sensors' stated noise (:attr:`sigma`) as the weights and for the covariance.
        start : array-like, shape (C, 2), optional
            The forces of the frame before, N (a stream's last estimate, ``est.force[-1]``):
            the first frame starts warm from there (:mod:`magcilia.readout.array_inverse`),
            else cold, from the linear solution about rest. The frames are taken in order of
            time: each block of :data:`BLOCK` frames starts warm from the last estimate of the
            block before. The start changes the work, not the estimates (they agree to the
            fit's tolerance).
        """
        arr = self.array
        c = self.rest.size
        try:
            y = np.array(readings, dtype=np.float64)
        except (TypeError, ValueError):
            raise v.fail("readings", v.short(readings), "numbers, T") from None
        one = y.ndim == 1 or (y.shape == (arr.n_sensors, 3) and arr.n_sensors > 1)
        if one:
            y = y.reshape(1, -1)
        if y.ndim != 2 or y.shape[1] != c:
            raise v.fail("readings", f"an array of shape {np.shape(readings)}",
                         f"shape ({c},) or ({arr.n_sensors}, 3) for one set, or (n, {c}) for n "
                         "sets: each sensor's three axes, T")
        sigma = self.sigma
        if noise is not None:
            given = v.finite_array("noise", noise, unit="T").reshape(-1)
            if given.size not in (1, c) or np.any(given <= 0.0):
                raise v.fail("noise", v.short(noise),
                             f"a positive RMS noise per input ({c} of them, or one), T")
            sigma = np.broadcast_to(given, (c,)).copy()
        missing = ~np.isfinite(y)
        saturated = arr.saturated(np.where(missing, 0.0, y).reshape(-1, arr.n_sensors, 3))
        saturated = saturated.reshape(y.shape) & ~missing
        weight = np.where(missing | saturated, 0.0, 1.0 / sigma)
        if self.baseline is not None:
            y = y + self.baseline.correction
        y = np.where(missing, 0.0, y)
        x_s = None
        if start is not None:
            f0 = v.finite_array("start", start, unit="N")
            if f0.shape != (len(arr), 2):
                raise v.fail("start", f"an array of shape {f0.shape}",
                             f"forces of shape ({len(arr)}, 2), N: the frame before's")
            x_s = (f0 / self.span[:, None]).reshape(-1)
        parts = []
        for i in range(0, y.shape[0], BLOCK):
            part = self._solve(y[i:i + BLOCK], weight[i:i + BLOCK], one, x_s)
            parts.append(part)
            last = part["force"][-1] / self.span[:, None]
            x_s = last.reshape(-1) if part["converged"][-1] and np.all(
                np.abs(last) < BOUND) else None  # else the next block starts cold
        out = ({k: np.concatenate([p[k] for p in parts]) for k in parts[0]} if parts
               else self._empty())
        flags = out["flags"]
        flags |= FLAG_DTYPE(tare_flags(self.baseline))  # a tare taken under load
        for bad, flag in ((saturated, Flag.SATURATED), (missing, Flag.MISSING)):
            if bad.any():  # the cilia a left-out reading informs (≥ 1 σ over the span)
                informed = np.abs(self.jacobian / sigma[:, None]) * np.repeat(self.span, 2) >= 1.0
                hit = (bad.astype(np.float64) @ informed).reshape(len(y), -1, 2).any(axis=2)
                flags |= hit.astype(FLAG_DTYPE) * FLAG_DTYPE(flag)
        for item in out.values():
            item.setflags(write=False)
        if one:
            return ArrayEstimate(arr.names, out["force"][0], out["sigma"][0],
                                 out["magnitude"][0], out["sigma_magnitude"][0],
                                 out["direction"][0], out["sigma_direction"][0],
                                 out["covariance"][0], flags[0], self.span.copy(),
                                 int(out["iterations"][0]), bool(out["converged"][0]),
                                 float(out["chi2"][0]), int(out["used"][0]),
                                 out["covariance_scale"][0], self._scale[1])
        return ArrayEstimates(arr.names, out["force"], out["sigma"], out["magnitude"],
                              out["sigma_magnitude"], out["direction"], out["sigma_direction"],
                              out["covariance"], out["covariance_scale"], flags,
                              self.span.copy(), out["iterations"], out["converged"],
                              out["chi2"], out["used"], self._scale[1])

    def read_one(self, readings: ArrayLike, /, *, noise: ArrayLike | None = None
                 ) -> ArrayEstimate:
        """:meth:`read` of one set of readings, (3 S,) or (S, 3), T: its
        :class:`ArrayEstimate` (the full covariance), typed as such."""
        y = np.asarray(readings, dtype=np.float64)
        if y.size != self.rest.size:
            raise v.fail("readings", f"an array of shape {y.shape}",
                         f"shape ({self.rest.size},) or ({self.array.n_sensors}, 3): one set")
        out = self.read(y.reshape(-1), noise=noise)
        assert isinstance(out, ArrayEstimate)
        return out

    def stream(self) -> ArrayStream:
        """This read-out over a stream of frames: an :class:`ArrayStream`, whose ``read``
        starts every call warm from the last estimate of the call before (a live array)."""
        return ArrayStream(self)

    def _empty(self) -> dict[str, Any]:
        """:meth:`_solve`'s arrays for no samples."""
        c_n = len(self.array)
        return {"force": np.zeros((0, c_n, 2)), "sigma": np.zeros((0, c_n, 2)),
                **{k: np.zeros((0, c_n)) for k in ("magnitude", "sigma_magnitude", "direction",
                                                    "sigma_direction")},
                "covariance": np.zeros((0, c_n, 2, 2)),
                "covariance_scale": np.zeros((0, c_n, 2, 2)),
                "flags": np.zeros((0, c_n), dtype=FLAG_DTYPE),
                "iterations": np.zeros(0, dtype=np.int64), "converged": np.zeros(0, dtype=bool),
                "chi2": np.zeros(0), "used": np.zeros(0, dtype=np.int64)}

    def _solve(self, y: F64, w: F64, full: bool, start: F64 | None) -> dict[str, Any]:
        """Fit readings ``y`` (n, 3 S), T (tare applied), with weights ``w`` (n, 3 S) (1/σ, 0
        for a reading left out), from ``start`` (2 C,) (F / span of the frame before) or cold:
        the estimates of :meth:`read` as arrays with a leading n (the covariance (n, 2C, 2C)
        if ``full``, else its (n, C, 2, 2) blocks)."""
        n, c_n = y.shape[0], len(self.array)
        p = 2 * c_n
        scale = np.repeat(self.span, 2)  # x = F / span
        alpha = self.regularization
        fit, jw = solve(self._model[0], self.span, alpha, y, w, start, self.max_iterations,
                        self.tolerance)
        x, a, converged = np.asarray(fit.x), np.asarray(fit.jtj), np.asarray(fit.converged)
        a_inv = np.linalg.inv(a)
        # covariance of x: A⁻¹ JᵀWJ A⁻¹ = A⁻¹ − α A⁻², and a tare's shared error G S Gᵀ
        tare_var = np.zeros(y.shape[1]) if self.baseline is None else np.asarray(
            self.baseline.standard_error) ** 2
        gain = None
        if np.any(tare_var > 0.0):
            gain = a_inv @ (jw * w[:, :, None]).transpose(0, 2, 1)  # (n, p, 3S)
        force = x.reshape(n, c_n, 2) * self.span[:, None]
        moduli = self._scale[0]
        if full:
            cov_x = a_inv - alpha * (a_inv @ a_inv)
            if gain is not None:
                cov_x = cov_x + (gain * tare_var) @ gain.transpose(0, 2, 1)
            cov_scale = array_scale_covariance(force, moduli)
            cov = cov_x * np.outer(scale, scale) + cov_scale
            idx = np.arange(c_n)
            blocks = cov.reshape(n, c_n, 2, c_n, 2)[:, idx, :, idx, :].transpose(1, 0, 2, 3)
            covariance, covariance_scale = cov, cov_scale
        else:
            rows_ = a_inv.reshape(n, c_n, 2, p)
            cols_ = a_inv.reshape(n, p, c_n, 2)
            sq = np.einsum("ncik,nkcj->ncij", rows_, cols_)
            cov_b = a_inv.reshape(n, c_n, 2, c_n, 2)[:, np.arange(c_n), :, np.arange(c_n), :]
            cov_b = cov_b.transpose(1, 0, 2, 3) - alpha * sq
            if gain is not None:
                g = gain.reshape(n, c_n, 2, -1)
                cov_b = cov_b + np.einsum("ncis,s,ncjs->ncij", g, tare_var, g)
            span2 = self.span[:, None, None] ** 2
            covariance_scale = array_scale_blocks(force, moduli)
            blocks = covariance = cov_b * span2 + covariance_scale
        sig = np.sqrt(np.clip(np.diagonal(blocks, axis1=-2, axis2=-1), 0.0, None))
        mag = np.hypot(force[..., 0], force[..., 1])
        direction = np.arctan2(force[..., 1], force[..., 0])
        with np.errstate(invalid="ignore", divide="ignore"):
            safe = np.where(mag > 0.0, mag, 1.0)
            u = np.where(mag[..., None] > 0.0, force / safe[..., None], np.array([1.0, 0.0]))
            perp = np.stack([-u[..., 1], u[..., 0]], axis=-1)
            s_mag = np.sqrt(np.einsum("nci,ncij,ncj->nc", u, blocks, u))
            s_dir = np.where(mag > 0.0, np.sqrt(np.einsum("nci,ncij,ncj->nc", perp, blocks,
                                                          perp)) / safe, np.inf)
        flags = np.zeros((n, c_n), dtype=FLAG_DTYPE)
        flags[mag > self.span * (1.0 + 1e-9)] |= FLAG_DTYPE(Flag.ABOVE_SPAN)
        flags[~converged] |= FLAG_DTYPE(Flag.NOT_CONVERGED)
        return {"force": force, "sigma": sig, "magnitude": mag, "sigma_magnitude": s_mag,
                "direction": direction, "sigma_direction": s_dir, "covariance": covariance,
                "covariance_scale": covariance_scale, "flags": flags,
                "iterations": fit.iterations.astype(np.int64), "converged": converged.copy(),
                "chi2": fit.cost - alpha * np.einsum("np,np->n", x, x),
                "used": np.count_nonzero(w, axis=1).astype(np.int64)}

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
