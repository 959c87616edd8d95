"""Centrelines of the cilium (planar and in space): the poses that the field model consumes.

A centreline is parametrised by arc length ``s`` from the base (0) to the tip (L). At each point
it has a tangent angle ``theta`` measured from +z toward +x (the paper's tilt angle is a constant
theta) and a position relative to the base centre. Both a rigid tilt and a bent shape are
centrelines; a :class:`Centreline` holds a batch of ``a`` of them on a common arc-length grid.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from numpy.typing import ArrayLike, NDArray

from magcilia import _validate as v
from magcilia._display import Display, Item, scaled
from magcilia.model.azimuth import turn_about_z
from magcilia.model.layout import spatial_frames


@dataclass(frozen=True, eq=False, repr=False)
class Centreline(Display):
    """A batch of planar centrelines in the xz plane, on a common arc-length grid.

    Parameters
    ----------
    s : ndarray, shape (m,)
        Arc length from the base, m, strictly increasing from 0 to the length L.
    angles : ndarray, shape (a, m)
        Tangent angle at each grid point, rad, from +z toward +x.
    points : ndarray, shape (a, m, 3)
        Positions relative to the base centre, m (y = 0; ``points[:, 0]`` is the origin).
    """

    s: NDArray[np.float64]
    angles: NDArray[np.float64]
    points: NDArray[np.float64]

    def __post_init__(self) -> None:
        s = v.finite_array("s", self.s, ndim=1, unit="m")
        if s.size < 2 or s[0] != 0.0 or np.any(np.diff(s) <= 0.0):
            raise v.fail("s", f"an array from {s[0] if s.size else None}",
                         "strictly increasing arc lengths starting at 0 (at least 2 points)")
        angles = v.finite_array("angles", self.angles, unit="rad")
        if angles.ndim == 1:
            angles = angles[None, :]
        points = v.finite_array("points", self.points, unit="m")
        if points.ndim == 2:
            points = points[None, :, :]
        if angles.ndim != 2 or angles.shape[1] != s.size:
            raise v.fail("angles", f"an array of shape {angles.shape}", f"shape (a, {s.size})")
        if points.shape != (*angles.shape, 3):
            raise v.fail("points", f"an array of shape {points.shape}",
                         f"shape {(*angles.shape, 3)}")
        for name, arr in (("s", s), ("angles", angles), ("points", points)):
            arr.setflags(write=False)
            object.__setattr__(self, name, arr)

    # -- constructors -------------------------------------------------------------------------
    @classmethod
    def from_angles(cls, s: ArrayLike, angles: ArrayLike) -> Centreline:
        """Build centrelines from tangent angles by integrating (sin θ, 0, cos θ) along ``s``.

        The integration uses cubic Hermite segments of the tangent angle, exact to O(h⁴) for
        smooth shapes (Simpson's rule per interval with the mid-point angle from the Hermite
        interpolant of theta).

        Parameters
        ----------
        s : array-like, shape (m,)
            Arc lengths, m, from 0.
        angles : array-like, shape (m,) or (a, m)
            Tangent angles, rad.
        """
        s_arr = v.finite_array("s", s, ndim=1, unit="m")
        th = v.finite_array("angles", angles, unit="rad")
        if th.ndim == 1:
            th = th[None, :]
        if th.ndim != 2 or th.shape[1] != s_arr.size or s_arr.size < 2:
            raise v.fail("angles", f"an array of shape {th.shape}", f"shape (a, {s_arr.size})")
        h = np.diff(s_arr)
        # mid-interval angle from the quadratic through neighbours (second-order accurate
        # slope estimate); Simpson on each interval.
        dth = np.gradient(th, s_arr, axis=1, edge_order=2)
        mid = 0.5 * (th[:, :-1] + th[:, 1:]) + h / 8.0 * (dth[:, :-1] - dth[:, 1:])
        dx = h / 6.0 * (np.sin(th[:, :-1]) + 4.0 * np.sin(mid) + np.sin(th[:, 1:]))
        dz = h / 6.0 * (np.cos(th[:, :-1]) + 4.0 * np.cos(mid) + np.cos(th[:, 1:]))
        pts = np.zeros((*th.shape, 3))
        pts[:, 1:, 0] = np.cumsum(dx, axis=1)
        pts[:, 1:, 2] = np.cumsum(dz, axis=1)
        return cls(s_arr, th, pts)

    @classmethod
    def straight(cls, length: float, tilt: ArrayLike) -> Centreline:
        """Straight centrelines of ``length`` (m) rigidly tilted by ``tilt`` (rad, shape (a,))."""
        length = v.positive("length", length)
        tilt_arr = np.atleast_1d(v.finite_array("tilt", tilt, unit="rad"))
        if tilt_arr.ndim != 1:
            raise v.fail("tilt", f"an array of shape {tilt_arr.shape}", "a 1-D array of angles")
        s = np.array([0.0, length])
        angles = np.repeat(tilt_arr[:, None], 2, axis=1)
        pts = np.zeros((tilt_arr.size, 2, 3))
        pts[:, 1, 0] = length * np.sin(tilt_arr)
        pts[:, 1, 2] = length * np.cos(tilt_arr)
        return cls(s, angles, pts)

    # -- queries ------------------------------------------------------------------------------
    @property
    def length(self) -> float:
        """Arc length L, m."""
        return float(self.s[-1])

    def __len__(self) -> int:
        return int(self.angles.shape[0])

    @property
    def tip(self) -> NDArray[np.float64]:
        """Tip positions relative to the base centre, m, shape (a, 3)."""
        return self.points[:, -1, :]

    @property
    def tip_angle(self) -> NDArray[np.float64]:
        """Tangent angle at the tip, rad, shape (a,)."""
        return self.angles[:, -1]

    def frames(self, s_query: ArrayLike) -> tuple[NDArray[np.float64], NDArray[np.float64]]:
        """Positions and tangent angles at arc lengths ``s_query``.

        Cubic Hermite interpolation of the positions with the tangent (sin θ, 0, cos θ) as the
        derivative, and linear interpolation of the angle.

        Parameters
        ----------
        s_query : array-like, shape (q,)
            Arc lengths in [0, L], m.

        Returns
        -------
        points : ndarray, shape (a, q, 3)
            Positions relative to the base centre, m.
        angles : ndarray, shape (a, q)
            Tangent angles, rad.
        """
        sq = np.asarray(s_query, dtype=np.float64)
        s = self.s
        idx = np.clip(np.searchsorted(s, sq, side="right") - 1, 0, s.size - 2)
        h = s[idx + 1] - s[idx]
        t = (sq - s[idx]) / h
        th0, th1 = self.angles[:, idx], self.angles[:, idx + 1]
        angles = th0 + t * (th1 - th0)
        p0, p1 = self.points[:, idx, :], self.points[:, idx + 1, :]
        d0 = np.stack([np.sin(th0), np.zeros_like(th0), np.cos(th0)], axis=-1) * h[:, None]
        d1 = np.stack([np.sin(th1), np.zeros_like(th1), np.cos(th1)], axis=-1) * h[:, None]
        t2, t3 = t * t, t * t * t
        h00 = (2 * t3 - 3 * t2 + 1)[:, None]
        h10 = (t3 - 2 * t2 + t)[:, None]
        h01 = (-2 * t3 + 3 * t2)[:, None]
        h11 = (t3 - t2)[:, None]
        points = h00 * p0 + h10 * d0 + h01 * p1 + h11 * d1
        return points, angles

    def _display_items(self) -> list[Item]:
        tip = np.atleast_2d(self.angles)[:, -1]
        return [("poses", str(tip.size)), ("nodes", str(self.s.size)),
                ("length", scaled(float(self.s[-1]), 1e-3, "mm")),
                ("tip angle", ", ".join(scaled(t, np.pi / 180.0, "deg") for t in tip[:4])
                 + (", …" if tip.size > 4 else ""))]


def _unit(vec: NDArray[np.float64]) -> NDArray[np.float64]:
    """Vectors (..., 3) scaled to unit length."""
    return vec / np.linalg.norm(vec, axis=-1, keepdims=True)


def _turn_z(vec: NDArray[np.float64], azimuth: NDArray[np.float64]) -> NDArray[np.float64]:
    """Vectors (a, m, 3) turned about +z by ``azimuth`` (a,) rad
    (:func:`~magcilia.model.azimuth.turn_about_z`)."""
    return turn_about_z(vec, azimuth[:, None])


@dataclass(frozen=True, eq=False, repr=False)
class SpatialCentreline(Display):
    """A batch of centrelines in space (any bending direction, out-of-plane shapes included).

    Each shape carries, at every grid point, its position, its unit tangent and a unit normal
    ``e1`` (perpendicular to the tangent) from which the model's dipole rings measure their
    azimuths: ring dipole j of a slice sits at ``p + r (cos α_j e1 + sin α_j e2)``,
    ``e2 = t × e1``. The normals form a rotation-minimising (parallel-transported) frame that
    starts at the base along the shape's bending direction, so a planar shape bent toward
    azimuth φ is exactly the paper's planar layout (e1 = (cos θ, 0, −sin θ)) turned by φ about the
    vertical axis through its base (:meth:`from_planar`), the convention of
    :mod:`magcilia.model.azimuth`.

    Parameters
    ----------
    s : ndarray, shape (m,)
        Arc length from the base, m, strictly increasing from 0 to the length L.
    points : ndarray, shape (a, m, 3)
        Positions relative to the base centre, m (``points[:, 0]`` is the origin).
    tangents : ndarray, shape (a, m, 3)
        Unit tangents (``tangents[:, 0]`` is +z for a cilium clamped upright).
    normals : ndarray, shape (a, m, 3)
        Unit ring reference directions e1, perpendicular to the tangents.

    Examples
    --------
    >>> import numpy as np
    >>> planar = Centreline.straight(3e-3, [0.2])
    >>> c = SpatialCentreline.from_planar(planar, np.pi / 2)
    >>> np.round(c.tip[0] / 3e-3, 4)
    array([0.    , 0.1987, 0.9801])
    """

    s: NDArray[np.float64]
    points: NDArray[np.float64]
    tangents: NDArray[np.float64]
    normals: NDArray[np.float64]

    def __post_init__(self) -> None:
        s = v.finite_array("s", self.s, ndim=1, unit="m")
        if s.size < 2 or s[0] != 0.0 or np.any(np.diff(s) <= 0.0):
            raise v.fail("s", f"an array from {s[0] if s.size else None}",
                         "strictly increasing arc lengths starting at 0 (at least 2 points)")
        arrays = {}
        for name in ("points", "tangents", "normals"):
            arr = v.finite_array(name, getattr(self, name), unit="m" if name == "points" else "")
            if arr.ndim == 2:
                arr = arr[None]
            if arr.ndim != 3 or arr.shape[1:] != (s.size, 3):
                raise v.fail(name, f"an array of shape {arr.shape}", f"shape (a, {s.size}, 3)")
            arrays[name] = arr
        t, e1 = arrays["tangents"], arrays["normals"]
        if arrays["points"].shape != t.shape or e1.shape != t.shape:
            raise v.fail("normals", f"arrays of shapes {arrays['points'].shape}, {t.shape}, "
                         f"{e1.shape}", "points, tangents and normals of one shape (a, m, 3)")
        for name, vec in (("tangents", t), ("normals", e1)):
            norm = np.linalg.norm(vec, axis=-1)
            if np.any(np.abs(norm - 1.0) > 1e-6):
                raise v.fail(name, f"vectors of length {float(norm.min()):.6g} to "
                             f"{float(norm.max()):.6g}", "unit vectors")
        if np.any(np.abs(np.einsum("ami,ami->am", t, e1)) > 1e-6):
            raise v.fail("normals", "vectors not perpendicular to the tangents",
                         "unit vectors perpendicular to the tangents")
        object.__setattr__(self, "s", s)
        for name, arr in arrays.items():
            arr.setflags(write=False)
            object.__setattr__(self, name, arr)
        s.setflags(write=False)

    # -- constructors -------------------------------------------------------------------------
    @classmethod
    def from_planar(cls, centreline: Centreline, azimuth: ArrayLike = 0.0) -> SpatialCentreline:
        """Planar centrelines (the x–z plane) turned about the vertical axis through the base by
        ``azimuth`` (rad; a scalar for all shapes or shape (a,)): a shape bent toward +x becomes
        one bent toward ``(cos φ, sin φ, 0)``. Exact: no resampling."""
        th = centreline.angles
        phi = np.broadcast_to(np.asarray(v.finite_array("azimuth", azimuth, unit="rad"),
                                         dtype=np.float64), (th.shape[0],))
        zero = np.zeros_like(th)
        t = np.stack([np.sin(th), zero, np.cos(th)], axis=-1)
        e1 = np.stack([np.cos(th), zero, -np.sin(th)], axis=-1)
        return cls(centreline.s, _turn_z(centreline.points, phi), _turn_z(t, phi),
                   _turn_z(e1, phi))

    @classmethod
    def from_tangents(cls, s: ArrayLike, tangents: ArrayLike,
                      base_normal: ArrayLike | None = None) -> SpatialCentreline:
        """Centrelines from unit tangents on an arc-length grid.

        Positions integrate the tangent by Simpson's rule per interval (mid-interval tangent from
        the cubic Hermite interpolant, normalised); normals are parallel-transported from the
        base by the double-reflection rotation-minimising frame (Wang et al., ACM TOG 27, 2008).

        Parameters
        ----------
        s : array-like, shape (m,)
            Arc lengths, m, from 0.
        tangents : array-like, shape (m, 3) or (a, m, 3)
            Tangents (normalised here).
        base_normal : array-like, shape (3,) or (a, 3), optional
            e1 at the base (made perpendicular to the base tangent). Default: the horizontal
            direction of the tip's displacement (the bending direction; +x for a shape whose tip
            has not moved sideways).
        """
        s_arr = v.finite_array("s", s, ndim=1, unit="m")
        t = v.finite_array("tangents", tangents)
        if t.ndim == 2:
            t = t[None]
        if t.ndim != 3 or t.shape[1:] != (s_arr.size, 3) or s_arr.size < 2:
            raise v.fail("tangents", f"an array of shape {t.shape}", f"shape (a, {s_arr.size}, 3)")
        norm = np.linalg.norm(t, axis=-1, keepdims=True)
        if np.any(norm == 0.0):
            raise v.fail("tangents", "a zero vector", "non-zero tangent vectors")
        t = t / norm
        h = np.diff(s_arr)[None, :, None]
        dt = np.gradient(t, s_arr, axis=1, edge_order=2)
        mid = _unit(0.5 * (t[:, :-1] + t[:, 1:]) + h / 8.0 * (dt[:, :-1] - dt[:, 1:]))
        step = h / 6.0 * (t[:, :-1] + 4.0 * mid + t[:, 1:])
        pts = np.zeros_like(t)
        pts[:, 1:] = np.cumsum(step, axis=1)
        if base_normal is None:
            side = pts[:, -1].copy()
            side[:, 2] = 0.0
            flat = np.linalg.norm(side, axis=-1) <= 1e-12 * s_arr[-1]
            side[flat] = (1.0, 0.0, 0.0)
            e0 = side
        else:
            e0 = np.broadcast_to(v.finite_array("base_normal", base_normal), (t.shape[0], 3))
        e0 = e0 - np.einsum("ai,ai->a", e0, t[:, 0])[:, None] * t[:, 0]
        if np.any(np.linalg.norm(e0, axis=-1) <= 1e-12):
            raise v.fail("base_normal", "a vector along the base tangent",
                         "a direction not parallel to the base tangent")
        normals = np.empty_like(t)
        normals[:, 0] = _unit(e0)
        step_vec = pts[:, 1:] - pts[:, :-1]
        for i in range(s_arr.size - 1):  # double reflection (rotation-minimising frame)
            v1 = step_vec[:, i]
            c1 = np.einsum("ai,ai->a", v1, v1)[:, None]
            r_l = normals[:, i] - 2.0 / c1 * np.einsum("ai,ai->a", v1, normals[:, i])[:, None] * v1
            t_l = t[:, i] - 2.0 / c1 * np.einsum("ai,ai->a", v1, t[:, i])[:, None] * v1
            v2 = t[:, i + 1] - t_l
            c2 = np.einsum("ai,ai->a", v2, v2)[:, None]
            safe = np.where(c2 > 0.0, c2, 1.0)
            r_next = r_l - np.where(c2 > 0.0, 2.0 / safe, 0.0) \
                * np.einsum("ai,ai->a", v2, r_l)[:, None] * v2
            r_next -= np.einsum("ai,ai->a", r_next, t[:, i + 1])[:, None] * t[:, i + 1]
            normals[:, i + 1] = _unit(r_next)
        return cls(s_arr, pts, t, normals)

    def turned(self, azimuth: float) -> SpatialCentreline:
        """The shapes turned about the vertical axis through their base by ``azimuth`` (rad):
        points, tangents and normals alike (exact, no resampling)."""
        phi = np.full(len(self), v.real("azimuth", azimuth, "rad"))
        return SpatialCentreline(self.s, _turn_z(self.points, phi), _turn_z(self.tangents, phi),
                                 _turn_z(self.normals, phi))

    # -- queries ------------------------------------------------------------------------------
    @property
    def length(self) -> float:
        """Arc length L, m."""
        return float(self.s[-1])

    def __len__(self) -> int:
        return int(self.points.shape[0])

    @property
    def tip(self) -> NDArray[np.float64]:
        """Tip positions relative to the base centre, m, shape (a, 3)."""
        return self.points[:, -1, :]

    @property
    def azimuth(self) -> NDArray[np.float64]:
        """Bending direction of each shape, rad, shape (a,): the azimuth of the base normal e1
        (the horizontal direction the shape starts to bend toward; 0 for +x)."""
        e1 = self.normals[:, 0]
        return np.arctan2(e1[:, 1], e1[:, 0])

    def frames(self, s_query: ArrayLike) -> tuple[NDArray[np.float64], NDArray[np.float64],
                                                   NDArray[np.float64]]:
        """Positions, tangents and normals at arc lengths ``s_query``
        (:func:`magcilia.model.layout.spatial_frames`: cubic Hermite positions, tangents and
        normals turned on the sphere, so that :meth:`from_planar` shapes give the planar model's
        frames at any arc length).

        Parameters
        ----------
        s_query : array-like, shape (q,)
            Arc lengths in [0, L], m.

        Returns
        -------
        points, tangents, normals : ndarray, shape (a, q, 3)
            m, and unit vectors.
        """
        return spatial_frames(self.s, self.points, self.tangents, self.normals,
                              np.asarray(s_query, dtype=np.float64))

    def _display_items(self) -> list[Item]:
        tip = self.tip
        return [("poses", str(tip.shape[0])), ("nodes", str(self.s.size)),
                ("length", scaled(float(self.s[-1]), 1e-3, "mm")),
                ("tip", ", ".join("(" + ", ".join(f"{c * 1e3:.3g}" for c in p) + ") mm"
                                  for p in tip[:2]) + (", …" if tip.shape[0] > 2 else ""))]
