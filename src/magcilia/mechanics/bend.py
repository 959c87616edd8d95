"""The public bending functions: :func:`bend` (one equilibrium) and :func:`bend_sweep` (a batch),
and the sensor's output under a measurand's loads (:func:`poses_at`, :func:`output_at`).

All SI: forces in N, arc lengths in m, angles in rad, flow speeds in m/s.

The solvers live beside this module: :mod:`.planar` (loads in the x–z plane, the sweeps),
:mod:`.spatial` (loads in any direction, actuation, the 3-D rod, buckling) and
:mod:`.compliance` (the small-load tip compliance); their public names are importable from here
too, as before the split.
"""

from __future__ import annotations

import math
import numbers

import numpy as np
from numpy.typing import ArrayLike, NDArray

from magcilia import _validate as v
from magcilia.device.actuation import Actuation
from magcilia.device.setup import Setup
from magcilia.mechanics.compliance import tip_compliance
from magcilia.mechanics.flow import Flow
from magcilia.mechanics.planar import (
    OUTPUT_POINTS,
    SHARP_TIP,
    _bend_plane,
    _sweep_plane,
    require_tip_radius,
    sweep_values,
)
from magcilia.mechanics.shape import BentShape, SpatialBentShape
from magcilia.mechanics.spatial import (
    SOURCE_TOLERANCE,
    _angle,
    _bend_any,
    buckling_load,
    flip_field,
)
from magcilia.model.centreline import Centreline, SpatialCentreline
from magcilia.model.pose import Pose

F64 = NDArray[np.float64]

__all__ = [
    "OUTPUT_POINTS",
    "SHARP_TIP",
    "SOURCE_TOLERANCE",
    "bend",
    "bend_3d",
    "bend_sweep",
    "buckling_load",
    "flip_field",
    "output_at",
    "poses_at",
    "require_tip_radius",
    "tip_compliance",
]


def bend(setup: Setup, force: float | ArrayLike = 0.0, *, at: float | None = None,
         direction: float = 0.5 * math.pi, azimuth: float = 0.0, flow: Flow | None = None,
         actuation: Actuation | None = None,
         nodes: int | None = None) -> BentShape | SpatialBentShape:
    """Static large-deflection shape of the cilium under a dead point force, a fluid flow and/or
    a magnetic actuation field, bent in any direction.

    Inextensible, unshearable elastica of the real frustum (``setup.cilium``; E from
    ``setup.youngs_modulus``), clamped at the base along +z, free at the tip; solved as a
    boundary-value problem by Chebyshev collocation and Newton's method, started from the
    linear-beam solution saturated at the load's direction, with load continuation where Newton
    fails (relative tip accuracy ~1e-10 for smooth cases). The equilibrium is the one a slowly
    increased load reaches (all loads grow together).

    When all loads lie in one vertical plane (a force in it, a flow along it, a uniform field in
    it) the planar solver solves the x–z problem and the shape is turned into that plane
    (:meth:`SpatialCentreline.from_planar`, exact); loads in the x–z plane itself give a
    :class:`BentShape`, exactly today's for today's arguments. Loads that leave every single plane
    (a field or flow across the plane of the force, any non-uniform source field) are solved by
    the 3-D rod (:mod:`magcilia.mechanics.rod`).

    Magnetic actuation: the cilium is magnetized along its local tangent t (base to tip) with
    ``setup.spec.magnetization`` M (A/m), so its moment per length is μ(s) = M π r(s)²; a field B
    exerts per length the couple μ t × B (it turns the cilium toward B: a field along +x bends
    it toward +x) and the force μ (t·∇)B. A source's field is evaluated in the board frame at the
    cilium's actual points, ``setup.base_centre + shape.points``. For a uniform rod in a uniform
    field this is the same elastica as a tip force μB (the magnetic poles at the ends),
    :func:`magcilia.mechanics.exact.uniform_field_tip`.

    Axial loads: a force along the axis (a vector (0, 0, F_z)) or a field along it leave the
    straight rod in equilibrium. Below the critical load (:func:`buckling_load`,
    :func:`flip_field`) that is the shape returned; beyond it the straight rod is unstable and the
    returned shape is the buckled one in the vertical plane at ``azimuth`` (tip toward
    ``(cos φ, sin φ)``): the branch that a load tilted infinitesimally toward it reaches. A
    field against the magnetization beyond :func:`flip_field` flips the cilium over toward the
    field in that way. A force given as a magnitude keeps today's behaviour: with ``direction``
    0 or π it is solved as given (the straight rod, stable or not).

    Parameters
    ----------
    setup : Setup
        The sensor setup (geometry, modulus and magnetization).
    force : float or array-like, shape (3,)
        Dead point force: a magnitude, N (with ``direction`` and ``azimuth``; default 0), or the
        vector (F_x, F_y, F_z), N, board frame (then ``direction`` and ``azimuth`` follow from it
        and stay at their defaults, except ``azimuth`` choosing the buckling plane of a vertical
        force).
    at : float, optional
        Arc length of the point of application, m, in (0, L]; default the tip.
    direction : float
        Direction of a force magnitude in its vertical plane, rad from +z toward the plane's
        horizontal direction; default π/2 (horizontal).
    azimuth : float
        Azimuth of that vertical plane, rad from +x toward +y; default 0 (the x–z plane).
    flow : Flow, optional
        Fluid flow (drag from the normal velocity component; see
        :mod:`magcilia.mechanics.drag`), horizontal along ``flow.azimuth``.
    actuation : Actuation, optional
        External magnetic field (:class:`magcilia.device.actuation.Actuation`).
    nodes : int, optional
        Collocation nodes per piece (default: chosen from the taper for ~1e-12 accuracy).

    Returns
    -------
    BentShape or SpatialBentShape
        A :class:`BentShape` (a :class:`~magcilia.Centreline`) for loads in the x–z plane, else
        a :class:`SpatialBentShape` (a :class:`~magcilia.SpatialCentreline`); ``.tip`` has shape
        (3,), m.

    Raises
    ------
    MagciliaError
        A tip point load, a flow or a field on a sharp cone (tip_radius 0: see
        :data:`SHARP_TIP`), ``at`` outside the cilium, a flow faster than the drag law allows, a
        field that is not finite at the cilium, or loads beyond what the solver converges for
        (the message gives the largest converged load or scale).

    Examples
    --------
    >>> import magcilia as mc
    >>> s = mc.Setup.paper(height=3e-3, base_radius=2e-4, tip_radius=5e-5, youngs_modulus=2e6)
    >>> shape = mc.bend(s, force=1e-4)
    >>> shape.tip.shape
    (3,)
    >>> turned = mc.bend(s, force=1e-4, azimuth=np.pi / 2)  # toward +y
    >>> bool(np.allclose(turned.tip, shape.tip[[1, 0, 2]], rtol=0, atol=1e-15))
    True
    """
    # (a float first: an ABC's isinstance costs a first call in a process ~10 µs)
    if (actuation is None and (type(azimuth) is float or isinstance(azimuth, numbers.Real))
            and azimuth == 0.0 and (type(force) is float or isinstance(force, numbers.Real))
            and getattr(flow, "azimuth", 0.0) == 0.0):
        return _bend_plane(setup, force, at=at, direction=direction, flow=flow, nodes=nodes)
    return _bend_any(setup, force, at, direction, azimuth, flow, actuation, nodes, rod=False)


def bend_3d(setup: Setup, force: float | ArrayLike = 0.0, *, at: float | None = None,
            direction: float = 0.5 * math.pi, azimuth: float = 0.0, flow: Flow | None = None,
            actuation: Actuation | None = None, nodes: int | None = None) -> SpatialBentShape:
    """:func:`bend` by the 3-D rod solver whatever the loads (in one plane or not).

    :func:`bend` uses it for loads that leave every single plane; called directly it checks the
    3-D solver against the planar one (same arguments, same units). Axial loads beyond
    :func:`buckling_load` are not followed onto a buckled branch here.
    """
    shape = _bend_any(setup, force, at, direction, azimuth, flow, actuation, nodes, rod=True)
    assert isinstance(shape, SpatialBentShape)  # for mypy: the rod always gives one
    return shape

def bend_sweep(setup: Setup, forces: ArrayLike | None = None, *,
               speeds: ArrayLike | None = None, flow: Flow | None = None,
               at: float | None = None, direction: float = 0.5 * math.pi,
               azimuth: float = 0.0, actuation: Actuation | None = None,
               nodes: int | None = None) -> Centreline | SpatialCentreline:
    """Shapes for a sequence of loads, each solve continued from the previous one.

    Give ``forces`` (N, shape (a,)) for point loads, or ``speeds`` (m/s, shape (a,)) together
    with ``flow`` (whose profile is scaled to each speed). Each solve starts from the polynomial
    through the last (up to three) solutions, so ordered, finely spaced sweeps (e.g. a read-out
    table's) are cheapest: one Newton step per load. For building read-out tables.

    The loads act in the vertical plane at ``azimuth`` (rad from +x toward +y; default 0: the
    x–z plane); a swept flow blows along its own ``Flow.azimuth``, which sets the plane
    (``azimuth`` must then be 0 or the same). The x–z solutions are turned into that plane
    (:meth:`SpatialCentreline.from_planar`, exact).

    With an ``actuation`` (:class:`~magcilia.Actuation`) every shape carries the field at full
    strength besides its swept load (a read-out table while actuating); each load is then solved
    on its own by :func:`bend` (no warm start: ~0.1 ms a shape in one plane, ~10 ms on the 3-D
    rod, more for a magpylib source).

    Returns
    -------
    Centreline or SpatialCentreline
        a shapes on the common grid of :data:`OUTPUT_POINTS` arc lengths: a Centreline in the
        x–z plane, a SpatialCentreline in any other plane.
    """
    plane = _angle("azimuth", azimuth)
    if actuation is not None:
        return _sweep_each(setup, forces, speeds, flow, at, direction, plane, actuation, nodes)
    if speeds is not None and isinstance(flow, Flow) and flow.azimuth != 0.0:
        if plane not in (0.0, flow.azimuth):
            raise v.fail("azimuth", plane, f"0 or the swept flow's azimuth ({flow.azimuth:.6g} "
                         "rad): a flow sets its own plane")
        plane, flow = flow.azimuth, flow.with_azimuth(0.0)
    shapes = _sweep_plane(setup, forces, speeds=speeds, flow=flow, at=at, direction=direction,
                          nodes=nodes)
    return shapes if plane == 0.0 else SpatialCentreline.from_planar(shapes, plane)


def _sweep_each(setup: Setup, forces: ArrayLike | None, speeds: ArrayLike | None,
                flow: Flow | None, at: float | None, direction: float, azimuth: float,
                actuation: Actuation, nodes: int | None) -> Centreline | SpatialCentreline:
    """:func:`bend_sweep` with an actuation: one :func:`bend` per load, stacked."""
    values = sweep_values(forces, speeds, flow)
    shapes = []
    for value in values.tolist():
        if forces is not None:
            shape = bend(setup, value, at=at, direction=direction, azimuth=azimuth, flow=flow,
                         actuation=actuation, nodes=nodes)
        else:
            assert flow is not None  # for mypy: checked above
            shape = bend(setup, at=at, azimuth=azimuth, flow=flow.with_speed(value),
                         actuation=actuation, nodes=nodes)
        shapes.append(shape)
    s = shapes[0].s
    planar = [sh for sh in shapes if isinstance(sh, BentShape)]
    if len(planar) == len(shapes):
        return Centreline(s, np.concatenate([sh.angles for sh in planar]),
                          np.concatenate([sh.points for sh in planar]))
    spatial = [sh if isinstance(sh, SpatialBentShape) else SpatialCentreline.from_planar(sh)
               for sh in shapes]
    return SpatialCentreline(s, *(np.concatenate([getattr(sh, name) for sh in spatial])
                                  for name in ("points", "tangents", "normals")))

def poses_at(setup: Setup, quantity: str, values: ArrayLike, flow: Flow | None = None,
             actuation: Actuation | None = None) -> tuple[Pose, float]:
    """The cilium's poses at ``values`` (shape (a,), SI) of a measurand, and the azimuth (rad)
    to evaluate them at (:meth:`magcilia.Setup.field`): rigid tilt angles (``"angle"``, rad; an
    actuation does not bend a rigid tilt), dead tip forces along +x (``"force"``, N) or flow
    speeds (``"flow"``, m/s, the profile of ``flow`` scaled to each speed, from its azimuth;
    default uniform water flow), as sweeps continued from one load to the next (increasing
    values are cheapest), bent by ``actuation`` too when one is given."""
    q = v.finite_array("values", values, ndim=1)
    if quantity == "angle":
        return q, 0.0
    if quantity not in ("force", "flow"):
        raise v.fail("quantity", quantity, "one of 'angle', 'force', 'flow'")
    if quantity == "force":
        if actuation is not None:
            return bend_sweep(setup, forces=q, actuation=actuation), 0.0
        return _sweep_plane(setup, forces=q), 0.0
    flow = flow or Flow.uniform(1.0)
    if actuation is not None:
        return bend_sweep(setup, speeds=q, flow=flow, actuation=actuation), 0.0
    if flow.azimuth != 0.0:  # the x–z sweep turned: the model's azimuth (Setup.output)
        return _sweep_plane(setup, speeds=q, flow=flow.with_azimuth(0.0)), flow.azimuth
    return _sweep_plane(setup, speeds=q, flow=flow), 0.0


def output_at(setup: Setup, quantity: str, values: ArrayLike, flow: Flow | None = None) -> F64:
    """Sensor output (V), shape (a,), at ``values`` (shape (a,), SI) of a measurand: rigid tilt
    angles (``"angle"``, rad), dead tip forces along +x (``"force"``, N; a sweep continued from
    one load to the next, so increasing values are cheapest) or flow speeds (``"flow"``, m/s, the
    profile of ``flow`` scaled to each speed, from its azimuth; default uniform water flow):
    :func:`poses_at` through :meth:`magcilia.Setup.output`."""
    pose, azimuth = poses_at(setup, quantity, values, flow)
    return setup.output(pose, azimuth=azimuth)
