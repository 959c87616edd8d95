"""Small-load tip compliance of the cilium: the frustum in closed form, a measured profile by
quadrature (:func:`magcilia.mechanics.sections.compliance_integral`).

Examples
--------
>>> round(float(frustum_compliance(3e-3, 2e-4, 5e-5, 6.7e5)), 2)     # m/N
42.76
"""

from __future__ import annotations

import math
from typing import Any

from magcilia.device.setup import Setup
from magcilia.mechanics.sections import compliance_integral


def frustum_compliance(height: Any, base_radius: Any, tip_radius: Any, modulus: Any) -> Any:
    """Small-load tip compliance of a frustum, m/N: ``L³ / (3 E I₀ λ)`` with ``I₀ = π r_b⁴ / 4``
    (the base's second moment, m⁴) and ``λ = r_t / r_b`` (the exact linear cantilever of a
    linearly tapered circular rod under a tip force).

    Parameters
    ----------
    height, base_radius, tip_radius : float or ndarray
        L, r_b and r_t, m (arrays broadcast).
    modulus : float or ndarray
        Young's modulus E, Pa.

    Returns
    -------
    float or ndarray
        m/N; inf for a sharp cone (``tip_radius`` 0).
    """
    i0 = math.pi * base_radius**4 / 4.0
    return height**3 / (3.0 * modulus * i0 * (tip_radius / base_radius))


def tip_compliance(setup: Setup) -> float:
    """Small-load tip compliance, m/N: ``L³ / (3 E I₀ λ)`` for a frustum (λ = tip/base radius,
    :func:`frustum_compliance`), ``∫ (L − s)² / (E I(s)) ds`` for a measured profile.

    Infinite for a sharp cone (λ = 0).
    """
    c = setup.cilium
    if c.tip_radius == 0.0:
        return math.inf
    if c.profile is not None:  # ∫ (L − s)² / (E I(s)) ds, exact for a piecewise-linear r(s)
        return compliance_integral(c) / setup.youngs_modulus
    return float(frustum_compliance(c.height, c.base_radius, c.tip_radius, setup.youngs_modulus))
