"""An array of cilia over many three-axis magnetometers (the board frame, all SI).

:class:`CiliaArray` holds C cilia and S sensors. Each cilium is a :class:`~magcilia.Setup`: its
geometry, material, model options (n, k, ring) and modulus are its own, and its placement gives
its base centre in the board frame, ``setup.base_centre`` = (x_f, y_f, depth + z_f), the README's
sensor frame (the single-axis element of the paper at the origin, +z up) — so every single-cilium
function (``setup.field_at``, :func:`magcilia.bend`) applies to each cilium of an array as it is.
The Setup's single-axis :class:`~magcilia.Sensor` is not used by the array (only its ``depth``
places the base); the array's sensors are :class:`~magcilia.device.magnetometer.Magnetometer`s.

The field at every sensor is the superposition of all cilia's dipoles (:meth:`CiliaArray.field`),
one compiled kernel call over all dipoles × sensors (:mod:`magcilia.model.array`).

Every cilium's dipole layout follows the one rule (:meth:`magcilia.Setup.resolve_layout`) at the
array's sensors: a ``"converged"`` cilium gets the smallest rms layout within 0.5 % of the exact
body at every sensor (cilia of one shape share one layout, checked at all their sensors at once,
:func:`resolve_layouts`), a ``"given"`` one is checked there and warned about above 1 %, the
paper's is used as is.

Checks (one-line errors naming the cilia or sensor):

* two cilia overlap at rest: their upright bodies intersect (bases closer horizontally than the
  sum of their largest radii while their heights overlap);
* a sensor's sensing point lies inside or on an upright cilium.

Whether neighbours can touch when bent depends on the loads: :class:`magcilia.ArrayReadout`
checks it for its span (two neighbours bent toward each other by the span's force).
"""

from __future__ import annotations

import dataclasses
from collections.abc import Sequence
from dataclasses import dataclass
from functools import cached_property
from typing import Any

import numpy as np
from numpy.typing import ArrayLike, NDArray

from magcilia import _validate as v
from magcilia._display import Display, Item, scaled
from magcilia.device.magnetometer import Magnetometer
from magcilia.device.sensor import beyond_range
from magcilia.device.setup import Setup
from magcilia.model import body
from magcilia.model import pose as pose_model
from magcilia.model.array import ArrayLayout, array_field, segment_field
from magcilia.model.centreline import Centreline, SpatialCentreline
from magcilia.model.pose import Pose

F64 = NDArray[np.float64]

#: what :meth:`CiliaArray.field` takes as the cilia's poses
ArrayPoses = SpatialCentreline | Sequence[Pose] | None


def _mm(p: ArrayLike) -> str:
    return "(" + ", ".join(f"{x * 1e3:.4g}" for x in np.asarray(p, dtype=float)) + ") mm"


@dataclass(frozen=True, eq=False, repr=False)
class CiliaArray(Display):
    """C cilia over S three-axis magnetometers (immutable, checked; all SI, board frame).

    Parameters
    ----------
    cilia : sequence of Setup
        One Setup per cilium: its own geometry, material and model options; its base centre
        ``setup.base_centre`` (m) places it on the board. A converged layout is converged again
        at the sensors (:func:`resolve_layouts`): ``array.cilia`` holds the setups used.
    sensors : sequence of Magnetometer
        The sensors, each at its ``position`` (m) with its ``rotation``.
    names : sequence of str, optional
        Cilium names for reports and errors (default ``c1``, ``c2``, …; :meth:`grid` names them
        by row and column, ``r1c1``).

    Examples
    --------
    >>> import magcilia as mc
    >>> from magcilia.device.magnetometer import Magnetometer
    >>> part = Magnetometer(field_range=5e-3, resolution=1.5e-7, noise=3e-7, rate=100.0)
    >>> arr = CiliaArray.grid(mc.Setup.paper(tip_radius=5e-5, position=(0, 0, 0)), 2, 2,
    ...                       pitch=2e-3, sensor=part)
    >>> arr.field().shape
    (4, 3)
    """

    cilia: tuple[Setup, ...]
    sensors: tuple[Magnetometer, ...]
    names: tuple[str, ...] = ()

    def __post_init__(self) -> None:
        cilia = tuple(self.cilia)
        sensors = tuple(self.sensors)
        if not cilia:
            raise v.fail("cilia", "an empty list", "at least one magcilia.Setup")
        if not sensors:
            raise v.fail("sensors", "an empty list", "at least one Magnetometer")
        for i, c in enumerate(cilia):
            if not isinstance(c, Setup):
                raise v.fail(f"cilia[{i}]", type(c).__name__, "a magcilia.Setup")
        for i, s in enumerate(sensors):
            if not isinstance(s, Magnetometer):
                raise v.fail(f"sensors[{i}]", type(s).__name__, "a magcilia Magnetometer")
        names = tuple(str(n) for n in self.names) or tuple(f"c{i + 1}" for i in range(len(cilia)))
        if len(names) != len(cilia) or len(set(names)) != len(names):
            raise v.fail("names", f"{len(names)} names", f"{len(cilia)} distinct cilium names")
        object.__setattr__(self, "cilia", cilia)
        object.__setattr__(self, "sensors", sensors)
        object.__setattr__(self, "names", names)
        self._check_overlap()
        self._check_sensors()
        object.__setattr__(self, "cilia", resolve_layouts(cilia, self.sensor_positions))

    # -- construction ---------------------------------------------------------------------------
    @classmethod
    def grid(cls, setup: Setup, rows: int, cols: int, pitch: float | tuple[float, float], *,
             sensor: Magnetometer | None = None,
             sensors: str | Sequence[Magnetometer] = "below",
             depth: float | None = None) -> CiliaArray:
        """A regular rows × cols array of copies of ``setup``, centred on its base centre.

        Parameters
        ----------
        setup : Setup
            The cilium (all cilia alike) and the array's centre: cilium (i, j) stands at
            ``setup.base_centre + ((j − (cols − 1)/2) px, (i − (rows − 1)/2) py, 0)``.
        rows, cols : int
            Rows (along y) and columns (along x).
        pitch : float or (float, float)
            Spacing (px, py), m.
        sensor : Magnetometer, optional
            The part placed under each cilium with ``sensors="below"`` (its position replaced).
        sensors : "below" or sequence of Magnetometer
            ``"below"``: one ``sensor`` under each cilium, ``depth`` below its base centre; or
            the sensors as given.
        depth : float, optional
            Sensing point below the base centres, m; default the base centres' height, which puts
            the sensors in the plane z = 0 (the single-axis element's).
        """
        if not isinstance(setup, Setup):
            raise v.fail("setup", type(setup).__name__, "a magcilia.Setup")
        rows, cols = v.integer("rows", rows), v.integer("cols", cols)
        pair = np.broadcast_to(np.asarray(pitch, dtype=np.float64), (2,)) \
            if np.ndim(pitch) == 0 else np.asarray(pitch, dtype=np.float64)
        if pair.shape != (2,):
            raise v.fail("pitch", pitch, "a spacing in m, or two (x, y)")
        px, py = v.positive("pitch", float(pair[0])), v.positive("pitch", float(pair[1]))
        base = setup.base_centre
        cilia, names = [], []
        for i in range(rows):
            for j in range(cols):
                x = base[0] + (j - 0.5 * (cols - 1)) * px
                y = base[1] + (i - 0.5 * (rows - 1)) * py
                cilia.append(setup.replace(position=(x, y, setup.position[2])))
                names.append(f"r{i + 1}c{j + 1}")
        if isinstance(sensors, str):
            v.choice("sensors", sensors, ("below",))
            if sensor is None:
                raise v.fail("sensor", None, "a Magnetometer to place under each cilium "
                             "(sensors='below')")
            d = float(base[2]) if depth is None else v.positive("depth", depth)
            placed = tuple(sensor.replace(position=(float(c.base_centre[0]),
                                                    float(c.base_centre[1]),
                                                    float(c.base_centre[2]) - d),
                                          name=f"{sensor.name} {n}")
                           for c, n in zip(cilia, names, strict=True))
        else:
            placed = tuple(sensors)
        return cls(tuple(cilia), placed, tuple(names))

    @classmethod
    def place(cls, setup: Setup, bases: ArrayLike, sensors: Sequence[Magnetometer],
              names: Sequence[str] = ()) -> CiliaArray:
        """Copies of ``setup`` with their base centres at ``bases`` ((C, 3), m, board frame)."""
        pts = v.finite_array("bases", bases, unit="m").reshape(-1, 3)
        depth = setup.sensor.depth
        cilia = tuple(setup.replace(position=(float(p[0]), float(p[1]), float(p[2]) - depth))
                      for p in pts)
        return cls(cilia, tuple(sensors), tuple(names))

    # -- checks -----------------------------------------------------------------------------------
    def _check_overlap(self) -> None:
        b = self.bases
        r = np.array([c.spec.max_radius for c in self.cilia])
        h = np.array([c.cilium.height for c in self.cilia])
        dist = np.hypot(b[:, None, 0] - b[None, :, 0], b[:, None, 1] - b[None, :, 1])
        z_overlap = (b[:, None, 2] < b[None, :, 2] + h[None]) & (b[None, :, 2] < b[:, None, 2]
                                                                  + h[:, None])
        clash = (dist < r[:, None] + r[None]) & z_overlap
        np.fill_diagonal(clash, False)
        if clash.any():
            i, j = (int(k) for k in np.argwhere(clash)[0])
            raise v.fail("cilia", f"{self.names[i]} and {self.names[j]} "
                         f"{dist[i, j] * 1e3:.4g} mm apart",
                         f"cilia that do not overlap at rest (bases at least the sum of their "
                         f"largest radii, {(r[i] + r[j]) * 1e3:.4g} mm, apart); use a larger "
                         "pitch")

    def _check_sensors(self) -> None:
        pts = self.sensor_positions
        for c, (setup, name) in enumerate(zip(self.cilia, self.names, strict=True)):
            spec = setup.spec
            rel = pts - self.bases[c]
            inside = body.contains(spec.height, spec.base_radius, spec.knots, spec.radii,
                                   rel[:, 2], np.hypot(rel[:, 0], rel[:, 1]))
            if inside.any():
                s = int(np.argmax(inside))
                raise v.fail("sensors", f"sensor {s + 1} ({self.sensors[s].name}) at "
                             f"{_mm(pts[s])}",
                             f"sensing points outside every cilium (it is inside cilium {name} "
                             "at rest); move the sensor below the board")

    # -- geometry ---------------------------------------------------------------------------------
    @cached_property
    def bases(self) -> F64:
        """Base centres, m, shape (C, 3), read-only."""
        out = np.array([c.base_centre for c in self.cilia], dtype=np.float64).reshape(-1, 3)
        out.setflags(write=False)
        return out

    @cached_property
    def sensor_positions(self) -> F64:
        """Sensing points, m, shape (S, 3), read-only."""
        out = np.array([s.position for s in self.sensors], dtype=np.float64).reshape(-1, 3)
        out.setflags(write=False)
        return out

    @cached_property
    def rotations(self) -> F64:
        """Sensor axes in the board frame (columns), shape (S, 3, 3), read-only."""
        out = np.array([s.rotation for s in self.sensors], dtype=np.float64).reshape(-1, 3, 3)
        out.setflags(write=False)
        return out

    @cached_property
    def sigma(self) -> F64:
        """Standard deviation of each reading, T, shape (S, 3): the RMS noise and the
        quantisation (LSB/√12) together, per sensor axis."""
        noise = np.array([s.noise for s in self.sensors], dtype=np.float64)
        lsb = np.array([s.resolution for s in self.sensors], dtype=np.float64)
        return np.asarray(np.sqrt(noise**2 + lsb**2 / 12.0), dtype=np.float64)

    @cached_property
    def layout(self) -> ArrayLayout:
        """The dipoles' pose-independent layout (plain arrays, :mod:`magcilia.model.array`)."""
        return ArrayLayout.build([c.spec for c in self.cilia])

    def __len__(self) -> int:
        return len(self.cilia)

    @property
    def n_sensors(self) -> int:
        """S."""
        return len(self.sensors)

    # -- evaluation -------------------------------------------------------------------------------
    def dipoles(self, poses: ArrayPoses = None) -> tuple[F64, F64, NDArray[np.int64]]:
        """All cilia's dipoles: positions (D, 3) m, moments (D, 3) A·m², board frame, and
        ``starts`` (C + 1,): cilium c's dipoles are ``starts[c]:starts[c + 1]``.

        Parameters
        ----------
        poses : None, SpatialCentreline or sequence
            None: every cilium upright. A SpatialCentreline of C shapes: shape c poses cilium c
            (the fast path; the cilia must share its length). A sequence of C poses, one per
            cilium, each anything :meth:`Setup.field` takes for one pose (a tilt angle in rad, a
            Centreline or SpatialCentreline of one shape).
        """
        lay = self.layout
        if poses is None:
            pos, mom = self._rest
            return pos, mom, lay.starts
        if isinstance(poses, SpatialCentreline):
            if len(poses) != len(self):
                raise v.fail("poses", f"{len(poses)} shapes", f"{len(self)} (one per cilium)")
            if not np.allclose(lay.heights, poses.length, rtol=1e-9, atol=0.0):
                raise v.fail("poses", f"shapes of length {poses.length:.6g} m",
                             "shapes of every cilium's length (or one pose per cilium)")
            pos, mom = lay.spatial_dipoles(poses.s, poses.points, poses.tangents, poses.normals)
            return pos, mom, lay.starts
        if isinstance(poses, (Centreline, str)) or not isinstance(poses, Sequence):
            raise v.fail("poses", type(poses).__name__, "None, a SpatialCentreline of one shape "
                         "per cilium, or a sequence of one pose per cilium")
        if len(poses) != len(self):
            raise v.fail("poses", f"{len(poses)} poses", f"{len(self)} (one per cilium)")
        parts = [self._one(c, p) for c, p in enumerate(poses)]
        return (np.concatenate([p[0] for p in parts]), np.concatenate([p[1] for p in parts]),
                lay.starts)

    def _one(self, c: int, pose: Pose) -> tuple[F64, F64]:
        spec = self.cilia[c].spec
        shape = pose_model.as_centreline(spec, np.atleast_1d(np.asarray(pose, dtype=np.float64))
                                         if not isinstance(pose, (Centreline, SpatialCentreline))
                                         else pose)
        if len(shape) != 1:
            raise v.fail(f"poses[{c}]", f"{len(shape)} shapes", "one pose per cilium")
        pos, mom = pose_model.dipoles(spec, shape)
        return pos[0], mom[0]

    @cached_property
    def _rest(self) -> tuple[F64, F64]:
        parts = [self._one(c, 0.0) for c in range(len(self))]
        pos = np.concatenate([p[0] for p in parts])
        mom = np.concatenate([p[1] for p in parts])
        pos.setflags(write=False)
        mom.setflags(write=False)
        return pos, mom

    def field(self, poses: ArrayPoses = None, *, check: bool = True) -> F64:
        """Flux density at every sensor, T, board frame, shape (S, 3): the superposition of all
        cilia (``poses`` as :meth:`dipoles`).

        With ``check`` (default), raises a one-line error if a sensor lies inside a posed cilium
        (tested only for sensors within a cilium's reach) or the field is not finite."""
        pos, mom, _ = self.dipoles(poses)
        if check and poses is not None:
            self._check_posed(poses)
        with np.errstate(divide="ignore", invalid="ignore", over="ignore"):
            out = array_field(self.sensor_positions, pos, mom)
        if not np.isfinite(out).all():
            s = int(np.argmax(~np.isfinite(out).all(axis=1)))
            raise v.fail("sensors", f"sensor {s + 1} at {_mm(self.sensor_positions[s])}",
                         "sensing points off the cilia's dipoles (the field there is not finite)")
        return out

    def contributions(self, poses: ArrayPoses = None) -> F64:
        """Each cilium's field at each sensor, T, board frame, shape (C, S, 3) (sums to
        :meth:`field`)."""
        pos, mom, starts = self.dipoles(poses)
        return segment_field(np.asarray(self.sensor_positions), pos, mom, starts)

    def _check_posed(self, poses: SpatialCentreline | Sequence[Pose]) -> None:
        pts = self.sensor_positions
        pads = self._pads
        near = self._within_reach  # (C, S): sensors a shape of the cilium's length can reach
        if isinstance(poses, SpatialCentreline):  # and not below all of the shape
            low = poses.points[:, :, 2].min(axis=1) + self.bases[:, 2] - pads
            near = near & (pts[None, :, 2] >= low[:, None])
        for c in np.nonzero(near.any(axis=1))[0].tolist():
            spec = self.cilia[c].spec
            if isinstance(poses, SpatialCentreline):
                shape: Any = SpatialCentreline(poses.s, poses.points[c:c + 1],
                                               poses.tangents[c:c + 1], poses.normals[c:c + 1])
            else:
                pose = poses[c]
                shape = pose_model.as_centreline(
                    spec, pose if isinstance(pose, (Centreline, SpatialCentreline))
                    else np.atleast_1d(np.asarray(pose, dtype=np.float64)))
            grid = shape.frames(np.linspace(0.0, shape.length, 33))[0][0]
            lo_c = grid.min(axis=0) + self.bases[c] - pads[c]
            hi_c = grid.max(axis=0) + self.bases[c] + pads[c]
            near_c = np.all((pts >= lo_c) & (pts <= hi_c), axis=1)
            if near_c.any():
                try:
                    pose_model.check_outside(spec, pts[near_c], shape)
                except v.MagciliaError:
                    s = int(np.nonzero(near_c)[0][0])
                    raise v.fail("sensors", f"sensor {s + 1} at {_mm(pts[s])}",
                                 f"sensing points outside every cilium (it is inside cilium "
                                 f"{self.names[c]} in the given pose)") from None

    @cached_property
    def _within_reach(self) -> NDArray[np.bool_]:
        """(C, S): sensors closer to a cilium's base than its length and largest radius (a shape
        of arc length L stays within L of its base)."""
        heights = np.array([c.cilium.height for c in self.cilia])
        dist = np.linalg.norm(self.sensor_positions[None] - self.bases[:, None], axis=-1)
        return np.asarray(dist <= (heights + self._pads)[:, None])

    @cached_property
    def _pads(self) -> F64:
        """Margin of each cilium's bounding box around its centreline, m: its largest radius and
        2 % of its length (the sag of the chords between the samples)."""
        return np.array([c.spec.max_radius + 0.02 * c.cilium.height for c in self.cilia])

    @cached_property
    def _aligned(self) -> bool:
        """Whether every sensor's axes are the board's."""
        return bool(np.all(self.rotations == np.eye(3)))

    def to_sensor(self, field: ArrayLike) -> F64:
        """Board-frame fields (..., S, 3), T, on each sensor's axes, shape (..., S, 3)."""
        b = np.asarray(field, dtype=np.float64)
        if self._aligned:
            return b
        return np.asarray(np.matmul(b[..., None, :], self.rotations)[..., 0, :], dtype=np.float64)

    def readings(self, field: ArrayLike, rng: int | np.random.Generator | None = None,
                 noisy: bool = True) -> F64:
        """What the sensors report for board-frame fields (..., S, 3), T: each sensor's
        :meth:`Magnetometer.measure` (its axes, white noise if ``noisy``, clipped at its range,
        rounded to its LSB), shape (..., S, 3), T."""
        b = np.asarray(field, dtype=np.float64)
        if b.shape[-2:] != (self.n_sensors, 3):
            raise v.fail("field", f"an array of shape {b.shape}",
                         f"shape (..., {self.n_sensors}, 3)")
        gen = np.random.default_rng(rng)
        out = np.empty_like(b)
        for s, sensor in enumerate(self.sensors):
            out[..., s, :] = sensor.measure(b[..., s, :], gen, noisy)
        return out

    def saturated(self, readings: ArrayLike) -> NDArray[np.bool_]:
        """Readings (..., S, 3), T on the sensors' axes, at or beyond their range (clipped; within
        half an LSB of it: :func:`~magcilia.device.sensor.beyond_range`), shape (..., S, 3)."""
        r = np.asarray(readings, dtype=np.float64)
        limit = np.array([s.field_range for s in self.sensors], dtype=np.float64)
        lsb = np.array([s.resolution for s in self.sensors], dtype=np.float64)
        return beyond_range(r, limit, lsb)

    # -- hand-over --------------------------------------------------------------------------------
    def to_magpylib(self, poses: ArrayPoses = None, *, sensors: bool = True) -> Any:
        """All cilia's dipoles (one ``magpylib.Collection`` per cilium, named after it) and the
        sensors (``magpylib.Sensor``, oriented by their rotations) in one Collection, SI.
        ``collection.getB(array.sensor_positions)`` summed over the sources is :meth:`field`."""
        import magpylib as magpy
        from scipy.spatial.transform import Rotation

        pos, mom, starts = self.dipoles(poses)
        children: list[Any] = []
        for c, name in enumerate(self.names):
            j0, j1 = int(starts[c]), int(starts[c + 1])
            children.append(magpy.Collection(
                *[magpy.misc.Dipole(position=p, moment=m) for p, m in zip(pos[j0:j1], mom[j0:j1],
                                                                          strict=True)],
                style_label=f"cilium {name}"))
        if sensors:
            children += [magpy.Sensor(position=s.position,
                                      orientation=Rotation.from_matrix(s.rotation),
                                      style_label=s.name) for s in self.sensors]
        return magpy.Collection(*children, style_label="magcilia array")

    def show(self, poses: Sequence[Pose] | None = None, *, field: bool = True,
             backend: str = "auto", **kwargs: Any) -> Any:
        """Draw the array in 3-D through magpylib's display backends: every cilium as its exact
        body (upright, or one pose per cilium), the sensors with their axes and, with ``field``,
        B on the x–z slice through the bases (:func:`magcilia.device.scene.scene`). ``backend``
        and ``kwargs`` go to ``magpylib.show``; ``magcilia show`` writes a file."""
        from magcilia.device.scene import show

        return show(self, poses, field=field, backend=backend, **kwargs)

    # -- display ----------------------------------------------------------------------------------
    def _display_items(self) -> list[Item]:
        b = self.bases
        span = np.ptp(b[:, :2], axis=0) if len(self) > 1 else np.zeros(2)
        return [("cilia", str(len(self))), ("sensors", str(self.n_sensors)),
                ("extent", f"{span[0] * 1e3:.3g} × {span[1] * 1e3:.3g} mm"),
                ("height", scaled(float(self.cilia[0].cilium.height), 1e-3, "mm")),
                ("sensor", self.sensors[0].name)]


def resolve_layouts(cilia: Sequence[Setup], points: ArrayLike) -> tuple[Setup, ...]:
    """The cilia with their layouts resolved by the one rule (:meth:`Setup.resolve_layout`) at
    the sensing points ``points`` ((S, 3), m, board frame): cilia of one shape, layout and
    height above the sensors share one resolution, probed at every sensor offset any of them
    has (so a grid of copies costs one exact reference, not one per cilium)."""
    pts = np.asarray(points, dtype=np.float64).reshape(-1, 3)
    groups: dict[tuple[object, ...], list[int]] = {}
    for i, c in enumerate(cilia):
        if c.layout == "paper":
            continue
        s = c.spec
        key = (s.height, s.base_radius, s.knots.tobytes(), s.radii.tobytes(),
               float(s.base_centre[2]), c.layout, c.n_loops, c.dipoles_per_loop, c.ring)
        groups.setdefault(key, []).append(i)
    out = list(cilia)
    for members in groups.values():
        rep = cilia[members[0]]
        offsets = np.concatenate([pts - cilia[i].base_centre for i in members])
        offsets = np.unique(offsets.round(12), axis=0)
        where = ("the array's sensors" if len(members) == 1 else
                 f"the array's sensors, for {len(members)} cilia of this shape")
        done = rep.resolve_layout(rep.base_centre + offsets, where=where)
        if done is rep:
            continue
        for i in members:
            out[i] = dataclasses.replace(cilia[i], n_loops=done.n_loops,
                                         dipoles_per_loop=done.dipoles_per_loop, ring=done.ring)
    return tuple(out)
