"""The cilium's cross-sections on the elastica's collocation grid, at a cost bounded whatever the
number of points of a measured profile (pure arrays; :mod:`magcilia.mechanics.bend` uses it).

Exact sections. A frustum, or a measured profile with few points, gets a grid whose pieces end
at every kink of r(s): the load point and the profile's knots. Each piece's nodes (24 to 96,
from the Bernstein ellipse of its 1/EI) carry r(s), r(s)² and I(s) = π r⁴/4 sampled there:
spectrally accurate (~1e-12).

Resampled sections. A profile whose knots would need more than :data:`MAX_NODES` nodes (at least
24 per piece: a 1,000-point profile would need 24,000 nodes and a dense (24,000)² influence
matrix, 4.3 GiB, and Newton's O(N³) solves) is resampled onto the solver's grid instead: uniform
pieces (the load point kept as a bound) of :data:`RESAMPLED_NODES` nodes, :data:`MAX_NODES` in
all. Each node carries the mean, over its share of the quadrature (its *cell*: the piece cut at
the running sums of the quadrature weights), of 1/I(s) for the bending compliance (so that
``Σ w_j / EI_j = ∫ ds / EI`` exactly), of r(s) for the diameter (drag) and of r(s)² for the
magnetic moment per length: exact integrals of the piecewise-linear r(s) between its knots, so
that no kink or measurement noise between the nodes is lost or aliased. The bend then costs the
same at any point count and converges as O(N⁻²): the small-load tip deflection of noisy
1,000- and 10,000-point profiles within 1e-5 of the exact ``∫ (L − s)² / EI ds``, large
deflections within 2e-5 of the exact-knot solution where that can still be computed.

A sharp tip (r = 0 at the last knot) makes the last cell's mean compliance infinite; that node
keeps its sampled value (nodes never sit at the tip), as the exact grid does.
"""

from __future__ import annotations

import itertools
import math
from dataclasses import dataclass
from functools import lru_cache

import numpy as np
from numpy.typing import NDArray

from magcilia import _validate as v
from magcilia.device.cilium import Cilium
from magcilia.mechanics.elastica import Grid

F64 = NDArray[np.float64]

#: most collocation nodes of a bend's grid (the influence matrix is N × N, a Newton step O(N³)):
#: a profile whose knots need more is resampled (the module notes)
MAX_NODES = 800
#: nodes per piece of a resampled grid (its pieces: about MAX_NODES / RESAMPLED_NODES)
RESAMPLED_NODES = 24


@dataclass(frozen=True)
class Sections:
    """A bend's collocation grid and the cross-sections at its nodes (immutable arrays).

    Attributes
    ----------
    grid : Grid
        The collocation grid (nodes ``grid.s``, m, shape (N,)).
    radius : ndarray, shape (N,)
        r at the nodes (or its cell mean), m.
    radius_squared : ndarray, shape (N,)
        r² at the nodes (or its cell mean), m².
    second_moment : ndarray, shape (N,)
        I = π r⁴/4 at the nodes (or the harmonic mean of I over the cell), m⁴.
    resampled : bool
        True when the profile was resampled onto a uniform grid (the module notes).
    """

    grid: Grid
    radius: F64
    radius_squared: F64
    second_moment: F64
    resampled: bool


def check_nodes(nodes: object) -> int | None:
    """``nodes`` per piece, checked: None, or a whole number in 4 … MAX_NODES / 2 (a frustum's
    two pieces then stay within :data:`MAX_NODES`)."""
    if nodes is None:
        return None
    count = v.integer("nodes", nodes, 4)
    if count > MAX_NODES // 2:
        raise v.fail("nodes", count, f"at most {MAX_NODES // 2} collocation nodes per piece "
                                     "(MAX_NODES / 2; the default, from the taper, converges to "
                                     "~1e-12)")
    return count


def piece_nodes(cilium: Cilium, bounds: F64) -> tuple[int, ...]:
    """Nodes per piece for ~1e-12 accuracy: from the Bernstein ellipse through the zero of the
    piece's linear r(s) (where 1/EI has its pole). A piece that reaches a cone's tip converges
    only algebraically."""
    sizes = []
    for b0, b1 in itertools.pairwise(bounds):
        r0, r1 = (float(r) for r in cilium.radius(np.array([b0, b1])))
        if r0 == r1:
            n = 24
        else:
            s_pole = b0 + r0 * (b1 - b0) / (r0 - r1)  # beyond either end of the piece
            t = abs(2.0 * s_pole - b0 - b1) / (b1 - b0)
            if t <= 1.0 + 1e-9:
                n = 64
            else:
                rho = t + math.sqrt(t * t - 1.0)
                n = min(max(math.ceil(30.0 / math.log(rho)) + 6, 24), 96)
        sizes.append(n)
    return tuple(sizes)


def _with(bounds: F64, points: F64, length: float) -> F64:
    """``bounds`` with the ``points`` not already within 1e-9 L of one of them."""
    if points.size == 0:
        return bounds
    far = np.abs(points[:, None] - bounds).min(axis=1) > 1e-9 * length
    return np.union1d(bounds, points[far])


def _cell_edges(grid: Grid) -> F64:
    """Cell edges (N + 1,) m: each piece cut at the running sums of its quadrature weights."""
    edges = [np.array([grid.bounds[0]])]
    start = 0
    for k, n in enumerate(grid.sizes):
        inner = grid.bounds[k] + np.cumsum(grid.w[start:start + n])
        inner[-1] = grid.bounds[k + 1]
        edges.append(inner)
        start += n
    return np.concatenate(edges)


def _cell_means(cilium: Cilium, edges: F64) -> tuple[F64, F64, F64]:
    """Means of r, r² and r⁻⁴ over the cells between ``edges`` (m), exact for the piecewise
    linear r(s): the cells cut at the profile's knots, each part integrated in closed form."""
    knots = np.asarray(cilium.shape[0]) * cilium.height
    t = np.union1d(edges, knots[(knots > edges[0]) & (knots < edges[-1])])
    r = cilium.radius(t)
    ra, rb, ds = r[:-1], r[1:], np.diff(t)
    quad = ra * ra + ra * rb + rb * rb
    with np.errstate(divide="ignore"):
        parts = (ds * (ra + rb) / 2.0, ds * quad / 3.0,
                 ds * quad / (3.0 * (ra * rb) ** 3))  # ∫ r, ∫ r², ∫ r⁻⁴ of a linear r
    first = np.searchsorted(t, edges[:-1])
    width = np.diff(edges)
    m1, m2, m4 = (np.add.reduceat(p, first) / width for p in parts)
    return m1, m2, m4


@lru_cache(maxsize=64)
def sections(cilium: Cilium, at: float, point_load: bool, nodes: int | None) -> Sections:
    """The grid and sections of a load case (cached: sweeps and repeated bends share them).

    Parameters
    ----------
    cilium : Cilium
        The body (frustum or measured profile).
    at : float
        Arc length of a point load, m (a piece ends there when ``point_load``).
    point_load : bool
        Whether a point force acts at ``at``.
    nodes : int or None
        Nodes per piece (None: from each piece's taper; a resampled grid uses it instead of
        :data:`RESAMPLED_NODES` and keeps about :data:`MAX_NODES` nodes in all).
    """
    length = cilium.height
    split = point_load and at < length * (1.0 - 1e-12)
    bounds = np.array([0.0, at, length]) if split else np.array([0.0, length])
    knots = (np.asarray(cilium.profile[0][1:-1]) * length if cilium.profile is not None
             else np.empty(0))
    per_piece = RESAMPLED_NODES if nodes is None else nodes
    if (knots.size + bounds.size - 1) * per_piece <= MAX_NODES:
        exact = _with(bounds, knots, length)
        sizes = piece_nodes(cilium, exact) if nodes is None else (nodes,) * (exact.size - 1)
        if sum(sizes) <= MAX_NODES or cilium.profile is None:
            grid = Grid.build(exact, sizes)
            r = cilium.radius(grid.s)
            return _frozen(Sections(grid, r, r * r, cilium.second_moment(grid.s), False))
    pieces = max(1, MAX_NODES // per_piece - (bounds.size - 2))
    uniform = _with(np.linspace(0.0, length, pieces + 1), bounds[1:-1], length)
    grid = Grid.build(uniform, (per_piece,) * (uniform.size - 1))
    m1, m2, m4 = _cell_means(cilium, _cell_edges(grid))
    sampled = cilium.second_moment(grid.s)
    with np.errstate(divide="ignore"):
        second = np.where(np.isfinite(m4), 0.25 * math.pi / m4, sampled)  # a sharp tip's cell
    return _frozen(Sections(grid, m1, m2, second, True))


def _frozen(sec: Sections) -> Sections:
    for arr in (sec.radius, sec.radius_squared, sec.second_moment):
        arr.setflags(write=False)
    return sec


def compliance_integral(cilium: Cilium) -> float:
    """``∫₀ᴸ (L − s)² / I(s) ds`` of a measured profile, m⁻¹ (the small-load tip compliance
    times E): Gauss–Legendre on each knot interval, where r(s) is linear and 1/I smooth, its
    order from the distance to the pole of 1/r⁴ (as :func:`piece_nodes`; ~1e-14 relative), all
    intervals of one order at once: a cost linear in the points (an interval next to a
    near-zero radius, which would need more than 96 points, by adaptive quadrature)."""
    length = cilium.height
    knots = np.asarray(cilium.shape[0]) * length
    a, b = knots[:-1], knots[1:]
    ra, rb = cilium.radius(a), cilium.radius(b)
    with np.errstate(divide="ignore", invalid="ignore"):
        pole = np.where(ra == rb, np.inf, a + ra * (b - a) / (ra - rb))
        t = np.abs(2.0 * pole - a - b) / (b - a)
        rho = t + np.sqrt(np.maximum(t * t - 1.0, 0.0))
        order = np.where(np.isfinite(rho) & (rho > 1.0),
                         np.ceil(16.0 / np.log(np.where(rho > 1.0, rho, 2.0))) + 2, 4)
    order = np.maximum(order, 4).astype(np.int64)
    total = 0.0
    for i in np.flatnonzero(order > 96):  # next to a near-zero radius: adaptive quadrature
        from scipy.integrate import quad  # (SciPy: where first needed)

        total += quad(lambda s: (length - s) ** 2 / float(cilium.second_moment(s)), a[i], b[i],
                      epsabs=0.0, epsrel=1e-12, limit=200)[0]
    for n in np.unique(order[order <= 96]):
        x, w = np.polynomial.legendre.leggauss(int(n))
        sel = order == n
        lo, hi = a[sel, None], b[sel, None]
        s = 0.5 * (lo + hi) + 0.5 * (hi - lo) * x
        total += float(np.sum(0.5 * (hi - lo) * w * (length - s) ** 2 / cilium.second_moment(s)))
    return total
