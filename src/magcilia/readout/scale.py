"""The force scale's share of a read-out's uncertainty: the Young's modulus.

Tilt data cannot tell the Young's modulus E (the field does not depend on it), yet every tip
force and flow speed read from an output scales with it. Until E is fitted from load data, given
with its σ or measured, a read-out carries the modulus's relative 1 σ
(:attr:`magcilia.Setup.youngs_modulus_uncertainty`) into every estimate:

* **tip force**: at a fixed shape the elastica depends on the load only through F·L²/(E·I), so
  the force that gives a reading scales *exactly* with E: ``σ_F = |F| · σ_E/E`` (and a force
  vector's magnitude likewise, its direction unchanged);
* **flow speed**: at a fixed shape the drag per length must scale with E, and the drag grows as
  ``U^n`` with the drag law's local exponent ``n = d ln f / d ln U`` (1 for creeping flow: the
  slender-body law; 2 for form drag at constant C_D; Lamb's and White's laws between:
  :func:`magcilia.mechanics.drag.drag_exponent`), so ``σ_U ≈ (U/n) · σ_E/E``. The read-out
  takes the factor from the model itself: the output's derivative with respect to ln E at each
  table node (:func:`output_rate`, a central difference), through the table's slope;
* **under an actuation** the magnetic loads do not scale with E, so the share of a force or
  flow is also taken from the model;
* a rigid **tilt angle** does not depend on E.

This part is **systematic**: one error of E shared by every reading of the setup (fully
correlated between readings, unlike the noise); results keep it apart (``sigma_scale``) from the
noise (``sigma_noise``), and say where E comes from (:meth:`magcilia.Modulus.note`).
"""

from __future__ import annotations

from collections.abc import Callable, Sequence

import numpy as np
from numpy.typing import NDArray

from magcilia.device.setup import Setup
from magcilia.device.stiffness import Modulus
from magcilia.model.azimuth import turn_xy

F64 = NDArray[np.float64]

#: relative step of E in the model's central difference (the output is smooth in E)
MODULUS_STEP = 1e-3
#: points across the span at which the derivative is taken (interpolated to the table nodes)
RATE_POINTS = 33


def scales_exactly(quantity: str, actuated: bool) -> bool:
    """Whether a measurand scales exactly with E at a fixed reading: a tip force without an
    actuation (F ∝ E; ``σ = |F| · σ_E/E``)."""
    return quantity == "force" and not actuated


def per_ln_modulus(evaluate: Callable[[Setup], F64], setup: Setup) -> F64:
    """∂/∂ln E of ``evaluate(setup)`` (an array of any shape, in its own unit): a central
    difference over the setup with its Young's modulus E·(1 ± :data:`MODULUS_STEP`)."""
    e = setup.youngs_modulus
    up = evaluate(setup.replace(youngs_modulus=e * (1.0 + MODULUS_STEP)))
    down = evaluate(setup.replace(youngs_modulus=e * (1.0 - MODULUS_STEP)))
    return np.asarray((up - down) / (2.0 * MODULUS_STEP), dtype=np.float64)


def output_rate(output: Callable[[Setup, F64], F64], setup: Setup, nodes: F64) -> F64:
    """dV/d ln E, V, at the quantity ``nodes`` (SI, increasing, shape (t,)): the model's output
    ``output(setup, q)`` (V, shape of q) differentiated by :func:`per_ln_modulus` at
    :data:`RATE_POINTS` points across the nodes, interpolated to them."""
    q = np.linspace(nodes[0], nodes[-1], RATE_POINTS)
    rate = per_ln_modulus(lambda s: output(s, q), setup)
    return np.asarray(np.interp(nodes, q, rate), dtype=np.float64)


def modulus_sigma(output: Callable[[Setup, F64], F64], setup: Setup, quantity: str,
                  nodes: F64, volts: F64, actuated: bool) -> F64:
    """The output's 1 σ from the modulus, V, at the table ``nodes`` (SI, shape (t,), outputs
    ``volts``): ``|dV/d ln E| · σ_E/E``; zeros for a tilt angle or a modulus taken as exact. For
    a tip force without actuation ``dV/d ln E = −F dV/dF`` exactly (from the table)."""
    relative = setup.youngs_modulus_uncertainty
    if quantity == "angle" or relative == 0.0:
        return np.zeros(nodes.size)
    if scales_exactly(quantity, actuated):
        rate = -nodes * np.gradient(volts, nodes)
    else:
        rate = output_rate(output, setup, nodes)
    return np.asarray(np.abs(rate) * relative, dtype=np.float64)


# -- force vectors (biaxial read-out) --------------------------------------------------------------

#: magnitudes and directions of the grid on which an actuated force-vector read-out takes the
#: force's derivative with respect to ln E from the model (interpolated bilinearly between, in
#: its components along and across the force)
VECTOR_RATE_GRID = (9, 16)


def least_squares_rate(jx: F64, jy: F64, g: F64, weight: F64) -> F64:
    """∂(Fx, Fy)/∂ ln E at fixed readings, N, (b, 2): the readings' derivative ``g = ∂B/∂ln E``
    (b, c), T, through the weighted least squares of the read-out, ``−(JᵀWJ)⁻¹ JᵀW g``, with the
    Jacobian columns ``jx``, ``jy`` (∂B/∂Fx, ∂B/∂Fy, (b, c), T/N) and ``weight`` (b, c), 1/T²."""
    a11 = np.einsum("bc,bc->b", weight, jx * jx)
    a22 = np.einsum("bc,bc->b", weight, jy * jy)
    a12 = np.einsum("bc,bc->b", weight, jx * jy)
    b1 = np.einsum("bc,bc->b", weight, jx * g)
    b2 = np.einsum("bc,bc->b", weight, jy * g)
    det = a11 * a22 - a12 * a12
    with np.errstate(divide="ignore", invalid="ignore"):
        return np.stack([-(a22 * b1 - a12 * b2) / det, -(a11 * b2 - a12 * b1) / det], axis=-1)


def to_polar(rate: F64, direction: F64) -> F64:
    """Rates (b, 2) in x, y as components along and across the directions (b,), rad."""
    return np.stack(turn_xy(rate[:, 0], rate[:, 1], direction, inverse=True), -1)


def vector_rate(fx: F64, fy: F64, grid: tuple[F64, F64, F64] | None) -> F64:
    """∂(Fx, Fy)/∂ ln E at fixed readings, N, shape (b, 2), for estimates ``fx``, ``fy`` (b,):
    exactly the force itself without an actuation (``grid`` None: F ∝ E at a fixed shape); under
    one, the model's rates on ``grid`` (magnitudes (m,), N; directions (d,) from 0 over 2π; the
    rates' components along and across the force (m, d, 2), N, :func:`to_polar` of
    :func:`least_squares_rate`), interpolated bilinearly."""
    if grid is None:
        return np.stack([fx, fy], axis=-1)
    direction = np.arctan2(fy, fx)
    polar = _bilinear(grid, np.hypot(fx, fy), direction)
    return np.stack(turn_xy(polar[:, 0], polar[:, 1], direction), -1)


def _bilinear(grid: tuple[F64, F64, F64], magnitude: F64, direction: F64) -> F64:
    """Values (m, d, k) on magnitudes (m,) × directions (d,) (periodic over 2π) at points (b,),
    bilinear: (b, k); magnitudes beyond the grid take its ends."""
    mags, dirs, values = grid
    u = np.interp(magnitude, mags, np.arange(mags.size, dtype=np.float64))
    i = np.minimum(u.astype(np.intp), mags.size - 2)
    u = (u - i)[:, None]
    w = np.mod(direction, 2.0 * np.pi) / (dirs[1] - dirs[0])
    j = np.minimum(w.astype(np.intp), dirs.size - 1)
    w = (w - j)[:, None]
    k = (j + 1) % dirs.size
    return np.asarray((1 - u) * ((1 - w) * values[i, j] + w * values[i, k])
                      + u * ((1 - w) * values[i + 1, j] + w * values[i + 1, k]),
                      dtype=np.float64)


def vector_scale_covariance(rate: F64, relative: float) -> F64:
    """The force scale's covariance of (Fx, Fy), N², shape (b, 2, 2): ``(σ_E/E)² r rᵀ`` of the
    rates ``rate`` (b, 2) (:func:`vector_rate`); along the force itself without an actuation, so
    a direction keeps its σ."""
    return np.asarray(relative**2 * rate[:, :, None] * rate[:, None, :], dtype=np.float64)


# -- arrays ---------------------------------------------------------------------------------------

def array_scale_covariance(force: F64, moduli: Sequence[Modulus]) -> F64:
    """The force scale's covariance of all cilia's (Fx1, Fy1, Fx2, …), N², (..., 2C, 2C), for
    forces ``force`` (..., C, 2), N, and each cilium's :class:`~magcilia.Modulus`: cilia of one
    modulus (the same value, σ and source: one material) share its error, fully correlated;
    cilia of different moduli are independent."""
    n = force.shape[-2]
    flat = force.reshape(*force.shape[:-2], 2 * n)
    cov = np.zeros((*force.shape[:-2], 2 * n, 2 * n))
    for modulus in dict.fromkeys(moduli):
        if not modulus.relative:
            continue
        mine = np.repeat([m == modulus for m in moduli], 2)
        vec = np.where(mine, flat, 0.0)
        cov += modulus.relative**2 * (vec[..., :, None] * vec[..., None, :])
    return cov


def array_scale_blocks(force: F64, moduli: Sequence[Modulus]) -> F64:
    """The blocks on the diagonal of :func:`array_scale_covariance`: each cilium's force scale
    covariance of (Fx, Fy), N², (..., C, 2, 2): ``(σ_E/E)² F Fᵀ``."""
    rel2 = np.array([m.relative**2 if m.relative else 0.0 for m in moduli])
    return np.asarray(rel2[:, None, None] * force[..., :, None] * force[..., None, :])


def scale_notes(moduli: Sequence[Modulus]) -> str:
    """The notes of the distinct moduli (:meth:`~magcilia.Modulus.note`), joined by ``"; "``."""
    return "; ".join(dict.fromkeys(m.note() for m in moduli))


# -- single values (design metrics) --------------------------------------------------------------

def fixed_output_rate(output: Callable[[Setup, F64], F64], setup: Setup, values: F64) -> F64:
    """∂q/∂ln E at a fixed output, SI, at the measurand's ``values`` (shape (a,), > 0): the
    model's ``output(setup, q)`` (V) differentiated by central differences in ln E
    (:func:`per_ln_modulus`) and in q (a relative step of 1e-4),
    ``−(∂V/∂ln E) / (∂V/∂q)``."""
    q = np.asarray(values, dtype=np.float64)
    dv_de = per_ln_modulus(lambda s: output(s, q), setup)
    h = 1e-4 * q
    dv_dq = (output(setup, q + h) - output(setup, q - h)) / (2.0 * h)
    return np.asarray(-dv_de / dv_dq, dtype=np.float64)
