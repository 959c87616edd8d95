"""BentShape and SpatialBentShape: one static equilibrium shape of the cilium, usable wherever a
Centreline (planar, in the x–z plane) or a SpatialCentreline (any direction) is."""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Any

import numpy as np
from numpy.typing import NDArray

from magcilia._display import Item, dataframe, number, scaled, si
from magcilia.device.actuation import Actuation
from magcilia.mechanics.flow import Flow
from magcilia.model.centreline import Centreline, SpatialCentreline

F64 = NDArray[np.float64]


@dataclass(frozen=True)
class Load:
    """The load of a bent shape (SI).

    Parameters
    ----------
    force : float
        Dead point force magnitude, N (signed: negative pushes the other way).
    direction : float
        Direction of the force in its vertical plane, rad from +z toward the plane's horizontal
        direction (π/2: horizontal).
    at : float
        Arc length of the point of application, m.
    flow : Flow or None
        Fluid flow past the cilium (it carries its own azimuth).
    azimuth : float
        Azimuth of the force's vertical plane, rad from +x toward +y (0: the x–z plane).
    actuation : Actuation or None
        External field acting on the cilium's magnetization.
    """

    force: float = 0.0
    direction: float = 0.5 * np.pi
    at: float = 0.0
    flow: Flow | None = None
    azimuth: float = 0.0
    actuation: Actuation | None = None

    @property
    def vector(self) -> F64:
        """The dead force as a vector (F_x, F_y, F_z), N, shape (3,)."""
        h = self.force * math.sin(self.direction)
        return np.array([h * math.cos(self.azimuth), h * math.sin(self.azimuth),
                         self.force * math.cos(self.direction)])

    def describe(self) -> dict[str, Any]:
        """JSON-ready (SI) description: the force vector, its arc length, the flow, the field."""
        return {"force_N": self.vector.tolist(), "at_m": self.at,
                "flow": None if self.flow is None else self.flow.describe(),
                "actuation": None if self.actuation is None else self.actuation.to_dict()}


@dataclass(frozen=True, eq=False, repr=False)
class BentShape(Centreline):
    """One static shape of the cilium (a :class:`~magcilia.Centreline` with a = 1).

    ``setup.output(shape)`` and ``setup.field(shape)`` evaluate the bent field (slices follow the
    centreline, each magnetized along its local tangent). ``s`` (m,), ``angles`` (1, m) and
    ``points`` (1, m, 3) are as for any Centreline, on a uniform arc-length grid.

    Attributes
    ----------
    load : Load
        The load that made it.
    residual : float
        Largest collocation residual at convergence, rad.
    iterations : int
        Newton iterations in total (over all continuation steps).
    nodes : int
        Collocation nodes used.
    """

    load: Load = Load()
    residual: float = 0.0
    iterations: int = 0
    nodes: int = 0

    @classmethod
    def _solved(cls, s: F64, angles: F64, points: F64, load: Load, residual: float,
                iterations: int, nodes: int) -> BentShape:
        """The shape of the solver's own arrays, ``s`` (m,), ``angles`` (1, m) and ``points``
        (1, m, 3) (float64, finite and of matching shapes by construction: a converged
        solution), made read-only as the constructor makes them, without the constructor's
        checks of user input (a tenth of a bend's time)."""
        shape = object.__new__(cls)
        for arr in (s, angles, points):
            arr.setflags(write=False)
        for name, value in (("s", s), ("angles", angles), ("points", points), ("load", load),
                            ("residual", residual), ("iterations", iterations),
                            ("nodes", nodes)):
            object.__setattr__(shape, name, value)
        return shape

    @property
    def tip(self) -> F64:  # one shape: (3,) rather than (1, 3)
        """Tip position relative to the base centre, m, shape (3,): x along +x (the default
        force direction), z along the unloaded axis."""
        return np.asarray(self.points[0, -1, :], dtype=np.float64)

    @property
    def tip_angle(self) -> float:  # type: ignore[override]
        """Tangent angle at the tip, rad (from +z toward +x)."""
        return float(self.angles[0, -1])

    @property
    def deflection(self) -> float:
        """Tip displacement along x, m."""
        return float(self.points[0, -1, 0])

    def to_dict(self) -> dict[str, Any]:
        """JSON-ready content (SI): the load, the tip, the solver figures and the centreline."""
        load = self.load
        described: dict[str, Any] = {
            "force_N": load.force, "direction_rad": load.direction, "at_m": load.at,
            "flow": None if load.flow is None else load.flow.describe()}
        if load.actuation is not None:
            described["actuation"] = load.actuation.to_dict()
        return {
            "load": described,
            "tip_m": self.tip.tolist(), "tip_angle_rad": self.tip_angle,
            "residual_rad": self.residual, "iterations": self.iterations, "nodes": self.nodes,
            "centreline_m": {"s": self.s.tolist(), "x": self.points[0, :, 0].tolist(),
                             "z": self.points[0, :, 2].tolist()},
        }

    def report(self) -> str:
        """One line: the tip position (mm) and angle (deg)."""
        x, _, z = self.tip * 1e3
        return (f"tip x {x:.6g} mm, z {z:.6g} mm from the base centre; tip angle "
                f"{math.degrees(self.tip_angle):.6g} deg")

    def _display_items(self) -> list[Item]:
        load = self.load
        items = [("tip angle", scaled(float(np.ravel(self.angles)[-1]), math.pi / 180.0, "deg")),
                 ("force", si(load.force, "N"))]
        if load.flow is not None:
            items.append(("flow", f"{load.flow.kind} {number(load.flow.speed)} m/s"))
        if load.actuation is not None:
            items.append(("actuation", load.actuation.kind))
        tip = np.reshape(self.points, (-1, 3))[-1]
        return [*items, ("tip x, z", f"{tip[0] * 1e3:.3g}, {tip[2] * 1e3:.3g} mm"),
                ("nodes", str(self.nodes)), ("iterations", str(self.iterations)),
                ("residual", number(self.residual))]

    def to_dataframe(self) -> Any:
        """The centreline as a ``pandas.DataFrame``, one row per node: ``s_m`` (arc length),
        ``angle_rad`` (tangent angle from +z toward +x), ``x_m``, ``z_m`` (from the base centre).
        """
        points = np.reshape(self.points, (-1, 3))
        return dataframe({"s_m": self.s, "angle_rad": np.ravel(self.angles),
                          "x_m": points[:, 0], "z_m": points[:, 2]})


@dataclass(frozen=True, eq=False, repr=False)
class SpatialBentShape(SpatialCentreline):
    """One static shape of the cilium bent in any direction (a
    :class:`~magcilia.SpatialCentreline` with a = 1).

    Returned by :func:`magcilia.bend` when the loads do not all lie in the x–z plane: a planar
    shape turned into its vertical plane (``plane`` is that plane's azimuth), or the 3-D rod's
    shape for loads that leave any one plane (``plane`` None). ``s`` (m,), ``points``,
    ``tangents`` and ``normals`` (1, m, 3) are as for any SpatialCentreline, on a uniform
    arc-length grid.

    Attributes
    ----------
    load : Load
        The load that made it.
    residual : float
        Largest collocation residual at convergence (rad for the planar solver; tangent-vector
        units, also ~rad, for the 3-D rod).
    iterations : int
        Newton iterations in total (over all continuation steps).
    nodes : int
        Collocation nodes used.
    plane : float or None
        Azimuth of the vertical plane of a planar shape, rad; None for a 3-D shape.
    """

    load: Load = Load()
    residual: float = 0.0
    iterations: int = 0
    nodes: int = 0
    plane: float | None = None

    @property
    def tip(self) -> F64:  # one shape: (3,) rather than (1, 3)
        """Tip position relative to the base centre, m, shape (3,)."""
        return np.asarray(self.points[0, -1, :], dtype=np.float64)

    @property
    def tip_tangent(self) -> F64:
        """Unit tangent at the tip, shape (3,)."""
        return np.asarray(self.tangents[0, -1, :], dtype=np.float64)

    @property
    def tip_angle(self) -> float:
        """Angle of the tip tangent from +z, rad, in [0, π]."""
        t = self.tip_tangent
        return float(math.atan2(math.hypot(t[0], t[1]), t[2]))

    @property
    def deflection(self) -> float:
        """Horizontal tip displacement, m (≥ 0)."""
        return float(math.hypot(self.tip[0], self.tip[1]))

    @property
    def tip_azimuth(self) -> float:
        """Azimuth of the horizontal tip displacement, rad from +x toward +y (0 if none)."""
        return float(math.atan2(self.tip[1], self.tip[0])) if self.deflection > 0.0 else 0.0

    def to_dict(self) -> dict[str, Any]:
        """JSON-ready content (SI): the load, the tip, the solver figures and the centreline."""
        pts, tan = self.points[0], self.tangents[0]
        return {
            "load": self.load.describe(), "plane_azimuth_rad": self.plane,
            "tip_m": self.tip.tolist(), "tip_angle_rad": self.tip_angle,
            "tip_azimuth_rad": self.tip_azimuth, "deflection_m": self.deflection,
            "residual_rad": self.residual, "iterations": self.iterations, "nodes": self.nodes,
            "centreline_m": {"s": self.s.tolist(), "x": pts[:, 0].tolist(),
                             "y": pts[:, 1].tolist(), "z": pts[:, 2].tolist()},
            "tangents": {"x": tan[:, 0].tolist(), "y": tan[:, 1].tolist(),
                         "z": tan[:, 2].tolist()},
        }

    def report(self) -> str:
        """One line: the tip position (mm), its azimuth and the tip angle (deg)."""
        x, y, z = self.tip * 1e3
        return (f"tip x {x:.6g} mm, y {y:.6g} mm, z {z:.6g} mm from the base centre (azimuth "
                f"{math.degrees(self.tip_azimuth):.6g} deg); tip angle "
                f"{math.degrees(self.tip_angle):.6g} deg")

    def _display_items(self) -> list[Item]:
        load = self.load
        force = float(np.linalg.norm(load.vector))
        items = [("tip angle", scaled(self.tip_angle, math.pi / 180.0, "deg")),
                 ("azimuth", scaled(self.tip_azimuth, math.pi / 180.0, "deg")),
                 ("force", si(force, "N"))]
        if load.flow is not None:
            items.append(("flow", f"{load.flow.kind} {number(load.flow.speed)} m/s"))
        if load.actuation is not None:
            items.append(("actuation", load.actuation.kind))
        tip = self.tip * 1e3
        return [*items, ("tip", "(" + ", ".join(f"{c:.3g}" for c in tip) + ") mm"),
                ("solver", "3-D rod" if self.plane is None else "planar"),
                ("nodes", str(self.nodes)), ("iterations", str(self.iterations)),
                ("residual", number(self.residual))]

    def to_dataframe(self) -> Any:
        """The centreline as a ``pandas.DataFrame``, one row per node: ``s_m`` (arc length),
        ``x_m``, ``y_m``, ``z_m`` (from the base centre) and the unit tangent ``tx``, ``ty``,
        ``tz``."""
        pts, tan = self.points[0], self.tangents[0]
        return dataframe({"s_m": self.s, "x_m": pts[:, 0], "y_m": pts[:, 1], "z_m": pts[:, 2],
                          "tx": tan[:, 0], "ty": tan[:, 1], "tz": tan[:, 2]})
