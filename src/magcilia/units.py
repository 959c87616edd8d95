"""Unit-bearing values at the edges: ``"3.0 mm"``, ``"7.5 V"``, ``"30 mg"`` → SI floats.

Only the CLI and setup files use this; the Python API takes SI numbers. Each key of a setup file
names a *dimension* (length, mass, …); a value with a unit of another dimension, or none, is an
error that names the key.

On the command line a bare number means the option's display unit (:func:`parse_values`,
:func:`parse_value`), and :class:`OutputUnits` shows a command's outputs in display units or SI
with the unit in every key (the policy in the README's "Units").

Examples
--------
>>> parse_quantity("3.2613 mm", "length")
0.0032613
>>> parse_quantity("1.0 mV/V/gauss", "sensitivity")
10.0
>>> format_quantity(0.0032613, "mm")
'3.2613 mm'
"""

from __future__ import annotations

import math
import re

from magcilia._validate import fail
from magcilia.constants import GAUSS, MU_B

#: unit symbol -> SI factor, per dimension
UNITS: dict[str, dict[str, float]] = {
    "length": {"m": 1.0, "cm": 1e-2, "mm": 1e-3, "um": 1e-6, "µm": 1e-6, "nm": 1e-9},
    "mass": {"kg": 1.0, "g": 1e-3, "mg": 1e-6, "ug": 1e-9, "µg": 1e-9},
    "density": {"kg/m^3": 1.0, "kg/m3": 1.0, "g/cm^3": 1e3, "g/cm3": 1e3, "g/ml": 1e3},
    "number_density": {"m^-3": 1.0, "1/m^3": 1.0, "cm^-3": 1e6, "1/cm^3": 1e6},
    "moment_per_atom": {"muB": MU_B, "μB": MU_B, "A*m^2": 1.0, "A m^2": 1.0, "J/T": 1.0},
    "magnetization": {"A/m": 1.0, "kA/m": 1e3, "MA/m": 1e6},
    "voltage": {"V": 1.0, "mV": 1e-3, "uV": 1e-6, "µV": 1e-6},
    "field": {"T": 1.0, "mT": 1e-3, "uT": 1e-6, "µT": 1e-6, "nT": 1e-9, "gauss": GAUSS, "G": GAUSS,
              "mG": 1e-3 * GAUSS, "ugauss": 1e-6 * GAUSS, "µgauss": 1e-6 * GAUSS},
    "sensitivity": {"V/V/T": 1.0, "mV/V/gauss": 1e-3 / GAUSS, "mV/V/G": 1e-3 / GAUSS,
                    "mV/V/mT": 1.0},
    "angle": {"rad": 1.0, "deg": math.pi / 180.0, "°": math.pi / 180.0},
    "force": {"N": 1.0, "mN": 1e-3, "uN": 1e-6, "µN": 1e-6, "nN": 1e-9},
    "pressure": {"Pa": 1.0, "kPa": 1e3, "MPa": 1e6, "GPa": 1e9},
    "speed": {"m/s": 1.0, "mm/s": 1e-3, "cm/s": 1e-2},
    "frequency": {"Hz": 1.0, "kHz": 1e3},
    "time": {"s": 1.0, "ms": 1e-3, "us": 1e-6, "µs": 1e-6},
    "noise_density": {"T/sqrt(Hz)": 1.0, "nT/sqrt(Hz)": 1e-9, "pT/sqrt(Hz)": 1e-12,
                      "ugauss/sqrt(Hz)": 1e-6 * GAUSS, "µgauss/sqrt(Hz)": 1e-6 * GAUSS},
    "viscosity": {"Pa*s": 1.0, "Pa s": 1.0, "mPa*s": 1e-3, "mPa s": 1e-3},
    # absolute temperatures in K; °C is an offset scale (not a factor): its own dimension, which
    # the recordings' readers turn into kelvin (magcilia.io.columns.to_kelvin)
    "temperature": {"K": 1.0, "mK": 1e-3},
    "celsius": {"degC": 1.0, "°C": 1.0},
    # temperature coefficients (magcilia.TemperatureModel): relative per kelvin, and a field's
    # drift per kelvin (a kelvin and a degree Celsius are the same step)
    "tempco": {"1/K": 1.0, "ppm/K": 1e-6, "ppm/degC": 1e-6, "ppm/°C": 1e-6, "%/K": 1e-2,
               "%/degC": 1e-2, "%/°C": 1e-2},
    "field_drift": {"T/K": 1.0, "uT/K": 1e-6, "µT/K": 1e-6, "nT/K": 1e-9, "mG/K": 1e-3 * GAUSS,
                    "gauss/K": GAUSS, "G/K": GAUSS, "mG/degC": 1e-3 * GAUSS,
                    "nT/degC": 1e-9},
}

#: 0 °C in kelvin (°C is an offset scale: :func:`parse_temperature`)
ZERO_CELSIUS = 273.15

#: longest text of a quantity (a number and a unit; longer text is refused before parsing)
MAX_QUANTITY_CHARS = 200

_NUMBER = re.compile(r"^\s*([-+]?(?:\d+\.?\d*|\.\d+)(?:[eE][-+]?\d+)?)\s*(.*?)\s*$")


def parse_quantity(text: object, dimension: str, key: str = "value") -> float:
    """Parse ``"<number> <unit>"`` into an SI float of the given dimension.

    Parameters
    ----------
    text : str
        The value with its unit, e.g. ``"0.71 mm"``. A bare number is an error (say the unit).
    dimension : str
        A key of :data:`UNITS`, e.g. ``"length"``.
    key : str
        The setup-file key or CLI option, used in the error message.

    Returns
    -------
    float
        The value in SI units (m, kg, V, T, …).
    """
    units = UNITS[dimension]
    allowed = (f"a {dimension.replace('_', ' ')} with a unit ({', '.join(units)}), "
               f"e.g. '1.0 {next(iter(units))}'")
    if not isinstance(text, str):
        raise fail(key, text, allowed)
    match = _NUMBER.match(text) if len(text) <= MAX_QUANTITY_CHARS else None
    if match is None or match.group(2) not in units:
        raise fail(key, text, allowed)
    value = float(match.group(1)) * units[match.group(2)]
    if not math.isfinite(value):
        raise fail(key, text, allowed)
    return value


def parse_temperature(text: object, key: str = "temperature", bare: str | None = None) -> float:
    """An absolute temperature, K, from ``"293.15 K"``, ``"20 degC"`` or ``"20 °C"`` (a bare number
    is in ``bare``, "K" or "degC"; None: an error, say the unit).

    >>> parse_temperature("20 degC"), parse_temperature("300K"), parse_temperature("5", bare="K")
    (293.15, 300.0, 5.0)
    """
    allowed = "an absolute temperature with a unit (K, mK, degC, °C), e.g. '293.15 K' or '20 degC'"
    if isinstance(text, (int, float)) and not isinstance(text, bool) and bare is not None:
        text = f"{text} {bare}"
    if not isinstance(text, str):
        raise fail(key, text, allowed)
    match = _NUMBER.match(text) if len(text) <= MAX_QUANTITY_CHARS else None
    unit = None if match is None else (match.group(2) or bare)
    if match is None or unit is None:
        raise fail(key, text, allowed)
    number = float(match.group(1))
    if unit in UNITS["celsius"]:
        value = number + ZERO_CELSIUS
    elif unit in UNITS["temperature"]:
        value = number * UNITS["temperature"][unit]
    else:
        raise fail(key, text, allowed)
    if not (math.isfinite(value) and value > 0.0):
        raise fail(key, text, "a temperature above absolute zero (0 K, −273.15 °C)")
    return value


def format_quantity(value: float, unit: str, digits: int = 6) -> str:
    """Format an SI value in ``unit`` (which must be known to :data:`UNITS`), e.g.
    ``'3.2613 mm'``."""
    for table in UNITS.values():
        if unit in table:
            return f"{value / table[unit]:.{digits}g} {unit}"
    raise KeyError(unit)


def parse_range(text: str, key: str, unit: str = "deg") -> tuple[float, float, float | None]:
    """Parse ``"start:stop[:step]"`` into SI floats; step is None if absent. Bare numbers are in
    ``unit``; each part, or the last, may carry a unit of the same dimension (``0:85:5deg``,
    ``0.5Hz:0.5kHz``)."""
    dimension = unit_dimension(unit)
    start, stop, *rest = parse_values(text, dimension, unit, key, (2, 3), f"0:85:5 ({unit})")
    step = rest[0] if rest else None
    if step is not None and step <= 0:
        raise fail(key, text, "a range with a positive step")
    if stop <= start:
        raise fail(key, text, "a range with stop > start")
    return start, stop, step


# --- values and ranges typed on a command line (a bare number is in the option's unit) --------

def unit_dimension(unit: str) -> str | None:
    """The dimension (key of :data:`UNITS`) of a unit symbol, or None if unknown."""
    for dimension, table in UNITS.items():
        if unit in table:
            return dimension
    return None


def si_unit(dimension: str) -> str:
    """The SI unit of a dimension: the first of its units with factor 1 (``m``, ``rad``, …)."""
    return next(u for u, f in UNITS[dimension].items() if f == 1.0)


def dimension_words(dimension: str | None, unit: str) -> str:
    """What a value of this dimension may be, for messages (``"a number in mm or with a length
    unit (m, cm, mm, um, nm)"``)."""
    bare = f"a number in {unit}" if unit else "a plain number"
    if dimension is None:
        return bare
    units = ", ".join(u for u in UNITS[dimension] if u.isascii())
    noun = dimension.replace("_", " ")
    return f"{bare} or with {'an' if noun[0] in 'aeiou' else 'a'} {noun} unit ({units})"


def _split(text: str) -> tuple[float, str] | None:
    """``"0.2 mN"`` -> (0.2, "mN"); ``"3"`` -> (3.0, ""); None if not a number (and a unit)."""
    match = _NUMBER.match(text) if len(text) <= MAX_QUANTITY_CHARS else None
    if match is None:
        return None
    return float(match.group(1)), match.group(2)


def parse_values(text: object, dimension: str | None, unit: str, key: str,
                 counts: tuple[int, ...] = (1,), example: str = "") -> list[float]:
    """Parse ``a[:b[:c]]`` with optional units into SI floats.

    Each part may carry its own unit (``0mN:0.2mN``); a bare part takes the unit of the last part
    that has one (``0:0.2mN``, ``0:85:5deg``), or ``unit`` (the option's documented display unit)
    when none has (``0:85``).

    Parameters
    ----------
    text : str
        The option's text.
    dimension : str or None
        Key of :data:`UNITS` the units must belong to; None for plain numbers (no unit allowed).
    unit : str
        The unit of bare numbers (a key of ``UNITS[dimension]``; "" when ``dimension`` is None).
    key : str
        The option, for the one-line error.
    counts : tuple of int
        The numbers of parts allowed (``(1,)`` a value, ``(2,)`` a range, ``(2, 3)`` with a step).
    example : str
        An example for the error message.

    Returns
    -------
    list of float
        The parts in SI units, finite.

    Examples
    --------
    >>> parse_values("0:0.2mN", "force", "mN", "--span", (2,))
    [0.0, 0.0002]
    >>> parse_values("2mm:0.4cm", "length", "mm", "--bound", (2,))
    [0.002, 0.004]
    >>> [round(x, 6) for x in parse_values("0:10:5", "angle", "deg", "--angles", (2, 3))]
    [0.0, 0.174533, 0.087266]
    """
    form = ("START:STOP or START:STOP:STEP" if counts == (2, 3) else
            " or ".join({1: "VALUE", 2: "LOW:HIGH", 3: "START:STOP:STEP"}[n] for n in counts))
    words = dimension_words(dimension, unit)
    allowed = words if counts == (1,) else f"{form}, each {words}"
    if example:
        allowed += f", e.g. {example}"
    if not isinstance(text, str) or len(text) > MAX_QUANTITY_CHARS:
        raise fail(key, text, allowed)
    split = [_split(part) for part in text.split(":")]
    if len(split) not in counts or any(s is None for s in split):
        raise fail(key, text, allowed)
    parts = [s for s in split if s is not None]
    typed = [u for _, u in parts if u]
    default = typed[-1] if typed else unit
    table = UNITS[dimension] if dimension is not None else {"": 1.0}
    out = []
    for number, part_unit in parts:
        factor = table.get(part_unit or default)
        if factor is None:
            raise fail(key, text, allowed)
        value = number * factor
        if not math.isfinite(value):
            raise fail(key, text, allowed)
        out.append(value)
    return out


def parse_value(text: object, dimension: str | None, unit: str, key: str,
                example: str = "") -> float:
    """One value with an optional unit (a bare number is in ``unit``) -> SI float.

    >>> parse_value("2um", "length", "mm", "--tip-radius")
    2e-06
    >>> parse_value("2", "length", "mm", "--tip-radius")
    0.002
    """
    return parse_values(text, dimension, unit, key, (1,), example)[0]


# --- the units of a command's outputs (display units by default, SI with --si) ----------------

#: dimensions whose values an output document converts by the unit suffix of their key
#: (``angle_rad`` -> ``angle_deg``); others (mass, density, …) are named per parameter
CONVERTIBLE = ("length", "angle", "force", "field", "voltage", "speed", "time", "frequency")


def ascii_unit(unit: str) -> str:
    """A unit as it is spelled in a CSV column or JSON key: ASCII, ``/`` as ``_per_``.

    >>> ascii_unit("µm"), ascii_unit("mV/V/gauss"), ascii_unit("m/s"), ascii_unit("nT/sqrt(Hz)")
    ('um', 'mV_per_V_per_gauss', 'm_per_s', 'nT_per_rtHz')
    """
    text = unit.replace("µ", "u").replace("μ", "u").replace("°", "deg")
    text = text.replace("sqrt(Hz)", "rtHz").replace("^", "").replace("*", "").replace(" ", "")
    return text.replace("/", "_per_")


def _suffixes() -> dict[str, tuple[str, float]]:
    """ASCII unit token -> (dimension, SI factor) of the :data:`CONVERTIBLE` dimensions."""
    out: dict[str, tuple[str, float]] = {}
    for dimension in CONVERTIBLE:
        for unit, factor in UNITS[dimension].items():
            if unit.isascii() and unit != "G":
                out.setdefault(ascii_unit(unit), (dimension, factor))
    return out


_SUFFIXES = _suffixes()


class OutputUnits:
    """The units of one command's outputs: display units (``si=False``) or SI.

    Parameters
    ----------
    si : bool
        SI everywhere (``--si``) instead of display units.
    dimensions : mapping
        Dimension -> display unit (``{"length": "mm", "angle": "deg", …}``); a dimension not
        named is shown in SI.
    names : mapping
        Quantity or parameter name -> (dimension or None, display unit), for values whose unit
        is not the dimension's (a parameter registry's entries).

    Examples
    --------
    >>> u = OutputUnits(False, {"length": "mm", "angle": "deg", "voltage": "mV"})
    >>> u.unit("length"), u.key("tip", "length"), u.value(0.0025, "length")
    ('mm', 'tip_mm', 2.5)
    >>> u.convert({"knots_rad": [0.0], "max_error_V": 0.002, "slopes_V_per_rad": [-1.0]})
    {'knots_deg': [0.0], 'max_error_mV': 2.0, 'slopes_mV_per_deg': [-17.453292519943297]}
    >>> OutputUnits(True, {}).convert({"at_mm": 2.5, "angle_deg": 90.0})
    {'at_m': 0.0025, 'angle_rad': 1.5707963267948966}
    """

    def __init__(self, si: bool, dimensions: dict[str, str],
                 names: dict[str, tuple[str | None, str]] | None = None) -> None:
        self.si = si
        self.dimensions = dict(dimensions)
        self.names = dict(names or {})

    @property
    def system(self) -> str:
        """``"SI"`` or ``"display"``: the value of the ``units`` key of a JSON document."""
        return "SI" if self.si else "display"

    def _entry(self, what: str) -> tuple[str | None, str]:
        if what in self.names:
            return self.names[what]
        if what in UNITS:
            return what, self.dimensions.get(what, si_unit(what))
        raise KeyError(what)

    def dimension(self, what: str) -> str | None:
        """The dimension of a dimension or a named quantity (None for plain numbers)."""
        return self._entry(what)[0]

    def unit(self, what: str) -> str:
        """The output unit of a dimension or a named quantity ("" for plain numbers)."""
        dimension, display = self._entry(what)
        if dimension is None:
            return ""
        return si_unit(dimension) if self.si else display

    def factor(self, what: str) -> float:
        """SI value of one output unit (1e-3 for mm; 1 with ``si``)."""
        dimension, _ = self._entry(what)
        return UNITS[dimension][self.unit(what)] if dimension is not None else 1.0

    def value(self, si_value: object, what: str) -> object:
        """An SI value (a number, None or nested lists of them) in the output unit."""
        return _scale(si_value, 1.0 / self.factor(what))

    def key(self, base: str, what: str) -> str:
        """``base`` with the output unit as suffix (``force_mN``; ``base`` for plain numbers)."""
        unit = self.unit(what)
        return f"{base}_{ascii_unit(unit)}" if unit else base

    def named(self, values: dict[str, object]) -> dict[str, object]:
        """SI values by parameter name -> output values by suffixed name
        (``{"height": 0.003}`` -> ``{"height_mm": 3.0}``)."""
        return {self.key(name, name): self.value(v, name) for name, v in values.items()}

    def label(self, what: str) -> str:
        """The unit for a table header or a message (``mm``; "" for plain numbers)."""
        return self.unit(what)

    def convert(self, doc: object) -> object:
        """A JSON-ready document with every key whose suffix names a unit of a
        :data:`CONVERTIBLE` dimension (``_rad``, ``_V``, ``_mm``, ``_V2``, ``_V_per_rad``, …)
        renamed and its value converted to the output unit; a key that then repeats another
        (``knots_rad`` and ``knots_deg``) is kept once. Squares (``cost_V2``, sums of squared
        residuals) stay in SI in both systems."""
        if isinstance(doc, list | tuple):
            return [self.convert(x) for x in doc]
        if not isinstance(doc, dict):
            return doc
        out: dict[str, object] = {}
        for key, item in doc.items():
            new_key, scale = self._rename(str(key))
            if new_key in out:
                continue
            out[new_key] = _scale(item, scale) if scale != 1.0 else self.convert(item)
        return out

    def _rename(self, key: str) -> tuple[str, float]:
        """(new key, factor to multiply the value by) for a key with a unit suffix: one unit or a
        ratio ``A_per_B[_per_C]`` (A over B over C; a speed ``m_per_s`` is one unit)."""
        parts = key.split("_")
        tokens: list[tuple[str, float]] = []
        end = len(parts)
        while end > 1:
            joined = "_".join(parts[end - 3:end]) if end > 3 and parts[end - 2] == "per" else ""
            token = self._token(joined) if joined else None
            width = 3 if token is not None else 1
            if token is None:
                token = self._token(parts[end - 1])
            if token is None:
                break
            tokens.insert(0, token)
            end -= width
            if end > 2 and parts[end - 1] == "per":
                end -= 1
                continue
            break
        if not tokens or parts[end - 1] == "per":  # no unit, or x_per_V: not a unit of x
            return key, 1.0
        scale = tokens[0][1]
        for _, factor in tokens[1:]:
            scale /= factor
        return "_".join([*parts[:end], "_per_".join(t for t, _ in tokens)]), scale

    def _token(self, token: str) -> tuple[str, float] | None:
        """(output token, SI-to-output factor) of one unit token (``V2`` is V squared)."""
        power = 1
        if token.endswith("2") and token[:-1] in _SUFFIXES:
            token, power = token[:-1], 2
        if token not in _SUFFIXES:
            return None
        dimension, factor = _SUFFIXES[token]
        unit = self.unit(dimension) if power == 1 else si_unit(dimension)  # costs stay in V^2
        scale = (factor / UNITS[dimension][unit]) ** power
        return ascii_unit(unit) + ("2" if power == 2 else ""), scale


#: a unit conversion's result within its rounding (:data:`CONVERTED_DIGITS` significant digits)
#: of a decimal of at most this many significant digits is that decimal (:func:`converted`)
SHORT_DIGITS = 12
CONVERTED_DIGITS = 15


def converted(value: float, scale: float) -> float:
    """``value * scale``, and where that is within its last-bit rounding of a short decimal
    (at most :data:`SHORT_DIGITS` significant digits), that decimal: numbers echoed from input
    round-trip as typed (0.07 mm, stored as 7e-05 m, comes back as 0.07, not
    0.06999999999999999), while other values keep every digit (90 deg is 1.5707963267948966
    rad).

    >>> 0.1801e-3 * 1e3, converted(0.1801e-3, 1e3), converted(0.07e-3, 1e3)
    (0.18009999999999998, 0.1801, 0.07)
    >>> converted(math.pi / 180, 90.0)
    1.5707963267948966
    """
    out = float(value) * scale
    if scale == 1.0 or not math.isfinite(out) or out == 0.0:  # no conversion: every digit
        return out
    text = f"{out:.{CONVERTED_DIGITS - 1}e}"  # d.ddd…e±xx: CONVERTED_DIGITS significant
    mantissa = text.split("e", maxsplit=1)[0].replace("-", "").replace(".", "").rstrip("0")
    return float(text) if len(mantissa) <= SHORT_DIGITS else out


def _scale(value: object, scale: float) -> object:
    """Numbers (in nested lists and dicts) times ``scale``; None, bools and text unchanged."""
    if isinstance(value, dict):
        return {k: _scale(v, scale) for k, v in value.items()}
    if isinstance(value, list | tuple):
        return [_scale(v, scale) for v in value]
    if isinstance(value, bool) or not isinstance(value, int | float):
        return value
    return converted(value, scale) if scale != 1.0 else value * scale
