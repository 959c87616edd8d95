"""Arrays of cilia under loads: the forward map, crosstalk, the inverse and design metrics.

Where each part lives: the loaded shapes, exact and tabulated (:mod:`.array_model`), the
read-out (:mod:`.array_readout`: :class:`ArrayReadout`), its construction checks
(:mod:`.array_checks`), its results (:mod:`.array_results`), and here the metrics against the
pitch (:func:`array_metrics`); every public name is importable from here.

Loads. A horizontal force F = (Fx, Fy) (N) on cilium c's tip bends it in the vertical plane at
azimuth φ = atan2(Fy, Fx): the planar large-deflection shape of :func:`magcilia.bend` under
``|F|`` turned by φ about the vertical axis through its base
(:meth:`SpatialCentreline.from_planar`), its dipole rings kept fixed in the board frame
(:func:`magcilia.model.array.board_normals`; see :mod:`magcilia.model.array` for why).
:func:`loaded_poses` / :func:`field_for_loads` solve the elastica for each cilium (exact);
:class:`ArrayReadout` tabulates each kind of cilium's planar shape against |F| once (a cubic
spline through :func:`magcilia.bend_sweep` shapes on a uniform grid over ``[−span, span]``, the
shapes at −F being the mirror images, so that the model is smooth through zero load), and turns
it for every cilium and azimuth at the cost of a few array operations.

Crosstalk (:meth:`ArrayReadout.crosstalk`). The matrix J (3S × 2C, T/N): the response of each
sensor axis (on the sensor's own axes) to a unit horizontal load on each cilium at rest, along x
(column 2c) and y (column 2c + 1), by central differences of the model (step 1e-4 of the span).
A sensor's response to a cilium is the spectral norm of its 3 × 2 block (the largest field change
per newton over load directions). Cilium c's *site* is the sensor nearest its base
(horizontally); its crosstalk ratio is the largest response of any other sensor over the site's.

Inverse (:meth:`ArrayReadout.read`). All cilia's force vectors from all sensors at once:
minimise ``Σ ((y − f(F)) / σ)² + α Σ (F / span)²`` over the 2C components, y the readings
(T, on the sensors' axes), σ each axis's noise and quantisation (:attr:`CiliaArray.sigma`, or a
tare's measured spread), f the tabulated model. The one batched least squares
(:func:`magcilia.fitting.fit_batch`; n samples at once: one kernel call evaluates the model of
all of them) from the linear solution ``(JᵀWJ + α/span²)⁻¹ JᵀW (y − f(0))``, or warm from the
frame before (``start``; the blocks of a long read chain: :mod:`.array_inverse`), with the
Jacobian analytic (the tables' slopes chained through the turn and the dipole field, one fused
kernel with the model: :mod:`magcilia.model.array_tabulated`; a sample's Jacobian is taken again
only after its estimate moved by more than 1e-2 of the span, or a step with the kept one failed:
chord steps near the solution). :meth:`ArrayReadout.stream` reads frame after frame, each call
warm from the last (the live views read an array so). The Tikhonov weight α
(``regularization``, dimensionless, default 1e-6) acts as a prior of span/√α (1000 spans) on
each component: it steadies the solve and biases an estimate by about
α / (α + (span · response / σ)²) of itself, ~1e-12 for a cilium whose full-span load moves its
readings by 1000 σ. Saturated and NaN readings are left
out of the fit (and flag the cilia they inform). Covariance: ``A⁻¹ JᵀWJ A⁻¹``, A = JᵀWJ +
α/span², at the solution (the sensors' white noise through the linearised model), plus a tare's
standard error through the same gain, plus the force scale's: each force scales with its
cilium's Young's modulus at a fixed shape, so the modulus's relative 1 σ adds along the force,
shared by the cilia of one modulus (:mod:`magcilia.readout.scale`); σ of |F| and of the
direction from it.

A problem is refused as singular (one-line error, at construction) when the readings are fewer
than the unknowns (3S < 2C), when a cilium's full-span load moves no reading by one σ in some
direction (its load does not reach any sensor), or when the loads of some cilia cannot be told
apart (the whitened, span-scaled matrix has a singular value below 1).

Neighbours. Two cilia that could touch when both are bent toward each other by their span's load
(the distance between their centrelines, point to point, less both radii, below zero anywhere)
are refused too: the array cannot measure beyond that contact; so is a sensor that a cilium
reaches under a load up to its span in some direction.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Any

import numpy as np
from numpy.typing import ArrayLike, NDArray

from magcilia import _validate as v
from magcilia._display import Display, Item, Table, dataframe, number, rows_table
from magcilia.device.array import CiliaArray
from magcilia.device.magnetometer import Magnetometer
from magcilia.device.setup import Setup
from magcilia.readout.array_model import LoadTable, field_for_loads, loaded_poses
from magcilia.readout.array_readout import (
    CROSSTALK_STEP,
    JACOBIAN_STEP,
    REFRESH_STEP,
    ArrayReadout,
)
from magcilia.readout.array_results import (
    ARRAY_FLAGS,
    ArrayEstimate,
    ArrayEstimates,
    ArrayFlag,
    Crosstalk,
)
from magcilia.readout.array_stream import ArrayStream
from magcilia.readout.protocol import Flag

F64 = NDArray[np.float64]


# -- design metrics vs pitch -----------------------------------------------------------------------

@dataclass(frozen=True, eq=False, repr=False)
class ArrayMetrics(Display):
    """Crosstalk and minimum detectable force of regular arrays against their pitch (SI).

    Attributes
    ----------
    pitches : ndarray, shape (P,)
        m.
    ratio : ndarray, shape (P, C)
        Crosstalk ratio of each cilium (:class:`Crosstalk`).
    minimum : ndarray, shape (P, C)
        Minimum detectable force per site, N (:meth:`ArrayReadout.sigma_at_rest`).
    isolated : float
        The minimum detectable force of one cilium alone over its sensor, N.
    names : tuple of str
        Cilium names.
    """

    pitches: F64
    ratio: F64
    minimum: F64
    isolated: float
    names: tuple[str, ...]

    def table(self) -> list[dict[str, Any]]:
        """One row per pitch (SI): the crosstalk ratio (median, largest) and the minimum
        detectable force (median, largest) over the sites."""
        return [{"pitch_m": float(p), "ratio_median": float(np.median(r)),
                 "ratio_max": float(r.max()), "minimum_median_N": float(np.median(m)),
                 "minimum_max_N": float(m.max()), "minimum_isolated_N": self.isolated}
                for p, r, m in zip(self.pitches, self.ratio, self.minimum, strict=True)]

    def to_dict(self) -> dict[str, Any]:
        """JSON-ready content (SI)."""
        return {"pitch_m": self.pitches.tolist(), "ratio": self.ratio.tolist(),
                "minimum_N": self.minimum.tolist(), "minimum_isolated_N": self.isolated,
                "names": list(self.names), "table": self.table()}

    def to_dataframe(self) -> Any:
        """One row per pitch, SI columns (:meth:`table`)."""
        rows = self.table()
        return dataframe({key: [r[key] for r in rows] for key in rows[0]})

    def report(self) -> str:
        """The table in display units (mm, mN)."""
        lines = [(f"array metrics vs pitch ({len(self.names)} cilia; one cilium alone: minimum "
                 f"detectable force {self.isolated * 1e3:.4g} mN)"),
                 (f"{'pitch mm':>9} {'ratio med':>10} {'ratio max':>10} {'min mN med':>11} "
                 f"{'min mN max':>11}")]
        for r in self.table():
            lines.append(f"{r['pitch_m'] * 1e3:>9.4g} {r['ratio_median']:>10.4g} "
                         f"{r['ratio_max']:>10.4g} {r['minimum_median_N'] * 1e3:>11.4g} "
                         f"{r['minimum_max_N'] * 1e3:>11.4g}")
        return "\n".join(lines)

    def _display_items(self) -> list[Item]:
        return [("pitches", f"{self.pitches.min() * 1e3:.3g}…{self.pitches.max() * 1e3:.3g} mm"),
                ("cilia", str(len(self.names))),
                ("largest ratio", number(float(self.ratio.max())))]

    def _display_table(self) -> Table | None:
        return rows_table(self.table())


def array_metrics(setup: Setup, pitches: ArrayLike, *, sensor: Magnetometer, span: float,
                  rows: int = 4, cols: int = 4, depth: float | None = None,
                  table_size: int = 17) -> ArrayMetrics:
    """Crosstalk ratio and minimum detectable force per site of rows × cols arrays of ``setup``
    with one ``sensor`` under each cilium (:meth:`CiliaArray.grid`), against the pitch.

    Parameters
    ----------
    setup : Setup
        The cilium.
    pitches : array-like, shape (P,)
        m (each large enough for the cilia not to touch at ``span``).
    sensor : Magnetometer
        The part under each cilium.
    span : float
        Largest horizontal tip force, N.
    rows, cols : int
        Array size (default 4 × 4).
    depth : float, optional
        Sensing points below the bases, m (see :meth:`CiliaArray.grid`).
    table_size : int
        Loads tabulated over the span (the metrics need the model at rest only).
    """
    p = v.finite_array("pitches", pitches, ndim=1, unit="m")
    if p.size == 0 or np.any(p <= 0.0):
        raise v.fail("pitches", pitches, "positive pitches in m")
    ratio, minimum = [], []
    names: tuple[str, ...] = ()
    for pitch in p.tolist():
        arr = CiliaArray.grid(setup, rows, cols, pitch, sensor=sensor, depth=depth)
        ro = ArrayReadout(arr, span, table_size=table_size)
        ratio.append(ro.crosstalk().ratio)
        minimum.append(ro.sigma_at_rest())
        names = arr.names
    alone = ArrayReadout(CiliaArray.grid(setup, 1, 1, float(p[0]), sensor=sensor, depth=depth),
                         span, table_size=table_size)
    out_r, out_m = np.array(ratio), np.array(minimum)
    for arr_ in (p, out_r, out_m):
        arr_.setflags(write=False)
    return ArrayMetrics(p, out_r, out_m, float(alone.sigma_at_rest()[0]), names)


__all__ = ["ARRAY_FLAGS", "CROSSTALK_STEP", "JACOBIAN_STEP", "REFRESH_STEP", "ArrayEstimate",
           "ArrayEstimates", "ArrayFlag", "ArrayMetrics", "ArrayReadout", "ArrayStream",
           "Crosstalk", "Flag",
           "LoadTable", "array_metrics", "field_for_loads", "loaded_poses"]
