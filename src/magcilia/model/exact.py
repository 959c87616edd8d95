"""Exact reference field: the cilium as a stack of homogeneously magnetized cylinders (magpylib).

magpylib has no cone (its issue #290), but its ``Cylinder`` field is exact. Each of ``n_slices``
equal-length slices of the (possibly bent) cilium becomes a cylinder of the same length and volume
(for a frustum slice: radius sqrt((r1² + r1 r2 + r2²)/3)), centred on the centreline at the
slice's mid-arc-length, with its axis along the local tangent and polarization J = μ0 M along
that axis. The stack converges to the true body (frustum or measured profile) as O(1/n²)
everywhere outside the body, near field included (docs/convergence.md), so it measures the error
of the dipole model.
"""

from __future__ import annotations

import math
from typing import Any

import numpy as np
from numpy.typing import ArrayLike, NDArray

from magcilia import _validate as v
from magcilia.constants import MU0
from magcilia.model import body
from magcilia.model.centreline import Centreline, SpatialCentreline
from magcilia.model.pose import Pose, as_centreline, check_outside
from magcilia.model.spec import ModelSpec, SupportsSpec, as_spec

F64 = NDArray[np.float64]


def exact_field(
    setup: ModelSpec | SupportsSpec, pose: Pose, n_slices: int = 200,
    points: ArrayLike | None = None, *, check: bool = True,
) -> F64:
    """B of the cilium from a stack of exact magpylib cylinders, T.

    Parameters
    ----------
    setup : Setup or ModelSpec
        Geometry, material and placement (its n_loops/dipoles_per_loop are not used).
    pose : array-like, shape (a,), Centreline or SpatialCentreline
        Tilt angles in rad, or centrelines (planar or in space).
    n_slices : int
        Cylinder slices (error O(1/n²): ~1e-4 relative at 200 for hair-like bodies).
    points : array-like, shape (o, 3), optional
        Observers in the sensor frame, m; default the sensing element (origin).
    check : bool
        Raise when an observer lies inside the cilium in a pose (default). False skips the test
        (the caller masks such pairs: the field inside a magnet is not the model's concern).

    Returns
    -------
    ndarray
        Shape (a, 3) at the sensing element, or (a, o, 3) when ``points`` is given.
    """
    import magpylib as magpy

    spec = as_spec(setup)
    n = v.integer("n_slices", n_slices, 1)
    pts = np.zeros((1, 3)) if points is None else v.finite_array("points", points).reshape(-1, 3)
    centreline = as_centreline(spec, pose)
    if check:
        check_outside(spec, pts, centreline)
    centres, rotvec, r_eq = _slices(spec, centreline, n)
    a, o = centres.shape[0], pts.shape[0]
    j = MU0 * spec.magnetization
    # one instance per (pose, slice, observer)
    obs = np.broadcast_to(pts[None, None, :, :], (a, n, o, 3)).reshape(-1, 3)
    pos = np.broadcast_to(centres[:, :, None, :], (a, n, o, 3)).reshape(-1, 3)
    dims = np.broadcast_to(
        np.stack([2.0 * r_eq, np.full(n, spec.height / n)], axis=-1)[None, :, None, :],
        (a, n, o, 2),
    ).reshape(-1, 2)
    from scipy.spatial.transform import Rotation  # (SciPy: where first needed)

    rot = Rotation.from_rotvec(np.repeat(rotvec.reshape(-1, 3), o, axis=0))
    b = magpy.func.cylinder_field(
        field="B", observers=obs, dimensions=dims, polarizations=(0.0, 0.0, j),
        positions=pos, orientations=rot, squeeze=False,
    )
    b = np.asarray(b).reshape(a, n, o, 3).sum(axis=1)
    return b[:, 0, :] if points is None else b


def _slices(spec: ModelSpec, centreline: Centreline | SpatialCentreline,
            n: int) -> tuple[F64, F64, F64]:
    """The stack's cylinders for each pose: centres (a, n, 3) m in the sensor frame, rotation
    vectors (a, n, 3) rad turning +z onto the local tangent, equal-volume radii (n,) m (each
    ``spec.height / n`` long)."""
    mean2, _ = body.slice_means(spec.knots, spec.radii, n)
    r_eq = spec.base_radius * np.sqrt(mean2)  # same volume as each slice
    s_mid = spec.height * (np.arange(n) + 0.5) / n
    if isinstance(centreline, SpatialCentreline):  # the cylinders' axes along the tangents
        centres, tangents, _ = centreline.frames(s_mid)
        lean = np.arctan2(np.hypot(tangents[..., 0], tangents[..., 1]), tangents[..., 2])
        axis = np.stack([-tangents[..., 1], tangents[..., 0], np.zeros_like(lean)], axis=-1)
        norm = np.linalg.norm(axis, axis=-1, keepdims=True)
        rotvec = np.where(norm > 0.0, axis / np.where(norm > 0.0, norm, 1.0), 0.0) \
            * lean[..., None]
    else:
        centres, angles = centreline.frames(s_mid)  # (a, n, 3), (a, n)
        rotvec = np.stack([np.zeros_like(angles), angles, np.zeros_like(angles)], axis=-1)
    return centres + spec.base_centre, rotvec, r_eq


def exact_body(setup: ModelSpec | SupportsSpec, pose: Pose = 0.0, n_slices: int = 40) -> Any:
    """The cilium in one pose as the exact reference body (:func:`exact_field`'s stack of
    magnetized cylinders) in a ``magpylib.Collection``, SI, to draw or compute with.

    Parameters
    ----------
    setup : Setup or ModelSpec
        Geometry, material and placement.
    pose : float, Centreline or SpatialCentreline
        One rigid tilt angle in rad, or one centreline (a single bent shape).
    n_slices : int
        Cylinders in the stack (each ``height / n_slices`` long, of the slice's volume).

    Returns
    -------
    magpylib.Collection
        ``n_slices`` ``magpylib.magnet.Cylinder`` (dimensions m, polarization T along each
        cylinder's axis); its ``getB`` at a point is :func:`exact_field` with the same
        ``n_slices``.
    """
    import magpylib as magpy
    from scipy.spatial.transform import Rotation

    spec = as_spec(setup)
    n = v.integer("n_slices", n_slices, 1)
    if isinstance(pose, (Centreline, SpatialCentreline)):
        centreline = as_centreline(spec, pose)
    else:
        centreline = as_centreline(spec, np.array([v.real("pose", pose, "rad")]))
    if len(centreline) != 1:
        raise v.fail("pose", f"{len(centreline)} poses", "one pose")
    centres, rotvec, r_eq = _slices(spec, centreline, n)
    j = MU0 * spec.magnetization
    cylinders = [magpy.magnet.Cylinder(position=c, orientation=Rotation.from_rotvec(r),
                                       dimension=(2.0 * rad, spec.height / n),
                                       polarization=(0.0, 0.0, j))
                 for c, r, rad in zip(centres[0], rotvec[0], r_eq, strict=True)]
    return magpy.Collection(*cylinders, style_label="cilium (exact body)")


def single_dipole_field(setup: ModelSpec | SupportsSpec, pose: Pose) -> F64:
    """Field of one dipole carrying the whole moment at the volume centroid, T, shape (a, 3).

    The crude far-field model, for comparison (good to ~2 % only beyond ~5 body lengths).
    """
    spec = as_spec(setup)
    centreline = as_centreline(spec, pose)
    n = 64
    mean2, _ = body.slice_means(spec.knots, spec.radii, n)
    w = mean2 / mean2.sum()
    s_mid = spec.height * (np.arange(n) + 0.5) / n
    if isinstance(centreline, SpatialCentreline):
        pts, tangents, _ = centreline.frames(s_mid)
        direction = np.einsum("n,ani->ai", w, tangents)
    else:
        pts, ang = centreline.frames(s_mid)
        direction = np.stack([np.einsum("n,an->a", w, np.sin(ang)), np.zeros(ang.shape[0]),
                              np.einsum("n,an->a", w, np.cos(ang))], axis=-1)
    centroid = np.einsum("n,ani->ai", w, pts) + spec.base_centre
    m = spec.moment * direction
    r = -centroid
    rn = np.linalg.norm(r, axis=-1, keepdims=True)
    mr = np.sum(m * r, axis=-1, keepdims=True)
    return MU0 / (4.0 * math.pi) * (3.0 * r * mr / rn**5 - m / rn**3)
