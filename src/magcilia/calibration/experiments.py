"""Calibration experiments as residual objects that add (iminuit's cost functions are the model:
``cost1 + cost2``).

Each experiment contributes weighted residual rows ``(measured − model − bias) / s.e.`` to one
:class:`~magcilia.calibration.problem.Problem`, and its own linear bias parameters (a constant
offset, a polynomial in the angle, one offset per field axis), which the problem solves in closed
form; a :class:`Prior` contributes the row ``(p − μ) / σ``. Experiments add:
``TiltPath(a) + FieldPath(b) + Prior("height", 3e-3, 2e-4)`` is an :class:`Experiments`, the
sum of their costs (χ²) when nothing links them but the shared parameters.

* :class:`TiltPath`: a single-axis sensor's output (V) along rigid tilts toward any azimuth; with
  ``weighted=False`` and a polynomial bias it is the paper's single-path model (cost in V², the
  paper's eq. 6), not a second pipeline;
* :class:`FieldPath`: a 3-axis magnetometer's field (T) along rigid tilts;
* :class:`LoadExperiment`: the output or field under tip forces or flow speeds (the bent cilium);
* :class:`CoilExperiment`: the output or field under applied uniform fields (a Helmholtz coil):
  the cilium bent by the field's couple plus the applied field itself
  (:mod:`~magcilia.calibration.coil_model`);
* :class:`Prior`: a Gaussian prior from a manual measurement.

:func:`experiment` picks the type of a :class:`~magcilia.io.recordings.Measurement`.
"""

from __future__ import annotations

from collections.abc import Iterator, Sequence
from dataclasses import dataclass

import numpy as np
from numpy.typing import NDArray

from magcilia import _validate as v
from magcilia.calibration.parameters import ParameterKey
from magcilia.io.recordings import Measurement
from magcilia.mechanics.drag import FLUIDS, Fluid

F64 = NDArray[np.float64]

#: standard errors are floored at this fraction of the experiment's median positive s.e. …
SEM_FLOOR_FRACTION = 0.1
#: … and at these absolute values (output V, field T): a zero s.e. (noise-free or single-sample
#: data) cannot blow the weight up
SEM_FLOOR = {"output": 1e-7, "field": 1e-10}


def floored_sigma(values: F64, observable: str) -> F64:
    """Standard errors with the floors of :data:`SEM_FLOOR_FRACTION` and :data:`SEM_FLOOR`."""
    s = np.where(np.isfinite(values), values, 0.0)
    positive = s[s > 0]
    floor = SEM_FLOOR[observable]
    if positive.size:
        floor = max(floor, SEM_FLOOR_FRACTION * float(np.median(positive)))
    return np.maximum(s, floor)


def fluid_of(e: Measurement) -> Fluid:
    """The fluid of a flow experiment (``metadata["fluid"]``: a name of
    :data:`~magcilia.mechanics.drag.FLUIDS`, default water)."""
    name = e.fluid.strip().lower()
    if name not in FLUIDS:
        raise v.fail(f"{v.printable(str(e.source))}: fluid", e.fluid,
                     "one of " + ", ".join(sorted(FLUIDS)) + " (metadata 'fluid')")
    return FLUIDS[name]


def canonical_azimuths(azimuths: F64) -> F64:
    """Azimuths folded into [0, 2π) and rounded (12 decimals), so that equal directions meet."""
    return np.asarray(np.round(np.mod(np.asarray(azimuths, dtype=np.float64), 2 * np.pi), 12),
                      dtype=np.float64)


@dataclass(frozen=True)
class Rows:
    """What one experiment contributes to a problem: its residual rows.

    Attributes
    ----------
    column : ndarray of int, shape (d,)
        Each row's column of the problem's model table.
    factor : ndarray, shape (d,)
        Multiplies that column (the sensor scale for an output read from a field column, else 1).
    y : ndarray, shape (d,)
        The measured values, V or T.
    sigma : ndarray, shape (d,)
        Their standard errors (1 where unweighted).
    basis : ndarray, shape (d, g)
        The experiment's bias columns (its linear parameters, unweighted).
    keys : tuple of ParameterKey, length g
        Their names.
    """

    column: NDArray[np.intp]
    factor: F64
    y: F64
    sigma: F64
    basis: F64
    keys: tuple[ParameterKey, ...]


class Experiment:
    """A residual object of a calibration; ``a + b`` is their sum (:class:`Experiments`)."""

    def __add__(self, other: Experiment) -> Experiments:
        return Experiments((*self, *other))

    def __iter__(self) -> Iterator[Experiment]:
        yield self


class Table:
    """The model table of a problem's data experiments: the field (or, when every experiment is an
    output tilted toward azimuth 0, the output) at each distinct (azimuth, angle), then each load
    experiment's block; experiments ask it for their columns."""

    def __init__(self, x_only: bool) -> None:
        self.x_only = x_only
        self.stride = 1 if x_only else 3
        self.azimuths: F64 = np.zeros(0)
        self.angles: list[F64] = []
        self.starts: list[int] = []
        self.width = 0
        #: load blocks (experiment, azimuth, sorted distinct loads, first column)
        self.loads: list[tuple[int, float, F64, int]] = []
        #: coil blocks (experiment, first column, width): one column per condition (output) or
        #: three (field), in the experiment's order
        self.coils: list[tuple[int, int, int]] = []

    def add_tilts(self, azimuths: F64, angles: F64) -> None:
        """Lay out the tilt conditions (every (azimuth, angle) of the tilt experiments)."""
        phi = canonical_azimuths(azimuths)
        self.azimuths = np.unique(phi)
        for az in self.azimuths:
            a = np.unique(np.asarray(angles, dtype=np.float64)[np.isclose(phi, az)])
            self.angles.append(a)
            self.starts.append(self.width)
            self.width += self.stride * a.size

    def tilt_columns(self, azimuths: F64, angles: F64) -> NDArray[np.intp]:
        """First column of each condition (its x component)."""
        j = np.searchsorted(self.azimuths, canonical_azimuths(azimuths))
        pos = np.array([np.searchsorted(self.angles[jj], a)
                        for jj, a in zip(j, angles, strict=True)], dtype=np.intp)
        return np.asarray(self.starts, dtype=np.intp)[j] + self.stride * pos

    def load_columns(self, e_index: int, azimuths: F64, loads: F64) -> NDArray[np.intp]:
        """Add the blocks of a load experiment (one per azimuth); first column of each
        condition."""
        phi = canonical_azimuths(azimuths)
        cond = np.zeros(phi.size, dtype=np.intp)
        for az in np.unique(phi):
            at = phi == az
            values = np.unique(loads[at])
            self.loads.append((e_index, float(az), values, self.width))
            cond[at] = self.width + 3 * np.searchsorted(values, loads[at])
            self.width += 3 * values.size
        return cond


    def coil_columns(self, e_index: int, conditions: int, stride: int) -> NDArray[np.intp]:
        """Add the block of a coil experiment (``conditions`` values of ``stride`` columns each:
        1 output, 3 field components); first column of each condition."""
        first = self.width
        self.coils.append((e_index, first, stride * conditions))
        self.width += stride * conditions
        return np.asarray(first + stride * np.arange(conditions), dtype=np.intp)


@dataclass(frozen=True, eq=False)
class RecordedExperiment(Experiment):
    """An experiment on a recording."""

    data: Measurement
    weighted: bool = True

    def __post_init__(self) -> None:
        if not isinstance(self.data, Measurement):
            raise v.fail(f"{type(self).__name__} data", type(self.data).__name__,
                         "a magcilia Measurement (use read_measurements)")
        kind = experiment_type(self.data)
        if not isinstance(self, kind):
            raise v.fail(f"{type(self).__name__} data", v.printable(str(self.data.source)),
                         f"a recording of its kind ({kind.__name__} fits this one; "
                         "experiment(data) picks the type)")

    @property
    def tilts(self) -> tuple[F64, F64] | None:
        """Its tilt conditions (azimuths, angles), rad; None for a load or coil experiment."""
        if self.data.loads is not None or self.data.actuation is not None:
            return None
        return np.asarray(self.data.azimuths, dtype=np.float64), np.asarray(self.data.angles)

    def _columns(self, table: Table, e_index: int) -> NDArray[np.intp]:
        e = self.data
        if e.loads is not None:
            return table.load_columns(e_index, np.asarray(e.azimuths), np.asarray(e.loads))
        return table.tilt_columns(np.asarray(e.azimuths), np.asarray(e.angles))

    def rows(self, table: Table, e_index: int, sensor_scale: float) -> Rows:
        """The rows of this experiment, experiment ``e_index`` of the problem."""
        raise NotImplementedError


@dataclass(frozen=True, eq=False)
class TiltPath(RecordedExperiment):
    """A single-axis sensor's output (V) along rigid tilts, toward any azimuth.

    Parameters
    ----------
    data : Measurement
        Per-angle mean outputs (``observable == "output"``).
    weighted : bool
        Residuals divided by the floored standard errors (χ²); False: in V (the paper's cost).
    bias_degree : int or None
        The bias: a polynomial of this degree in the angle (0: a constant offset), None: none.
    """

    bias_degree: int | None = 0

    def rows(self, table: Table, e_index: int, sensor_scale: float) -> Rows:
        e = self.data
        cond = self._columns(table, e_index)
        y = np.asarray(e.volts, dtype=np.float64)
        sigma = (floored_sigma(np.asarray(e.sem, dtype=np.float64), "output") if self.weighted
                 else np.ones(y.size))
        degree = -1 if self.bias_degree is None else self.bias_degree
        angles = np.asarray(e.angles, dtype=np.float64)
        basis = (np.vander(angles, degree + 1, increasing=True) if degree >= 0
                 else np.zeros((y.size, 0)))
        keys = tuple(ParameterKey("offset", e_index) if d == 0
                     else ParameterKey("bias", e_index, degree=d) for d in range(degree + 1))
        factor = np.ones(y.size) if table.x_only else np.full(y.size, sensor_scale)
        return Rows(cond, factor, y, sigma, basis, keys)


@dataclass(frozen=True, eq=False)
class FieldPath(RecordedExperiment):
    """A 3-axis magnetometer's field (T) along rigid tilts (or under loads), one constant offset
    per axis (the Earth's field and the magnetometer's own offsets)."""

    def rows(self, table: Table, e_index: int, sensor_scale: float,  # noqa: ARG002
             columns: NDArray[np.intp] | None = None) -> Rows:
        e = self.data
        cond = self._columns(table, e_index) if columns is None else columns
        a = cond.size
        fields = np.asarray(e.fields, dtype=np.float64)
        fsem = floored_sigma(np.asarray(e.field_sem, dtype=np.float64).ravel(), "field")
        fsem = fsem.reshape(-1, 3) if self.weighted else np.ones((a, 3))
        basis = np.zeros((3 * a, 3))
        for c in range(3):
            basis[c * a:(c + 1) * a, c] = 1.0
        return Rows(np.concatenate([cond + c for c in range(3)]), np.ones(3 * a),
                    fields.T.ravel(), fsem.T.ravel(), basis,
                    tuple(ParameterKey("offset", e_index, axis=c) for c in range(3)))


@dataclass(frozen=True, eq=False)
class LoadExperiment(RecordedExperiment):
    """The output (V) or field (T) of the bent cilium under tip forces (N) or flow speeds (m/s),
    with its constant offset(s); its model is the bent shapes of
    :func:`~magcilia.mechanics.bend.bend_sweep` and their field, for every parameter set of a
    population at once (:func:`~magcilia.calibration.load_model.load_fields`)."""

    def rows(self, table: Table, e_index: int, sensor_scale: float) -> Rows:
        kind = FieldPath.rows if self.data.fields is not None else TiltPath.rows
        return kind(self, table, e_index, sensor_scale)  # type: ignore[arg-type]


@dataclass(frozen=True, eq=False)
class CoilExperiment(RecordedExperiment):
    """The output (V) or field (T) of the upright cilium under known applied uniform fields (a
    Helmholtz coil's, :attr:`~magcilia.io.recordings.Measurement.actuation`), with its constant
    offset(s) (the Earth's and the lab's field, the bridge offset); its model is the cilium bent
    by each field's couple, its field at the sensing element, plus the applied field as the sensor
    sees it (times the sensitivity for a single-axis output), for every parameter set of a
    population at once (:func:`~magcilia.calibration.coil_model.coil_block`).

    Its model values are the problem's own columns (the sensitivity is a fitted parameter, not a
    fixed factor): one per condition for an output, three for a field."""

    def rows(self, table: Table, e_index: int, sensor_scale: float) -> Rows:
        e = self.data
        field = e.fields is not None
        cond = table.coil_columns(e_index, len(e), 3 if field else 1)
        if field:
            return FieldPath.rows(self, table, e_index, sensor_scale,  # type: ignore[arg-type]
                                  columns=cond)
        y = np.asarray(e.volts, dtype=np.float64)
        sigma = (floored_sigma(np.asarray(e.sem, dtype=np.float64), "output") if self.weighted
                 else np.ones(y.size))
        return Rows(cond, np.ones(y.size), y, sigma, np.ones((y.size, 1)),
                    (ParameterKey("offset", e_index),))


@dataclass(frozen=True, eq=False)
class Prior(Experiment):
    """A Gaussian prior (a manual measurement): the residual row ``(p − value) / sigma``.

    Parameters
    ----------
    name : str
        A fitted parameter (registry name).
    value, sigma : float
        Its value and σ (> 0), SI.
    """

    name: str
    value: float
    sigma: float

    def jacobian(self, names: Sequence[str]) -> F64:
        """Its row's derivative with respect to the search vector ``names`` (p,): 1/σ at its
        parameter (exact; no model call)."""
        row = np.zeros(len(names))
        row[list(names).index(self.name)] = 1.0 / self.sigma
        return row


class Experiments(tuple[Experiment, ...]):
    """A sum of experiments (what ``a + b`` gives); iterates over its terms."""

    def __add__(self, other: Experiment) -> Experiments:  # type: ignore[override]
        return Experiments((*self, *other))

    @property
    def recorded(self) -> tuple[RecordedExperiment, ...]:
        """The experiments on recordings, in order (their index names their bias parameters)."""
        return tuple(e for e in self if isinstance(e, RecordedExperiment))

    @property
    def priors(self) -> dict[str, tuple[float, float]]:
        """The priors, name → (value, σ), SI."""
        return {e.name: (e.value, e.sigma) for e in self if isinstance(e, Prior)}


def y_sign_determined(experiments: Sequence[Measurement]) -> bool:
    """Whether the data fix the sign of y: B_x along tilts toward 0 or π is even in y, so only
    field data (B_y is odd in y) or another azimuth determine it."""
    for e in experiments:
        if e.fields is not None:
            return True
        s = np.sin(np.asarray(e.azimuths))
        if np.any(np.abs(s) > 1e-9):
            return True
    return False


def experiment_type(data: Measurement) -> type[RecordedExperiment]:
    """The experiment type of a recording: :class:`CoilExperiment` with applied fields,
    :class:`LoadExperiment` with loads, else :class:`FieldPath` for 3-axis field data, else
    :class:`TiltPath`."""
    if data.actuation is not None:
        return CoilExperiment
    if data.loads is not None:
        return LoadExperiment
    return FieldPath if data.fields is not None else TiltPath


def experiment(data: Measurement, weighted: bool = True) -> RecordedExperiment:
    """The recording as the experiment of its type (:func:`experiment_type`), weighted by its
    standard errors unless ``weighted`` is False."""
    return experiment_type(data)(data, weighted)
