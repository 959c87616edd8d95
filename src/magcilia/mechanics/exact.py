"""Exact large deflection of a uniform cantilever under a perpendicular dead tip load.

Bisshopp & Drucker, Q. Appl. Math. 3, 272 (1945). A straight rod of length L and bending
stiffness EI, clamped along +z, carries a dead force P along +x at its free end; α = P L² / EI.
With the tip angle θ₀ and the elliptic modulus ``k² = (1 + sin θ₀) / 2``, ``sin φ₁ = 1/(k√2)``::

    √α = K(k) − F(φ₁, k)                          (fixes k, hence θ₀)
    x_tip / L = 1 − (2/√α) (E(k) − E(φ₁, k))      (deflection along the load)
    z_tip / L = √(2 sin θ₀ / α)                   (remaining height)

Used by the tests as an independent reference for the collocation solver.
"""

from __future__ import annotations

import math

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
