"""A complete sensor setup: cilium, material, sensor, placement and model options.

:class:`Setup` is the object the rest of magcilia works with. ``setup.field(pose)`` and
``setup.output(pose)`` evaluate the distributed-dipole model at the sensing element for a batch of
poses: rigid tilt angles (the paper's experiment), a :class:`~magcilia.Centreline` (bent shapes in
the x–z plane) or a :class:`~magcilia.SpatialCentreline` (shapes in space, any bending direction).
"""

from __future__ import annotations

import dataclasses
import warnings
from dataclasses import dataclass, field, fields
from functools import cached_property
from typing import Any

import numpy as np
from numpy.typing import ArrayLike, NDArray

from magcilia import _validate as v
from magcilia._display import Display, Item, number, si
from magcilia._errors import LayoutWarning
from magcilia.device.cilium import Cilium
from magcilia.device.material import Material
from magcilia.device.parameters import PARAMETERS, check_dipoles, parameter
from magcilia.device.sensor import DEFAULT_BANDWIDTH, Sensor, SensorCheck
from magcilia.device.stiffness import Modulus, percent
from magcilia.model import convergence
from magcilia.model import pose as pose_model
from magcilia.model.azimuth import field_from_tilt_frame, placement_in_tilt_frame
from magcilia.model.centreline import Centreline, SpatialCentreline
from magcilia.model.convergence import Layout
from magcilia.model.pose import Pose, Shapes
from magcilia.model.spec import ModelSpec

F64 = NDArray[np.float64]

#: Table I of the paper: initial and optimized parameters (SI)
PAPER_INITIAL: dict[str, Any] = {
    "height": 3.0e-3, "base_radius": 0.25e-3, "position": (0.0, 0.0, 0.0),
    "n_loops": 6, "dipoles_per_loop": 3,
}
PAPER_OPTIMIZED: dict[str, Any] = {
    "height": 3.2613e-3, "base_radius": 0.1801e-3, "position": (1.4727e-3, 1.9891e-3, 0.3804e-3),
    "n_loops": 2, "dipoles_per_loop": 5,
}

_PARTS = {"cilium": Cilium, "material": Material, "sensor": Sensor}
_PART_FIELDS = {name: {f.name for f in fields(cls)} for name, cls in _PARTS.items()}


@dataclass(frozen=True, eq=False, repr=False)
class Setup(Display):
    """A cilium standing on a single-axis sensor (all SI; the frame is drawn in the README's
    "Coordinate frame" section and in docs/frame.png).

    Parameters
    ----------
    cilium : Cilium
        Geometry (and optional Young's modulus).
    material : Material
        Composite recipe and magnetization scale.
    sensor : Sensor
        AMR sensor and amplifier; its depth places the element below the case top.
    position : tuple of 3 float
        (x_f, y_f, z_f), m: the base centre relative to the case-top point above the element;
        the base centre sits at (x_f, y_f, depth + z_f).
    n_loops, dipoles_per_loop : int
        The model's n slices and k dipoles per slice (1 … 1000 each, n·k ≤ 100 000: the
        registry's :data:`~magcilia.device.parameters.MAX_DIPOLES`).
    ring : {"mean", "rms"}
        Ring radius rule: the paper's mean radius or sqrt<rho²> (converges to the exact body).
    layout : {"given", "paper", "converged"}
        What n, k and ring are (the one rule of every path that predicts a field,
        :meth:`resolve_layout`; docs/convergence.md):

        * ``"paper"``: the paper's dipole model by name, used as is everywhere: replication
          stays exact. :meth:`paper` and :meth:`paper_initial` make it with Table I's layouts
          (2 × 5 or 6 × 3, mean rings); other n, k or ring given to them make it ``"given"``.
          ``layout="paper"`` said explicitly names the paper's model with other n × k too (mean
          rings): the paper-model calibration's fits are;
        * ``"converged"``: n, k and ring are chosen by the rule, the smallest rms-ring layout
          within 0.5 % of the exact body (:data:`magcilia.model.convergence.TOLERANCE`) at the
          points where a path evaluates the field; the classmethods and setup files converge it
          at the sensing element, and each path again at its own points;
        * ``"given"`` (the constructor's default): this exact layout, used as is; each path
          estimates its error against the exact body at its points and warns
          (:class:`~magcilia.LayoutWarning`) when it exceeds 1 %.

    Examples
    --------
    >>> s = Setup.paper()
    >>> s.sensor.scale
    75.0
    >>> s.output([0.0, 0.5]).shape
    (2,)
    """

    cilium: Cilium
    material: Material = field(default_factory=Material)
    sensor: Sensor = field(default_factory=Sensor)
    position: tuple[float, float, float] = (0.0, 0.0, 0.0)
    n_loops: int = 6
    dipoles_per_loop: int = 3
    ring: str = "mean"
    layout: str = "given"

    def __post_init__(self) -> None:
        for name, cls in _PARTS.items():
            if not isinstance(getattr(self, name), cls):
                raise v.fail(name, type(getattr(self, name)).__name__, f"a magcilia.{cls.__name__}")
        pos = v.vector3("position", self.position)
        object.__setattr__(self, "position",
                           tuple(PARAMETERS[n].check(float(p)) for n, p in zip("xyz", pos,
                                                                               strict=True)))
        for name in ("n_loops", "dipoles_per_loop", "ring", "layout"):
            object.__setattr__(self, name, PARAMETERS[name].check(getattr(self, name)))
        check_dipoles(self.n_loops, self.dipoles_per_loop)
        if self.layout == "paper" and self.ring != "mean":
            raise v.fail("layout", "'paper' with ring 'rms'",
                         "'paper' only with the paper's mean ring; set layout='given' for your "
                         "own rms layout, or 'converged' to have it chosen")
        # the sensing element must lie outside the unloaded (upright) cilium
        pose_model.check_element_outside(self.spec, np.array([0.0]))

    # -- construction -------------------------------------------------------------------------
    @classmethod
    def paper(cls, **overrides: Any) -> Setup:
        """The paper's sensor: Table I optimized geometry and placement, n = 2, k = 5, 30 mg Co +
        30 mg polymer, textbook cobalt, HMC1021Z at 7.5 V bridge, gain 1, element 0.71 mm below the
        case top, zero offset.

        Any keyword overrides a field of the setup (``position``, ``n_loops``,
        ``dipoles_per_loop``, ``ring``, ``layout``), of the cilium (``height``, ``base_radius``,
        ``tip_radius``, ``youngs_modulus``, ``youngs_modulus_sigma``), the material
        (``cobalt_mass``, …, ``magnetization_scale``, ``polymer_modulus``,
        ``polymer_modulus_uncertainty``) or the sensor (``bridge_voltage``, ``gain``,
        ``offset``, ``depth``, …), or a position component ``x``, ``y``, ``z``. SI units.
        A whole ``cilium=`` (e.g. :meth:`Cilium.from_profile`), ``material=`` or ``sensor=`` is
        taken as given, without the paper's values for its fields.

        The layout is the paper's by name (``layout="paper"``: used as is by every path) while
        it is Table I's; other ``n_loops``, ``dipoles_per_loop`` or ``ring`` make it ``"given"``
        (used as is, warned about where it is more than 1 % off; ``layout="paper"`` with them
        keeps the paper's model by name, mean rings only), and ``layout="converged"`` has it
        chosen: here at the sensing element, and again by each path at its points (``n_loops``,
        ``dipoles_per_loop`` and ``ring`` are then left out).

        Examples
        --------
        >>> Setup.paper().layout, Setup.paper(n_loops=8).layout, Setup.paper(ring="rms").layout
        ('paper', 'given', 'given')
        >>> Setup.paper(n_loops=6, dipoles_per_loop=3).layout  # Table I's initial layout
        'paper'
        >>> s = Setup.paper(tip_radius=5e-5, layout="converged")
        >>> s.n_loops, s.dipoles_per_loop, s.ring
        (12, 5, 'rms')
        """
        return _build(_defaults(PAPER_OPTIMIZED, overrides), layout="paper", user=overrides)

    @classmethod
    def paper_initial(cls, **overrides: Any) -> Setup:
        """As :meth:`paper` but with Table I's *initial* values
        (3 mm, 0.25 mm, origin, n=6, k=3)."""
        return _build(_defaults(PAPER_INITIAL, overrides), layout="paper", user=overrides)

    def replace(self, **changes: Any) -> Setup:
        """A copy with some parameters changed (same keywords as :meth:`paper`). A new
        ``youngs_modulus`` without a ``youngs_modulus_sigma`` is taken as exact (the old σ
        belonged to the old value).

        The layout mode is kept, except that a new ``n_loops``, ``dipoles_per_loop`` or
        ``ring`` makes a converged layout ``"given"``, and a paper one too unless it is another
        of Table I's; ``layout="converged"`` converges it at the sensing element. A converged
        setup keeps its n × k through other changes (cheap); field paths converge it again
        (:meth:`resolve_layout`)."""
        return _build(changes, base=self)

    # -- the layout rule --------------------------------------------------------------------------
    def layout_check(self, points: ArrayLike | None = None) -> Layout:
        """The layout this setup predicts fields with at ``points`` and how far it is from the
        exact body there (the one rule, :mod:`magcilia.model.convergence`).

        Parameters
        ----------
        points : array-like, shape (o, 3), optional
            Where the field is predicted, m in the sensor frame (default the sensing element),
            probed in rigid tilts of 0–85° toward ±x and ±y.

        Returns
        -------
        Layout
            ``"converged"``: the converged layout (its error within the tolerance, or the
            largest tried, above it, where nothing converges); ``"given"``: the setup's own with
            its estimated error; ``"paper"``: the setup's own, the error not estimated (NaN).

        Examples
        --------
        >>> Setup.paper(ring="rms", n_loops=4).layout_check().text()
        '4×5 rms, 5.4 % from the exact body'
        """
        if self.layout == "converged":
            return convergence.converged_layout(self.spec, points=points)
        if self.layout == "paper":
            return Layout(self.n_loops, self.dipoles_per_loop, self.ring)
        return Layout(self.n_loops, self.dipoles_per_loop, self.ring,
                      convergence.layout_error(self.spec, self.n_loops, self.dipoles_per_loop,
                                               self.ring, points=points))

    def resolve_layout(self, points: ArrayLike | None = None, *, where: str = "the sensing "
                       "element") -> Setup:
        """The setup a path predicts fields with at ``points`` (default the sensing element):
        itself for a paper or given layout, with a :class:`~magcilia.LayoutWarning` when a given
        layout's estimated error there exceeds 1 %
        (:data:`magcilia.model.convergence.WARN_ABOVE`); for ``layout="converged"`` the copy
        with the converged n × k (rms ring), warned about only when no layout reaches the
        tolerance. ``where`` names the points in the warning.

        Examples
        --------
        >>> near = Setup.paper(layout="converged", position=(0.5e-3, 0.0, 0.0))
        >>> near.resolve_layout().n_loops  # the element 0.87 mm from the base centre
        48
        """
        lay = self.layout_check(points)
        if self.layout == "paper":
            return self
        if self.layout == "given":
            if lay.error > convergence.WARN_ABOVE:
                warnings.warn(LayoutWarning(
                    f"the given dipole layout {lay.text()} at {where} (tilted 0-85 deg in any "
                    f"direction), above {100 * convergence.WARN_ABOVE:g} %; set layout = "
                    f"\"converged\" (or leave n_loops, dipoles_per_loop and ring out of a setup "
                    f"file's [model]) to have one within {100 * convergence.TOLERANCE:g} % "
                    "chosen"), stacklevel=3)
            return self
        if not lay.converged:
            warnings.warn(LayoutWarning(
                f"no dipole layout up to {lay.n_loops} slices reaches "
                f"{100 * lay.tolerance:g} % at {where}: using {lay.text()}; the field "
                "is predicted very close to the cilium"), stacklevel=3)
        if (lay.n_loops, lay.dipoles_per_loop, lay.ring) == (
                self.n_loops, self.dipoles_per_loop, self.ring):
            return self
        return dataclasses.replace(self, n_loops=lay.n_loops,
                                   dipoles_per_loop=lay.dipoles_per_loop, ring=lay.ring)

    # -- derived quantities ---------------------------------------------------------------------
    @property
    def base_centre(self) -> F64:
        """Base centre in the sensor frame, m, shape (3,): (x_f, y_f, depth + z_f)."""
        return self.spec.base_centre.copy()

    @property
    def moment(self) -> float:
        """Total moment m_c = M · V_c (eq. 1, times the magnetization scale), A·m²."""
        return self.spec.moment

    @property
    def youngs_modulus(self) -> float:
        """Young's modulus for mechanics, Pa: the cilium's, else Guth–Gold from the material
        (0.669 MPa for the paper's recipe; ``docs/stiffness.md``)."""
        e = self.cilium.youngs_modulus
        return self.material.composite_modulus if e is None else e

    @property
    def modulus(self) -> Modulus:
        """The Young's modulus with its 1 σ and its source (:class:`~magcilia.device.stiffness.
        Modulus`): ``"assumed"`` from the material (σ from
        :attr:`Material.composite_modulus_uncertainty`), ``"measured"`` for a cilium's modulus
        given with a σ (or fitted from load data), ``"exact"`` for one given without.

        Examples
        --------
        >>> Setup.paper().modulus.note()
        'force scale from an assumed modulus ±27 % (E 0.669 MPa)'
        >>> Setup.paper(youngs_modulus=1e6).modulus.note()
        'force scale: modulus given, taken as exact (E 1 MPa)'
        >>> Setup.paper(youngs_modulus=5e5, youngs_modulus_sigma=3e4).modulus.note()
        'force scale from a measured modulus ±6 % (E 0.5 MPa)'
        """
        c, m = self.cilium, self.material
        if c.youngs_modulus is None:
            e = m.composite_modulus
            return Modulus(e, e * m.composite_modulus_uncertainty, "assumed")
        if not c.youngs_modulus_sigma:
            return Modulus(c.youngs_modulus, 0.0, "exact")
        return Modulus(c.youngs_modulus, c.youngs_modulus_sigma, "measured")

    @property
    def youngs_modulus_sigma(self) -> float:
        """1 σ of :attr:`youngs_modulus`, Pa (0 for a modulus taken as exact)."""
        return self.modulus.sigma

    @property
    def youngs_modulus_uncertainty(self) -> float:
        """Relative 1 σ of :attr:`youngs_modulus`, the force scale's: every tip force (and,
        through the drag law, every flow speed) read from this setup shares it (0 for a modulus
        taken as exact)."""
        return self.modulus.relative

    def params(self) -> dict[str, float]:
        """The model's parameters in SI by name: the paper's seven (height, base_radius, x, y, z,
        n_loops, dipoles_per_loop) plus tip_radius, magnetization_scale and offset."""
        return self.spec.params()

    def value(self, name: str) -> Any:
        """The current value of any setup parameter by its registry name (SI; e.g. ``"height"``,
        ``"x"``, ``"gain"``; see :data:`magcilia.device.parameters.PARAMETERS`)."""
        p = parameter(name)
        if name in ("x", "y", "z"):
            return self.position["xyz".index(name)]
        return getattr(self if p.part == "setup" else getattr(self, p.part), name)

    @cached_property
    def spec(self) -> ModelSpec:
        """What the field model needs, as plain values (the fast functions of
        :mod:`magcilia.model` take it)."""
        c, m, s = self.cilium, self.material, self.sensor
        knots, radii = c.shape
        return ModelSpec(
            height=c.height, base_radius=c.base_radius, tip_radius=c.tip_radius, knots=knots,
            radii=radii, measured=c.profile is not None, position=self.position, depth=s.depth,
            full_magnetization=m.volume_fraction * m.cobalt_magnetization,
            magnetization_scale=m.magnetization_scale, n_loops=self.n_loops,
            dipoles_per_loop=self.dipoles_per_loop, ring=self.ring, scale=s.scale,
            offset=s.offset,
        )

    # -- evaluation ---------------------------------------------------------------------------
    def field(self, pose: Pose, azimuth: float = 0.0) -> F64:
        """Flux density at the sensing element (origin), T, shape (a, 3).

        Parameters
        ----------
        pose : array-like, shape (a,), Centreline or SpatialCentreline
            Rigid tilt angles in rad (the paper's experiment), a batch of ``a`` centrelines
            (e.g. bent shapes from :func:`magcilia.bend`), or ``a`` shapes in space.
        azimuth : float
            Direction of the tilt or bending, rad: 0 toward +x (the paper's path), π/2 toward +y
            (:mod:`magcilia.model.azimuth`). For a SpatialCentreline, the shapes are turned by it
            about the vertical axis through the base (so ``field(planar, azimuth=φ)`` equals
            ``field(SpatialCentreline.from_planar(planar, φ))``, and a SpatialCentreline with
            ``azimuth=φ`` equals ``from_planar`` of it turned by φ).
        """
        phi = _azimuth(azimuth)
        if phi == 0.0:
            return pose_model.field(self.spec, pose)
        if isinstance(pose, SpatialCentreline):
            return pose_model.field(self.spec, pose.turned(phi))
        x, y = placement_in_tilt_frame(self.position[0], self.position[1], phi)
        turned = self.replace(position=(float(x), float(y), self.position[2]))
        return field_from_tilt_frame(pose_model.field(turned.spec, pose), phi)

    def output(self, pose: Pose, azimuth: float = 0.0) -> F64:
        """Sensor output, V, shape (a,): ``scale · B_x + offset`` (75 V/T for the paper).

        Parameters
        ----------
        pose : array-like, shape (a,), Centreline or SpatialCentreline
            Tilt angles in rad, or a batch of centrelines (planar or in space).
        azimuth : float
            Direction of the tilt or bending, rad (see :meth:`field`).
        """
        if _azimuth(azimuth) == 0.0:
            return pose_model.output(self.spec, pose)
        return self.sensor.voltage(self.field(pose, azimuth)[:, 0])

    def check_sensor(self, pose: Pose, azimuth: float = 0.0,
                     bandwidth: tuple[float, float] = DEFAULT_BANDWIDTH) -> SensorCheck:
        """The single-axis element's limits in each pose: the field at the element, the
        :class:`~magcilia.device.sensor.SensorFlag` bits (beyond range, cross-axis error above
        the noise, risk of a flipped magnetization) and a one-line summary per pose
        (:meth:`Sensor.check`).

        Parameters
        ----------
        pose : array-like, shape (a,), or Centreline
            Tilt angles in rad, or a batch of centrelines.
        azimuth : float
            Direction of the tilt or bending, rad (see :meth:`field`).
        bandwidth : (float, float)
            Noise band of one reading, Hz (the cross-axis criterion's noise).

        Examples
        --------
        >>> Setup.paper_initial().check_sensor([0.0]).summaries()[0][:42]
        '0 deg: B = (0, 0, 27.7) G, |B| 27.7 G: bey'
        """
        labels = None if isinstance(pose, Centreline) else np.asarray(pose, dtype=np.float64)
        return SensorCheck.of(self.sensor, self.field(pose, azimuth), labels, azimuth, bandwidth)

    def field_at(self, points: ArrayLike, pose: Pose) -> F64:
        """Flux density at arbitrary points, T, shape (a, o, 3).

        Parameters
        ----------
        points : array-like, shape (o, 3) or (3,)
            Observer positions in the sensor frame, m; they must lie outside the cilium.
        pose : array-like, shape (a,), Centreline or SpatialCentreline
            Tilt angles in rad, or centrelines (planar or in space).
        """
        return pose_model.field_at(self.spec, points, pose)

    def dipoles(self, pose: Pose) -> tuple[F64, F64]:
        """Lab-frame dipoles of the model for each pose: positions (a, d, 3) m, moments (a, d, 3)
        A·m², d = n_loops · dipoles_per_loop."""
        return pose_model.dipoles(self.spec, self.centreline(pose))

    def centreline(self, pose: Pose) -> Shapes:
        """The pose as centrelines: tilt angles (rad, shape (a,)) become straight centrelines of
        the cilium's length; a Centreline or SpatialCentreline is checked to have that length."""
        return pose_model.as_centreline(self.spec, pose)

    def check_outside(self, points: ArrayLike, pose: Pose) -> None:
        """Raise a :class:`~magcilia.MagciliaError` if any of ``points`` ((o, 3) or (3,), m in the
        sensor frame) lies inside the cilium in any pose."""
        pts = v.finite_array("points", points, unit="m").reshape(-1, 3)
        pose_model.check_outside(self.spec, pts, self.centreline(pose))

    # -- hand-over --------------------------------------------------------------------------------
    def to_magpylib(self, pose: float | Centreline | SpatialCentreline = 0.0, *,
                    sensor: bool = True) -> Any:
        """The model's dipoles in one pose as a ``magpylib.Collection``, to draw or to compute
        with in magpylib (SI, magpylib ≥ 5): ``magpylib.show(setup.to_magpylib(0.3))``.

        Parameters
        ----------
        pose : float, Centreline or SpatialCentreline
            One rigid tilt angle in rad, or one centreline (a single bent shape from
            :func:`magcilia.bend`, or one shape in space).
        sensor : bool
            Add a ``magpylib.Sensor`` at the sensing element (the origin; its x axis is the
            sensitive axis), as the collection's last child.

        Returns
        -------
        magpylib.Collection
            ``n_loops · dipoles_per_loop`` ``magpylib.misc.Dipole`` sources at the model's
            dipole positions (m) with its moments (A·m²), then the sensor. Their field at the
            sensor, ``collection.getB()`` (with the sensor) or ``collection.getB((0, 0, 0))``
            (without), is :meth:`field` of the same pose.

        Examples
        --------
        >>> c = Setup.paper().to_magpylib(0.2)
        >>> len(c.sources), len(c.sensors)
        (10, 1)
        """
        from magcilia.device import scene

        return scene.dipole_collection(self, pose, sensor)

    def show(self, pose: float | Centreline | SpatialCentreline = 0.0, *, field: bool = True,
             backend: str = "auto", **kwargs: Any) -> Any:
        """Draw the setup in 3-D (:func:`magcilia.device.scene.show`): the exact body in ``pose``
        (a tilt, rad, or a bent centreline), the sensor's axis and, with ``field``, B on the x–z
        slice; ``backend`` and ``kwargs`` go to ``magpylib.show`` (``magcilia show``: a file)."""
        from magcilia.device import scene

        return scene.show(self, pose, field=field, backend=backend, **kwargs)

    # -- display --------------------------------------------------------------------------------
    def _display_items(self) -> list[Item]:
        p, par = self.params(), PARAMETERS
        items = [(n, par[n].text(p[n])) for n in ("height", "base_radius")]
        if p["tip_radius"]:
            items.append(("tip_radius", par["tip_radius"].text(p["tip_radius"])))
        items += [(n, par[n].text(p[n])) for n in "xyz"]
        ring = "" if self.ring == "mean" else f" {self.ring}"
        mode = "" if self.layout == "given" else f" ({self.layout})"
        items.append(("n×k", f"{self.n_loops}×{self.dipoles_per_loop}{ring}{mode}"))
        items.append(("sensor", f"{self.sensor.name} {self.sensor.scale:.3g} V/T"))
        if p["offset"]:
            items.append(("offset", par["offset"].text(p["offset"])))
        if p["magnetization_scale"] != 1.0:
            items.append(("magnetization_scale", number(p["magnetization_scale"])))
        return [*items, ("moment", si(self.moment, "A·m²")),
                ("youngs_modulus", _modulus_text(self.modulus)),
                ("depth", par["depth"].text(self.sensor.depth))]


def _modulus_text(modulus: Modulus) -> str:
    """``0.67 MPa ±27 % assumed``, ``1 MPa exact``."""
    text = PARAMETERS["youngs_modulus"].text(modulus.value)
    if modulus.source == "exact":
        return f"{text} exact"
    return f"{text} ±{percent(modulus.relative)} {modulus.source}"


def _azimuth(azimuth: object) -> float:
    """A checked tilt azimuth, rad; the default 0.0 passes without the check (the paper's path
    is the hot path of read-out and calibration)."""
    if type(azimuth) is float and azimuth == 0.0:
        return 0.0
    return v.real("azimuth", azimuth, "rad")


def _defaults(table: dict[str, Any], overrides: dict[str, Any]) -> dict[str, Any]:
    """Table I values under the overrides, leaving out those of a part given as a whole."""
    given = {f for name in _PARTS if name in overrides for f in _PART_FIELDS[name]}
    return {**{k: val for k, val in table.items() if k not in given}, **overrides}


#: the setup fields that make up a dipole layout
_LAYOUT_KEYS = ("n_loops", "dipoles_per_loop", "ring")


def _layout_mode(overrides: dict[str, Any], base: Setup | None, default: str,
                 user: dict[str, Any] | None) -> str:
    """The layout mode of a setup built from ``overrides`` (see :meth:`Setup.paper` and
    :meth:`Setup.replace`): a layout set by its keys is the paper's only while it is one of
    Table I's (:data:`~magcilia.model.convergence.PAPER_LAYOUTS`), and never a converged one."""
    if "layout" in overrides:
        return str(PARAMETERS["layout"].check(overrides["layout"]))
    mode = base.layout if base is not None else default
    asked = overrides if user is None else user
    if not any(k in asked for k in _LAYOUT_KEYS):
        return mode
    if mode == "converged":
        return "given"
    if mode == "paper":
        old = (base.n_loops, base.dipoles_per_loop, base.ring) if base is not None else (
            None, None, "mean")
        n, k, ring = (overrides.get(key, was) for key, was in zip(_LAYOUT_KEYS, old,
                                                                   strict=True))
        if (n, k, ring) not in convergence.PAPER_LAYOUTS:
            return "given"
    return mode


def _build(overrides: dict[str, Any], base: Setup | None = None,
           layout: str = "given", user: dict[str, Any] | None = None) -> Setup:
    """Create a Setup from keyword overrides routed to the setup or its parts (``layout``: the
    mode of a new setup, :meth:`Setup.paper`'s ``"paper"``; ``user``: the keywords the caller
    gave, when ``overrides`` also holds defaults)."""
    mode = _layout_mode(overrides, base, layout, user)
    converge = mode == "converged" and (base is None or "layout" in overrides)
    if converge:
        asked = overrides if user is None else user
        given = [k for k in _LAYOUT_KEYS if k in asked]
        if given and "layout" in asked:
            raise v.fail(given[0], overrides[given[0]],
                         "left out with layout='converged' (the rule chooses n, k and ring); "
                         "set layout='given' to use your own")
        overrides = {k: val for k, val in overrides.items() if k not in _LAYOUT_KEYS}
    overrides = {**overrides, "layout": mode}
    top: dict[str, Any] = {}
    parts: dict[str, dict[str, Any]] = {name: {} for name in _PARTS}
    pos = list(base.position) if base is not None else [0.0, 0.0, 0.0]
    setup_fields = {f.name for f in fields(Setup)}
    for key, value in overrides.items():
        if key in ("x", "y", "z"):
            pos["xyz".index(key)] = value
        elif key == "position":
            pos = list(v.vector3("position", value))
        elif key in setup_fields:
            top[key] = value
        else:
            owner = next((n for n, names in _PART_FIELDS.items() if key in names), None)
            if owner is None:
                known = sorted(setup_fields | {"x", "y", "z"} | set().union(*_PART_FIELDS.values()))
                raise v.fail("keyword", key, "a setup parameter (" + ", ".join(known) + ")")
            parts[owner][key] = value
    if "youngs_modulus" in parts["cilium"]:  # a new modulus without its σ is taken as exact
        parts["cilium"].setdefault("youngs_modulus_sigma", None)
    built: dict[str, Any] = {}
    for name, cls in _PARTS.items():
        current = top.pop(name, None) or (getattr(base, name) if base is not None else None)
        if name == "cilium" and "tip_radius" in parts[name] and (
                getattr(current, "profile", None) is not None or "profile" in parts[name]):
            raise v.fail("tip_radius", parts[name]["tip_radius"],
                         "left out for a cilium with a measured profile (its last radius is the "
                         "tip radius: change the profile instead)")
        if current is None:
            built[name] = cls(**parts[name])
        else:
            built[name] = dataclasses.replace(current, **parts[name]) if parts[name] else current
    if base is not None:
        kept = {f.name: getattr(base, f.name) for f in fields(Setup) if f.name not in _PARTS}
        top = {**kept, **top}
    top["position"] = tuple(pos)
    setup = Setup(**built, **top)
    if converge:  # at the sensing element (the paths converge again at their points)
        lay = convergence.converged_layout(setup.spec)
        setup = dataclasses.replace(setup, n_loops=lay.n_loops,
                                    dipoles_per_loop=lay.dipoles_per_loop, ring=lay.ring)
    return setup
