"""Flow profiles past the cilium: uniform, linear wall shear and user-supplied.

The cilium stands on a wall: ``z`` is the height above the wall, measured from the cilium's base
(z = 0), in m. The flow is horizontal, along +x (the sensor's sensitive axis; negative speeds flow
toward −x) by default, or along ``(cos φ, sin φ, 0)`` for a flow of ``azimuth`` φ (rad).
A profile is ``U(z) = speed · shape(z)``; ``speed`` is the single number that the read-out
estimates (the uniform speed, the speed at a reference height, or a user factor).
"""

from __future__ import annotations

import math
from collections.abc import Callable
from dataclasses import dataclass, field, replace

import numpy as np
from numpy.typing import NDArray

from magcilia import _validate as v
from magcilia._display import Display, Item, number, scaled
from magcilia.mechanics.drag import WATER, Fluid

F64 = NDArray[np.float64]


def _one(z: F64) -> F64:
    return np.ones_like(z)


@dataclass(frozen=True, repr=False)
class Flow(Display):
    """A horizontal flow over the wall, ``U(z) = speed · shape(z)`` (m/s) along
    ``(cos φ, sin φ, 0)`` (φ = ``azimuth``; default 0: along +x).

    Build it with :meth:`uniform`, :meth:`shear` or :meth:`custom`.

    Parameters
    ----------
    speed : float
        Scale of the profile, m/s (the read-out quantity).
    shape : callable
        Vectorised ``shape(z)`` for heights z (m, ndarray of any shape) -> same shape,
        dimensionless.
    fluid : Fluid
        The fluid (default :data:`~magcilia.mechanics.WATER`).
    kind : str
        ``"uniform"``, ``"shear"`` or ``"custom"`` (for reports).
    reference_height : float
        Height (m) at which ``U = speed`` for a shear flow; 0 otherwise.
    azimuth : float
        Direction of the flow in the horizontal plane, rad from +x toward +y (default 0: +x).
    """

    speed: float
    shape: Callable[[F64], F64] = field(default=_one, repr=False)
    fluid: Fluid = WATER
    kind: str = "uniform"
    reference_height: float = 0.0
    azimuth: float = 0.0

    def __post_init__(self) -> None:
        object.__setattr__(self, "speed", v.real("speed", self.speed, "m/s"))
        if not (isinstance(self.azimuth, float | int) and self.azimuth == 0.0):
            object.__setattr__(self, "azimuth", v.real("azimuth", self.azimuth, "rad"))
        if not isinstance(self.fluid, Fluid):
            raise v.fail("fluid", type(self.fluid).__name__, "a magcilia Fluid (AIR, WATER, …)")

    @classmethod
    def uniform(cls, speed: float, fluid: Fluid = WATER, *, azimuth: float = 0.0) -> Flow:
        """Uniform flow ``U(z) = speed`` (m/s), toward ``azimuth`` (rad from +x)."""
        return cls(speed=speed, fluid=fluid, kind="uniform", azimuth=azimuth)

    @classmethod
    def shear(cls, *, rate: float | None = None, speed: float | None = None,
              height: float | None = None, fluid: Fluid = WATER, azimuth: float = 0.0) -> Flow:
        """Linear wall shear ``U(z) = rate · z``, toward ``azimuth`` (rad from +x).

        Give either ``rate`` (1/s) or ``speed`` (m/s) at reference ``height`` (m, > 0).
        """
        if rate is not None:
            if speed is not None or height is not None:
                raise v.fail("shear", "rate with speed/height", "either rate, or speed and height")
            r = v.real("rate", rate, "1/s")
            return cls(speed=r * 1e-3, shape=_Linear(1e-3), fluid=fluid, kind="shear",
                       reference_height=1e-3, azimuth=azimuth)
        if speed is None or height is None:
            raise v.fail("shear", "incomplete arguments", "given a rate, or a speed and a height")
        h = v.positive("height", height)
        return cls(speed=speed, shape=_Linear(h), fluid=fluid, kind="shear", reference_height=h,
                   azimuth=azimuth)

    @classmethod
    def custom(cls, profile: Callable[[F64], F64], fluid: Fluid = WATER,
               speed: float = 1.0, *, azimuth: float = 0.0) -> Flow:
        """A user profile ``U(z) = speed · profile(z)``; ``profile`` must be vectorised (m -> m/s
        for ``speed = 1``); toward ``azimuth`` (rad from +x)."""
        if not callable(profile):
            raise v.fail("profile", type(profile).__name__, "a callable U(z)")
        z = np.linspace(0.0, 1e-2, 5)
        try:
            test = np.asarray(profile(z), dtype=np.float64)
        except Exception as exc:  # any user error is reported as one line
            raise v.fail("profile", f"a callable raising {type(exc).__name__}",
                         "a vectorised callable U(z) (ndarray in, same-shape ndarray out)") from exc
        if test.shape != z.shape or not np.all(np.isfinite(test)):
            raise v.fail("profile", f"a callable returning shape {test.shape}",
                         "a vectorised callable returning finite values of the shape of z")
        return cls(speed=speed, shape=profile, fluid=fluid, kind="custom", azimuth=azimuth)

    def with_speed(self, speed: float) -> Flow:
        """The same profile scaled to another ``speed`` (m/s)."""
        return replace(self, speed=speed)

    def with_azimuth(self, azimuth: float) -> Flow:
        """The same flow turned toward another ``azimuth`` (rad from +x)."""
        return replace(self, azimuth=azimuth)

    @property
    def direction(self) -> F64:
        """Unit vector of the flow, ``(cos φ, sin φ, 0)``, shape (3,)."""
        return np.array([math.cos(self.azimuth), math.sin(self.azimuth), 0.0])

    def velocity(self, z: F64) -> F64:
        """Flow speed along the flow's direction (+x for azimuth 0), m/s, at heights ``z``
        (m above the base, any shape)."""
        return self.speed * np.asarray(self.shape(z), dtype=np.float64)

    def describe(self) -> str:
        """One-line description (mm, m/s; deg for a flow not along +x)."""
        toward = "" if self.azimuth == 0.0 else \
            f", toward azimuth {math.degrees(self.azimuth):.4g} deg"
        if self.kind == "shear":
            return (f"linear shear flow of {self.fluid.name}, {self.speed:.4g} m/s at "
                    f"{self.reference_height * 1e3:.4g} mm{toward}")
        return f"{self.kind} flow of {self.fluid.name}, {self.speed:.4g} m/s{toward}"

    def _display_items(self) -> list[Item]:
        items = [("", self.kind), ("speed", f"{number(self.speed)} m/s"),
                 ("fluid", self.fluid.name)]
        if self.reference_height:
            items.append(("reference_height", scaled(self.reference_height, 1e-3, "mm")))
        if self.azimuth:
            items.append(("azimuth", scaled(self.azimuth, math.pi / 180.0, "deg")))
        return items


@dataclass(frozen=True)
class _Linear:
    """shape(z) = z / height (picklable, comparable)."""

    height: float

    def __call__(self, z: F64) -> F64:
        return np.asarray(z, dtype=np.float64) / self.height
