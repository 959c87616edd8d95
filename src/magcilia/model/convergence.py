"""Converged dipole layouts: how far a layout is from the exact body, and the smallest one that
is close enough, at the points where a field is predicted.

The paper's layout (n = 2 slices × k = 5 dipoles on mean rings) is a *fitted* model: its
parameters absorb its error, 17 % at the paper's placement and 45–55 % a millimetre from the
base (docs/convergence.md). A field predicted for a new geometry, placement or observer must come
from a layout that converges to the real body. This module is the one mechanism that says how far
a layout is from it and picks a converged one; :meth:`magcilia.Setup.resolve_layout` applies it
for every path that predicts a field (the single-axis element, 3-axis sensors, arrays, read-out
tables, design, optimisation, live, the simulated source), and the physical calibration uses it
with its own, tighter tolerance (:func:`magcilia.calibration.joint.converged_layout`).

* **The reference** is the exact body: a stack of :data:`REFERENCE_SLICES` magpylib cylinders
  (:func:`magcilia.model.exact.exact_field`, error O(1/n²): ~4e-6 relative at 500 slices for a
  sensor 1 mm under the base of the paper's cilium, far below the tolerance).
* **The probe** is every observer where the path evaluates the field, in the rigid tilts
  :data:`TILTS` toward the azimuths :data:`AZIMUTHS` (a tilt toward φ is the tilt toward +x seen
  from the observer turned by −φ about the base's vertical axis). Tilts are a superset of the
  bent shapes a read-out meets: the near-base body, which sets the error, moves the same way.
  Observer/pose pairs inside the body are left out.
* **The error** of a layout is the largest relative error |B_model − B_exact| / |B_exact| (vector
  norm) over the probe.
* **The converged layout** is the smallest rms-ring layout (``ring="rms"``, k = :data:`DIPOLES`,
  n from :data:`SLICES`) within the tolerance (:data:`TOLERANCE`, 0.5 %). The rms ring converges
  to the exact body as O(1/n²); the paper's mean ring plateaus (0.25 % at the paper's placement,
  2.5 % 1 mm under the base), and k = 1 never converges.

References are cached per geometry, placement and probe (:data:`CACHE_SIZE` of them), so that a
path evaluated again for the same body costs only the (compiled) model evaluations.
"""

from __future__ import annotations

import math
from collections import OrderedDict
from dataclasses import asdict, dataclass, replace
from typing import Any

import numpy as np
from numpy.typing import ArrayLike, NDArray

from magcilia import _validate as v
from magcilia.model import body, layout_cache
from magcilia.model.azimuth import turn_about_z
from magcilia.model.centreline import Centreline
from magcilia.model.exact import exact_field
from magcilia.model.kernels import pose_field
from magcilia.model.pose import dipoles
from magcilia.model.spec import ModelSpec, SupportsSpec, as_spec

F64 = NDArray[np.float64]

#: how a setup names its layout: the paper's by name (Table I's, used as is: replication), one
#: converged at the points of every prediction, or one given by the user (used as is, its error
#: estimated and warned about above :data:`WARN_ABOVE`)
MODES = ("paper", "converged", "given")
#: the paper's layouts (n, k, ring), Table I optimized and initial: the only ones ``"paper"`` names
PAPER_LAYOUTS = ((2, 5, "mean"), (6, 3, "mean"))
#: the rule's tolerance: largest relative error of a converged layout over the probe
TOLERANCE = 5e-3
#: a given layout whose estimated error exceeds this is warned about
WARN_ABOVE = 1e-2
#: dipoles per ring of a converged layout (the rms ring converges for k ≥ 5: docs/convergence.md)
DIPOLES = 5
#: slice counts tried, smallest first (a sensor 1 mm under a 0.18 mm base needs 32–64)
SLICES = (8, 12, 16, 24, 32, 48, 64, 96, 128, 192, 256)
#: cylinder slices of the exact reference
REFERENCE_SLICES = 500
#: rigid tilts of the probe, rad (0–85°)
TILTS = np.radians([0.0, 15.0, 30.0, 45.0, 60.0, 75.0, 85.0])
#: tilt directions of the probe, rad (toward +x, +y, −x, −y)
AZIMUTHS = (0.0, 0.5 * math.pi, math.pi, 1.5 * math.pi)
#: exact references kept in memory
CACHE_SIZE = 64


@dataclass(frozen=True)
class Layout:
    """A dipole layout and how far it is from the exact body.

    Attributes
    ----------
    n_loops, dipoles_per_loop : int
        Slices n and dipoles per ring k.
    ring : str
        The ring radius rule (``"rms"`` converges to the exact body; ``"mean"`` is the paper's).
    error : float
        Largest relative error |B_model − B_exact| / |B_exact| over the probe it was checked on
        (dimensionless; NaN when not estimated).
    tolerance : float
        The tolerance it was chosen for (NaN when it was not chosen by
        :func:`converged_layout`).
    """

    n_loops: int
    dipoles_per_loop: int
    ring: str = "rms"
    error: float = math.nan
    tolerance: float = math.nan

    @property
    def converged(self) -> bool:
        """Whether it was chosen for a tolerance and meets it."""
        return bool(self.error <= self.tolerance)

    def text(self) -> str:
        """One line for reports: ``"32×5 rms, 0.12 % from the exact body"``."""
        out = f"{self.n_loops}×{self.dipoles_per_loop} {self.ring}"
        if math.isfinite(self.error):
            out += f", {100 * self.error:.2g} % from the exact body"
        if math.isfinite(self.tolerance):
            out += f" (tolerance {100 * self.tolerance:g} %)"
        return out


def probe_points(spec: ModelSpec | SupportsSpec, points: ArrayLike | None = None,
                 azimuths: ArrayLike = AZIMUTHS) -> F64:
    """The observers of the probe: each of ``points`` ((o, 3), m in the sensor frame; default the
    sensing element, the origin) turned by −φ about the vertical axis through the base centre
    for each azimuth φ, shape (len(azimuths) · o, 3), m. A tilt toward +x seen from a turned
    observer is the tilt toward φ seen from the observer."""
    s = as_spec(spec)
    pts = np.zeros((1, 3)) if points is None else \
        v.finite_array("points", points, unit="m").reshape(-1, 3)
    base = s.base_centre
    rel = pts - base
    out = []
    for phi in np.asarray(azimuths, dtype=np.float64).reshape(-1):
        out.append(turn_about_z(rel, phi, inverse=True) + base)
    return np.unique(np.concatenate(out).round(15), axis=0)


def _outside(spec: ModelSpec, pts: F64, tilts: F64) -> NDArray[np.bool_]:
    """(a, o): observer o outside the cilium tilted by ``tilts[a]`` toward +x (with a margin of
    1 % of the largest radius: the surface itself is left out too)."""
    rel = pts - spec.base_centre
    c, s = np.cos(tilts)[:, None], np.sin(tilts)[:, None]
    axial = s * rel[None, :, 0] + c * rel[None, :, 2]
    radial = np.hypot(c * rel[None, :, 0] - s * rel[None, :, 2], rel[None, :, 1])
    pad = 0.01 * spec.max_radius
    near = body.contains(spec.height + 2 * pad, spec.base_radius, spec.knots, spec.radii,
                         axial + pad, radial - pad)
    return np.asarray(~near)


def _key(spec: ModelSpec, pts: F64, tilts: F64, slices: int) -> tuple[object, ...]:
    """What the exact reference depends on (not the magnetization: errors are relative)."""
    return (spec.height, spec.base_radius, spec.knots.tobytes(), spec.radii.tobytes(),
            tuple(spec.base_centre.tolist()), pts.tobytes(), tilts.tobytes(), slices)


_REFERENCES: OrderedDict[tuple[object, ...], tuple[F64, NDArray[np.bool_]]] = OrderedDict()


def reference(spec: ModelSpec | SupportsSpec, pts: F64, tilts: ArrayLike = TILTS,
              reference_slices: int = REFERENCE_SLICES) -> tuple[F64, NDArray[np.bool_]]:
    """The exact body's field at observers ``pts`` ((o, 3), m) in rigid tilts toward +x, T,
    shape (a, o, 3), and the mask (a, o) of the pairs with the observer outside the body
    (cached per unit magnetization; the field of the others is 0)."""
    s = as_spec(spec)
    angles = np.asarray(tilts, dtype=np.float64).reshape(-1)
    n = v.integer("reference_slices", reference_slices, 1)
    key = _key(s, pts, angles, n)
    hit = _REFERENCES.get(key)
    if hit is None:
        mask = _outside(s, pts, angles)
        unit = replace(s, full_magnetization=1.0, magnetization_scale=1.0)  # per A/m
        b = exact_field(unit, Centreline.straight(s.height, angles), n_slices=n, points=pts,
                        check=False)
        b = np.where(mask[..., None], b, 0.0)
        b.setflags(write=False)
        mask.setflags(write=False)
        hit = _REFERENCES[key] = (b, mask)
        while len(_REFERENCES) > CACHE_SIZE:
            _REFERENCES.popitem(last=False)
    else:
        _REFERENCES.move_to_end(key)
    return hit[0] * s.magnetization, hit[1]


def _probe(spec: ModelSpec | SupportsSpec, points: ArrayLike | None, tilts: ArrayLike,
           azimuths: ArrayLike, reference_slices: int
           ) -> tuple[ModelSpec, F64, F64, F64, NDArray[np.bool_]]:
    """The probe of :func:`layout_error` and :func:`converged_layout`: the spec, its observers
    (:func:`probe_points`), the tilts (rad) and the exact reference with its mask
    (:func:`reference`)."""
    s = as_spec(spec)
    pts = probe_points(s, points, azimuths)
    angles = np.asarray(tilts, dtype=np.float64).reshape(-1)
    exact, mask = reference(s, pts, angles, reference_slices)
    return s, pts, angles, exact, mask


def _error(n_loops: int, dipoles_per_loop: int, ring: str, spec: ModelSpec, pts: F64,
           angles: F64, exact: F64, mask: NDArray[np.bool_]) -> float:
    """Largest relative error of the n × k layout with ``ring`` over a probe (:func:`_probe`)."""
    trial = replace(spec, n_loops=int(n_loops), dipoles_per_loop=int(dipoles_per_loop),
                    ring=ring)
    pos, mom = dipoles(trial, Centreline.straight(spec.height, angles))
    with np.errstate(divide="ignore", invalid="ignore", over="ignore"):
        model = pose_field(pts, pos, mom)
        norm = np.linalg.norm(exact, axis=-1)
        rel = np.linalg.norm(model - exact, axis=-1) / np.where(norm > 0.0, norm, 1.0)
    rel = np.where(mask & (norm > 0.0), rel, 0.0)
    worst = float(np.max(rel)) if rel.size else 0.0
    return worst if math.isfinite(worst) else math.inf


def layout_error(spec: ModelSpec | SupportsSpec, n_loops: int, dipoles_per_loop: int,
                 ring: str = "rms", *, points: ArrayLike | None = None,
                 tilts: ArrayLike = TILTS, azimuths: ArrayLike = AZIMUTHS,
                 reference_slices: int = REFERENCE_SLICES) -> float:
    """Largest relative error |B_model − B_exact| / |B_exact| of the n × k layout with ``ring``
    over the probe (dimensionless; module docstring).

    Parameters
    ----------
    spec : ModelSpec or Setup
        Geometry, magnetization and placement (its own n, k and ring are not used).
    n_loops, dipoles_per_loop : int
        The layout: slices and dipoles per ring.
    ring : {"mean", "rms"}
        Ring radius rule.
    points : array-like, shape (o, 3), optional
        Observers in the sensor frame, m (default the sensing element).
    tilts : array-like, shape (a,)
        Rigid tilts of the probe, rad.
    azimuths : array-like
        Tilt directions of the probe, rad.
    reference_slices : int
        Cylinder slices of the exact reference.

    Examples
    --------
    >>> import magcilia as mc
    >>> round(100 * layout_error(mc.Setup.paper(), 2, 5, "mean", azimuths=[0.0]))  # percent
    17
    """
    return _error(n_loops, dipoles_per_loop, ring,
                  *_probe(spec, points, tilts, azimuths, reference_slices))


def converged_layout(spec: ModelSpec | SupportsSpec, tolerance: float = TOLERANCE, *,
                     points: ArrayLike | None = None, tilts: ArrayLike = TILTS,
                     azimuths: ArrayLike = AZIMUTHS, slices: tuple[int, ...] = SLICES,
                     dipoles_per_loop: int = DIPOLES,
                     reference_slices: int = REFERENCE_SLICES, strict: bool = False) -> Layout:
    """The smallest rms-ring layout (n from ``slices``, k = ``dipoles_per_loop``) whose field is
    within ``tolerance`` of the exact body over the probe (module docstring).

    Parameters
    ----------
    spec : ModelSpec or Setup
        Geometry, magnetization and placement (its own n, k and ring are not used).
    tolerance : float
        Largest relative error |B_model − B_exact| / |B_exact| (dimensionless, > 0).
    points, tilts, azimuths, reference_slices
        The probe, as :func:`layout_error`.
    slices : tuple of int
        Slice counts tried, smallest first.
    dipoles_per_loop : int
        k of every layout tried.
    strict : bool
        Raise when no layout reaches the tolerance; else (default) return the largest one tried,
        its ``error`` above the tolerance (``Layout.converged`` False: an observer very close to
        the body converges slowly).

    Returns
    -------
    Layout

    Examples
    --------
    >>> import magcilia as mc
    >>> lay = converged_layout(mc.Setup.paper())
    >>> lay.n_loops, lay.dipoles_per_loop, lay.ring, lay.converged
    (16, 5, 'rms', True)
    """
    tol = v.real("tolerance", tolerance, "")
    if not tol > 0.0:
        raise v.fail("tolerance", tolerance, "a positive relative error, e.g. 5e-3")
    tried = tuple(v.integer("slices", n, 1) for n in slices)
    if not tried:
        raise v.fail("slices", slices, "at least one slice count")
    # remembered across processes (model/layout_cache.py): the probe's reference needs magpylib
    s = as_spec(spec)
    pts = probe_points(s, points, azimuths)
    angles = np.asarray(tilts, dtype=np.float64).reshape(-1)
    refs = v.integer("reference_slices", reference_slices, 1)
    name = layout_cache.key((*_key(s, pts, angles, refs), tol, tried, dipoles_per_loop))
    known = _known(layout_cache.load(name))
    if known is not None and (known.converged or not strict):
        return known
    probe = _probe(s, points, tilts, azimuths, reference_slices)
    error = math.nan
    for n in tried:
        error = _error(n, dipoles_per_loop, "rms", *probe)
        if error <= tol:
            return _remember(name, Layout(n, dipoles_per_loop, "rms", error, tol))
    if strict:
        raise v.MagciliaError(
            f"no layout up to {tried[-1]} slices reaches the tolerance {tol:g} here (best "
            f"{error:.3g}): an observer is very close to the cilium; raise the tolerance or "
            "give the layout (n_loops, dipoles_per_loop)")
    return _remember(name, Layout(tried[-1], dipoles_per_loop, "rms", error, tol))


def _known(data: dict[str, Any] | None) -> Layout | None:
    """A stored layout (:mod:`magcilia.model.layout_cache`), or None if absent or malformed."""
    if data is None:
        return None
    try:
        return Layout(int(data["n_loops"]), int(data["dipoles_per_loop"]), str(data["ring"]),
                      float(data["error"]), float(data["tolerance"]))
    except (KeyError, TypeError, ValueError):
        return None


def _remember(name: str, layout: Layout) -> Layout:
    layout_cache.store(name, asdict(layout))
    return layout
