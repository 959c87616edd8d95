"""The model of the coil experiments for many parameter sets at once: the cilium bent by an applied
uniform field, its field at the sensing element, plus the applied field itself.

A coil experiment (:class:`~magcilia.calibration.experiments.CoilExperiment`) applies known
uniform fields B (a Helmholtz pair's current times its constant) to the upright cilium. The
field's couple ``μ t × B`` (the cilium magnetized along its tangent, ``μ = M π r²``,
:mod:`magcilia.device.actuation`) bends it in the vertical plane of B's horizontal part; the
sensor sees the bent cilium's field and the applied field directly:

* 3-axis part: ``B_read = B_cilium(bent by B) + B + offsets`` (T, per axis);
* single-axis part: ``V = S (B_cilium,x + B_x) + offset`` with ``S = sensitivity · bridge · gain``:
  the applied field calibrates the sensitivity.

The magnetization scale enters twice (the cilium's field ∝ M, its bending ∝ M·B/E) and the
modulus once (the bending), so a coil sequence separates M and E where the bend is measurable.

:func:`coil_block` gives one experiment's model values for every set of a population: the shapes
of every set under every field in one batched solve
(:func:`magcilia.mechanics.field_batch.field_batch`, the equilibria of :func:`magcilia.bend` with
``actuation=Actuation.uniform(B)``), their dipoles and field in one kernel call
(:func:`~magcilia.calibration.load_model.bent_fields`, as :meth:`magcilia.Setup.field` gives it
for each shape). A set whose setup is invalid, whose bend does not converge or whose field is not
finite gets NaN (the problem's non-finite cost).
"""

from __future__ import annotations

from collections.abc import Mapping

import numpy as np
from numpy.typing import NDArray

from magcilia.calibration.load_model import _Sets, bent_fields
from magcilia.device.setup import Setup
from magcilia.io.recordings import Measurement
from magcilia.mechanics.field_batch import field_batch

F64 = NDArray[np.float64]

#: the parameters the coil model reads besides the geometry (SI; a missing one takes the base
#: setup's value)
COIL_PARAMETERS = ("youngs_modulus", "magnetization_scale", "sensitivity")


def cilium_fields(base: Setup, fields: F64, prm: Mapping[str, F64]) -> F64:
    """The bent cilium's own field at the sensing element, (N, a, 3), T, board frame, for each
    set of ``prm`` under each applied field (``fields`` (a, 3), T); NaN rows for a set whose
    model fails.

    Parameters
    ----------
    base : Setup
        Supplies everything not in ``prm`` (tip radius or profile, material, sensor depth, the
        layout n, k and ring).
    fields : ndarray, shape (a, 3)
        Applied uniform fields, T.
    prm : mapping of str to ndarray, shape (N,)
        height, base_radius, x, y, z (m), youngs_modulus (Pa) and magnetization_scale of each
        set (the latter two default to ``base``'s).
    """
    n = np.asarray(prm["x"]).size
    cols = {k: np.broadcast_to(np.asarray(prm.get(k, default), dtype=np.float64), (n,))
            for k, default in (("height", base.cilium.height),
                               ("base_radius", base.cilium.base_radius), ("x", 0.0),
                               ("y", 0.0), ("z", 0.0), ("youngs_modulus", base.youngs_modulus),
                               ("magnetization_scale", base.material.magnetization_scale))}
    b = np.asarray(fields, dtype=np.float64).reshape(-1, 3)
    out = np.full((n, b.shape[0], 3), np.nan)
    sets = _Sets.valid(base, cols)
    if base.cilium.profile is None and base.cilium.tip_radius == 0.0:
        return out  # a sharp cone: a field's couple bends it infinitely (bend refuses it)
    if not sets.index.size:
        return out
    relative = cols["magnetization_scale"][sets.index] / base.material.magnetization_scale
    magnetization = base.spec.magnetization * relative
    shapes = field_batch(base, sets.height, sets.radius, sets.modulus, magnetization, b)
    out[sets.index] = bent_fields(base, sets, shapes.s, shapes.angles, shapes.points, shapes.ok,
                                  shapes.planes, relative)
    return out


def coil_block(base: Setup, data: Measurement, prm: Mapping[str, F64]) -> F64:
    """One coil experiment's model values, (N, a) V for a single-axis output or (N, 3a) T
    (condition-major: B_x, B_y, B_z of each condition) for 3-axis field data, bias-free: the
    bent cilium's field (:func:`cilium_fields`) plus the applied field, an output times each
    set's sensor scale (``prm["sensitivity"]`` V/V/T times the base's bridge voltage and
    gain)."""
    assert data.actuation is not None  # (a coil experiment's data)
    applied = np.asarray(data.actuation, dtype=np.float64)
    total = cilium_fields(base, applied, prm) + applied[None, :, :]
    n = total.shape[0]
    if data.fields is not None:
        return total.reshape(n, -1)
    sensor = base.sensor
    sensitivity = np.broadcast_to(np.asarray(prm.get("sensitivity", sensor.sensitivity),
                                             dtype=np.float64), (n,))
    scale = sensitivity * (sensor.scale / sensor.sensitivity)
    return np.asarray(scale[:, None] * total[:, :, 0], dtype=np.float64)
