"""A setup or an array as a 3-D magpylib scene: the cilia as bodies, the sensors, the field.

:func:`scene` builds the ``magpylib.Collection`` that :meth:`Setup.show
<magcilia.Setup.show>`, :meth:`CiliaArray.show <magcilia.device.CiliaArray.show>` and
``magcilia show`` draw through magpylib's display backends (matplotlib, plotly):

* each cilium as its exact reference body in its pose (:func:`magcilia.model.exact.exact_body`:
  a stack of magnetized cylinders following the cone, or the bent centreline);
* each sensor as a ``magpylib.Sensor`` at its sensing element, oriented by its rotation, with only
  its sensitive axes drawn (a single-axis part: x; a three-axis part: x, y, z);
* the field on a slice: a ``magpylib.Sensor`` whose pixels cover the vertical plane through the
  cilia's bases along x (the tilt direction), each pixel drawn as an arrow along B coloured by
  |B| (magpylib's pixel-field style).

All in SI (magpylib ≥ 5: metres, tesla).
"""

from __future__ import annotations

from collections.abc import Sequence
from typing import TYPE_CHECKING, Any

import numpy as np

from magcilia import _validate as v
from magcilia.model.centreline import Centreline, SpatialCentreline
from magcilia.model.exact import exact_body

if TYPE_CHECKING:
    from magcilia.model.pose import Pose

#: a Setup or a CiliaArray (their modules import this one, so it names neither: an array is
#: told by its ``cilia``)
Target = Any

#: cylinders per cilium body (a smooth cone on screen; exact_field's own default is 200)
BODY_SLICES = 40
#: pixels along each side of the field slice
FIELD_PIXELS = 13
#: labels of the scene's parts (tests and the HTML look for them)
FIELD_LABEL = "field B on the x–z slice"


def _slice_sensor(bases: np.ndarray, height: float, pixels: int) -> Any:
    """A pixel grid (pixels × pixels) on the plane y = mean base y, x over the bases ± 1.2 height,
    z from the board up to 1.3 height, each pixel drawing B as an arrow."""
    import magpylib as magpy

    x = np.linspace(bases[:, 0].min() - 1.2 * height, bases[:, 0].max() + 1.2 * height, pixels)
    z = np.linspace(bases[:, 2].min() + 0.02 * height, bases[:, 2].max() + 1.3 * height, pixels)
    y = float(bases[:, 1].mean())
    grid = np.stack(np.meshgrid(x, [y], z, indexing="ij"), axis=-1)[:, 0, :, :]  # (px, px, 3)
    return magpy.Sensor(pixel=grid, style_label=FIELD_LABEL,
                        style_pixel_field_source="B", style_pixel_field_symbol="arrow",
                        style_pixel_size=2.5,
                        style_pixel_field_sizescaling="uniform",
                        style_pixel_field_colormap="Viridis",
                        style_arrows_x_show=False, style_arrows_y_show=False,
                        style_arrows_z_show=False)


def _sensor(position: Any, rotation: Any, label: str, axes: int) -> Any:
    """A magpylib Sensor at ``position`` (m) turned by ``rotation`` (3 × 3), only its first
    ``axes`` axes drawn (x, then y, z)."""
    import magpylib as magpy
    from scipy.spatial.transform import Rotation

    return magpy.Sensor(position=np.asarray(position, dtype=np.float64),
                        orientation=Rotation.from_matrix(np.asarray(rotation, dtype=np.float64)),
                        style_label=label, style_size=2.0,
                        style_arrows_y_show=axes > 1, style_arrows_z_show=axes > 2)


def scene(target: Target, pose: Pose | Sequence[Pose] | None = None, *,
          field: bool = True, n_slices: int = BODY_SLICES,
          pixels: int = FIELD_PIXELS) -> Any:
    """The setup or array as a ``magpylib.Collection`` to draw (``magpylib.show(scene(...))``).

    Parameters
    ----------
    target : Setup or CiliaArray
        One cilium on its sensor, or an array of cilia over three-axis sensors.
    pose : float, Centreline, SpatialCentreline or sequence, optional
        A Setup: one rigid tilt angle in rad or one centreline (a bent shape from
        :func:`magcilia.bend`); default upright. An array: one such pose per cilium; default
        every cilium upright.
    field : bool
        Add the field slice (a pixel sensor through the bases, arrows along B).
    n_slices : int
        Cylinders per cilium body.
    pixels : int
        Pixels along each side of the field slice (≥ 2).

    Returns
    -------
    magpylib.Collection
        The bodies (one Collection of cylinders per cilium), the sensors and, with ``field``,
        the slice; SI units. ``collection.sources_all`` are the bodies' cylinders.
    """
    import magpylib as magpy

    n = v.integer("n_slices", n_slices, 1)
    px = v.integer("pixels", pixels, 2)
    if not hasattr(target, "cilia"):  # a Setup
        one: Pose = 0.0 if pose is None else pose  # type: ignore[assignment]
        if isinstance(pose, Sequence) and not isinstance(pose, (Centreline, SpatialCentreline)):
            raise v.fail("pose", f"{len(pose)} poses", "one pose (a tilt angle in rad or one "
                                                       "centreline)")
        bodies = [exact_body(target, one, n)]
        sensors = [_sensor((0.0, 0.0, 0.0), np.eye(3),
                           f"{target.sensor.name} (x: sensitive axis)", 1)]
        bases = np.array([target.spec.base_centre], dtype=np.float64)
        height = float(target.cilium.height)
    else:
        cilia = target.cilia
        if pose is None:
            poses: Sequence[Any] = [0.0] * len(cilia)
        elif isinstance(pose, Sequence) and len(pose) == len(cilia):
            poses = pose
        else:
            raise v.fail("pose", type(pose).__name__,
                         f"None or a sequence of {len(cilia)} poses (one per cilium)")
        bodies = [exact_body(c, p, n) for c, p in zip(cilia, poses, strict=True)]
        for body, name in zip(bodies, target.names, strict=True):
            body.style.label = f"cilium {name}"
        sensors = [_sensor(s.position, s.rotation, f"{s.name} (x, y, z)", 3)
                   for s in target.sensors]
        bases = np.array([c.spec.base_centre for c in cilia], dtype=np.float64)
        height = max(float(c.cilium.height) for c in cilia)
    children = [*bodies, *sensors]
    if field:
        children.append(_slice_sensor(bases, height, px))
    return magpy.Collection(*children, style_label="magcilia scene")


def show(target: Target, pose: Pose | Sequence[Pose] | None = None, *,
         field: bool = True, backend: str = "auto", **kwargs: Any) -> Any:
    """Draw ``target`` in 3-D with ``magpylib.show`` (on screen, in a notebook, or into a given
    ``canvas``): the :func:`scene` of ``target`` in ``pose``; ``backend`` is magpylib's
    (``"auto"``, ``"matplotlib"``, ``"plotly"``, ``"pyvista"``) and ``kwargs`` go to
    ``magpylib.show`` (``canvas=ax``, ``return_fig=True``, ...). Returns what it returns."""
    import magpylib as magpy

    return magpy.show(*scene(target, pose, field=field).children, backend=backend, **kwargs)


def dipole_collection(setup: Target, pose: float | Centreline | SpatialCentreline,
                      sensor: bool) -> Any:
    """The model's dipoles in one pose as a ``magpylib.Collection`` (and the sensor last):
    :meth:`Setup.to_magpylib <magcilia.Setup.to_magpylib>`."""
    import magpylib as magpy

    if isinstance(pose, (Centreline, SpatialCentreline)):
        if len(pose) != 1:
            raise v.fail("pose", f"{len(pose)} centrelines", "one centreline")
        shape: Pose = pose
    else:
        shape = np.array([v.real("pose", pose, "rad")])
    positions, moments = setup.dipoles(shape)
    dipoles = [magpy.misc.Dipole(position=p, moment=m,
                                 style_label=f"dipole {i // setup.dipoles_per_loop + 1}."
                                             f"{i % setup.dipoles_per_loop + 1}")
               for i, (p, m) in enumerate(zip(positions[0], moments[0], strict=True))]
    children: list[Any] = list(dipoles)
    if sensor:
        children.append(magpy.Sensor(position=(0.0, 0.0, 0.0),
                                     style_label=f"{setup.sensor.name} (x: sensitive)"))
    return magpy.Collection(*children, style_label="magcilia cilium")
