"""The optimiser's screen model: cheap, vectorised stand-ins for the exact metrics of many designs.

Each design's tip force becomes the equivalent rigid tilt ``θ = atan(C F / L)`` (the chord of a
tip-loaded cantilever, exact for small loads) evaluated by the vectorised tilt model
(:class:`magcilia.model.TiltBatch`) on one grid of equivalent linear deflections
(:data:`SCREEN_U`); C is the closed-form tip compliance (:func:`magcilia.mechanics.
frustum_compliance`) with each design's Guth–Gold modulus (:func:`magcilia.device.stiffness.
composite_modulus` of its cobalt fraction, :func:`magcilia.device.material.volume_fraction`);
a flow is the cylinder drag per length, its tip-equivalent force 3/8 of the total
(:func:`flow_curve`).
"""

from __future__ import annotations

import numpy as np
from numpy.typing import NDArray

from magcilia.design.sweeps import DEFLECTION_LIMIT
from magcilia.device.material import volume_fraction
from magcilia.device.setup import Setup
from magcilia.device.stiffness import composite_modulus
from magcilia.mechanics import Fluid, frustum_compliance, tip_compliance
from magcilia.mechanics.drag import drag_per_length

F64 = NDArray[np.float64]

#: the screen's grid of equivalent linear deflections C F / L
SCREEN_U = np.concatenate([np.linspace(0.0, 0.6, 25), np.linspace(0.65, DEFLECTION_LIMIT, 48)])
#: small equivalent tilt of the screen's zero-load slope, rad
SLOPE_TILT = 1e-4


def cobalt_fraction(setup: Setup, values: dict[str, F64]) -> F64:
    """The cobalt's volume fraction of each design (its ``cobalt_mass`` in the setup's
    material), dimensionless (N,)."""
    m = setup.material
    return np.asarray(volume_fraction(values["cobalt_mass"], m.polymer_mass, m.cobalt_density,
                                      m.polymer_density), dtype=np.float64)


def modulus(setup: Setup, values: dict[str, F64]) -> F64:
    """Young's modulus of each design, Pa (Guth–Gold of its cobalt fraction unless the cilium
    fixes it)."""
    n = values["height"].size
    if setup.cilium.youngs_modulus is not None or "cobalt_mass" not in values:
        return np.full(n, setup.youngs_modulus)
    return np.asarray(composite_modulus(setup.material.polymer_modulus,
                                        cobalt_fraction(setup, values)), dtype=np.float64)


def compliance(setup: Setup, values: dict[str, F64]) -> F64:
    """Small-load tip compliance of each design, m/N (frusta in closed form; a measured profile
    scaled from the setup's: C ∝ L³ / (E r_b⁴))."""
    c = setup.cilium
    h, rb, rt = values["height"], values["base_radius"], values["tip_radius"]
    e = modulus(setup, values)
    if c.profile is not None:
        c0 = tip_compliance(setup)
        return np.asarray(c0 * (h / c.height) ** 3 * (c.base_radius / rb) ** 4
                          * setup.youngs_modulus / e, dtype=np.float64)
    with np.errstate(divide="ignore"):
        return np.asarray(frustum_compliance(h, rb, rt, e), dtype=np.float64)


def moment_scale(setup: Setup, values: dict[str, F64]) -> F64:
    """Magnetization scale of each design relative to the setup's full magnetization (the
    cobalt fraction folded in)."""
    scale = values["magnetization_scale"]
    if "cobalt_mass" in values:
        scale = scale * cobalt_fraction(setup, values) / setup.material.volume_fraction
    return np.asarray(scale, dtype=np.float64)


def mean_radius(values: dict[str, F64], sel: NDArray[np.int64]) -> F64:
    """The mean of base and tip radius of the designs ``sel``, m."""
    return np.asarray(0.5 * (values["base_radius"][sel] + values["tip_radius"][sel]),
                      dtype=np.float64)


def flow_curve(q: F64, d: F64, h: F64, c: F64, reading: F64, fluid: Fluid) -> F64:
    """Readings (N, s, 3) at speeds q (N, s): the tip-equivalent force of the cylinder drag
    (3/8 of the total on an upright rod) turned into the equivalent tilt, interpolated on the
    screen's curve ``reading`` (N, a, 3) over :data:`SCREEN_U`."""
    per_length = drag_per_length(q, d[:, None], fluid)
    u_eq = np.clip(0.375 * per_length * h[:, None] * (c / h)[:, None], 0.0, DEFLECTION_LIMIT)
    hi = np.clip(np.searchsorted(SCREEN_U, u_eq, side="right"), 1, SCREEN_U.size - 1)
    lo = hi - 1
    t = (u_eq - SCREEN_U[lo]) / (SCREEN_U[hi] - SCREEN_U[lo])  # linear, as np.interp
    r_lo = np.take_along_axis(reading, lo[:, :, None], axis=1)
    r_hi = np.take_along_axis(reading, hi[:, :, None], axis=1)
    return np.asarray(r_lo + t[:, :, None] * (r_hi - r_lo), dtype=np.float64)
