"""Arrays of cilia over many sensors, as plain values: all cilia's dipoles and their field.

An array's dipoles are one list, cilium after cilium (cilium c holds dipoles
``starts[c]:starts[c + 1]``; within a cilium slice after slice, ring dipole after ring dipole, as
:func:`magcilia.model.layout.pose_dipoles`). :class:`ArrayLayout` holds, per dipole, what does not
change with the pose (its cilium, its slice's arc length, its ring offset and moment), so that the
dipoles of every cilium in any pose come from the cilia's frames at the slice mid-points in a few
vectorised NumPy operations, and their field at every sensor from one compiled kernel call:
:func:`array_field` (the sum) or :func:`segment_field` (each cilium's contribution).

Ring orientation. The loaded shapes of an array (:meth:`ArrayLayout.planar_dipoles`) keep every
ring's azimuths fixed in the board frame: ring dipole j sits at angle ``2πj/k`` from the board's +x
axis as seen at the base, carried up the shape by the rotation-minimising frame
(:func:`board_normals`). A planar shape turned by ``SpatialCentreline.from_planar`` instead turns
its rings with the bending direction (the single-cilium convention), so that the field of an
unloaded cilium would depend on the direction it is about to bend in by the discrete ring's
k-fold harmonic (~(r/D)^k of the field: 4e-10 T at 2 mm for the paper's cilium, k = 5). With the
rings fixed in the board the field is a smooth function of the force vector through zero load,
which the array's crosstalk matrix and inverse need.

Shape letters: ``C`` cilia, ``S`` sensors (observers), ``D`` dipoles of the whole array, ``q``
slice arc lengths (the union over the cilia).
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from dataclasses import dataclass

import numpy as np
from numpy.typing import NDArray

from magcilia.model import body, compiled
from magcilia.model.kernels import _dipole_field_numpy, dipole_field
from magcilia.model.layout import _rotate, cross, spatial_frames
from magcilia.model.spec import ModelSpec

F64 = NDArray[np.float64]
I64 = NDArray[np.int64]


def segment_field(observers: F64, positions: F64, moments: F64, starts: I64) -> F64:
    """Field of each segment of a dipole list at common observers.

    Parameters
    ----------
    observers : ndarray, shape (S, 3)
        m.
    positions, moments : ndarray, shape (D, 3)
        m and A·m².
    starts : ndarray, shape (C + 1,)
        Segment c is ``starts[c]:starts[c + 1]``.

    Returns
    -------
    ndarray, shape (C, S, 3)
        B of each segment, T (compiled kernel, or NumPy per segment).
    """
    jit = compiled.kernels()
    out = np.empty((starts.size - 1, observers.shape[0], 3))
    if jit is not None:
        jit.segment_batch(np.ascontiguousarray(observers, dtype=np.float64),
                          np.ascontiguousarray(positions.T, dtype=np.float64),
                          np.ascontiguousarray(moments.T, dtype=np.float64),
                          np.ascontiguousarray(starts, dtype=np.int64), out)
        return out
    for c in range(starts.size - 1):
        j0, j1 = int(starts[c]), int(starts[c + 1])
        out[c] = _dipole_field_numpy(observers, positions[j0:j1], moments[j0:j1])
    return out


def array_field(observers: F64, positions: F64, moments: F64) -> F64:
    """Total field of all dipoles at the observers, T, shape (S, 3) (the superposition;
    :func:`magcilia.model.kernels.dipole_field`)."""
    return dipole_field(observers, positions, moments)


def board_normals(tangents: F64, normals: F64) -> F64:
    """Normals (a, m, 3) turned about the tangents by one angle per shape, so that the base's
    normal points along the board's +x axis (made perpendicular to the base tangent; +y where the
    base tangent is along x). A rotation-minimising frame stays one under a constant turn."""
    t0, e0 = tangents[:, 0], normals[:, 0]
    ref = np.zeros_like(t0)
    ref[:, 0] = 1.0
    along_x = np.abs(t0[:, 0]) > 1.0 - 1e-9
    ref[along_x] = (0.0, 1.0, 0.0)
    ref = ref - np.einsum("ai,ai->a", ref, t0)[:, None] * t0
    ref /= np.linalg.norm(ref, axis=-1, keepdims=True)
    psi = np.arctan2(np.einsum("ai,ai->a", cross(e0, ref), t0), np.einsum("ai,ai->a", e0, ref))
    c = np.broadcast_to(np.cos(psi)[:, None], normals.shape[:2])
    s = np.broadcast_to(np.sin(psi)[:, None], normals.shape[:2])
    out = _rotate(normals, tangents, c, s)
    return np.asarray(out / np.linalg.norm(out, axis=-1, keepdims=True), dtype=np.float64)


@dataclass(frozen=True, eq=False)
class ArrayLayout:
    """The pose-independent part of an array's dipoles (plain arrays, SI).

    Attributes
    ----------
    bases : ndarray, shape (C, 3)
        Base centres, m, board frame.
    starts : ndarray, shape (C + 1,)
        Cilium c's dipoles are ``starts[c]:starts[c + 1]``.
    cilium : ndarray, shape (D,)
        Each dipole's cilium.
    s_query : ndarray, shape (q,)
        The slice mid-points' arc lengths (m) of all cilia, sorted, distinct.
    slot : ndarray, shape (D,)
        Each dipole's slice mid-point as an index into ``s_query``.
    ring_cos, ring_sin : ndarray, shape (D,)
        ``r cos α``, ``r sin α`` of each dipole's ring offset, m.
    moment : ndarray, shape (D,)
        Each dipole's moment ``m_c · share / k``, A·m².
    heights : ndarray, shape (C,)
        Cilium lengths, m.
    """

    bases: F64
    starts: I64
    cilium: I64
    s_query: F64
    slot: I64
    ring_cos: F64
    ring_sin: F64
    moment: F64
    heights: F64

    @classmethod
    def build(cls, specs: Sequence[ModelSpec]) -> ArrayLayout:
        """The layout of cilia described by their specs (base centres from their placement)."""
        s_all, rows = [], []
        for spec in specs:
            n, k = spec.n_loops, spec.dipoles_per_loop
            radius, share = body.slice_rings(spec.knots, spec.radii, n, spec.ring)
            alpha = 2.0 * math.pi * np.arange(k) / k
            r = spec.base_radius * np.repeat(radius, k)
            a = np.tile(alpha, n)
            s_mid = spec.height * (np.arange(n) + 0.5) / n
            s_all.append(s_mid)
            rows.append((np.repeat(s_mid, k), r * np.cos(a), r * np.sin(a),
                         np.repeat(spec.moment * share / k, k)))
        s_query = np.unique(np.concatenate(s_all))
        sizes = np.array([row[0].size for row in rows], dtype=np.int64)
        starts = np.concatenate([[0], np.cumsum(sizes)]).astype(np.int64)
        s_dip = np.concatenate([row[0] for row in rows])
        return cls(
            bases=np.array([spec.base_centre for spec in specs], dtype=np.float64).reshape(-1, 3),
            starts=starts, cilium=np.repeat(np.arange(len(specs)), sizes).astype(np.int64),
            s_query=s_query, slot=np.searchsorted(s_query, s_dip).astype(np.int64),
            ring_cos=np.concatenate([row[1] for row in rows]),
            ring_sin=np.concatenate([row[2] for row in rows]),
            moment=np.concatenate([row[3] for row in rows]),
            heights=np.array([spec.height for spec in specs], dtype=np.float64))

    @property
    def size(self) -> int:
        """Dipoles in all, D."""
        return int(self.moment.size)

    def spatial_dipoles(self, s: F64, points: F64, tangents: F64,
                        normals: F64) -> tuple[F64, F64]:
        """All dipoles (D, 3) (m, A·m²) of cilia posed by centrelines in space, one per cilium
        on a common grid ``s`` (m,) whose length every cilium has: ``points``, ``tangents``,
        ``normals`` (C, m, 3) (frames between grid points: :func:`spatial_frames`)."""
        pts, tan, nor = spatial_frames(s, points, tangents, normals, self.s_query)
        c, q = self.cilium, self.slot
        t, e1 = tan[c, q], nor[c, q]
        e2 = cross(t, e1)
        pos = pts[c, q] + self.ring_cos[:, None] * e1 + self.ring_sin[:, None] * e2
        pos += self.bases[c]
        return pos, self.moment[:, None] * t

    def planar_dipoles(self, x: F64, z: F64, theta: F64, azimuth: F64) -> tuple[F64, F64]:
        """All dipoles (..., D, 3) (m, A·m²) of cilia bent in vertical planes, rings fixed in the
        board.

        Parameters
        ----------
        x, z, theta : ndarray, shape (..., C, q)
            Each cilium's planar shape at ``s_query``: the slice mid-points' x and z relative to
            the base (m) and tangent angles from +z toward +x (rad), as if bent toward +x; any
            leading axes are sets of poses (one array operation for all).
        azimuth : ndarray, shape (..., C)
            Each cilium's bending direction, rad: the planar shape is turned by it about the
            vertical axis through the base, the rings are not (see the module's notes).
        """
        c, q = self.cilium, self.slot
        cp, sp = np.cos(azimuth)[..., c], np.sin(azimuth)[..., c]
        rc = self.ring_cos * cp + self.ring_sin * sp  # r cos(α − φ)
        rs = self.ring_sin * cp - self.ring_cos * sp  # r sin(α − φ)
        th = theta[..., c, q]
        st, ct = np.sin(th), np.cos(th)
        lx = x[..., c, q] + rc * ct
        pos = np.empty((*th.shape, 3))
        pos[..., 0] = cp * lx - sp * rs
        pos[..., 1] = sp * lx + cp * rs
        pos[..., 2] = z[..., c, q] - rc * st
        pos += self.bases[c]
        mom = np.empty((*th.shape, 3))
        m_h = self.moment * st
        mom[..., 0] = cp * m_h
        mom[..., 1] = sp * m_h
        mom[..., 2] = self.moment * ct
        return pos, mom
