"""Large-deflection mechanics of the cilium: static elastica under point loads and fluid flow.

* :func:`bend` / :func:`bend_sweep`: static shapes (:class:`BentShape`, a Centreline);
* :class:`Flow` (uniform, wall shear, custom profiles) and :class:`Fluid` with :data:`AIR`,
  :data:`WATER`; :func:`drag_coefficient` (Lamb–Oseen / White cylinder drag) and
  :func:`slender_log` (the low-Re drag of a finite slender body standing on the wall);
* :func:`cantilever_tip`: the exact elastica (elliptic integrals) used as a reference.
"""

from __future__ import annotations

from magcilia.mechanics.bend import (
    SHARP_TIP,
    bend,
    bend_sweep,
    output_at,
    require_tip_radius,
    tip_compliance,
)
from magcilia.mechanics.drag import (
    AIR,
    FLUIDS,
    WATER,
    Fluid,
    drag_coefficient,
    drag_per_length,
    slender_log,
)
from magcilia.mechanics.exact import cantilever_tip
from magcilia.mechanics.flow import Flow
from magcilia.mechanics.shape import BentShape, Load

__all__ = [
    "AIR",
    "FLUIDS",
    "SHARP_TIP",
    "WATER",
    "BentShape",
    "Flow",
    "Fluid",
    "Load",
    "bend",
    "bend_sweep",
    "cantilever_tip",
    "drag_coefficient",
    "drag_per_length",
    "output_at",
    "require_tip_radius",
    "slender_log",
    "tip_compliance",
]
