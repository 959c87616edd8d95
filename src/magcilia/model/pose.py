"""One sensor's field for a batch of poses: the checked functional layer over the kernels.

A pose is rigid tilt angles (rad, shape (a,)), a :class:`~magcilia.model.centreline.Centreline`
of ``a`` (bent) shapes in the x–z plane, or a
:class:`~magcilia.model.centreline.SpatialCentreline` of ``a`` shapes in space (any bending
direction; its dipoles follow :func:`magcilia.model.layout.spatial_dipoles`, its frames at the
slice mid-points :func:`magcilia.model.layout.spatial_frames`). Tilt angles and planar
centrelines run the same code as before 3-D shapes existed; a SpatialCentreline has a path of its
own beside them. These functions take a :class:`~magcilia.model.spec.ModelSpec`, check the
poses (finite angles, the sensing element and any observer outside the cilium) and evaluate the
dipole model; :class:`magcilia.Setup` calls them with its spec. Rigid tilts run the compiled
kernel of the batch path (:func:`magcilia.model.batch.evaluate`) for one set; the finiteness
check reads the flag it returns, so only a non-finite result costs the search for its pose.
"""

from __future__ import annotations

import math
from weakref import WeakKeyDictionary

import numpy as np
from numpy.typing import ArrayLike, NDArray

from magcilia import _validate as v
from magcilia.model import body, compiled
from magcilia.model.batch import evaluate, pack
from magcilia.model.centreline import Centreline, SpatialCentreline
from magcilia.model.kernels import pose_field, tilt_fields
from magcilia.model.layout import pose_dipoles, spatial_dipoles
from magcilia.model.spec import ModelSpec

F64 = NDArray[np.float64]
Pose = ArrayLike | Centreline | SpatialCentreline
#: a pose as centrelines: planar (the x–z plane) or in space
Shapes = Centreline | SpatialCentreline

#: angles × dipoles (or observers × polyline segments) evaluated in one NumPy block by the inside
#: check and the NumPy fallback of :func:`field` and :func:`output`: larger batches are split into
#: blocks of about this many pairs, so that memory stays near 100 MB whatever the number of angles
#: (the compiled kernel works in blocks of its own)
BLOCK_PAIRS = 1 << 21


def check_element_outside(spec: ModelSpec, angles: F64) -> None:
    """Raise unless the sensing element (origin) lies outside the cilium at every tilt angle."""
    rel = -spec.base_centre
    c, s = np.cos(angles), np.sin(angles)
    axial = s * rel[0] + c * rel[2]
    radial = np.hypot(c * rel[0] - s * rel[2], rel[1])
    inside = body.contains(spec.height, spec.base_radius, spec.knots, spec.radii, axial, radial)
    if inside.any():
        bad = float(angles[np.argmax(inside)])
        raise v.fail(
            "position", spec.position,
            f"a placement that keeps the sensing element outside the cilium (it is inside at "
            f"tilt {math.degrees(bad):.4g} deg); move the base up (z) or sideways (x, y)",
        )


def tilt_angles(spec: ModelSpec, pose: ArrayLike) -> F64:
    """Rigid tilt angles, rad, shape (a,): finite, and keeping the element outside the cilium
    (a new C-contiguous array)."""
    angles = np.array(pose, dtype=np.float64, ndmin=1)
    if angles.ndim != 1 or not np.isfinite(angles).all():
        angles = v.finite_array("tilt", angles, ndim=1, unit="rad")
    if not spec.element_always_clear:
        check_element_outside(spec, angles)
    return angles


def as_centreline(spec: ModelSpec, pose: Pose) -> Shapes:
    """The pose as centrelines: tilt angles become straight ones; a Centreline or
    SpatialCentreline must have the cilium's length."""
    if isinstance(pose, (Centreline, SpatialCentreline)):
        if not math.isclose(pose.length, spec.height, rel_tol=1e-9):
            raise v.fail("centreline length", pose.length,
                         f"the cilium height ({spec.height:.6g} m)")
        return pose
    return Centreline.straight(spec.height, tilt_angles(spec, pose))


def check_outside(spec: ModelSpec, points: F64, centreline: Shapes) -> None:
    """Raise if any observer (o, 3), m in the sensor frame, lies inside any posed cilium (checked
    against a fine polyline of each centreline, planar or in space)."""
    m = max(64, 8 * spec.n_loops)
    s = np.linspace(0.0, centreline.length, m + 1)
    pts = centreline.frames(s)[0]  # (a, m+1, 3)
    p0 = pts[:, :-1, :] + spec.base_centre
    seg = pts[:, 1:, :] - pts[:, :-1, :]
    seg_len2 = np.einsum("ami,ami->am", seg, seg)
    block = max(1, BLOCK_PAIRS // max(1, seg_len2.size))  # observers per block (memory)
    for start in range(0, points.shape[0], block):
        _check_outside_block(spec, points[start:start + block], s, p0, seg, seg_len2)


def _check_outside_block(spec: ModelSpec, points: F64, s: F64, p0: F64, seg: F64,
                         seg_len2: F64) -> None:
    rel = points[:, None, None, :] - p0[None]  # (o, a, m, 3)
    t = np.clip(np.einsum("oami,ami->oam", rel, seg) / seg_len2, 0.0, 1.0)
    closest = rel - t[..., None] * seg[None]
    dist = np.sqrt(np.einsum("oami,oami->oam", closest, closest))
    s_at = s[:-1][None, None, :] + t * np.diff(s)[None, None, :]
    inside = dist <= spec.radius(s_at)
    # points beyond the flat base (below it along the axis at s = 0) are outside
    axial0 = np.einsum("oai,ai->oa", rel[:, :, 0, :], seg[:, 0, :]) / np.sqrt(seg_len2[:, 0])
    inside[:, :, 0] &= axial0 >= 0.0
    if inside.any():
        o_idx = int(np.nonzero(inside.any(axis=(1, 2)))[0][0])
        raise v.fail("points", tuple(float(x) for x in points[o_idx]),
                     "observer positions outside the cilium")


def dipoles(spec: ModelSpec, centreline: Shapes) -> tuple[F64, F64]:
    """Lab-frame dipoles of the model for each centreline: positions (a, d, 3) m, moments
    (a, d, 3) A·m², d = n_loops · dipoles_per_loop."""
    n = spec.n_loops
    radius, share = body.slice_rings(spec.knots, spec.radii, n, spec.ring)
    s_mid = centreline.length * (np.arange(n) + 0.5) / n
    if isinstance(centreline, SpatialCentreline):
        pts, tan, nor = centreline.frames(s_mid)
        return spatial_dipoles(pts, tan, nor, spec.base_centre, spec.base_radius * radius,
                               share, spec.moment, spec.dipoles_per_loop)
    points, angles = centreline.frames(s_mid)
    return pose_dipoles(points, angles, spec.base_centre, spec.base_radius * radius, share,
                        spec.moment, spec.dipoles_per_loop)


def field_at(spec: ModelSpec, points: ArrayLike, pose: Pose) -> F64:
    """Flux density at observers ``points`` ((o, 3) or (3,), m), T, shape (a, o, 3).

    Raises a one-line error if the field is not finite anywhere (an observer on a dipole of the
    model, or a field beyond float range)."""
    pts = v.finite_array("points", points, unit="m").reshape(-1, 3)
    centreline = as_centreline(spec, pose)
    check_outside(spec, pts, centreline)
    pos, mom = dipoles(spec, centreline)
    with np.errstate(divide="ignore", invalid="ignore", over="ignore"):  # checked below
        out = pose_field(pts, pos, mom)
    if not np.isfinite(out).all():
        a_idx, o_idx = (int(i[0]) for i in np.nonzero(~np.isfinite(out).all(axis=2)))
        _nonfinite("field", out[a_idx, o_idx], pts[o_idx], pos[a_idx],
                   f"centreline {a_idx} at the point {tuple(float(x) for x in pts[o_idx])} m")
    return out


#: each spec's row of parameters for the compiled kernel (:func:`magcilia.model.batch.pack`)
_ROWS: WeakKeyDictionary[ModelSpec, F64] = WeakKeyDictionary()


def _tilt(spec: ModelSpec, angles: F64, x_only: bool) -> tuple[F64, bool]:
    """Output (a,), V, or field (a, 3), T, at the element for tilt ``angles`` (C-contiguous), and
    whether it is finite: the compiled kernel, or NumPy in blocks (:func:`_tilt_blocks`)."""
    if compiled.kernels() is None:
        bx, by, bz = _tilt_blocks(spec, angles, x_only)
        with np.errstate(over="ignore", invalid="ignore"):  # the callers check
            out = spec.scale * bx + spec.offset if x_only else np.stack([bx, by, bz], axis=-1)
        return out, bool(np.isfinite(out).all())
    row = _ROWS.get(spec)
    if row is None:
        row = _ROWS.setdefault(spec, pack(spec, {}))
    out = np.empty((1, angles.size, 1 if x_only else 3))
    finite = evaluate(spec, row, angles, out, measured=True)
    return (out[0, :, 0] if x_only else out[0]), finite


def _tilt_blocks(spec: ModelSpec, angles: F64, x_only: bool) -> tuple[F64, F64, F64]:
    """:func:`tilt_fields` of the spec's straight dipoles, in blocks of angles (memory)."""
    pos, mom = spec.body_dipoles
    rel = -spec.base_centre
    block = max(1, BLOCK_PAIRS // max(1, mom.size))
    with np.errstate(divide="ignore", invalid="ignore", over="ignore"):  # the callers check
        if angles.size <= block:
            return tilt_fields(angles, rel, pos, mom, x_only)
        parts = [tilt_fields(angles[i:i + block], rel, pos, mom, x_only)
                 for i in range(0, angles.size, block)]
    return tuple(np.concatenate([p[c] for p in parts]) for c in range(3))  # type: ignore[return-value]


def _nonfinite(what: str, value: ArrayLike, observer: F64, positions: F64, where: str) -> None:
    """Raise the one-line error for a non-finite model result: where, and why (the observer's
    distance from the nearest dipole of the model)."""
    dist = float(np.min(np.linalg.norm(positions - observer, axis=-1)))
    shown = np.array2string(np.asarray(value, dtype=np.float64), precision=4, separator=", ")
    raise v.MagciliaError(
        f"the model's {what} at {where} is not finite ({shown}): the point lies {dist:.3g} m from "
        "one of the model's dipoles, where a point dipole's field diverges; move the cilium "
        "(position x, y, z) or change n_loops / dipoles_per_loop"
    )


def _check_tilt(spec: ModelSpec, what: str, angles: F64, result: F64) -> F64:
    """``result`` (a, ...) if finite; else the one-line error naming the first bad angle."""
    bad = ~np.isfinite(result.reshape(angles.size, -1)).all(axis=1)
    if bad.any():
        i = int(np.argmax(bad))
        pos, _ = dipoles(spec, Centreline.straight(spec.height, angles[i:i + 1]))
        _nonfinite(what, result[i], np.zeros(3), pos[0],
                   f"tilt {math.degrees(float(angles[i])):.6g} deg")
    return result


def field(spec: ModelSpec, pose: Pose) -> F64:
    """Flux density at the sensing element (origin), T, shape (a, 3).

    Raises a one-line error naming the pose if the field is not finite (the element on a dipole
    of the model)."""
    if isinstance(pose, (Centreline, SpatialCentreline)):
        return field_at(spec, np.zeros((1, 3)), pose)[:, 0, :]
    angles = tilt_angles(spec, pose)
    out, finite = _tilt(spec, angles, x_only=False)
    return out if finite else _check_tilt(spec, "field", angles, out)


def output(spec: ModelSpec, pose: Pose) -> F64:
    """Sensor output, V, shape (a,): ``scale · B_x + offset``.

    Raises a one-line error naming the pose if the output is not finite (the element on a dipole
    of the model)."""
    if isinstance(pose, (Centreline, SpatialCentreline)):
        with np.errstate(over="ignore"):
            out = spec.scale * field(spec, pose)[:, 0] + spec.offset
        if not np.isfinite(out).all():
            i = int(np.argmax(~np.isfinite(out)))
            raise v.MagciliaError(f"the model's output for centreline {i} is not finite "
                                  f"({out[i]}): the field times the sensor's scale "
                                  f"({spec.scale:.4g} V/T) overflows; lower the gain")
        return out
    angles = tilt_angles(spec, pose)
    out, finite = _tilt(spec, angles, x_only=True)
    return out if finite else _check_tilt(spec, "output", angles, out)
