"""Large-deflection mechanics of the cilium: static elastica under point loads and fluid flow.

* :func:`bend` / :func:`bend_sweep`: static shapes (:class:`BentShape`, a Centreline, for loads in
  the x–z plane; :class:`SpatialBentShape`, a SpatialCentreline, for any other direction), under a
  force vector, a flow from any azimuth and magnetic actuation (:class:`~magcilia.Actuation`);
  :func:`bend_3d` (the 3-D rod, :mod:`.rod`, for loads that leave every plane),
  :func:`buckling_load` and :func:`flip_field` (axial loads that destabilise the straight rod);
* :class:`Flow` (uniform, wall shear, custom profiles) and :class:`Fluid` with :data:`AIR`,
  :data:`WATER`; :func:`drag_coefficient` (Lamb–Oseen / White cylinder drag) and
  :func:`slender_log` (the low-Re drag of a finite slender body standing on the wall);
* :func:`cantilever_tip`: the exact elastica (elliptic integrals) used as a reference, and
  :func:`uniform_field_tip` (a uniform rod in a uniform perpendicular field, by quadrature);
* :func:`tip_compliance` and :func:`frustum_compliance`: the small-load tip compliance;
* :func:`modes` (:class:`Modes`): the bending modes, in vacuum or a fluid (Sader's hydrodynamic
  function, :mod:`.hydrodynamic`), with or without the hair's own weight (:mod:`.modal`, on the
  beam elements of :mod:`.beam`);
* :func:`frequency_response` (:class:`FrequencyResponse`): the sensor's transfer from a tip force
  or a flow to its output about a static operating point, its −3 dB bandwidth and settling time
  (:mod:`.response`);
* :func:`simulate_response` (:class:`TransientResponse`): a force, flow or tilt over time → the
  hair's motion → the sensor's output, by a reduced modal model around the static map
  (:mod:`.transient`).

Modules: :mod:`.bend` (the public bending functions), :mod:`.planar` (the x–z solver and sweeps),
:mod:`.spatial` (loads in any direction, actuation, the 3-D rod, buckling), :mod:`.compliance`.
"""

from __future__ import annotations

from typing import TYPE_CHECKING

from magcilia._lazy import attach

if TYPE_CHECKING:
    from magcilia.mechanics.bend import bend, bend_3d, bend_sweep, output_at, poses_at
    from magcilia.mechanics.compliance import frustum_compliance, tip_compliance
    from magcilia.mechanics.drag import (
        AIR,
        FLUIDS,
        GLYCEROL,
        WATER,
        Fluid,
        drag_coefficient,
        drag_per_length,
        slender_log,
    )
    from magcilia.mechanics.exact import cantilever_tip, uniform_field_tip
    from magcilia.mechanics.flow import Flow
    from magcilia.mechanics.modal import Modes, modes
    from magcilia.mechanics.planar import SHARP_TIP, require_tip_radius
    from magcilia.mechanics.response import FrequencyResponse, frequency_response
    from magcilia.mechanics.shape import BentShape, Load, SpatialBentShape
    from magcilia.mechanics.spatial import buckling_load, flip_field
    from magcilia.mechanics.transient import TransientResponse, simulate_response

__all__ = [
    "AIR",
    "FLUIDS",
    "GLYCEROL",
    "SHARP_TIP",
    "WATER",
    "BentShape",
    "Flow",
    "Fluid",
    "FrequencyResponse",
    "Load",
    "Modes",
    "SpatialBentShape",
    "TransientResponse",
    "bend",
    "bend_3d",
    "bend_sweep",
    "buckling_load",
    "cantilever_tip",
    "drag_coefficient",
    "drag_per_length",
    "flip_field",
    "frequency_response",
    "frustum_compliance",
    "modes",
    "output_at",
    "poses_at",
    "require_tip_radius",
    "simulate_response",
    "slender_log",
    "tip_compliance",
    "uniform_field_tip",
]

__getattr__, __dir__ = attach(__name__)
