"""Fast evaluation of many parameter sets at once, for optimisers and global sensitivity analysis.

No input checks: the caller keeps the parameters physical (positive lengths, n and k ≥ 1, the
sensing element outside the cilium). A set that puts the element on a dipole gives non-finite
values in its row (no error, no warning from the compiled kernel). Shape letters: ``N`` parameter
sets, ``a`` tilt angles.

:class:`TiltBatch` holds what depends only on the setup and the angles; each call packs the
parameters into one array (:func:`pack`, columns :data:`magcilia.model.compiled.COLUMNS`) and runs
one compiled kernel for all sets (:func:`magcilia.model.compiled.tilt_batch`: layout, field and
output fused, no grouping). Without numba, the NumPy reference runs instead: the sets grouped by
(n, k), each group one vectorised :func:`~magcilia.model.layout.ring_layout` and
:func:`~magcilia.model.kernels.tilt_field`.
"""

from __future__ import annotations

import math
from collections.abc import Mapping

import numpy as np
from numpy.typing import ArrayLike, NDArray

from magcilia.model import body, compiled
from magcilia.model.batch_jacobian import jacobian_numpy
from magcilia.model.kernels import tilt_field
from magcilia.model.layout import ring_layout
from magcilia.model.spec import ModelSpec, SupportsSpec, as_spec

F64 = NDArray[np.float64]

#: the parameters of :meth:`TiltBatch.output_jacobian` and :meth:`TiltBatch.field_jacobian`,
#: in the order of their last axis
JACOBIAN_NAMES = ("height", "base_radius", "x", "y", "z", "magnetization_scale")


#: the parameter names of :func:`pack`, in the order of its columns
#: (:data:`magcilia.model.compiled.COLUMNS`)
KEYS = ("height", "base_radius", "tip_radius", "x", "y", "z", "n_loops", "dipoles_per_loop",
        "magnetization_scale", "offset")


def pack(spec: ModelSpec, params: Mapping[str, ArrayLike]) -> F64:
    """Parameter sets as the kernels' array, shape (N, len(COLUMNS)), SI.

    Parameters
    ----------
    spec : ModelSpec
        Supplies every parameter missing from ``params``, the sensor depth and the material.
    params : mapping of str to array-like, each shape (N,) or scalar
        Any of the spec's :meth:`~magcilia.model.spec.ModelSpec.params` keys: ``height``,
        ``base_radius``, ``tip_radius``, ``x``, ``y``, ``z`` (m), ``n_loops``,
        ``dipoles_per_loop`` (rounded to integers), ``magnetization_scale`` and ``offset`` (V).
        N is the largest size among them (1 if none is given).
    """
    sizes = {np.size(val) for val in params.values()}
    out = np.empty((max(sizes) if sizes else 1, len(compiled.COLUMNS)))
    defaults = spec.params()
    for j, key in enumerate(KEYS):
        out[:, j] = params.get(key, defaults[key])
    return _finish(spec, out)


def pack_rows(spec: ModelSpec, columns: NDArray[np.intp], rows: F64,
              template: F64 | None = None) -> F64:
    """:func:`pack` of parameter rows (N, c) whose columns are the :data:`KEYS` at positions
    ``columns`` (c,), the others the spec's (or ``template``'s, (len(KEYS),): the spec's values
    in that order, kept by a caller that packs often): one step per call, not one per name
    (optimisers call it once per iteration)."""
    if template is None:
        defaults = spec.params()
        template = np.array([defaults[key] for key in KEYS], dtype=np.float64)
    out = np.empty((rows.shape[0], template.size))
    out[:] = template
    out[:, columns] = rows
    return _finish(spec, out)


def _finish(spec: ModelSpec, out: F64) -> F64:
    """The packed columns from the named values: taper, base height above the element, whole
    n and k, magnetization in A/m."""
    out[:, 2] /= out[:, 1]  # taper = tip / base radius
    out[:, 5] += spec.depth  # base centre height above the element
    np.rint(out[:, 6:8], out=out[:, 6:8])
    out[:, 8] *= spec.full_magnetization
    return out


def evaluate(spec: ModelSpec, packed: F64, angles: F64, out: F64, measured: bool) -> bool:
    """Fill ``out`` (N, a, 1) with outputs (V) or (N, a, 3) with fields (T) of the ``packed`` sets
    (N, len(COLUMNS)) at ``angles`` (a,), rad; return whether all are finite.

    ``measured`` uses the spec's shape for every set (its height and base radius scaled), else each
    set's frustum of its taper. Compiled when numba is available, else the NumPy reference. The
    arrays must be float64 and C-contiguous (``out`` writable)."""
    jit = compiled.kernels()
    if jit is not None:
        return bool(jit.tilt_batch(packed, angles, spec.knots, spec.radii, measured,
                                   spec.ring == "rms", spec.scale, out))
    with np.errstate(divide="ignore", invalid="ignore", over="ignore"):  # returned as non-finite
        _evaluate_numpy(spec, packed, angles, out, measured)
    return bool(np.isfinite(out).all())


def evaluate_jacobian(spec: ModelSpec, packed: F64, angles: F64, out: F64, jac: F64,
                      measured: bool) -> bool:
    """:func:`evaluate`, and the derivatives of ``out`` with respect to the columns
    :data:`~magcilia.model.compiled.JACOBIAN_COLUMNS` into ``jac`` (N, a, c, 6), in one pass;
    return whether all values and derivatives are finite. Compiled when numba is available, else
    the NumPy reference (:func:`magcilia.model.batch_jacobian.jacobian_numpy`)."""
    jit = compiled.kernels()
    if jit is not None:
        return bool(jit.tilt_jacobian_batch(packed, angles, spec.knots, spec.radii, measured,
                                            spec.ring == "rms", spec.scale, out, jac))
    with np.errstate(divide="ignore", invalid="ignore", over="ignore"):
        jacobian_numpy(spec, packed, angles, out, jac, measured)
    return bool(np.isfinite(out).all() and np.isfinite(jac).all())


def _evaluate_numpy(spec: ModelSpec, packed: F64, angles: F64, out: F64, measured: bool) -> None:
    """:func:`evaluate` in NumPy, the sets grouped by (n, k)."""
    h, rb, taper, x, y, z, nl, kd, mag, offset = packed.T
    base = np.stack([x, y, z], axis=-1)
    u, rho = (spec.knots, spec.radii) if measured else body.frustum_shape(taper)
    moment = mag * math.pi * h * rb * rb * body.mean_square_radius(u, rho)
    cos_t, sin_t = np.cos(angles), np.sin(angles)
    x_only = out.shape[2] == 1
    keys = nl * 100_003 + kd
    for key in np.unique(keys):
        sel = np.nonzero(keys == key)[0]
        n, k = int(nl[sel[0]]), int(kd[sel[0]])
        pos, w = ring_layout(h[sel], rb[sel], u, rho if rho.ndim == 1 else rho[sel], n, k,
                             spec.ring)
        bx, by, bz = tilt_field(cos_t, sin_t, -base[sel], pos, w * moment[sel, None], x_only)
        if x_only:
            out[sel, :, 0] = spec.scale * bx + offset[sel, None]
        else:
            out[sel] = np.stack([bx, by, bz], axis=-1)


class TiltBatch:
    """One setup's model at fixed tilt angles, prepared for many parameter sets (optimisers, Sobol).

    Parameters
    ----------
    setup : Setup or ModelSpec
        Supplies every parameter not given per set (material, sensor depth and scale, ring rule,
        a measured profile).
    angles : array-like, shape (a,)
        Tilt angles, rad.

    Notes
    -----
    The per-set parameters are those of :func:`pack`. With a measured profile, ``height`` and
    ``base_radius`` scale the measured shape and ``tip_radius`` is not used; a frustum setup gives
    each set the frustum of its own tip radius.

    Examples
    --------
    >>> import numpy as np, magcilia as mc
    >>> batch = TiltBatch(mc.Setup.paper(), np.radians([0.0, 30.0, 60.0]))
    >>> batch.output({"x": np.array([1.0e-3, 1.5e-3]), "n_loops": np.array([2, 6])}).shape
    (2, 3)
    """

    def __init__(self, setup: ModelSpec | SupportsSpec, angles: ArrayLike) -> None:
        self.spec = as_spec(setup)
        self.angles = np.array(angles, dtype=np.float64, ndmin=1)
        self.angles.setflags(write=False)
        self._angles = self.angles.copy()  # writable: one kernel specialisation for every caller
        defaults = self.spec.params()
        self._template = np.array([defaults[key] for key in KEYS], dtype=np.float64)

    def output(self, params: Mapping[str, ArrayLike]) -> F64:
        """Sensor output, V, shape (N, a): ``scale · B_x + offset`` of each set (``params`` as in
        :func:`pack`; ``offset`` defaults to the setup's)."""
        packed = pack(self.spec, params)
        out = np.empty((packed.shape[0], self._angles.size, 1))
        evaluate(self.spec, packed, self._angles, out, self.spec.measured)
        return out[..., 0]

    def output_jacobian(self, params: Mapping[str, ArrayLike]) -> tuple[F64, F64]:
        """The output, V, shape (N, a), and its derivatives, shape (N, a, 6), with respect to
        height, base radius, x, y, z (V/m) and the magnetization scale (V)
        (:data:`JACOBIAN_NAMES`), computed in the same pass (a frustum's tip radius held)."""
        packed = pack(self.spec, params)
        out = np.empty((packed.shape[0], self._angles.size, 1))
        jac = np.empty((packed.shape[0], self._angles.size, 1, 6))
        evaluate_jacobian(self.spec, packed, self._angles, out, jac, self.spec.measured)
        jac[..., 5] *= self.spec.full_magnetization
        return out[..., 0], jac[:, :, 0]

    def output_jacobian_rows(self, columns: NDArray[np.intp], rows: F64) -> tuple[F64, F64]:
        """:meth:`output_jacobian` of parameter rows (N, c) whose columns are the :data:`KEYS`
        at positions ``columns`` (:func:`pack_rows`): output (N, a) and derivatives
        (N, a, 6)."""
        packed = pack_rows(self.spec, columns, rows, self._template)
        out = np.empty((packed.shape[0], self._angles.size, 1))
        jac = np.empty((packed.shape[0], self._angles.size, 1, 6))
        evaluate_jacobian(self.spec, packed, self._angles, out, jac, self.spec.measured)
        jac[..., 5] *= self.spec.full_magnetization
        return out[..., 0], jac[:, :, 0]

    def field_jacobian(self, params: Mapping[str, ArrayLike]) -> tuple[F64, F64]:
        """B at the sensing element, T, shape (N, a, 3), and its derivatives, shape
        (N, a, 3, 6), with respect to :data:`JACOBIAN_NAMES` (T/m; T per unit scale)."""
        packed = pack(self.spec, params)
        out = np.empty((packed.shape[0], self._angles.size, 3))
        jac = np.empty((packed.shape[0], self._angles.size, 3, 6))
        evaluate_jacobian(self.spec, packed, self._angles, out, jac, self.spec.measured)
        jac[..., 5] *= self.spec.full_magnetization
        return out, jac

    def field(self, params: Mapping[str, ArrayLike], x_only: bool = False) -> F64:
        """B at the sensing element, T, shape (N, a, 3); with ``x_only`` the other components
        are set to zero."""
        packed = pack(self.spec, params)
        out = np.empty((packed.shape[0], self._angles.size, 3))
        evaluate(self.spec, packed, self._angles, out, self.spec.measured)
        if x_only:
            out[..., 1:] = 0.0
        return out


def tilt_field_batch(
    setup: ModelSpec | SupportsSpec, params: Mapping[str, ArrayLike], angles: ArrayLike,
    x_only: bool = False,
) -> F64:
    """B (T) at the sensing element for N parameter sets and a tilt angles: shape (N, a, 3).

    Parameters
    ----------
    setup : Setup or ModelSpec
        Supplies every parameter not given in ``params`` (material, sensor depth, ring rule…).
    params : mapping of str to array-like, each shape (N,)
        Any of ``height``, ``base_radius``, ``tip_radius`` (m), ``x``, ``y``, ``z`` (m, the
        paper's position), ``n_loops``, ``dipoles_per_loop`` (integers) and
        ``magnetization_scale``. Missing keys take the value of ``setup``. With a measured
        profile, ``height`` and ``base_radius`` scale the measured shape and ``tip_radius`` is
        not used.
    angles : array-like, shape (a,)
        Tilt angles, rad.
    x_only : bool
        Fill in only B_x (the other components stay zero).

    Notes
    -----
    A thin wrapper of :class:`TiltBatch`; build one to evaluate the same angles repeatedly.
    """
    return TiltBatch(setup, angles).field(params, x_only)


def tilt_output_batch(
    setup: ModelSpec | SupportsSpec, params: Mapping[str, ArrayLike], angles: ArrayLike
) -> F64:
    """Sensor output (V) for N parameter sets at a tilt angles: shape (N, a).

    As :func:`tilt_field_batch`, plus an optional ``offset`` key (V) in ``params``; the sensor's
    scale (V/T) comes from ``setup``. A thin wrapper of :meth:`TiltBatch.output`.
    """
    return TiltBatch(setup, angles).output(params)
