"""Planar centrelines of the cilium: the pose that the field model consumes.

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
