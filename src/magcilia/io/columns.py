"""Which column of a recording holds what, and in which unit: the column and unit mapping.

A recording has up to fifteen *roles*, each read from one column (CSV), variable (MATLAB),
channel (TDMS) or dataset (HDF5):

===================  ================  ===========  ===============================================
role                 default           dimension    becomes (:func:`magcilia.io.read_samples` key)
===================  ================  ===========  ===============================================
angle                angle_deg         angle        ``angle_deg``, tilt in degrees
voltage              voltage_V         voltage      ``voltage_V``, sensor output in volts
time                 time_s            time         ``time_s``, seconds
setreset             setreset          (none)       ``setreset``, +1 set / −1 reset
azimuth              azimuth_deg       angle        ``azimuth_deg``, tilt direction in degrees
field_x              field_x_T         field        ``field_x_T``, 3-axis field B_x in tesla
field_y              field_y_T         field        ``field_y_T``, B_y in tesla
field_z              field_z_T         field        ``field_z_T``, B_z in tesla
force                force_N           force        ``force_N``, known tip force in newtons
flow                 flow_m_per_s      speed        ``flow_m_per_s``, known flow speed in m/s
actuation_x          actuation_x_T     field        ``actuation_x_T``, coil field B_x in tesla
actuation_y          actuation_y_T     field        ``actuation_y_T``, coil field B_y in tesla
actuation_z          actuation_z_T     field        ``actuation_z_T``, coil field B_z in tesla
temperature          temperature_K     temperature  ``temperature_K``, the temperature in kelvin
temperature_celsius  temperature_degC  celsius      ``temperature_K`` too, from °C (+273.15)
===================  ================  ===========  ===============================================

A recording may carry its temperature (the temperature compensation,
:class:`magcilia.ThermalReadout`) as ``temperature_K`` (K, or mK mapped) or ``temperature_degC``
(°C; the readers return it as ``temperature_K``), not both. It is read only where it is used
(``read_samples(..., temperature=True)``, ``magcilia readout``; :meth:`Columns.with_temperature`):
then any other column whose name starts with ``temp`` or ``temperature`` (``temperature``,
``temp_F``, ``Temp [C]``) is a temperature in units magcilia does not take, a one-line error
naming it and the accepted names (map it with ``--columns temperature=NAME[K]`` when it is in
kelvin). MATLAB files name no units: only the two accepted variable names are read.

A *load recording* has a ``force`` or a ``flow`` column in place of the angle (one of them, not
both, and no angle column): the cilium stands upright and bends under the load, toward the
azimuth (:attr:`magcilia.io.recordings.Measurement.forces`, ``speeds``); force units N, mN, uN,
nN; speed units m/s, mm/s, cm/s (``flow_mm_per_s`` spells mm/s in a name).

A *coil recording* has the three ``actuation`` columns in place of the angle (all three, no
angle, force or flow column): the applied uniform field at the cilium, board frame (a Helmholtz
coil's current times its constant); the cilium stands upright and bends under the field's couple,
and the sensor sees the applied field besides the cilium's
(:attr:`magcilia.io.recordings.Measurement.actuation`).

The observable is either the single-axis output (voltage) or the 3-axis field (all three of
field_x, field_y, field_z): a file with both, with only some of the field columns, or with set/reset
marks beside field columns is an error (:meth:`Columns.locate`).

:class:`Columns` maps roles to a file's names, each with an optional unit in brackets:
``Columns(angle="Tilt[deg]", voltage="Vout[mV]")``, or from the command line's text
``Columns.parse("angle=Tilt[deg],voltage=Vout[mV]")``. The unit is any unit of
:data:`magcilia.units.UNITS` of the role's dimension (angle: rad, deg; voltage: V, mV, uV;
time: s, ms, us; field: T, mT, uT, nT, gauss, G, mG). Where the mapping gives none, the unit
is taken from the file's own name (a header ``Vout [mV]`` or ``Vout (mV)`` matches the name
``Vout``), from a ``units`` attribute (HDF5 datasets) or from a unit suffix of the name
(``angle_deg``, ``Vout_mV``); a column without any is an error rather than a guess. Units
that disagree (``Vout[V]`` mapped onto a header ``Vout [mV]``, a dataset ``voltage_V`` with
``units="mV"``) are an error too; a unit the file spells in a way magcilia does not know
(``degrees``) yields to the mapping's.

Examples
--------
>>> cols = Columns.parse("angle=Tilt[deg],voltage=Vout[mV]")
>>> cols.voltage
'Vout[mV]'
>>> found = cols.locate(["Time", "Tilt", "Vout"], where="run.csv")
>>> found["voltage_V"]
(2, 0.001)
>>> Columns().locate(["angle_deg", "Vout", "voltage_V"], where="x.csv")["voltage_V"]
(2, 1.0)
>>> Columns(voltage="Vout").locate(["angle_deg", "Vout (uV)"], where="x.csv")["voltage_V"][1]
1e-06
"""

from __future__ import annotations

import dataclasses
import re
from collections.abc import Mapping, Sequence
from dataclasses import dataclass
from typing import Any

import numpy as np
from numpy.typing import NDArray

from magcilia._errors import MagciliaError
from magcilia._validate import fail, printable
from magcilia.units import UNITS

#: role -> (key of the columns read, dimension, unit of that key); setreset has no dimension.
ROLES: dict[str, tuple[str, str | None, str | None]] = {
    "angle": ("angle_deg", "angle", "deg"),
    "voltage": ("voltage_V", "voltage", "V"),
    "time": ("time_s", "time", "s"),
    "setreset": ("setreset", None, None),
    "azimuth": ("azimuth_deg", "angle", "deg"),
    "field_x": ("field_x_T", "field", "T"),
    "field_y": ("field_y_T", "field", "T"),
    "field_z": ("field_z_T", "field", "T"),
    "force": ("force_N", "force", "N"),
    "flow": ("flow_m_per_s", "speed", "m/s"),
    "actuation_x": ("actuation_x_T", "field", "T"),
    "actuation_y": ("actuation_y_T", "field", "T"),
    "actuation_z": ("actuation_z_T", "field", "T"),
    "temperature": ("temperature_K", "temperature", "K"),
    "temperature_celsius": ("temperature_degC", "celsius", "degC"),
}
#: the accepted names of a recording's temperature column (kelvin, °C)
TEMPERATURE_NAMES = ("temperature_K", "temperature_degC")
#: 0 °C in K
_ZERO_CELSIUS = 273.15
#: a name that says temperature (checked for a unit magcilia takes)
_TEMPERATURE_LIKE = re.compile(r"(?i)^(?:temp|temperature)(?:$|[_\s\[(.-])")
#: the keys of a load recording's condition column (in place of ``angle_deg``)
LOAD_KEYS = ("force_N", "flow_m_per_s")
#: the keys of a 3-axis field's components (all three, or none)
FIELD_KEYS = ("field_x_T", "field_y_T", "field_z_T")
#: the keys of a coil recording's applied field (all three, or none), in place of the angle
ACTUATION_KEYS = ("actuation_x_T", "actuation_y_T", "actuation_z_T")
#: a ``required`` key of :meth:`Columns.locate` standing for the observable: ``voltage_V``, or
#: the three field components :data:`FIELD_KEYS`
OBSERVABLE = "observable"
#: key of the columns read -> role
KEY_ROLE = {key: role for role, (key, _, _) in ROLES.items()}

_TRAILING_UNIT = re.compile(r"^(.*?)\s*(?:\[([^\[\]]*)\]|\(([^()]*)\))\s*$", re.DOTALL)


#: conditions are grouped after rounding to this many decimals (of deg, uN or mm/s): angles
#: equal to 1e-9 deg are the same angle
ANGLE_DECIMALS = 9
#: a load recording's loads are grouped in these units (key, factor from SI, unit): the rounding
#: to :data:`ANGLE_DECIMALS` decimals then separates loads 1e-15 N or 1e-12 m/s apart
LOAD_UNITS = {"force": ("force_N", 1e6, "uN"), "flow": ("flow_m_per_s", 1e3, "mm/s")}


def actuation_ids(components: Sequence[NDArray[np.float64]],
                  known: dict[tuple[float, float, float], int]) -> NDArray[np.float64]:
    """A coil recording's condition of each sample: the index (as a float) of its applied field
    (B_x, B_y, B_z) (three arrays (s,), T) among the distinct fields seen so far (a block's new
    ones numbered in sorted order), rounded to
    :data:`ANGLE_DECIMALS` decimals of µT; ``known`` (field → index) is updated, so that blocks
    of one recording share their indices. NaN where a component is not finite.

    >>> known = {}
    >>> actuation_ids([np.array([1e-4, 0.0, 1e-4]), np.zeros(3), np.zeros(3)], known).tolist()
    [1.0, 0.0, 1.0]
    """
    b = np.stack([np.asarray(c, dtype=np.float64).ravel() for c in components], axis=1)
    out = np.full(b.shape[0], np.nan)
    with np.errstate(invalid="ignore", over="ignore"):
        finite = np.isfinite(b).all(axis=1) & (np.abs(b) <= 1e3).all(axis=1)
        rounded = np.round(b[finite] * 1e6, ANGLE_DECIMALS)
    if not rounded.size:
        return out
    unique, inverse = np.unique(rounded, axis=0, return_inverse=True)
    index = np.array([known.setdefault((float(u[0]), float(u[1]), float(u[2])), len(known))
                      for u in unique], dtype=np.float64)
    out[finite] = index[np.ravel(inverse)]
    return out


def scaled(values: NDArray[np.float64], factor: float) -> NDArray[np.float64]:
    """A column read (any shape) times its unit's ``factor`` to deg, V, s, T, N or m/s: the
    same array when the factor is 1; a value that overflows is infinite and a signalling NaN a
    NaN, without a warning (the readers' NaN/inf policy counts or refuses them)."""
    if factor == 1.0:
        return values
    with np.errstate(over="ignore", invalid="ignore"):
        return values * factor


def split_unit(text: str) -> tuple[str, str | None]:
    """A name with a trailing unit in brackets or parentheses -> (name, unit); else (text, None).

    >>> split_unit("Vout [mV]"), split_unit("Tilt(deg)"), split_unit("angle_deg")
    (('Vout', 'mV'), ('Tilt', 'deg'), ('angle_deg', None))
    """
    text = text.strip()
    match = _TRAILING_UNIT.match(text)
    if match is None or not match.group(1):
        return text, None
    unit = match.group(2) if match.group(2) is not None else match.group(3)
    return match.group(1), unit.strip()


def _units_text(dimension: str) -> str:
    return ", ".join(UNITS[dimension])


def _a(dimension: str) -> str:
    return "an" if dimension[0] in "aeiou" else "a"


def _short(name: str) -> str:
    return printable(name if len(name) <= 40 else name[:40] + "…")


@dataclass(frozen=True)
class Columns:
    """Where a recording's roles are, each ``"NAME"`` or ``"NAME[unit]"`` (see the module
    docstring; defaults: magcilia's own names ``angle_deg``, ``voltage_V``, ``time_s``,
    ``setreset``, ``azimuth_deg``, ``field_x_T``, ``field_y_T``, ``field_z_T``). Two roles may not
    name the same column.

    Parameters
    ----------
    angle, voltage, time, setreset, azimuth, field_x, field_y, field_z, force, flow : str
        The file's name for each role, with an optional unit in brackets (angle and azimuth: an
        angle unit, voltage: a voltage unit, time: a time unit, field_x/y/z: a field unit;
        setreset takes none).
    """

    angle: str = "angle_deg"
    voltage: str = "voltage_V"
    time: str = "time_s"
    setreset: str = "setreset"
    azimuth: str = "azimuth_deg"
    field_x: str = "field_x_T"
    field_y: str = "field_y_T"
    field_z: str = "field_z_T"
    force: str = "force_N"
    flow: str = "flow_m_per_s"
    actuation_x: str = "actuation_x_T"
    actuation_y: str = "actuation_y_T"
    actuation_z: str = "actuation_z_T"
    temperature: str = "temperature_K"
    temperature_celsius: str = "temperature_degC"
    #: whether the temperature roles are read (:meth:`with_temperature`), not a role
    read_temperature: bool = False
    #: whether another column named like a temperature is then an error, not a role
    temperature_strict: bool = True

    def __post_init__(self) -> None:
        seen: dict[str, str] = {}
        for role in ROLES:
            text = getattr(self, role)
            if not isinstance(text, str) or not text.strip():
                raise fail(f"columns {role}", text, "a column name, e.g. "
                                                    f"{role}={self.example(role)}")
            name, unit = self.spec(role)
            dimension = ROLES[role][1]
            if unit is not None and dimension is None:
                raise fail(f"columns {role}", text, f"a column name without a unit (the {role} "
                                                    "column holds set/reset marks)")
            if unit is not None and dimension is not None and unit not in UNITS[dimension]:
                raise fail(f"columns {role}", text,
                           f"NAME[unit] with {_a(dimension)} {dimension} unit "
                           f"({_units_text(dimension)})")
            if name in seen:
                raise fail(f"columns {role}", text, f"a column other than the {seen[name]}'s "
                                                    f"({_short(name)}); each role needs its own")
            seen[name] = role

    @staticmethod
    def example(role: str) -> str:
        """An example spec for ``role`` (used in messages)."""
        return {"angle": "Tilt[deg]", "voltage": "Vout[mV]", "time": "t[s]",
                "setreset": "SR", "azimuth": "Phi[deg]", "field_x": "Bx[uT]",
                "field_y": "By[uT]", "field_z": "Bz[uT]", "force": "F[mN]",
                "flow": "U[mm/s]", "actuation_x": "Bcx[mT]", "actuation_y": "Bcy[mT]",
                "actuation_z": "Bcz[mT]", "temperature": "T[K]",
                "temperature_celsius": "T[degC]"}[role]

    def spec(self, role: str) -> tuple[str, str | None]:
        """The name and the unit (None if not given) mapped to ``role``. A trailing ``(unit)``
        counts as a unit only if it is one of the role's dimension (else it is part of the
        name); a trailing ``[unit]`` always does."""
        text = getattr(self, role).strip()
        name, unit = split_unit(text)
        dimension = ROLES[role][1]
        if unit is not None and text.endswith(")") and (
                dimension is None or unit not in UNITS[dimension]):
            return text, None
        return name, unit

    @classmethod
    def parse(cls, text: str) -> Columns:
        """The command line's ``ROLE=NAME[unit],...`` (roles angle, voltage, time, setreset,
        azimuth, field_x, field_y, field_z, force, flow; others keep their defaults; a name with a
        comma needs the API's mapping).

        >>> Columns.parse("voltage=Vout[mV]").voltage
        'Vout[mV]'
        >>> Columns.parse("azimuth=Phi[rad],field_x=Bx[uT]").locate(
        ...     ["angle_deg", "Phi", "Bx", "field_y_T", "field_z_T"], where="r.csv",
        ...     required=("observable",))["field_x_T"]
        (2, 1e-06)
        """
        allowed = ("ROLE=NAME[unit],... with ROLE one of " + ", ".join(ROLES)
                   + ", e.g. angle=Tilt[deg],voltage=Vout[mV]")
        items: dict[str, Any] = {}
        for item in text.split(","):
            role, eq, name = item.partition("=")
            role = role.strip()
            if not eq or role not in ROLES or not name.strip():
                raise fail("--columns", item.strip() or text, allowed)
            if role in items:
                raise fail("--columns", text, f"each role once ({role} is given twice)")
            items[role] = name.strip()
        return cls(**items)

    @classmethod
    def coerce(cls, value: Columns | Mapping[str, str] | str | None) -> Columns:
        """``value`` as a :class:`Columns`: None (the defaults), a Columns, a mapping
        ``{"voltage": "Vout[mV]"}`` or the command line's text."""
        if value is None:
            return cls()
        if isinstance(value, Columns):
            return value
        if isinstance(value, str):
            return cls.parse(value)
        if isinstance(value, Mapping):
            unknown = [k for k in value if k not in ROLES]
            if unknown:
                raise fail("columns", unknown[0], "a role: " + ", ".join(ROLES))
            given: dict[str, Any] = dict(value)
            return cls(**given)
        raise fail("columns", type(value).__name__,
                   "a Columns, a mapping {role: 'NAME[unit]'} or 'angle=Tilt[deg],...'")

    @property
    def is_default(self) -> bool:
        """Whether every role has magcilia's own name."""
        return all(getattr(self, role) == getattr(_DEFAULT, role) for role in ROLES)

    def with_temperature(self, strict: bool = True) -> Columns:
        """This mapping, reading the temperature too (see the module docstring); with ``strict``
        False another column named like a temperature is left alone (the calibration's reading:
        its temperature range is a by-product, a recording it took before stays readable)."""
        return dataclasses.replace(self, read_temperature=True, temperature_strict=strict)

    def _roles(self) -> tuple[str, ...]:
        """The roles read: all, or all but the temperature's."""
        return tuple(ROLES) if self.read_temperature else tuple(
            r for r in ROLES if r not in _TEMPERATURE_ROLES)

    def names(self) -> dict[str, str]:
        """Key of the columns read (``angle_deg``, …) -> the name mapped to it."""
        return {ROLES[role][0]: self.spec(role)[0] for role in self._roles()}

    def locate(self, names: Sequence[str], *, where: str,
               required: tuple[str, ...] = ("angle_deg", OBSERVABLE),
               units: Mapping[str, Any] | None = None, kind: str = "column"
               ) -> dict[str, tuple[int, float]]:
        """Where each role is among a file's ``names`` and the factor to its key's unit.

        Parameters
        ----------
        names : sequence of str
            The file's column (variable, channel, dataset) names, in order.
        where : str
            The file, for messages.
        required : tuple of str
            Keys (``angle_deg``, ``voltage_V``, ``time_s``, ``setreset``, ``azimuth_deg``,
            ``field_x_T``, …) that must be found; :data:`OBSERVABLE` (``"observable"``) asks for
            ``voltage_V`` or the three field components.
        units : mapping of str to str, optional
            A unit the file gives for a name (an HDF5 ``units`` attribute).
        kind : str
            What the names are, for messages ("column", "variable", "channel", "dataset").

        Returns
        -------
        dict of str to (int, float)
            Key -> (index into ``names``, factor to its unit: deg, V, s, T; 1.0 for setreset),
            for the roles found.

        Raises
        ------
        MagciliaError
            A required role missing (the names the file has listed), a name matched twice, a
            unit missing, of the wrong dimension or in conflict; a voltage beside field
            components (one observable per recording), some but not all three field components,
            or set/reset marks beside field components.
        """
        from magcilia.io.csvfile import names_text

        stripped = [str(n).strip() for n in names]
        parts = [split_unit(n) for n in stripped]
        out: dict[str, tuple[int, float]] = {}

        def where_is(name: str) -> list[int]:
            at = [i for i, n in enumerate(stripped) if n == name]
            if not at:  # a header that carries its unit: "Vout [mV]" for the name Vout
                at = [i for i, (base, u) in enumerate(parts) if u is not None and base == name]
            return at

        loads = [role for role in ("force", "flow") if where_is(self.spec(role)[0])]
        coil = [role for role in ("actuation_x", "actuation_y", "actuation_z")
                if where_is(self.spec(role)[0])]
        for role in self._roles():
            key, dimension, target = ROLES[role]
            name, unit = self.spec(role)
            at = where_is(name)
            if not at:
                if key in required and not (key == "angle_deg" and (loads or coil)):
                    raise MagciliaError(self._missing(role, name, where, kind,
                                                      names_text(stripped), required))
                continue
            if len(at) > 1:
                raise MagciliaError(
                    f"{where}: {kind} {name!r} appears {len(at)} times in the "
                    f"{'header' if kind == 'column' else 'file'} ({kind}s "
                    f"{', '.join(str(i + 1) for i in at)}); keep one, it is ambiguous which to use"
                )
            i = at[0]
            if dimension is None or target is None:
                out[key] = (i, 1.0)
                continue
            attribute = None if units is None else units.get(stripped[i])
            unit_found = self._unit(role, name, unit, parts[i][1] if stripped[i] != name else None,
                                    attribute, where, kind)
            table = UNITS[dimension]
            out[key] = (i, table[unit_found] / table[target])
        self._check_observable(out, required, where, kind, names_text(stripped))
        if self.read_temperature:
            self._check_temperature(out, stripped, where, kind)
        names_of = self.names()
        if len(loads) == 2:
            raise MagciliaError(
                f"{where}: both a force {kind} ({_short(names_of['force_N'])}) and a flow "
                f"{kind} ({_short(names_of['flow_m_per_s'])}); a load recording holds one kind "
                "of load: split the file into a force and a flow recording")
        self._check_coil(out, loads, where, kind, names_text(stripped))
        if loads and "angle_deg" in out:
            raise MagciliaError(
                f"{where}: an angle {kind} ({_short(names_of['angle_deg'])}) beside the "
                f"{loads[0]} {kind}; a load recording bends the upright cilium (no tilt): drop "
                f"the angle {kind}, or record tilts and loads separately")
        return out

    def _check_coil(self, found: Mapping[str, Any], loads: Sequence[str], where: str, kind: str,
                    listed: str) -> None:
        """A coil recording: all three applied-field components, no angle and no load."""
        names = self.names()
        coil = [k for k in ACTUATION_KEYS if k in found]
        if not coil:
            return
        if len(coil) < len(ACTUATION_KEYS):
            missing = [k for k in ACTUATION_KEYS if k not in found]
            raise MagciliaError(
                f"{where}: missing applied-field {kind}(s) "
                f"{', '.join(_short(names[k]) for k in missing)} "
                f"({'header' if kind == 'column' else 'found'}: {listed}); a coil recording needs "
                f"all three {', '.join(_short(names[k]) for k in ACTUATION_KEYS)} (map yours with "
                "--columns actuation_x=NAME[unit],actuation_y=...,actuation_z=...)")
        if "angle_deg" in found or loads:
            other = "an angle" if "angle_deg" in found else f"a {loads[0]}"
            raise MagciliaError(
                f"{where}: {other} {kind} beside the applied-field {kind}s; a coil recording "
                f"bends the upright cilium by the applied field alone: drop the {kind}, or record "
                "tilts, loads and coil fields separately")

    def _check_observable(self, found: Mapping[str, Any], required: tuple[str, ...], where: str,
                          kind: str, listed: str) -> None:
        """One observable per recording: the voltage, or all three field components (without
        set/reset marks); :data:`OBSERVABLE` in ``required`` asks for one of them."""
        names = self.names()
        fields = [k for k in FIELD_KEYS if k in found]
        field_names = ", ".join(_short(names[k]) for k in FIELD_KEYS)
        if fields and "voltage_V" in found:
            raise MagciliaError(
                f"{where}: both a voltage {kind} ({_short(names['voltage_V'])}) and field "
                f"{kind}s ({', '.join(_short(names[k]) for k in fields)}); a recording holds one "
                "observable, the single-axis output or the 3-axis field: split the file into one "
                "recording of each")
        if fields and len(fields) < len(FIELD_KEYS):
            missing = [k for k in FIELD_KEYS if k not in found]
            raise MagciliaError(
                f"{where}: missing field {kind}(s) {', '.join(_short(names[k]) for k in missing)}"
                f" ({'header' if kind == 'column' else 'found'}: {listed}); 3-axis data need all "
                f"three {kind}s {field_names} (map yours with --columns "
                "field_x=NAME[unit],field_y=...,field_z=...)")
        if fields and "setreset" in found:
            raise MagciliaError(
                f"{where}: a set/reset {kind} ({_short(names['setreset'])}) beside the 3-axis "
                f"field {kind}s; set/reset differences are for the single-axis AMR output: drop "
                f"the {kind} (3-axis samples are averaged as they are)")
        if OBSERVABLE in required and not fields and "voltage_V" not in found:
            raise MagciliaError(self._missing("voltage", names["voltage_V"], where, kind, listed,
                                              required))

    def _check_temperature(self, found: Mapping[str, tuple[int, float]], stripped: list[str],
                           where: str, kind: str) -> None:
        """One temperature per recording, in kelvin or °C; any other column named like a
        temperature is one in units magcilia does not take."""
        names = self.names()
        if all(k in found for k in TEMPERATURE_NAMES):
            raise MagciliaError(
                f"{where}: both a kelvin ({_short(names['temperature_K'])}) and a °C "
                f"({_short(names['temperature_degC'])}) temperature {kind}; keep one")
        taken = {i for i, _ in found.values()}
        for i, name in enumerate(stripped):
            if self.temperature_strict and i not in taken and _TEMPERATURE_LIKE.match(name):
                raise MagciliaError(
                    f"{where}: {kind} {_short(name)!r} looks like a temperature in units magcilia "
                    f"does not take; name it temperature_K (kelvin) or temperature_degC (°C), or "
                    f"map a kelvin {kind} with --columns temperature=NAME[K]")

    def _missing(self, role: str, name: str, where: str, kind: str, listed: str,
                 required: tuple[str, ...]) -> str:
        mapping = f"--columns {role}=NAME[unit] (API: columns={{'{role}': 'NAME[unit]'}})"
        names = self.names()
        fields = (f" (or the 3-axis {', '.join(names[k] for k in FIELD_KEYS)})"
                  if role == "voltage" and OBSERVABLE in required else "")
        if self.is_default:
            need = " and ".join(names["voltage_V" if k == OBSERVABLE else k] for k in required)
            fix = (f"the file needs {kind}s {need}{fields}, or map the {role} to yours with "
                   f"{mapping}")
        else:
            fix = f"map the {role} to one of them with {mapping}{fields}"
        found = "header" if kind == "column" else "found"
        return f"{where}: missing {kind} {_short(name)!r} ({found}: {listed}); {fix}"

    def _unit(self, role: str, name: str, given: str | None, header: str | None,
              attribute: Any, where: str, kind: str) -> str:
        """The unit of ``role``'s column (see the module docstring for the order)."""
        dimension = ROLES[role][1]
        assert dimension is not None
        table = UNITS[dimension]
        fix = f"give it in the mapping, e.g. --columns {role}={_short(name)}[{ROLES[role][2]}]"
        what = f"{where}: {kind} {_short(name)!r} ({role})"
        if header is not None and header not in table:
            if given is None:
                raise MagciliaError(f"{what} has the unit {_short(header)!r}, not {_a(dimension)} "
                                    f"{dimension} unit ({_units_text(dimension)}); {fix}")
            header = None  # the mapping's unit decides
        if isinstance(attribute, bytes):
            attribute = attribute.decode("utf-8", "replace")
        attribute = attribute.strip() if isinstance(attribute, str) else None
        if attribute is not None and attribute not in table:
            if given is None and header is None:
                raise MagciliaError(f"{what} has units={_short(attribute)!r}, not {_a(dimension)} "
                                    f"{dimension} unit ({_units_text(dimension)}); {fix}")
            attribute = None
        base, _, suffix = name.rpartition("_")
        if not (base and suffix in table):  # a ratio spelled in a name: flow_mm_per_s
            spelled = [u for u in table
                       if "/" in u and name.endswith("_" + u.replace("/", "_per_"))]
            base, suffix = (name, spelled[0]) if spelled else (base, suffix)
        said = [(u, how) for u, how in ((given, "the mapping"), (header, "the file's name"),
                                        (attribute, "its units attribute"),
                                        (suffix if base and suffix in table else None,
                                         "its name's suffix")) if u is not None]
        for u, how in said[1:]:
            if table[u] != table[said[0][0]]:
                raise MagciliaError(f"{what}: {said[0][1]} says {said[0][0]}, {how} says {u}; "
                                    "make them agree")
        if said:
            return said[0][0]
        raise MagciliaError(f"{what} has no unit; {fix} ({_a(dimension)} {dimension} unit: "
                            f"{_units_text(dimension)})")

_DEFAULT = Columns()
#: the roles of a temperature (read only with Columns.read_temperature)
_TEMPERATURE_ROLES = ("temperature", "temperature_celsius")


def to_kelvin(columns: dict[str, NDArray[np.float64]]) -> dict[str, NDArray[np.float64]]:
    """A recording's columns with a °C temperature (``temperature_degC``) as ``temperature_K``
    (+273.15 K): the readers' last step (the same dict, changed in place)."""
    celsius = columns.pop("temperature_degC", None)
    if celsius is not None:
        columns["temperature_K"] = celsius + _ZERO_CELSIUS
    return columns


def columns_help() -> str:
    """One line for the CLI's ``--columns`` help."""
    roles = ", ".join(ROLES)
    return (f"Map roles ({roles}) to the file's names with units, e.g. "
            "angle=Tilt[deg],voltage=Vout[mV] or azimuth=Phi[deg],field_x=Bx[uT],... Default: "
            "angle_deg, voltage_V, time_s, setreset, azimuth_deg, field_x_T, field_y_T, "
            "field_z_T, force_N, flow_m_per_s, actuation_x_T, actuation_y_T, actuation_z_T (a "
            "load recording: force or flow in place of the angle; a coil recording: the three "
            "applied-field columns in place of the angle), temperature_K or temperature_degC.")
