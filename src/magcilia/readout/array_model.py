"""The loaded shapes of an array's cilia: exact (one elastica each) and tabulated (SI).

A horizontal force F = (Fx, Fy) (N) on cilium c's tip bends it in the vertical plane at azimuth
φ = atan2(Fy, Fx): the planar large-deflection shape of :func:`magcilia.bend` under ``|F|``
turned by φ about the vertical axis through its base (:meth:`SpatialCentreline.from_planar`),
its dipole rings kept fixed in the board frame (:func:`magcilia.model.array.board_normals`; see
:mod:`magcilia.model.array` for why). :func:`loaded_poses` / :func:`field_for_loads` solve the
elastica for each cilium (exact); :class:`LoadTable` tabulates one kind of cilium's planar shape
against |F| (a cubic spline through :func:`magcilia.bend_sweep` shapes on a uniform grid over
``[−span, span]``, the shapes at −F being the mirror images, so that the model is smooth through
zero load), which :class:`~magcilia.ArrayReadout` turns for every cilium and azimuth at the cost
of a few array operations.
"""

from __future__ import annotations

import dataclasses
import math
from dataclasses import dataclass
from functools import lru_cache
from typing import Any

import numpy as np
from numpy.typing import ArrayLike, NDArray

from magcilia import _validate as v
from magcilia.device.array import CiliaArray
from magcilia.device.cilium import Cilium
from magcilia.device.setup import Setup
from magcilia.mechanics import bend, bend_sweep
from magcilia.model.array import board_normals
from magcilia.model.centreline import Centreline, SpatialCentreline

F64 = NDArray[np.float64]


@dataclass(frozen=True, eq=False)
class LoadTable:
    """Planar slice frames of one kind of cilium against the force magnitude (plain values).

    Attributes
    ----------
    span : float
        Largest tabulated force, N (the grid is uniform over [−span, span]).
    step : float
        Grid step, N.
    coefficients : ndarray, shape (4, 2 g − 2, 3 n)
        The cubic spline's polynomial coefficients per interval (highest power first) of the
        slice mid-points' x (m), z (m) and tangent angle θ (rad), n slices each.
    error : ndarray, shape (3,)
        Largest difference between the spline and directly solved shapes at the mid-points of
        the positive half grid: x, z (m) and θ (rad).
    """

    span: float
    step: float
    coefficients: F64
    error: F64

    @property
    def slices(self) -> int:
        """Slices n."""
        return int(self.coefficients.shape[2] // 3)

    def frames(self, magnitude: F64) -> tuple[F64, F64, F64]:
        """x, z (m) and θ (rad) of the slice mid-points at force magnitudes (C,) N, each (C, n);
        beyond the span the last interval's cubic continues."""
        cells = self.coefficients.shape[1]
        idx = np.clip(((magnitude + self.span) / self.step).astype(np.int64), 0, cells - 1)
        u = (magnitude + self.span - idx * self.step)[:, None]
        c = self.coefficients[:, idx]
        out = ((c[0] * u + c[1]) * u + c[2]) * u + c[3]
        n = self.slices
        return out[:, :n], out[:, n:2 * n], out[:, 2 * n:]


def slice_frames(shapes: Centreline, s_mid: F64) -> F64:
    """x, z, θ of the slice mid-points of planar shapes, (a, 3 n)."""
    pts, th = shapes.frames(s_mid)
    return np.concatenate([pts[..., 0], pts[..., 2], th], axis=1)


@lru_cache(maxsize=32)
def load_table(cilium: Cilium, modulus: float, n_loops: int, span: float,
                size: int) -> LoadTable:
    setup = Setup(dataclasses.replace(cilium, youngs_modulus=modulus), n_loops=n_loops)
    s_mid = cilium.height * (np.arange(n_loops) + 0.5) / n_loops
    grid = np.linspace(0.0, span, size)
    shapes = bend_sweep(setup, forces=grid)
    assert isinstance(shapes, Centreline)  # for mypy: loads in the x–z plane give planar shapes
    frames = slice_frames(shapes, s_mid)  # (size, 3n)
    n = n_loops
    mirror = frames[:0:-1].copy()  # −F: x and θ change sign, z does not
    mirror[:, :n] *= -1.0
    mirror[:, 2 * n:] *= -1.0
    both = np.concatenate([mirror, frames])
    forces = np.concatenate([-grid[:0:-1], grid])
    from scipy.interpolate import CubicSpline
    spline = CubicSpline(forces, both, axis=0)
    mids = 0.5 * (grid[:-1] + grid[1:])
    mid_shapes = bend_sweep(setup, forces=mids)
    assert isinstance(mid_shapes, Centreline)  # for mypy (as above)
    exact = slice_frames(mid_shapes, s_mid)
    err = np.abs(spline(mids) - exact)
    error = np.array([err[:, :n].max(), err[:, n:2 * n].max(), err[:, 2 * n:].max()])
    coefficients = np.ascontiguousarray(spline.c)
    for arr in (coefficients, error):
        arr.setflags(write=False)
    return LoadTable(span=span, step=span / (size - 1), coefficients=coefficients, error=error)


# -- exact loaded shapes --------------------------------------------------------------------------

def checked_forces(array: CiliaArray, forces: ArrayLike) -> F64:
    f = v.finite_array("forces", forces, unit="N")
    if f.ndim != 2 or f.shape[0] != len(array) or f.shape[1] not in (2, 3):
        raise v.fail("forces", f"an array of shape {f.shape}",
                     f"shape ({len(array)}, 2) or ({len(array)}, 3): (Fx, Fy[, Fz]) per cilium, N")
    return f


def loaded_poses(array: CiliaArray, forces: ArrayLike) -> SpatialCentreline | list[Any]:
    """The cilia's shapes under tip forces, solved exactly (one :func:`magcilia.bend` each).

    Parameters
    ----------
    array : CiliaArray
    forces : array-like, shape (C, 2) or (C, 3)
        (Fx, Fy) or (Fx, Fy, Fz) per cilium, N, board frame: the force bends the cilium in the
        vertical plane at azimuth atan2(Fy, Fx), with direction atan2(|F_h|, Fz) from +z in that
        plane.

    Returns
    -------
    SpatialCentreline or list
        One shape per cilium, rings fixed in the board (:func:`magcilia.model.array.board_normals`):
        one SpatialCentreline of C shapes when the cilia share their length, else a list of C
        one-shape SpatialCentrelines. For :meth:`CiliaArray.field`.
    """
    f = checked_forces(array, forces)
    shapes = []
    for c, setup in enumerate(array.cilia):
        fh = math.hypot(f[c, 0], f[c, 1])
        fz = f[c, 2] if f.shape[1] == 3 else 0.0
        magnitude = math.hypot(fh, fz)
        planar = bend(setup, force=magnitude, direction=math.atan2(fh, fz)) if magnitude \
            else bend(setup)
        assert isinstance(planar, Centreline)  # for mypy: a load in the x–z plane
        phi = math.atan2(f[c, 1], f[c, 0]) if fh > 0.0 else 0.0
        spatial = SpatialCentreline.from_planar(planar, phi)
        shapes.append(SpatialCentreline(spatial.s, spatial.points, spatial.tangents,
                                        board_normals(spatial.tangents, spatial.normals)))
    if all(sh.s.size == shapes[0].s.size and np.array_equal(sh.s, shapes[0].s) for sh in shapes):
        return SpatialCentreline(shapes[0].s, np.concatenate([sh.points for sh in shapes]),
                                 np.concatenate([sh.tangents for sh in shapes]),
                                 np.concatenate([sh.normals for sh in shapes]))
    return shapes


def field_for_loads(array: CiliaArray, forces: ArrayLike) -> F64:
    """Field at every sensor (T, board frame, shape (S, 3)) with every cilium bent by its tip
    force ((C, 2) or (C, 3), N; :func:`loaded_poses`, exact elastica)."""
    return array.field(loaded_poses(array, forces))
