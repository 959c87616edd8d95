"""The physical model's dipole layout: the smallest rms-ring layout whose field is within a
tolerance of the exact body (:func:`converged_layout`), or one given by hand."""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from numpy.typing import NDArray

from magcilia import _validate as v
from magcilia.device.setup import Setup
from magcilia.model import convergence
from magcilia.model.convergence import Layout

F64 = NDArray[np.float64]

#: relative error (max over 0–85° of |B_model − B_exact| / |B_exact|) the physical layout must
#: meet against the exact Cylinder stack at the initial setup (see docs/convergence.md)
PHYSICAL_TOLERANCE = 2e-4
#: rings per slice of the physical layout (the rms ring converges for k ≥ 5: docs/convergence.md)
PHYSICAL_DIPOLES = 5
#: slice counts tried by :func:`converged_layout`, smallest first
LAYOUT_SLICES = (8, 12, 16, 24, 32, 48, 64)
#: cylinder slices of the exact reference (converged to ~1e-6)
EXACT_SLICES = 2000
#: tilts of the physical layout's probe (toward +x, at the sensing element), rad
PHYSICAL_TILTS = np.radians(np.arange(0.0, 86.0, 5.0))


@dataclass(frozen=True)
class PhysicalLayout(Layout):
    """The dipole layout of the physical model: a :class:`~magcilia.model.convergence.Layout`
    (n_loops, dipoles_per_loop, ring — ``"rms"`` by default —, error, tolerance) chosen by
    :func:`converged_layout` with the calibration's tolerance, or given by hand (error and
    tolerance NaN)."""


def layout_error(setup: Setup, n_loops: int, dipoles_per_loop: int = PHYSICAL_DIPOLES,
                 angles: F64 | None = None) -> float:
    """Max over ``angles`` (rad, default 0–85° in 5° steps) of |B_model − B_exact| / |B_exact|
    at the sensing element for ``setup`` with the rms ring of ``n_loops`` × ``dipoles_per_loop``
    (dimensionless; :func:`magcilia.model.convergence.layout_error` with the calibration's
    probe: tilts toward +x, :data:`EXACT_SLICES` cylinders)."""
    a = PHYSICAL_TILTS if angles is None else np.asarray(angles, dtype=np.float64)
    return convergence.layout_error(setup, n_loops, dipoles_per_loop, "rms", tilts=a,
                                    azimuths=(0.0,), reference_slices=EXACT_SLICES)


def converged_layout(setup: Setup, tolerance: float = PHYSICAL_TOLERANCE,
                     strict: bool = True) -> PhysicalLayout:
    """The smallest rms-ring layout (n of :data:`LAYOUT_SLICES`, k = :data:`PHYSICAL_DIPOLES`)
    whose field at ``setup`` is within ``tolerance`` of the exact Cylinder stack over 0–85°
    (:func:`magcilia.model.convergence.converged_layout` with the calibration's probe).

    Parameters
    ----------
    setup : Setup
        Geometry and placement (its n, k and ring are not used).
    tolerance : float
        Max relative error |B_model − B_exact| / |B_exact| (dimensionless, > 0).
    strict : bool
        Raise when no layout reaches it; else return the largest one tried, its ``error`` above
        the tolerance (a sensing element very close to the base converges slowly).

    Returns
    -------
    PhysicalLayout

    Examples
    --------
    >>> import magcilia as mc
    >>> lay = converged_layout(mc.Setup.paper(), 1e-3)
    >>> lay.n_loops, lay.dipoles_per_loop, lay.ring, lay.error < 1e-3
    (32, 5, 'rms', True)
    >>> converged_layout(mc.Setup.paper()).n_loops  # the default tolerance, 2e-4
    64
    """
    lay = convergence.converged_layout(
        setup, tolerance, tilts=PHYSICAL_TILTS, azimuths=(0.0,), slices=LAYOUT_SLICES,
        dipoles_per_loop=PHYSICAL_DIPOLES, reference_slices=EXACT_SLICES, strict=strict)
    return PhysicalLayout(lay.n_loops, lay.dipoles_per_loop, lay.ring, lay.error, lay.tolerance)


def as_layout(layout: PhysicalLayout | tuple[int, int] | None, initial: Setup,
               tolerance: float) -> PhysicalLayout:
    """The layout to fit with: ``layout`` checked (a :class:`PhysicalLayout`, any
    :class:`~magcilia.model.convergence.Layout`, or (n, k)), or :func:`converged_layout` of
    ``initial`` at ``tolerance`` when None."""
    if layout is None:
        return converged_layout(initial, tolerance, strict=False)
    if isinstance(layout, Layout):
        return layout if isinstance(layout, PhysicalLayout) else PhysicalLayout(
            layout.n_loops, layout.dipoles_per_loop, layout.ring, layout.error, layout.tolerance)
    try:
        n, k = (int(layout[0]), int(layout[1]))
    except (TypeError, ValueError, IndexError):
        raise v.fail("layout", layout, "(n_loops, dipoles_per_loop), a PhysicalLayout or None "
                                       "(chosen by converged_layout)") from None
    if n < 1 or k < 1:
        raise v.fail("layout", layout, "two whole numbers ≥ 1")
    return PhysicalLayout(n, k)
