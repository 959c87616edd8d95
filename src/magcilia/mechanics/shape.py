"""BentShape: one static equilibrium shape of the cilium, usable wherever a Centreline is."""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Any

import numpy as np
from numpy.typing import NDArray

from magcilia._display import Item, dataframe, number, scaled, si
from magcilia.mechanics.flow import Flow
from magcilia.model.centreline import Centreline

F64 = NDArray[np.float64]


@dataclass(frozen=True)
class Load:
    """The load of a bent shape (SI).

    Parameters
    ----------
    force : float
        Dead point force magnitude, N (signed: negative pushes the other way).
    direction : float
        Direction of the force in the x–z plane, rad from +z toward +x (π/2 = +x).
    at : float
        Arc length of the point of application, m.
    flow : Flow or None
        Fluid flow past the cilium.
    """

    force: float = 0.0
    direction: float = 0.5 * np.pi
    at: float = 0.0
    flow: Flow | None = None


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
        return {
            "load": {"force_N": load.force, "direction_rad": load.direction, "at_m": load.at,
                     "flow": None if load.flow is None else load.flow.describe()},
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
