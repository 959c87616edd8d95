"""An independent full dynamic solve of the cilium for the transient tests: a linear
Euler–Bernoulli finite-element model of the tapered rod (Hermite cubic elements, consistent mass,
clamped base, sections from ``setup.cilium`` by 4-point Gauss quadrature in each element), its
modes, and a Newmark (average acceleration) integration of the full model.

Written apart from ``magcilia.mechanics`` (no import of its modal model or its discretisation), so
that the reduced modal model of :mod:`magcilia.mechanics.transient` is checked against another
route. Loaded by ``test_transient.py`` with importlib (the tests folder is not a package).
"""

from __future__ import annotations

from types import SimpleNamespace

import numpy as np
import scipy.linalg


def density(setup) -> float:
    """The composite's mass density, kg/m³, from the recipe's masses and densities."""
    m = setup.material
    return (m.cobalt_mass + m.polymer_mass) / (m.cobalt_mass / m.cobalt_density
                                               + m.polymer_mass / m.polymer_density)


def radius(setup, s):
    """r(s), m, of the frustum (or the measured profile), at arc lengths s, m."""
    c = setup.cilium
    if c.profile is not None:
        u, rho = (np.asarray(a) for a in c.profile)
        return c.base_radius * np.interp(s / c.height, u, rho)
    return c.base_radius + (c.tip_radius - c.base_radius) * s / c.height


def matrices(setup, elements: int = 60, added_mass: float = 0.0):
    """Stiffness K and mass M (free dofs: w, w' at nodes 1..n) and the tip's w index.

    ``added_mass`` (kg/m per m² of section, i.e. a fluid density) adds ρ_f π r² per length."""
    L, E, rho = setup.cilium.height, setup.youngs_modulus, density(setup)
    n = elements
    h = L / n
    dofs = 2 * (n + 1)
    K = np.zeros((dofs, dofs))
    M = np.zeros((dofs, dofs))
    xg, wg = np.polynomial.legendre.leggauss(6)
    for e in range(n):
        xi = 0.5 * (xg + 1.0)  # in [0, 1]
        s = (e + xi) * h
        r = radius(setup, s)
        ei = E * np.pi * r**4 / 4.0
        ra = (rho + added_mass) * np.pi * r**2
        # Hermite shape functions and their second derivatives (in s)
        N = np.stack([1 - 3 * xi**2 + 2 * xi**3, h * (xi - 2 * xi**2 + xi**3),
                      3 * xi**2 - 2 * xi**3, h * (-xi**2 + xi**3)])
        B = np.stack([-6 + 12 * xi, h * (-4 + 6 * xi), 6 - 12 * xi, h * (-2 + 6 * xi)]) / h**2
        w = 0.5 * wg * h
        ke = (B * (ei * w)) @ B.T
        me = (N * (ra * w)) @ N.T
        idx = slice(2 * e, 2 * e + 4)
        K[idx, idx] += ke
        M[idx, idx] += me
    K, M = K[2:, 2:], M[2:, 2:]  # clamped base
    return K, M, dofs - 4  # the tip's w


def modes(setup, count: int = 3, zeta=0.0, elements: int = 60):
    """The FE model's lowest modes as the attributes the transient model reads (tip-normalised
    shapes; modal masses, stiffnesses and dampings referred to the tip)."""
    K, M, tip = matrices(setup, elements)
    lam, phi = scipy.linalg.eigh(K, M, subset_by_index=[0, count - 1])
    phi = phi / phi[tip]
    omega = np.sqrt(lam)
    m = np.einsum("ij,ik,kj->j", phi, M, phi)
    z = np.broadcast_to(np.asarray(zeta, dtype=float), (count,)).copy()
    return SimpleNamespace(frequencies=omega / (2 * np.pi), damping_ratios=z,
                           modal_masses=m, modal_stiffnesses=omega**2 * m,
                           modal_dampings=2 * z * omega * m,
                           overdamped=z >= 1.0)


def newmark_tip(setup, force, rate, zeta, substeps: int = 16, elements: int = 40):
    """Tip displacement, m, at each sample of the full FE model under a tip force ``force``
    (N, (n,), each value held over its sample interval 1/rate s), at rest at t = 0 under
    ``force[0]``; modal damping ratio ``zeta`` on every mode (classical damping,
    C = M Φ diag(2ζω/m) Φᵀ M). Newmark's average acceleration with ``substeps`` steps per
    sample."""
    K, M, tip = matrices(setup, elements)
    lam, phi = scipy.linalg.eigh(K, M)
    m = np.einsum("ij,ik,kj->j", phi, M, phi)
    omega = np.sqrt(lam)
    Mphi = M @ phi
    C = Mphi @ np.diag(2 * zeta * omega / m) @ Mphi.T
    f = np.zeros(K.shape[0])
    f[tip] = 1.0
    dt = 1.0 / (rate * substeps)
    beta, gamma = 0.25, 0.5
    A = M / (beta * dt**2) + gamma / (beta * dt) * C + K
    lu = scipy.linalg.lu_factor(A)
    x = np.linalg.solve(K, f * force[0])
    vel = np.zeros_like(x)
    acc = np.zeros_like(x)
    out = np.empty(len(force))
    for k, fk in enumerate(force):
        out[k] = x[tip]
        for _ in range(substeps):
            rhs = (f * fk + M @ (x / (beta * dt**2) + vel / (beta * dt)
                                 + (0.5 / beta - 1) * acc)
                   + C @ (gamma / (beta * dt) * x + (gamma / beta - 1) * vel
                          + dt * (0.5 * gamma / beta - 1) * acc))
            xn = scipy.linalg.lu_solve(lu, rhs)
            an = (xn - x) / (beta * dt**2) - vel / (beta * dt) - (0.5 / beta - 1) * acc
            vel = vel + dt * ((1 - gamma) * acc + gamma * an)
            x, acc = xn, an
    return out
