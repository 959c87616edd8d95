"""Exact large deflection of a uniform cantilever under a perpendicular dead tip load or field.

Bisshopp & Drucker, Q. Appl. Math. 3, 272 (1945). A straight rod of length L and bending
stiffness EI, clamped along +z, carries a dead force P along +x at its free end; α = P L² / EI.
With the tip angle θ₀ and the elliptic modulus ``k² = (1 + sin θ₀) / 2``, ``sin φ₁ = 1/(k√2)``::

    √α = K(k) − F(φ₁, k)                          (fixes k, hence θ₀)
    x_tip / L = 1 − (2/√α) (E(k) − E(φ₁, k))      (deflection along the load)
    z_tip / L = √(2 sin θ₀ / α)                   (remaining height)

Used by the tests as an independent reference for the collocation solver; beside it
:func:`uniform_field_tip`, a uniform magnetized rod in a uniform perpendicular field (exact by
quadrature, and its small-deflection closed form).
"""

from __future__ import annotations

import math
from collections.abc import Callable

from scipy.integrate import quad
from scipy.optimize import brentq
from scipy.special import ellipe, ellipeinc, ellipk, ellipkinc

from magcilia import _validate as v


def cantilever_tip(alpha: float) -> tuple[float, float, float]:
    """Tip of a uniform cantilever under a perpendicular dead tip load (exact elastica).

    Parameters
    ----------
    alpha : float
        Load parameter P L² / (E I), ≥ 0.

    Returns
    -------
    x, z : float
        Tip position over L (x along the load, z along the unloaded axis).
    theta0 : float
        Tip angle, rad.
    """
    alpha = v.non_negative("alpha", alpha, "", "load parameter")
    if alpha == 0.0:
        return 0.0, 1.0, 0.0
    root = math.sqrt(alpha)

    def parts(theta0: float) -> tuple[float, float, float]:
        m = 0.5 * (1.0 + math.sin(theta0))  # k² (scipy uses the parameter m = k²)
        phi1 = math.asin(min(1.0, 1.0 / math.sqrt(2.0 * m)))
        return m, phi1, float(ellipk(m) - ellipkinc(phi1, m))

    # √α(θ₀) increases from 0 at θ₀ = 0 to ∞ at θ₀ = π/2
    hi = 0.5 * math.pi * (1.0 - 1e-15)
    theta0 = brentq(lambda t: parts(t)[2] - root, 0.0, hi, xtol=1e-15, rtol=1e-15, maxiter=200)
    m, phi1, _ = parts(theta0)
    x = 1.0 - 2.0 / root * float(ellipe(m) - ellipeinc(phi1, m))
    z = math.sqrt(2.0 * math.sin(theta0) / alpha)
    return x, z, float(theta0)


def uniform_field_tip(kappa: float, *, linear: bool = False) -> tuple[float, float, float]:
    """Tip of a uniform magnetized rod bent by a uniform field perpendicular to it.

    A straight rod of length L and bending stiffness EI, clamped along +z, magnetized along its
    tangent with moment per length μ, in a uniform field B along +x: the couple per length
    ``μ (t × B)_y = μ B cos θ`` gives the moment ``M(s) = ∫ₛᴸ μ B cos θ dσ``, hence
    ``EI θ'' = −μ B cos θ`` with θ(0) = 0, θ'(L) = 0 and the first integral
    ``EI θ'²/2 = μB (sin θ_L − sin θ)``. With κ = μ B L² / EI::

        √(2κ) = ∫₀^θ_L dθ / √(sin θ_L − sin θ)                       (fixes θ_L)
        x_tip / L = (1/√(2κ)) ∫₀^θ_L sin θ dθ / √(sin θ_L − sin θ)
        z_tip / L = √(2 sin θ_L / κ)

    computed here by adaptive quadrature in u = √(sin θ_L − sin θ) (which removes the end
    singularity: dθ / √(sin θ_L − sin θ) = 2 du / cos θ) and a root search, independently of the
    collocation solver. Small κ (``linear=True``):
    ``θ_L = κ/2``, ``x_tip/L = κ/3``, ``z_tip/L = 1`` (M(s) = μB(L − s)). It is the same boundary
    value problem as a dead tip force P = μB (:func:`cantilever_tip` with α = κ): the uniformly
    magnetized rod is a pair of magnetic poles ±μ at its ends, and the field's force μB on the
    tip pole bends it (the base pole's is taken by the clamp).

    Parameters
    ----------
    kappa : float
        Load parameter μ B L² / (E I), ≥ 0.
    linear : bool
        The small-deflection closed form instead of the exact elastica.

    Returns
    -------
    x, z : float
        Tip position over L (x along the field, z along the unloaded axis).
    theta_l : float
        Tip angle, rad.

    Examples
    --------
    >>> x, z, th = uniform_field_tip(1e-3)
    >>> round(x / 1e-3, 6), round(th / 1e-3, 6)
    (0.333333, 0.5)
    """
    kappa = v.non_negative("kappa", kappa, "", "load parameter")
    if linear:
        return kappa / 3.0, 1.0, 0.5 * kappa
    if kappa == 0.0:
        return 0.0, 1.0, 0.0

    def integral(theta_l: float, f: Callable[[float], float]) -> float:
        # ∫₀^θ_L f(sin θ) dθ / √(sin θ_L − sin θ) with u = √(sin θ_L − sin θ):
        # ∫₀^√(sin θ_L) 2 f(sin θ) du / cos θ, sin θ = sin θ_L − u² (smooth for θ_L < π/2)
        top = math.sin(theta_l)
        gap = 2.0 * math.sin(0.5 * (0.5 * math.pi - theta_l)) ** 2  # 1 − sin θ_L, accurately

        def integrand(u: float) -> float:
            s = top - u * u
            return 2.0 * f(s) / math.sqrt((gap + u * u) * (1.0 + s))

        return float(quad(integrand, 0.0, math.sqrt(top), epsabs=0.0, epsrel=1e-13,
                          limit=200)[0])

    target = math.sqrt(2.0 * kappa)
    # the length integral grows from 0 at θ_L = 0 to ∞ at θ_L = π/2
    hi = 0.5 * math.pi * (1.0 - 1e-12)
    theta_l = brentq(lambda t: integral(t, lambda _: 1.0) - target, 0.0, hi,
                     xtol=1e-15, rtol=1e-15, maxiter=200)
    x = integral(theta_l, lambda s: s) / target
    z = math.sqrt(2.0 * math.sin(theta_l) / kappa)
    return x, z, float(theta_l)
