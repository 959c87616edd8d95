"""The cilium's body: a cone or frustum of revolution, and its slicing into n equal-length slices.

Arc length ``s`` runs from the base (s = 0) to the tip (s = height). The radius varies linearly
from ``base_radius`` to ``tip_radius``.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np
from numpy.typing import ArrayLike, NDArray

from magcilia import _validate as v

RINGS = ("mean", "rms")


@dataclass(frozen=True)
class Cilium:
    """A frustum-shaped cilium (a cone when ``tip_radius`` is 0, the paper's case).

    Parameters
    ----------
    height : float
        Length along the axis (arc length when bent), m.
    base_radius : float
        Radius at the base, m.
    tip_radius : float
        Radius at the tip, m; 0 (default) is a sharp cone. Must not exceed ``base_radius``.
    youngs_modulus : float or None
        Young's modulus, Pa, for mechanics; None means "derive it from the material" (see
        :attr:`magcilia.Setup.youngs_modulus`).
    """

    height: float
    base_radius: float
    tip_radius: float = 0.0
    youngs_modulus: float | None = None

    def __post_init__(self) -> None:
        object.__setattr__(self, "height", v.positive("height", self.height))
        object.__setattr__(self, "base_radius", v.positive("base_radius", self.base_radius))
        tip = v.non_negative("tip_radius", self.tip_radius)
        if tip > self.base_radius:
            raise v.fail("tip_radius", tip, f"at most base_radius ({self.base_radius:.6g} m)")
        object.__setattr__(self, "tip_radius", tip)
        if self.youngs_modulus is not None:
            object.__setattr__(
                self,
                "youngs_modulus",
                v.positive("youngs_modulus", self.youngs_modulus, "Pa", "modulus"),
            )

    @property
    def taper(self) -> float:
        """lambda = tip_radius / base_radius (0 for a cone, 1 for a cylinder)."""
        return self.tip_radius / self.base_radius

    @property
    def volume(self) -> float:
        """Volume, m³: pi h/3 (r_b² + r_b r_t + r_t²)."""
        rb, rt = self.base_radius, self.tip_radius
        return math.pi * self.height / 3.0 * (rb * rb + rb * rt + rt * rt)

    def radius(self, s: ArrayLike) -> NDArray[np.float64]:
        """Radius at arc length ``s`` (m, any shape) -> same shape, m."""
        s = np.asarray(s, dtype=np.float64)
        return self.base_radius + (self.tip_radius - self.base_radius) * (s / self.height)

    def second_moment(self, s: ArrayLike) -> NDArray[np.float64]:
        """Second moment of area of the cross-section, I(s) = pi r(s)⁴ / 4, m⁴."""
        return 0.25 * math.pi * self.radius(s) ** 4

    def slice_edges(self, n: int) -> NDArray[np.float64]:
        """Arc lengths of the n + 1 slice boundaries, m, shape (n + 1,)."""
        return np.linspace(0.0, self.height, n + 1)

    def slice_volumes(self, n: int) -> NDArray[np.float64]:
        """Volumes of the n equal-length frustum slices, m³, shape (n,); they sum to the volume."""
        r = self.radius(self.slice_edges(n))
        r1, r2 = r[:-1], r[1:]
        return math.pi * (self.height / n) / 3.0 * (r1 * r1 + r1 * r2 + r2 * r2)

    def ring_radii(self, n: int, ring: str = "mean") -> NDArray[np.float64]:
        """Radius of each slice's dipole ring, m, shape (n,).

        ``"mean"`` (the paper): (r_bottom + r_top)/2. ``"rms"``: sqrt of the slice's
        volume-averaged rho², i.e. sqrt(∫ r⁴/2 dz / ∫ r² dz), which for a disc is r/√2 and makes
        the ring reproduce the slice's second radial moment.
        """
        r = self.radius(self.slice_edges(n))
        r1, r2 = r[:-1], r[1:]
        if ring == "mean":
            return 0.5 * (r1 + r2)
        # ∫0^1 (r1 + (r2-r1)u)^p du in closed form for p = 2 and 4
        int2 = (r1 * r1 + r1 * r2 + r2 * r2) / 3.0
        int4 = (r1**4 + r1**3 * r2 + r1**2 * r2**2 + r1 * r2**3 + r2**4) / 5.0
        return np.sqrt(0.5 * int4 / int2)

    def contains(self, axial: ArrayLike, radial: ArrayLike) -> NDArray[np.bool_]:
        """Whether points given in the body frame (axial coordinate from the base, m; distance
        from the axis, m) lie inside or on the body. Broadcasts."""
        axial = np.asarray(axial, dtype=np.float64)
        radial = np.asarray(radial, dtype=np.float64)
        inside_len = (axial >= 0.0) & (axial <= self.height)
        return inside_len & (radial <= self.radius(np.clip(axial, 0.0, self.height)))
