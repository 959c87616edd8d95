"""Finite elements of the cilium as a clamped Euler–Bernoulli beam of revolution (pure arrays;
:mod:`magcilia.mechanics.modal` builds the modes on them).

Hermite cubic elements (two nodes, deflection and slope at each: C¹ shapes) on a uniform mesh
of the length; the clamped base removes the first node's two degrees of freedom. Every matrix is
integrated by 5-point Gauss–Legendre on each part of an element between the profile's knots,
where r(s) is linear: the stiffness (EI ∝ r⁴ times products of linear second derivatives, degree
6), the mass (ρA ∝ r² times products of cubics, degree 8) and the geometric stiffness (degree ≤ 6)
are then integrated exactly for a frustum and for any measured profile, whatever its number of
points. The only discretisation error is the elements' (O(h⁴) in the eigenvalues; stated in
``docs/dynamics.md``).

Quantities per unit length are given at the quadrature points (:class:`Mesh` holds them), so the
fluid's added mass and damping, which depend on the local radius and the frequency, are
assembled the same way (:meth:`Mesh.assemble`).
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np
from numpy.typing import NDArray

from magcilia.device.cilium import Cilium

F64 = NDArray[np.float64]
I64 = NDArray[np.int64]

#: Gauss–Legendre points and weights on [0, 1], 5 points (exact to degree 9)
_GX, _GW = np.polynomial.legendre.leggauss(5)
_GX, _GW = 0.5 * (_GX + 1.0), 0.5 * _GW


@dataclass(frozen=True)
class Mesh:
    """A beam mesh and its quadrature points (arrays; built by :func:`mesh`).

    Attributes
    ----------
    nodes : ndarray, shape (E + 1,)
        Node arc lengths, m, 0 … L.
    element : ndarray of int, shape (q,)
        The element of each quadrature point.
    s : ndarray, shape (q,)
        Arc length of each quadrature point, m.
    weight : ndarray, shape (q,)
        Quadrature weights, m.
    radius : ndarray, shape (q,)
        Radius at each point, m.
    values : ndarray, shape (q, 4)
        The four Hermite shape functions at each point (deflection, slope, deflection, slope of
        the element's two nodes), dimensionless or m.
    slopes : ndarray, shape (q, 4)
        Their first derivatives along s.
    curvatures : ndarray, shape (q, 4)
        Their second derivatives along s.
    """

    nodes: F64
    element: I64
    s: F64
    weight: F64
    radius: F64
    values: F64
    slopes: F64
    curvatures: F64

    @property
    def dofs(self) -> int:
        """Free degrees of freedom: two per node, less the clamped base's two."""
        return 2 * (self.nodes.size - 1)

    def assemble(self, per_length: F64, kind: str) -> F64:
        """A free-free global matrix less the clamped node, shape (dofs, dofs):
        ``Σ_q w_q c_q a_q a_qᵀ`` with ``c`` ``per_length`` at the quadrature points (shape (q,))
        and ``a`` the shape functions (``kind="mass"``), their slopes (``"geometric"``) or their
        curvatures (``"stiffness"``)."""
        basis = {"mass": self.values, "geometric": self.slopes,
                 "stiffness": self.curvatures}[kind]
        weighted = basis * (self.weight * per_length)[:, None]
        count = self.nodes.size - 1
        blocks = np.zeros((count, 4, 4))
        np.add.at(blocks, self.element, weighted[:, :, None] * basis[:, None, :])
        full = np.zeros((2 * count + 2, 2 * count + 2))
        for e0 in (0, 1):  # even and odd elements do not share nodes: no overlap in one pass
            idx = np.arange(e0, count, 2)
            rows = 2 * idx[:, None] + np.arange(4)
            full[rows[:, :, None], rows[:, None, :]] += blocks[idx]
        return full[2:, 2:]

    def at_points(self, vectors: F64, which: str = "values") -> F64:
        """Fields at the quadrature points from free-DOF vectors ``vectors`` (shape (k, dofs)):
        their deflection (``"values"``), slope or curvature there, shape (k, q)."""
        basis = {"values": self.values, "slopes": self.slopes,
                 "curvatures": self.curvatures}[which]
        full = np.concatenate([np.zeros((vectors.shape[0], 2)), vectors], axis=1)
        idx = 2 * self.element[:, None] + np.arange(4)  # (q, 4)
        return np.asarray(np.einsum("kqj,qj->kq", full[:, idx], basis), dtype=np.float64)


def mesh(cilium: Cilium, elements: int) -> Mesh:
    """The uniform mesh of ``elements`` Hermite elements on the cilium and its quadrature
    (5 Gauss points on each part of an element between the profile's knots)."""
    length = cilium.height
    nodes = np.linspace(0.0, length, elements + 1)
    knots = np.asarray(cilium.shape[0]) * length
    inner = knots[(knots > 0.0) & (knots < length)]
    edges = np.union1d(nodes, inner)
    edges = edges[np.concatenate([[True], np.diff(edges) > 1e-12 * length])]
    edges[-1] = length
    a, b = edges[:-1], edges[1:]
    s = (a[:, None] + np.outer(b - a, _GX)).ravel()
    weight = np.outer(b - a, _GW).ravel()
    element = np.minimum(np.searchsorted(nodes, s, side="right") - 1, elements - 1)
    h = length / elements
    xi = (s - nodes[element]) / h
    return Mesh(nodes, element.astype(np.int64), s, weight, cilium.radius(s),
                *(_hermite(xi, h, which) for which in ("values", "slopes", "curvatures")))


def _hermite(xi: F64, h: float, which: str) -> F64:
    """The four Hermite cubics of an element of length ``h`` (m) at local coordinates ``xi``
    (0 … 1, shape (q,)): values, slopes (1/m) or curvatures (1/m²) along s, shape (q, 4)."""
    x2, x3 = xi * xi, xi * xi * xi
    if which == "values":
        parts = [1 - 3 * x2 + 2 * x3, h * (xi - 2 * x2 + x3), 3 * x2 - 2 * x3, h * (x3 - x2)]
    elif which == "slopes":
        parts = [(6 * x2 - 6 * xi) / h, 1 - 4 * xi + 3 * x2, (6 * xi - 6 * x2) / h,
                 3 * x2 - 2 * xi]
    else:
        parts = [(12 * xi - 6) / h**2, (6 * xi - 4) / h, (6 - 12 * xi) / h**2, (6 * xi - 2) / h]
    return np.stack(parts, axis=1)


def interpolate(grid: Mesh, vectors: F64, s: F64, which: str = "values") -> F64:
    """Fields of free-DOF vectors (shape (k, dofs)) at arc lengths ``s`` (m, shape (m,), within
    0 … L): their deflection (``"values"``), or slope (``"slopes"``), by the elements' Hermite
    cubics; shape (k, m)."""
    nodes = grid.nodes
    count = nodes.size - 1
    h = nodes[1] - nodes[0]
    element = np.clip(np.searchsorted(nodes, s, side="right") - 1, 0, count - 1)
    xi = (np.asarray(s, dtype=np.float64) - nodes[element]) / h
    basis = _hermite(xi, h, which)
    full = np.concatenate([np.zeros((vectors.shape[0], 2)), vectors], axis=1)
    idx = 2 * element[:, None] + np.arange(4)
    return np.asarray(np.einsum("kqj,qj->kq", full[:, idx], basis), dtype=np.float64)


def weight_above(cilium: Cilium, s: F64) -> F64:
    """Volume of the body above arc length ``s`` (m, shape (q,)), m³: exact for the piecewise
    linear radius (the axial load of self-weight is this times (ρ − ρ_fluid) g)."""
    length = cilium.height
    knots = np.asarray(cilium.shape[0]) * length
    r_knots = cilium.radius(knots)
    parts = math.pi * np.diff(knots) * (r_knots[:-1] ** 2 + r_knots[:-1] * r_knots[1:]
                                        + r_knots[1:] ** 2) / 3.0
    after = np.concatenate([np.cumsum(parts[::-1])[::-1], [0.0]])  # volume above each knot
    k = np.minimum(np.searchsorted(knots, s, side="right"), knots.size - 1)  # next knot's index
    r, rk = cilium.radius(s), r_knots[k]
    return np.asarray(math.pi * (knots[k] - s) * (r * r + r * rk + rk * rk) / 3.0 + after[k],
                      dtype=np.float64)
