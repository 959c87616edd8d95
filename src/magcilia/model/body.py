"""The cilium's body of revolution as plain numbers: radius, slice integrals and ring radii.

A body is its ``height`` (m), ``base_radius`` (m) and a normalised shape: knots ``u`` (s / height,
0 … 1, increasing) and radii ``rho`` (r / base_radius, ``rho[0] = 1``), linear in between. A frustum
is the two-knot shape ``u = (0, 1)``, ``rho = (1, tip_radius / base_radius)``; a measured profile
has more knots. Every formula of the model and of the exact reference that depends on the shape
(slice volumes, ring radii, the inside test) is here, once.

Shape letters: ``q`` knots, ``n`` slices, ``N`` bodies of a batch (sharing the knots ``u``).
"""

from __future__ import annotations

import math

import numpy as np
from numpy.typing import ArrayLike, NDArray

F64 = NDArray[np.float64]

#: ring radius rules of the dipole model (the paper's mean radius; the second radial moment)
RINGS = ("mean", "rms")


def frustum_shape(taper: ArrayLike) -> tuple[F64, F64]:
    """Knots (2,) and radii (..., 2) of frustums with ``taper`` = tip / base radius (any shape)."""
    lam = np.asarray(taper, dtype=np.float64)
    return np.array([0.0, 1.0]), np.stack([np.ones_like(lam), lam], axis=-1)


def _on_grid(u: F64, rho: F64, grid: F64) -> F64:
    """The shape's radii at the points ``grid`` (within [0, 1]), shape (..., g)."""
    if u.size == 2:  # a frustum: one linear piece
        return np.asarray(rho[..., :1] + (rho[..., 1:] - rho[..., :1]) * grid, dtype=np.float64)
    j = np.clip(np.searchsorted(u, grid, side="right") - 1, 0, u.size - 2)
    w = (grid - u[j]) / (u[j + 1] - u[j])
    return np.asarray(rho[..., j] * (1.0 - w) + rho[..., j + 1] * w, dtype=np.float64)


def _slices(u: F64, rho: F64, n: int) -> tuple[F64, F64, F64]:
    """Slice means of rho² and rho⁴ (..., n) and the radii at the n + 1 slice edges (..., n + 1)."""
    edges = np.linspace(0.0, 1.0, n + 1)
    grid = edges if u.size == 2 else np.union1d(edges, u)
    p = _on_grid(u, rho, grid)
    a, b = p[..., :-1], p[..., 1:]
    w = np.diff(grid)
    a2, b2, ab = a * a, b * b, a * b
    part2 = w * (a2 + ab + b2) / 3.0
    part4 = w * (a2 * a2 + a2 * ab + a2 * b2 + ab * b2 + b2 * b2) / 5.0
    if grid.size == edges.size:  # no knot inside a slice
        return n * part2, n * part4, p
    starts = np.searchsorted(grid, edges)
    mean2 = n * np.add.reduceat(part2, starts[:-1], axis=-1)
    return mean2, n * np.add.reduceat(part4, starts[:-1], axis=-1), p[..., starts]


def slice_means(u: F64, rho: F64, n: int) -> tuple[F64, F64]:
    """Slice means of rho² and rho⁴ of n equal-length slices, exact for the piecewise-linear shape.

    Parameters
    ----------
    u : ndarray, shape (q,)
        Knots, 0 … 1.
    rho : ndarray, shape (..., q)
        Normalised radii of one shape, or of a batch sharing the knots.
    n : int
        Equal-length slices.

    Returns
    -------
    mean2, mean4 : ndarray, shape (..., n)
        n ∫ rho² du and n ∫ rho⁴ du over each slice (dimensionless). A slice's volume is
        π (height / n) base_radius² mean2.
    """
    mean2, mean4, _ = _slices(u, rho, n)
    return mean2, mean4


def mean_square_radius(u: F64, rho: F64) -> F64:
    """∫ rho² du over the whole length, shape (...): volume = π height base_radius² × this."""
    if u.size == 2:  # a frustum
        a, b = rho[..., 0], rho[..., 1]
        return np.asarray((a * a + a * b + b * b) / 3.0, dtype=np.float64)
    return slice_means(u, rho, 1)[0][..., 0]


def slice_rings(u: F64, rho: F64, n: int, ring: str) -> tuple[F64, F64]:
    """Ring radius and moment share of each of n slices (the model's slices).

    Parameters
    ----------
    u, rho : ndarray, shapes (q,), (..., q)
        The normalised shape (see :func:`slice_means`).
    n : int
        Slices.
    ring : {"mean", "rms"}
        ``"mean"`` (the paper): (r_bottom + r_top)/2. ``"rms"``: sqrt of the slice's
        volume-averaged rho², sqrt(∫ r⁴/2 / ∫ r²), which for a disc is r/√2 and makes the ring
        reproduce the slice's second radial moment.

    Returns
    -------
    radius : ndarray, shape (..., n)
        Ring radii relative to the base radius.
    share : ndarray, shape (..., n)
        V_s / V_c of each slice (sums to 1; the paper's eq. 2).
    """
    mean2, mean4, r = _slices(u, rho, n)
    if ring == "mean":
        radius = 0.5 * (r[..., :-1] + r[..., 1:])
    else:
        radius = np.sqrt(0.5 * mean4 / np.where(mean2 > 0.0, mean2, 1.0))
    return radius, mean2 / mean2.sum(axis=-1, keepdims=True)


def frustum_slice_derivatives(taper: ArrayLike, n: int, ring: str) -> tuple[F64, F64]:
    """Derivatives of a frustum's ring radii and slice means of rho² with respect to its taper
    (tip / base radius), as :func:`slice_rings` and :func:`slice_means` give them.

    Parameters
    ----------
    taper : array-like, shape (N,)
    n : int
        Slices.
    ring : {"mean", "rms"}

    Returns
    -------
    d_radius, d_mean2 : ndarray, shape (N, n)
        ∂(ring radius / base radius)/∂taper and ∂(n ∫ rho² du over the slice)/∂taper.
    """
    lam = np.asarray(taper, dtype=np.float64)[..., None]
    edges = np.linspace(0.0, 1.0, n + 1)
    da, db = edges[:-1], edges[1:]  # rho = 1 + (taper - 1) u: ∂rho/∂taper = u
    a, b = 1.0 + (lam - 1.0) * da, 1.0 + (lam - 1.0) * db
    a2, b2, ab = a * a, b * b, a * b
    mean2 = (a2 + ab + b2) / 3.0
    d2 = ((2.0 * a + b) * da + (a + 2.0 * b) * db) / 3.0
    if ring == "mean":
        return np.asarray(0.5 * (da + db) + 0.0 * lam), np.asarray(d2)
    mean4 = (a2 * a2 + a2 * ab + a2 * b2 + ab * b2 + b2 * b2) / 5.0
    d4 = ((4.0 * a2 * a + 3.0 * a2 * b + 2.0 * a * b2 + b2 * b) * da
          + (a2 * a + 2.0 * a2 * b + 3.0 * a * b2 + 4.0 * b2 * b) * db) / 5.0
    safe2 = np.where(mean2 > 0.0, mean2, 1.0)
    radius = np.sqrt(0.5 * mean4 / safe2)
    good = (radius > 0.0) & (mean2 > 0.0)
    d_radius = np.where(good, 0.25 * (d4 * mean2 - mean4 * d2)
                        / (safe2 * safe2 * np.where(good, radius, 1.0)), 0.0)
    return np.asarray(d_radius), np.asarray(d2)


def radius_at(u: F64, rho: F64, t: ArrayLike) -> F64:
    """Normalised radius at fractions ``t`` = s / height of the length (any shape; clamped to the
    ends beyond [0, 1])."""
    return np.asarray(np.interp(np.asarray(t, dtype=np.float64), u, rho), dtype=np.float64)


def contains(height: float, base_radius: float, u: F64, rho: F64, axial: ArrayLike,
             radial: ArrayLike) -> NDArray[np.bool_]:
    """Whether points in the body frame (axial coordinate from the base and distance from the axis,
    m) lie inside or on the body. Broadcasts."""
    ax = np.asarray(axial, dtype=np.float64)
    inside_len = (ax >= 0.0) & (ax <= height)
    r = base_radius * radius_at(u, rho, np.clip(ax, 0.0, height) / height)
    return inside_len & (np.asarray(radial, dtype=np.float64) <= r)


def volume(height: float, base_radius: float, u: F64, rho: F64) -> float:
    """Volume of the body, m³ (a frustum: π h/3 (r_b² + r_b r_t + r_t²))."""
    return math.pi * height * base_radius**2 * float(mean_square_radius(u, rho))
