"""Fast evaluation of many parameter sets at once, for optimisers and global sensitivity analysis.

No input checks: the caller keeps the parameters physical (positive lengths, n and k ≥ 1, the
sensing element outside the cilium). Shape letters: ``N`` parameter sets, ``a`` tilt angles.
"""

from __future__ import annotations

import math
from collections.abc import Mapping

import numpy as np
from numpy.typing import ArrayLike, NDArray

from magcilia.model import body
from magcilia.model.kernels import tilt_field
from magcilia.model.layout import ring_layout
from magcilia.model.spec import ModelSpec, SupportsSpec, as_spec

F64 = NDArray[np.float64]


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
    Samples are grouped by (n, k); each group is one vectorised kernel call.
    """
    spec = as_spec(setup)
    ang = np.asarray(angles, dtype=np.float64)
    sizes = {np.size(v) for v in params.values()}
    n_set = max(sizes) if sizes else 1
    defaults = spec.params()

    def get(key: str) -> F64:
        val = params.get(key, defaults[key])
        return np.broadcast_to(np.asarray(val, dtype=np.float64), (n_set,))

    h, rb = get("height"), get("base_radius")
    base = np.stack([get("x"), get("y"), get("z") + spec.depth], axis=-1)
    nl = np.rint(get("n_loops")).astype(np.int64)
    kd = np.rint(get("dipoles_per_loop")).astype(np.int64)
    if spec.measured:  # one measured shape, scaled by each height and base radius
        u, rho = spec.knots, spec.radii
    else:  # frustums, each with its own taper
        u, rho = body.frustum_shape(get("tip_radius") / rb)
    volume = math.pi * h * rb * rb * body.mean_square_radius(u, rho)
    moment = get("magnetization_scale") * spec.full_magnetization * volume
    out = np.zeros((n_set, ang.size, 3))
    cos_t, sin_t = np.cos(ang), np.sin(ang)
    keys = nl * 100_003 + kd
    for key in np.unique(keys):
        sel = np.nonzero(keys == key)[0]
        n, k = int(nl[sel[0]]), int(kd[sel[0]])
        pos, w = ring_layout(h[sel], rb[sel], u, rho if rho.ndim == 1 else rho[sel], n, k,
                             spec.ring)
        bx, by, bz = tilt_field(cos_t, sin_t, -base[sel], pos, w * moment[sel, None], x_only)
        out[sel, :, 0] = bx
        if not x_only:
            out[sel, :, 1], out[sel, :, 2] = by, bz
    return out


def tilt_output_batch(
    setup: ModelSpec | SupportsSpec, params: Mapping[str, ArrayLike], angles: ArrayLike
) -> F64:
    """Sensor output (V) for N parameter sets at a tilt angles: shape (N, a).

    As :func:`tilt_field_batch`, plus an optional ``offset`` key (V) in ``params``; the sensor's
    scale (V/T) comes from ``setup``.
    """
    spec = as_spec(setup)
    bx = tilt_field_batch(spec, params, angles, x_only=True)[..., 0]
    offset = np.asarray(params.get("offset", spec.offset), dtype=np.float64)
    return spec.scale * bx + np.reshape(offset, (-1, 1))
