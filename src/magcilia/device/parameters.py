"""The parameter registry: every quantity a user names, once.

Each :class:`Parameter` says what a setup keyword is: its SI unit and the dimension its
unit-bearing strings must have, its domain (the one-line error when a value leaves it), its
setup-file key and unit, its default calibration bound and sweep span, its display unit and label.
Calibration, sensitivity, tolerance, reports, setup files and the CLI all read this table (the
idea behind lmfit's ``Parameter`` and SALib's ``problem``); nobody restates it, and code indexes
parameters by name, never by position.

Every number has limits as well as a domain (``minimum``/``maximum``, SI): generous physical
ranges (lengths up to 1 m, n and k up to 1000, …) that keep the model's float arithmetic finite,
so that anything read from a file or typed on a command line either builds a sensible setup or
fails with a one-line error naming the limit (issue 12). The model's size is bounded too:
:data:`MAX_LOOPS` slices, :data:`MAX_DIPOLES_PER_LOOP` dipoles per slice and
:data:`MAX_DIPOLES` dipoles per cilium (see :func:`check_dipoles`).

:data:`MEASURANDS` does the same for what read-out estimates (tilt angle, tip force, flow speed).

Examples
--------
>>> PARAMETERS["height"].display, PARAMETERS["height"].to_display(3.2613e-3)
('mm', 3.2613)
>>> FITTED
('height', 'base_radius', 'x', 'y', 'z', 'n_loops', 'dipoles_per_loop')
>>> PARAMETERS["x"].span.around(1.5e-3)
(0.0005, 0.0025)
"""

from __future__ import annotations

import math
from collections.abc import Mapping, Sequence
from dataclasses import dataclass
from typing import Any

import numpy as np
from numpy.typing import ArrayLike, NDArray

from magcilia import _validate as v
from magcilia._display import scaled
from magcilia._errors import MagciliaError
from magcilia.model.body import RINGS
from magcilia.model.convergence import MODES as LAYOUTS
from magcilia.units import UNITS

DOMAINS = ("positive", "non_negative", "real", "nonzero", "integer", "choice")

#: the longest length of a setup (height, radii, |x|, |y|, |z|, depth), m: a metre-sized cilium is
#: far beyond any sensor of this kind, and the bound keeps r³ and r⁵ of the field finite
MAX_LENGTH = 1.0
#: the shortest height or radius, m (1 nm: below it a "cilium" is not a continuum body, and
#: powers like r⁴ of the bending stiffness would underflow)
MIN_LENGTH = 1e-9
#: most slices n of the dipole model (a model converges with tens of slices)
MAX_LOOPS = 1000
#: most dipoles k per slice
MAX_DIPOLES_PER_LOOP = 1000
#: most dipoles n·k of one cilium's model: the field costs O(n·k) per angle and its arrays hold
#: n·k entries per angle, so this keeps one evaluation in memory and well under a second
MAX_DIPOLES = 100_000


@dataclass(frozen=True)
class Span:
    """A default one-at-a-time sweep range, relative to the nominal value or fixed (SI).

    ``kind`` is ``"around"`` (nominal + low … nominal + high), ``"scale"`` (nominal · low …
    nominal · high) or ``"fixed"`` (low … high).
    """

    kind: str
    low: float
    high: float

    def around(self, nominal: float) -> tuple[float, float]:
        """The range (low, high) for a setup whose value is ``nominal``."""
        if self.kind == "around":
            return nominal + self.low, nominal + self.high
        if self.kind == "scale":
            return nominal * self.low, nominal * self.high
        return self.low, self.high


@dataclass(frozen=True)
class Quantity:
    """A named quantity with its SI unit and display unit.

    Attributes
    ----------
    name : str
        The keyword it goes by in the API (``Setup.replace``, ``Setup.params()``, ``Readout``).
    dimension : str or None
        Key of :data:`magcilia.units.UNITS` that unit-bearing strings must have; None for plain
        numbers, whole numbers and choices.
    unit : str
        SI unit, as used in messages ("" for dimensionless).
    display : str
        Unit shown to people (tables, figures, CLI), a key of ``UNITS[dimension]`` ("" for none).
    label : str
        Short human name.
    """

    name: str
    dimension: str | None
    unit: str
    display: str
    label: str

    @property
    def display_factor(self) -> float:
        """SI value of one display unit (1e-3 for mm)."""
        return UNITS[self.dimension][self.display] if self.dimension and self.display else 1.0

    def to_display(self, value: float) -> float:
        """An SI value in the display unit."""
        return value / self.display_factor

    def from_display(self, value: float) -> float:
        """A value given in the display unit, in SI."""
        return value * self.display_factor

    def text(self, value: float, digits: int = 3) -> str:
        """An SI value as text in the display unit (``"3.26 mm"``; a bare number without one)."""
        return scaled(value, self.display_factor, self.display, digits)


@dataclass(frozen=True)
class Parameter(Quantity):
    """A setup parameter (see the module docstring).

    Attributes
    ----------
    domain : str
        One of :data:`DOMAINS`: the values allowed (integers are ≥ 1).
    what : str
        The noun of its one-line errors ("a positive *length* in m").
    part : str
        The object that holds it: ``"cilium"``, ``"material"``, ``"sensor"`` or ``"setup"``.
    file : (str, str) or None
        Table and key in setup files.
    file_unit : str
        Unit written to setup files.
    bound : (float, float) or None
        Default calibration bound, SI; the parameters with a bound are the ones
        :func:`magcilia.calibrate` fits (:data:`FITTED`).
    span : Span or None
        Default one-at-a-time sweep span (the paper's figs. 9–12).
    figure : int or None
        The paper's sensitivity figure that sweeps it (9–12).
    choices : tuple of str
        Allowed strings for ``domain="choice"``.
    model : bool
        Whether the dipole model takes it per parameter set (a key of ``Setup.params()`` and of
        :func:`magcilia.model.tilt_output_batch`).
    minimum : float
        Smallest magnitude of a non-zero value, SI (``positive`` and ``nonzero`` domains; the
        others allow 0). 0 for none.
    maximum : float
        Largest magnitude, SI (largest value of an integer). Every number in the registry has a
        finite one (see the module docstring).
    """

    domain: str = "real"
    what: str = "number"
    part: str = "setup"
    file: tuple[str, str] | None = None
    file_unit: str = ""
    bound: tuple[float, float] | None = None
    span: Span | None = None
    figure: int | None = None
    choices: tuple[str, ...] = ()
    model: bool = False
    minimum: float = 0.0
    maximum: float = math.inf

    def check(self, value: object, name: str | None = None) -> Any:
        """``value`` checked against the domain and the limits (an integer, a float or a choice),
        or a one-line :class:`~magcilia.MagciliaError` naming ``name`` (default: the parameter's
        name)."""
        key = self.name if name is None else name
        if self.domain == "choice":
            return v.choice(key, value, self.choices)
        try:
            out = self._in_domain(key, value)
        except OverflowError:  # an integer beyond float range, e.g. 400 digits from a file
            out = value
        if isinstance(out, float) and self.within(out):
            return out
        if isinstance(out, float):
            raise v.fail(key, out, f"{self._singular} {self.limits}")
        if not self.within(out):  # an integer, perhaps of hundreds of digits
            raise MagciliaError(f"{key} must be {self._singular} {self.limits}; "
                                f"got {v.short(out, 40)}")
        return out

    def accepts(self, values: ArrayLike) -> NDArray[np.bool_]:
        """Whether each of ``values`` (floats, SI, any shape) passes :meth:`check`: the
        vectorised form for a population of parameter sets (a real-valued parameter only)."""
        if self.domain in ("choice", "integer"):
            raise ValueError(f"accepts() is for real parameters; {self.name} is {self.domain}")
        x = np.asarray(values, dtype=np.float64)
        size = np.abs(x)
        ok = np.isfinite(x) & (size <= self.maximum)
        if self.domain == "positive":
            ok &= x > 0.0
        elif self.domain == "non_negative":
            ok &= x >= 0.0
        elif self.domain == "nonzero":
            ok &= x != 0.0
        if self.domain in ("positive", "nonzero"):
            ok &= size >= self.minimum
        return ok

    def _in_domain(self, key: str, value: object) -> Any:
        if self.domain == "positive":
            return v.positive(key, value, self.unit, self.what)
        if self.domain == "non_negative":
            return v.non_negative(key, value, self.unit, self.what)
        if self.domain == "integer":
            return v.integer(key, value, 1)
        out = v.real(key, value, self.unit)
        if self.domain == "nonzero" and out == 0.0:
            raise v.fail(key, out, "a non-zero finite number")
        return out

    @property
    def _singular(self) -> str:
        unit = f" in {self.unit}" if self.unit else ""
        return {
            "positive": f"a positive {self.what}{unit},",
            "non_negative": f"a non-negative {self.what}{unit},",
            "integer": "an integer >= 1,",
            "nonzero": "a non-zero finite number,",
        }.get(self.domain, f"a finite number{unit},")

    @property
    def limits(self) -> str:
        """The limits in words, e.g. ``"within [1e-09, 1] m"`` (SI; ``""`` for choices)."""
        unit = f" {self.unit}" if self.unit else ""
        lo, hi = self.minimum, self.maximum
        if self.domain == "integer":
            return f"at most {hi:g}"
        if self.domain == "positive":
            return f"within [{lo:g}, {hi:g}]{unit}"
        if self.domain == "non_negative":
            return f"within [0, {hi:g}]{unit}"
        if self.domain == "nonzero":
            return f"with |{self.name}| within [{lo:g}, {hi:g}]{unit}"
        if self.domain == "real":
            return f"within [{-hi:g}, {hi:g}]{unit}"
        return ""

    def within(self, value: float) -> bool:
        """Whether a value of the domain also lies within the limits."""
        size = abs(value)  # not float(): an integer may be too large for a float
        if self.domain in ("positive", "nonzero") and size < self.minimum:
            return False
        return size <= self.maximum

    @property
    def allowed(self) -> str:
        """What values of the domain are, in the plural (for arrays and ranges of values)."""
        return {
            "positive": (f"positive {_plural(self.what)} in {self.unit}" if self.unit
                         else "positive numbers"),
            "non_negative": "non-negative numbers",
            "integer": "whole numbers >= 1",
            "nonzero": "non-zero finite numbers",
        }.get(self.domain, "finite numbers")

    @property
    def allowed_within(self) -> str:
        """:attr:`allowed` with the limits, e.g. ``"whole numbers >= 1, at most 1000"``."""
        return f"{self.allowed}, {self.limits}" if self.limits else self.allowed

    def outside(self, values: ArrayLike) -> float | None:
        """The first of ``values`` (finite numbers) outside the domain, or None (the limits are
        :meth:`within`'s: a sweep skips values beyond them, naming the limit)."""
        arr = np.asarray(values, dtype=np.float64).ravel()
        if self.domain == "positive":
            bad = arr <= 0.0
        elif self.domain == "non_negative":
            bad = arr < 0.0
        elif self.domain == "integer":
            bad = (arr < 1.0) | (arr != np.round(arr))
        elif self.domain == "nonzero":
            bad = arr == 0.0
        else:
            return None
        return float(arr[bad][0]) if bad.any() else None

    def check_range(self, low: float, high: float, name: str) -> None:
        """Raise unless both ends of a (low, high) range lie in the domain and the limits."""
        if self.outside([low, high]) is not None or not (self.within(low)
                                                         and self.within(high)):
            raise v.fail(name, (low, high), self.allowed_within)


def _plural(noun: str) -> str:
    return f"{noun[:-1]}ies" if noun.endswith("y") else f"{noun}s"


_MM = {"dimension": "length", "unit": "m", "display": "mm", "file_unit": "mm", "what": "length",
       "maximum": MAX_LENGTH}
#: heights and radii: positive, from 1 nm to 1 m
_SIZE = {**_MM, "minimum": MIN_LENGTH}


def _p(name: str, label: str, **kw: object) -> Parameter:
    fields = {"dimension": None, "unit": "", "display": "", **kw}
    if "file_unit" not in kw and fields["display"]:
        fields["file_unit"] = fields["display"]
    return Parameter(name=name, label=label, **fields)  # type: ignore[arg-type]


#: every setup parameter, by name, in the order of setup files (tables cilium, material,
#: placement, sensor, amplifier, model)
PARAMETERS: dict[str, Parameter] = {p.name: p for p in (
    # cilium: the body
    _p("height", "height", **_SIZE, domain="positive", part="cilium",
       file=("cilium", "height"), bound=(2e-3, 4e-3), span=Span("scale", 0.8, 1.2), figure=12,
       model=True),
    _p("base_radius", "base radius", **_SIZE, domain="positive", part="cilium",
       file=("cilium", "base_radius"), bound=(1e-4, 4e-4), span=Span("scale", 0.8, 1.2),
       figure=12, model=True),
    _p("tip_radius", "tip radius", **_MM, domain="non_negative", part="cilium",
       file=("cilium", "tip_radius"), model=True),
    _p("youngs_modulus", "Young's modulus", dimension="pressure", unit="Pa", display="MPa",
       domain="positive", what="modulus", part="cilium", file=("cilium", "youngs_modulus"),
       minimum=1.0, maximum=1e13),
    # its 1 σ when measured or fitted (left out: a given modulus is taken as exact)
    _p("youngs_modulus_sigma", "Young's modulus 1-sigma", dimension="pressure", unit="Pa",
       display="MPa", domain="non_negative", what="modulus", part="cilium",
       file=("cilium", "youngs_modulus_sigma"), maximum=1e13),
    # material: the composite (eq. 1)
    _p("cobalt_mass", "cobalt mass", dimension="mass", unit="kg", display="mg",
       domain="positive", what="mass", part="material", file=("material", "cobalt_mass"),
       minimum=1e-12, maximum=1e3),
    _p("polymer_mass", "polymer mass", dimension="mass", unit="kg", display="mg",
       domain="positive", what="mass", part="material", file=("material", "polymer_mass"),
       minimum=1e-12, maximum=1e3),
    _p("cobalt_density", "cobalt density", dimension="density", unit="kg/m^3",
       display="g/cm^3", domain="positive", what="density", part="material",
       file=("material", "cobalt_density"), minimum=1e-2, maximum=1e6),
    _p("polymer_density", "polymer density", dimension="density", unit="kg/m^3",
       display="g/cm^3", domain="positive", what="density", part="material",
       file=("material", "polymer_density"), minimum=1e-2, maximum=1e6),
    _p("atom_density", "cobalt atom density", dimension="number_density", unit="m^-3",
       display="m^-3", domain="positive", what="number density", part="material",
       file=("material", "atom_density"), minimum=1e20, maximum=1e31),
    _p("moment_per_atom", "moment per cobalt atom", dimension="moment_per_atom", unit="A*m^2",
       display="muB", domain="positive", what="moment", part="material",
       file=("material", "moment_per_atom"), minimum=1e-30, maximum=1e-18),
    _p("magnetization_scale", "magnetization scale", domain="non_negative", what="factor",
       part="material", file=("material", "magnetization_scale"), model=True, maximum=100.0),
    _p("polymer_modulus", "polymer modulus", dimension="pressure", unit="Pa", display="MPa",
       domain="positive", what="modulus", part="material", file=("material", "polymer_modulus"),
       minimum=1.0, maximum=1e13),
    _p("polymer_modulus_uncertainty", "polymer modulus relative 1-sigma", domain="non_negative",
       what="fraction", part="material", file=("material", "polymer_modulus_uncertainty"),
       maximum=1.0),
    # placement: the paper's (x_f, y_f, z_f)
    _p("x", "x", **_MM, part="setup", file=("placement", "x"), bound=(-3e-3, 3e-3),
       span=Span("around", -1e-3, 1e-3), figure=9, model=True),
    _p("y", "y", **_MM, part="setup", file=("placement", "y"), bound=(-3e-3, 3e-3),
       span=Span("around", -1e-3, 1e-3), figure=9, model=True),
    _p("z", "z", **_MM, part="setup", file=("placement", "z"), bound=(0.0, 1e-3),
       span=Span("fixed", 0.0, 1e-3), figure=10, model=True),
    # sensor and amplifier
    _p("sensitivity", "bridge sensitivity", dimension="sensitivity", unit="V/V/T",
       display="mV/V/gauss", domain="positive", what="sensitivity", part="sensor",
       file=("sensor", "sensitivity"), minimum=1e-9, maximum=1e9),
    _p("bridge_voltage", "bridge voltage", dimension="voltage", unit="V", display="V",
       domain="positive", what="voltage", part="sensor", file=("sensor", "bridge_voltage"),
       minimum=1e-6, maximum=1e4),
    _p("depth", "depth of the sensing element", **_MM, domain="non_negative", part="sensor",
       file=("sensor", "depth")),
    _p("field_range", "linear range", dimension="field", unit="T", display="gauss",
       domain="positive", what="field", part="sensor", file=("sensor", "range"),
       minimum=1e-15, maximum=1e3),
    _p("noise_density", "noise density", dimension="noise_density", unit="T/sqrt(Hz)",
       display="nT/sqrt(Hz)", domain="non_negative", what="noise density", part="sensor",
       file=("sensor", "noise_density"), maximum=1.0),
    _p("flicker_corner", "1/f corner", dimension="frequency", unit="Hz", display="Hz",
       domain="non_negative", what="frequency", part="sensor",
       file=("sensor", "flicker_corner"), maximum=1e9),
    _p("cross_axis", "cross-axis effect (fraction of full scale)", domain="non_negative",
       what="fraction", part="sensor", file=("sensor", "cross_axis"), maximum=1.0),
    _p("flip_field", "flip (disturbing) field", dimension="field", unit="T", display="gauss",
       domain="positive", what="field", part="sensor", file=("sensor", "flip_field"),
       minimum=1e-15, maximum=1e3),
    _p("gain", "amplifier gain", domain="nonzero", part="sensor", file=("amplifier", "gain"),
       minimum=1e-9, maximum=1e9),
    _p("offset", "output offset", dimension="voltage", unit="V", display="mV", file_unit="V",
       part="sensor", file=("amplifier", "offset"), model=True, maximum=1e6),
    # the model's slices: what they are (the layout rule), then n, k and the ring
    _p("layout", "layout rule", domain="choice", choices=LAYOUTS, file=("model", "layout")),
    _p("n_loops", "slices n", domain="integer", file=("model", "n_loops"), bound=(1, 10),
       span=Span("fixed", 1, 10), figure=11, model=True, maximum=MAX_LOOPS),
    _p("dipoles_per_loop", "dipoles per slice k", domain="integer",
       file=("model", "dipoles_per_loop"), bound=(1, 10), span=Span("fixed", 1, 10), figure=11,
       model=True, maximum=MAX_DIPOLES_PER_LOOP),
    _p("ring", "ring radius rule", domain="choice", choices=RINGS, file=("model", "ring")),
)}

#: what read-out estimates: tilt angle, tip force along +x, flow speed
MEASURANDS: dict[str, Quantity] = {q.name: q for q in (
    Quantity("angle", "angle", "rad", "deg", "tilt angle"),
    Quantity("force", "force", "N", "mN", "tip force"),
    Quantity("flow", "speed", "m/s", "m/s", "flow speed"),
)}

#: the model's per-set parameters (keys of ``Setup.params()``), in registry order
MODEL = tuple(n for n, p in PARAMETERS.items() if p.model)
#: what :func:`magcilia.calibrate` fits: the paper's seven, those with a default bound
FITTED = tuple(n for n, p in PARAMETERS.items() if p.bound is not None)
#: what one-at-a-time sweeps, Sobol and tolerance studies may vary (the model's, but the offset)
SWEEPABLE = tuple(n for n in MODEL if n != "offset")
#: the sweeps of the paper's figs. 9–12, in figure order
STUDIED = tuple(sorted((n for n, p in PARAMETERS.items() if p.figure is not None),
                       key=lambda n: PARAMETERS[n].figure or 0))
#: fitted whole-number parameters (n and k)
INTEGER = tuple(n for n in FITTED if PARAMETERS[n].domain == "integer")


def parameter(name: str, among: tuple[str, ...] | None = None, key: str = "parameter") -> Parameter:
    """The registry entry of ``name``, or a one-line error listing the allowed names (all, or
    ``among``)."""
    names = tuple(PARAMETERS) if among is None else among
    v.choice(key, name, names)
    return PARAMETERS[name]


def default_bounds() -> dict[str, tuple[float, float]]:
    """The default calibration bounds of :data:`FITTED`, SI."""
    return {n: PARAMETERS[n].bound for n in FITTED}  # type: ignore[misc]


def default_spans(nominal: dict[str, float]) -> dict[str, tuple[float, float]]:
    """The default sweep spans of :data:`STUDIED` around the values ``nominal`` (SI)."""
    return {n: PARAMETERS[n].span.around(float(nominal[n])) for n in STUDIED}  # type: ignore[union-attr]


def check_dipoles(n_loops: float, dipoles_per_loop: float, name: str = "n_loops * dipoles_per_loop",
                  limit: int = MAX_DIPOLES, hint: str = "use fewer slices or dipoles per slice"
                  ) -> None:
    """Raise unless a model of ``n_loops`` × ``dipoles_per_loop`` dipoles stays within ``limit``
    (default :data:`MAX_DIPOLES`)."""
    total = float(n_loops) * float(dipoles_per_loop)
    if not total <= limit:
        raise MagciliaError(f"{name} must be at most {limit} dipoles per cilium; got "
                            f"{n_loops:g} x {dipoles_per_loop:g} = {total:g}; {hint}")


def check_ranges(ranges: Mapping[str, Sequence[float]], key: str = "bounds") -> None:
    """Raise unless each named (low, high) range lies in its parameter's domain and limits: n and
    k whole numbers from 1 to 1000, the height and base radius positive, …; with both n and k
    given, their upper ends must also keep the model within :data:`MAX_DIPOLES`."""
    for name, (lo, hi) in ranges.items():
        PARAMETERS[name].check_range(float(lo), float(hi), f"{key}[{name!r}]")
    if "n_loops" in ranges and "dipoles_per_loop" in ranges:
        check_dipoles(ranges["n_loops"][1], ranges["dipoles_per_loop"][1],
                      f"{key} n_loops x dipoles_per_loop (upper ends)",
                      hint="narrow the n_loops or dipoles_per_loop range")


def describe_bounds(names: tuple[str, ...] = FITTED) -> str:
    """The default bounds in display units, e.g. ``height 2:4, …`` (for help texts)."""
    parts = []
    for n in names:
        p = PARAMETERS[n]
        lo, hi = (p.to_display(b) for b in p.bound or (math.nan, math.nan))
        parts.append(f"{n} {lo:g}:{hi:g}")
    return ", ".join(parts)


def describe_spans(names: tuple[str, ...] = STUDIED) -> str:
    """The default sweep spans in display units, e.g. ``x ±1 mm, …`` (for help texts)."""
    parts = []
    for n in names:
        p = PARAMETERS[n]
        span = p.span
        if span is None:
            continue
        unit = f" {p.display}" if p.display else ""
        if span.kind == "scale":
            parts.append(f"{n} ±{abs(span.high - 1.0) * 100:g} %")
        elif span.kind == "around":
            parts.append(f"{n} ±{p.to_display(span.high):g}{unit}")
        else:
            parts.append(f"{n} {p.to_display(span.low):g}:{p.to_display(span.high):g}{unit}")
    return ", ".join(parts)
