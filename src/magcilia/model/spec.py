"""What the field model needs of a sensor, as plain numbers and small arrays.

:class:`ModelSpec` is built by :attr:`magcilia.Setup.spec`; the functions of :mod:`magcilia.model`
take a spec (or any object with a ``spec`` attribute, such as a Setup) and never import the
objects above them.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from functools import cached_property
from typing import Protocol

import numpy as np
from numpy.typing import NDArray

from magcilia import _validate as v
from magcilia.model import body
from magcilia.model.layout import ring_layout

F64 = NDArray[np.float64]


@dataclass(frozen=True, eq=False)
class ModelSpec:
    """A cilium over a single-axis sensor, reduced to what the dipole model evaluates (SI).

    Attributes
    ----------
    height, base_radius, tip_radius : float
        Length along the centreline and radii, m.
    knots, radii : ndarray, shape (q,)
        Normalised shape (s / height, r / base_radius), see :mod:`magcilia.model.body`.
    measured : bool
        True for a measured profile (batch samples scale it by their height and base radius);
        False for a frustum (batch samples take their own tip radius).
    position : (float, float, float)
        The paper's (x_f, y_f, z_f), m: base centre relative to the case top above the element.
    depth : float
        Depth of the sensing element below the case top, m.
    full_magnetization : float
        φ · M_Co, A/m: the composite's magnetization at ``magnetization_scale = 1``.
    magnetization_scale : float
        Effective fraction of it (dimensionless).
    n_loops, dipoles_per_loop : int
        The model's n slices and k dipoles per slice.
    ring : {"mean", "rms"}
        Ring radius rule.
    scale : float
        Sensor output per field on the sensitive axis (+x), V/T.
    offset : float
        Output offset, V.
    """

    height: float
    base_radius: float
    tip_radius: float
    knots: F64
    radii: F64
    measured: bool
    position: tuple[float, float, float]
    depth: float
    full_magnetization: float
    magnetization_scale: float
    n_loops: int
    dipoles_per_loop: int
    ring: str
    scale: float
    offset: float

    def __post_init__(self) -> None:
        for name in ("knots", "radii"):
            arr = np.array(getattr(self, name), dtype=np.float64)
            arr.setflags(write=False)
            object.__setattr__(self, name, arr)

    @cached_property
    def base_centre(self) -> F64:
        """Base centre in the sensor frame, m, shape (3,), read-only: (x_f, y_f, depth + z_f)."""
        x, y, z = self.position
        centre = np.array([x, y, self.depth + z])
        centre.setflags(write=False)
        return centre

    @property
    def magnetization(self) -> float:
        """Magnetization of the composite, A/m (scale included)."""
        return self.magnetization_scale * self.full_magnetization

    @property
    def volume(self) -> float:
        """Volume of the cilium, m³."""
        return body.volume(self.height, self.base_radius, self.knots, self.radii)

    @property
    def moment(self) -> float:
        """Total moment m_c = M · V_c (the paper's eq. 1), A·m²."""
        return self.magnetization * self.volume

    @property
    def max_radius(self) -> float:
        """Largest radius of the body, m."""
        return self.base_radius * float(self.radii.max())

    def params(self) -> dict[str, float]:
        """The model's parameters by name (SI): the keys that the batch functions accept."""
        x, y, z = self.position
        return {
            "height": self.height, "base_radius": self.base_radius, "tip_radius": self.tip_radius,
            "x": x, "y": y, "z": z, "n_loops": self.n_loops,
            "dipoles_per_loop": self.dipoles_per_loop,
            "magnetization_scale": self.magnetization_scale, "offset": self.offset,
        }

    def radius(self, s: object) -> F64:
        """Radius at arc length ``s`` (m, any shape) -> same shape, m."""
        t = np.asarray(s, dtype=np.float64) / self.height
        return self.base_radius * body.radius_at(self.knots, self.radii, t)

    @cached_property
    def body_dipoles(self) -> tuple[F64, F64]:
        """Dipoles of the straight cilium in the body frame: positions (d, 3), m, relative to the
        base centre with the axis along z, and moments along the axis (d,), A·m²."""
        pos, w = ring_layout(np.array([self.height]), np.array([self.base_radius]), self.knots,
                             self.radii, self.n_loops, self.dipoles_per_loop, self.ring)
        return pos[0], w[0] * self.moment

    @cached_property
    def element_always_clear(self) -> bool:
        """True if no tilt about y can bring the cilium onto the sensing element: its distance
        from the tilt plane (|y|) exceeds the largest radius, or its distance from the base centre
        exceeds the farthest point of the body."""
        rel = self.base_centre
        reach = math.hypot(self.height, self.max_radius)
        return abs(rel[1]) > self.max_radius or float(np.linalg.norm(rel)) > reach


class SupportsSpec(Protocol):
    """Anything that can describe itself as a :class:`ModelSpec` (e.g. :class:`magcilia.Setup`)."""

    @property
    def spec(self) -> ModelSpec: ...


def as_spec(model: ModelSpec | SupportsSpec) -> ModelSpec:
    """The :class:`ModelSpec` of ``model`` (a spec, or an object with a ``spec`` attribute)."""
    if isinstance(model, ModelSpec):
        return model
    spec = getattr(model, "spec", None)
    if not isinstance(spec, ModelSpec):
        raise v.fail("model", type(model).__name__, "a magcilia Setup (or its ModelSpec)")
    return spec
