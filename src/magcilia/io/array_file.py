"""Array setup files: many cilia over many three-axis magnetometers, TOML with units.

An array file is a setup file (:mod:`magcilia.io.setup_files`) whose ``[cilium]``,
``[material]``, ``[model]`` (and ``[sensor]``, for its ``depth``) tables describe the cilia as
defaults, plus either lists of cilia and sensors::

    [[cilia]]
    name = "a"
    base = ["0 mm", "0 mm", "0.71 mm"]   # base centre, board frame
    tip_radius = "40 um"                 # any [cilium], [material] or [model] key overrides

    [[sensors]]
    name = "s1"
    preset = "MMC5983MA"                 # any of MAGNETOMETERS, with its settings (rate, bits…)
    position = ["0 mm", "0 mm", "0 mm"]
    euler = "xyz 0 0 90 deg"             # or rotation = [[…], […], […]] (columns = sensor axes)

    [[sensors]]
    name = "s2"
    range = "8 gauss"                    # or a part by its figures: range, lsb, noise, rate
    lsb = "0.0625 mG"                    # (one value, or three: x, y, z)
    noise = ["0.4 mG", "0.4 mG", "0.6 mG"]
    rate = "100 Hz"
    position = ["2 mm", "0 mm", "0 mm"]

or the ``[array]`` shorthand of a regular grid (:meth:`magcilia.CiliaArray.grid`)::

    [array]
    rows = 4
    cols = 4
    pitch = "2 mm"                 # or ["2 mm", "3 mm"] (x, y)
    centre = ["0 mm", "0 mm", "0.71 mm"]   # the grid's centre (default: [placement]'s base)
    depth = "0.71 mm"              # sensing points below the bases (default: down to z = 0)
    sensor = "MMC5983MA"           # a preset name, or a table like a [[sensors]] entry
                                   # without position (e.g. {preset = "MLX90393", noise = …})

The board frame is the README's sensor frame (+z up; the paper's single-axis element at the
origin); a cilium's ``base`` is its base centre there. Every quantity needs its unit, as in a
setup file; rotations are plain numbers, Euler angles ``"SEQ A B C UNIT"`` (scipy's
``Rotation.from_euler`` sequences, e.g. ``xyz`` extrinsic or ``ZYX`` intrinsic; deg or rad).

Errors are one line naming the file, the entry (``cilia[2] 'a'``, ``sensors[0] 's1'``) and the
key; :class:`~magcilia.CiliaArray`'s own checks (overlapping cilia, a sensor inside a cilium)
name the cilia and sensors by the file's names. Reading is bounded as for setup files, and an
array holds at most :data:`MAX_ARRAY_ITEMS` cilia and as many sensors.
"""

from __future__ import annotations

import inspect
import math
import os
import tomllib
from collections.abc import Mapping
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import numpy as np
import tomli_w

from magcilia import _validate as v
from magcilia._atomic import write_text
from magcilia.device.array import CiliaArray
from magcilia.device.magnetometer import MAGNETOMETERS, Magnetometer, _preset_key
from magcilia.device.setup import Setup
from magcilia.io.loads_file import MAX_LOAD_SETS, MAX_LOADS_BYTES, read_loads
from magcilia.io.setup_files import (
    MAX_SETUP_BYTES,
    SCHEMA,
    _fail,
    _key,
    _read_document,
    setup_from_dict,
    setup_to_dict,
)
from magcilia.units import format_quantity, parse_quantity

#: most cilia (and most sensors) in an array file: the overlap checks compare every pair
MAX_ARRAY_ITEMS = 4096
#: largest |coordinate| of a base or sensor position, m (an array is a few cm across)
MAX_COORDINATE = 1.0
#: the tables of a setup file that describe arrays (ignored by load_setup)
ARRAY_TABLES = ("cilia", "sensors", "array")
#: the tables whose keys a [[cilia]] entry may override
CILIUM_TABLES = ("cilium", "material", "model")
#: a sensor's figures by their file keys: (Magnetometer field, dimension)
SENSOR_FIGURES = {"range": ("field_range", "field"), "lsb": ("resolution", "field"),
                  "noise": ("noise", "field"), "rate": ("rate", "frequency")}
#: preset settings by name: their dimension (None: a whole number or a word)
SETTING_DIMENSIONS = {"rate": "frequency", "full_scale": "field"}
_SENSOR_KEYS = ("name", "preset", "position", "rotation", "euler")
_GRID_KEYS = ("rows", "cols", "pitch", "centre", "depth", "sensor")


@dataclass(frozen=True)
class ArrayGrid:
    """The ``[array]`` shorthand of an array file: a regular grid of one cilium over one part.

    Attributes
    ----------
    setup : Setup
        The cilium; its base centre is the grid's centre (m, board frame).
    rows, cols : int
        Rows (along y) and columns (along x).
    pitch : (float, float)
        Spacing (x, y), m.
    sensor : Magnetometer
        The part under each cilium.
    depth : float or None
        Sensing points below the bases, m (None: down to z = 0).
    """

    setup: Setup
    rows: int
    cols: int
    pitch: tuple[float, float]
    sensor: Magnetometer
    depth: float | None

    def build(self, pitch: float | tuple[float, float] | None = None) -> CiliaArray:
        """The array (:meth:`CiliaArray.grid`), at ``pitch`` (m) instead of the file's if
        given."""
        return CiliaArray.grid(self.setup, self.rows, self.cols,
                               self.pitch if pitch is None else pitch, sensor=self.sensor,
                               depth=self.depth)


def _field_values(name: str, value: object, dimension: str) -> Any:
    """One unit-bearing value, or a list of three (x, y, z) -> SI float or tuple."""
    if isinstance(value, list):
        if len(value) != 3:
            raise _fail(name, value, f"one {dimension} with its unit or three (x, y, z)")
        return tuple(parse_quantity(x, dimension, f"{name}[{i}]") for i, x in enumerate(value))
    return parse_quantity(value, dimension, name)


def _point(name: str, value: object) -> tuple[float, float, float]:
    """``["x mm", "y mm", "z mm"]`` -> SI (m)."""
    if not isinstance(value, list) or len(value) != 3:
        raise _fail(name, value, 'three lengths with units, e.g. ["0 mm", "2 mm", "0.71 mm"]')
    x, y, z = (parse_quantity(p, "length", f"{name}[{i}]") for i, p in enumerate(value))
    if max(abs(x), abs(y), abs(z)) > MAX_COORDINATE:
        raise _fail(name, value, f"coordinates within ±{MAX_COORDINATE:g} m of the board's "
                    "origin (MAX_COORDINATE)")
    return (x, y, z)


def _name(where: str, entry: Mapping[str, Any], default: str) -> str:
    name = entry.get("name", default)
    if not isinstance(name, str) or not name.strip() or len(name) > 64 \
            or v.printable(name) != name:
        raise _fail(f"{where}.name", name, "a name of 1 to 64 printable characters")
    return name


def _rotation(where: str, entry: Mapping[str, Any]) -> Any:
    """The sensor's axes (columns, board frame) from ``rotation`` or ``euler``, or None."""
    from scipy.spatial.transform import Rotation

    if "rotation" in entry and "euler" in entry:
        raise _fail(f"{where}.euler", entry["euler"], "left out when rotation is given (one "
                    "orientation per sensor)")
    if "rotation" in entry:
        value = entry["rotation"]
        rows = value if isinstance(value, list) and len(value) == 3 else None
        if rows is None or not all(isinstance(r, list) and len(r) == 3 and all(
                isinstance(x, int | float) and not isinstance(x, bool) for x in r) for r in rows):
            raise _fail(f"{where}.rotation", value, "a 3 × 3 matrix of plain numbers, "
                        "[[…], […], […]], whose columns are the sensor's axes in the board frame")
        try:
            return Magnetometer(1.0, 1.0, 1.0, 1.0, rotation=rows).rotation
        except v.MagciliaError as exc:
            raise v.MagciliaError(f"{where}.{exc}") from None
    if "euler" in entry:
        value = entry["euler"]
        parts = value.split() if isinstance(value, str) and len(value) <= 200 else []
        allowed = ('"SEQ A B C UNIT": an axis sequence (xyz extrinsic, XYZ intrinsic, …) and '
                   'three angles in deg or rad, e.g. "xyz 0 0 90 deg"')
        if len(parts) != 5 or parts[4] not in ("deg", "rad"):
            raise _fail(f"{where}.euler", value, allowed)
        seq = parts[0]
        try:
            angles = [float(a) for a in parts[1:4]]
            if not all(math.isfinite(a) for a in angles):
                raise ValueError
            return Rotation.from_euler(seq, angles, degrees=parts[4] == "deg").as_matrix()
        except ValueError:
            raise _fail(f"{where}.euler", value, allowed) from None
    return None


def sensor_from_dict(entry: object, where: str = "sensor", *,
                     placed: bool = True) -> Magnetometer:
    """One ``[[sensors]]`` entry (unit-bearing strings) as a :class:`Magnetometer` (SI).

    Parameters
    ----------
    entry : mapping
        ``preset`` with its settings, or ``range``, ``lsb``, ``noise``, ``rate``; ``name``;
        ``position`` (three lengths); ``rotation`` or ``euler`` (see the module).
    where : str
        The entry's place in the file, for errors.
    placed : bool
        Whether ``position`` is required (False: the ``[array]`` table's part).
    """
    if not isinstance(entry, dict):
        raise _fail(where, entry, "a table of key = value lines (a [[sensors]] entry)")
    preset = entry.get("preset")
    kwargs: dict[str, Any] = {}
    settings: tuple[str, ...] = ()
    if preset is not None:
        try:
            key = _preset_key(preset)
        except v.MagciliaError as exc:
            raise v.MagciliaError(f"{where}.preset: {exc}") from None
        settings = tuple(p for p in inspect.signature(MAGNETOMETERS[key]).parameters
                         if p not in ("overrides", "cls"))
    known = (*_SENSOR_KEYS, *SENSOR_FIGURES, *settings)
    for k, value in entry.items():
        if k not in known:
            raise _fail(f"{where}.{_key(k)}", k, "one of " + ", ".join(known)
                        + ("" if preset is not None else " (a preset's settings with preset)"))
        name = f"{where}.{k}"
        if k in settings:
            dim = SETTING_DIMENSIONS.get(k)
            if dim is not None:
                kwargs[k] = parse_quantity(value, dim, name)
            elif isinstance(value, bool) or not isinstance(value, int | str):
                raise _fail(name, value, "a whole number or a word (the part's setting)")
            else:
                kwargs[k] = value
        elif k in SENSOR_FIGURES:
            field, dim = SENSOR_FIGURES[k]
            kwargs[field] = _field_values(name, value, dim)
    if placed and "position" not in entry:
        raise _fail(f"{where}.position", "nothing", 'three lengths with units, e.g. '
                    '["0 mm", "0 mm", "0 mm"]')
    if "position" in entry:
        if not placed:
            raise _fail(f"{where}.position", entry["position"], "left out (the grid places "
                        "the part under each cilium)")
        kwargs["position"] = _point(f"{where}.position", entry["position"])
    rotation = _rotation(where, entry)
    if rotation is not None:
        kwargs["rotation"] = rotation
    if "name" in entry:
        kwargs["name"] = _name(where, entry, "")
    try:
        if preset is not None:
            return Magnetometer.preset(str(preset), **kwargs)
        missing = [k for k, (f, _) in SENSOR_FIGURES.items() if f not in kwargs]
        if missing:
            raise v.fail(missing[0], "nothing", "given: a sensor needs preset = \"PART\" (one "
                         f"of {', '.join(MAGNETOMETERS)}) or range, lsb, noise and rate")
        return Magnetometer(**kwargs)
    except v.MagciliaError as exc:
        raise v.MagciliaError(f"{where}: {exc}") from None


def _list(doc: Mapping[str, Any], table: str, source: str) -> list[dict[str, Any]]:
    entries = doc.get(table, [])
    if not isinstance(entries, list) or not all(isinstance(e, dict) for e in entries):
        raise _fail(f"{source}: {table}", entries, f"a list of [[{table}]] tables")
    if len(entries) > MAX_ARRAY_ITEMS:
        raise _fail(f"{source}: [[{table}]]", f"{len(entries)} entries",
                    f"at most {MAX_ARRAY_ITEMS} (MAX_ARRAY_ITEMS)")
    return entries


def _cilium(doc: dict[str, Any], entry: dict[str, Any], where: str, source: str,
            base_doc: dict[str, Any]) -> Setup:
    """One ``[[cilia]]`` entry: the file's tables with its overrides, placed at ``base``."""
    tables = {t: dict(base_doc.get(t, {})) for t in CILIUM_TABLES}
    for k, value in entry.items():
        if k in ("name", "base"):
            continue
        table = next((t for t in CILIUM_TABLES if k in SCHEMA[t]), None)
        if table is None:
            allowed = [k2 for t in CILIUM_TABLES for k2 in SCHEMA[t]]
            raise _fail(f"{source}: {where}.{_key(k)}", k,
                        "name, base or a key of [cilium], [material] or [model]: "
                        + ", ".join(allowed))
        if k in ("profile_s", "profile_r"):  # a measured shape replaces the file's radii
            for shaped in ("height", "base_radius", "tip_radius"):
                tables["cilium"].pop(shaped, None)
        if k in ("height", "base_radius", "tip_radius"):
            tables["cilium"].pop("profile_s", None)
            tables["cilium"].pop("profile_r", None)
        tables[table][k] = value
    if "layout" not in entry and any(k in entry for k in ("n_loops", "dipoles_per_loop", "ring")):
        tables["model"].pop("layout", None)  # this cilium's own layout: as given
    if "base" not in entry:
        raise _fail(f"{source}: {where}.base", "nothing",
                    'the base centre, three lengths with units, e.g. ["0 mm", "0 mm", "0.71 mm"]')
    base = _point(f"{source}: {where}.base", entry["base"])
    one = {**{t: e for t, e in doc.items() if t in ("sensor", "amplifier")}, **tables}
    try:
        setup = setup_from_dict(one, source=f"{source}: {where}")
    except v.MagciliaError as exc:
        raise v.MagciliaError(str(exc)) from None
    depth = setup.sensor.depth
    try:
        return setup.replace(position=(base[0], base[1], base[2] - depth))
    except v.MagciliaError as exc:
        raise v.MagciliaError(f"{source}: {where}.base: {exc}") from None


def _defaults(doc: dict[str, Any]) -> dict[str, Any]:
    """The file's single-setup tables (what load_setup reads)."""
    return {t: e for t, e in doc.items() if t not in (*ARRAY_TABLES, "actuation", "priors")}


def grid_from_dict(doc: dict[str, Any], source: str = "array") -> ArrayGrid | None:
    """The ``[array]`` table of a parsed array document as an :class:`ArrayGrid` (None without
    one)."""
    source = v.printable(source)
    if "array" not in doc:
        return None
    table = doc["array"]
    if not isinstance(table, dict):
        raise _fail(f"{source}: [array]", table, "a table of key = value lines")
    for k in table:
        if k not in _GRID_KEYS:
            raise _fail(f"{source}: array.{_key(k)}", k, "one of " + ", ".join(_GRID_KEYS))
    for k in ("rows", "cols", "pitch"):
        if k not in table:
            raise _fail(f"{source}: array.{k}", "nothing", "given (rows, cols and pitch make "
                        "the grid)")
    counts = []
    for k in ("rows", "cols"):
        n = table[k]
        if isinstance(n, bool) or not isinstance(n, int) or not 1 <= n <= MAX_ARRAY_ITEMS:
            raise _fail(f"{source}: array.{k}", n, f"a whole number from 1 to {MAX_ARRAY_ITEMS}")
        counts.append(n)
    if counts[0] * counts[1] > MAX_ARRAY_ITEMS:
        raise _fail(f"{source}: array", f"{counts[0]} × {counts[1]} cilia",
                    f"at most {MAX_ARRAY_ITEMS} cilia (MAX_ARRAY_ITEMS)")
    pitch = table["pitch"]
    if isinstance(pitch, list) and len(pitch) == 2:
        px, py = (parse_quantity(p, "length", f"{source}: array.pitch[{i}]")
                  for i, p in enumerate(pitch))
    else:
        px = py = parse_quantity(pitch, "length", f"{source}: array.pitch")
    if not (px > 0 and py > 0):
        raise _fail(f"{source}: array.pitch", pitch, "a positive length with its unit")
    if "sensor" not in table:
        raise _fail(f"{source}: array.sensor", "nothing", 'the part under each cilium: a preset '
                    'name (e.g. "MMC5983MA") or a table like a [[sensors]] entry')
    part = table["sensor"]
    part = {"preset": part} if isinstance(part, str) else part
    sensor = sensor_from_dict(part, f"{source}: array.sensor", placed=False)
    depth = None
    if "depth" in table:
        depth = parse_quantity(table["depth"], "length", f"{source}: array.depth")
        if not depth > 0:
            raise _fail(f"{source}: array.depth", table["depth"], "a positive length")
    setup = setup_from_dict(_defaults(doc), source=source)
    if "centre" in table:
        c = _point(f"{source}: array.centre", table["centre"])
        try:
            setup = setup.replace(position=(c[0], c[1], c[2] - setup.sensor.depth))
        except v.MagciliaError as exc:
            raise v.MagciliaError(f"{source}: array.centre: {exc}") from None
    return ArrayGrid(setup, counts[0], counts[1], (px, py), sensor, depth)


def array_from_dict(doc: dict[str, Any], source: str = "array") -> CiliaArray:
    """Build a :class:`CiliaArray` from a parsed array document (see the module)."""
    source = v.printable(source)
    if not isinstance(doc, dict):
        raise _fail(source, doc, "a document of [tables] of key = value lines")
    setup_from_dict(doc, source)  # the single-setup tables, checked as load_setup does
    cilia_entries = _list(doc, "cilia", source)
    sensor_entries = _list(doc, "sensors", source)
    grid = grid_from_dict(doc, source)
    if grid is not None:
        if cilia_entries or sensor_entries:
            raise _fail(f"{source}: [array]", "with [[cilia]] or [[sensors]]",
                        "either the [array] shorthand or [[cilia]] and [[sensors]] lists")
        try:
            return grid.build()
        except v.MagciliaError as exc:
            raise v.MagciliaError(f"{source}: [array]: {exc}") from None
    if not cilia_entries or not sensor_entries:
        missing = "cilia" if not cilia_entries else "sensors"
        raise _fail(f"{source}: [[{missing}]]", "nothing", "an array file with [[cilia]] and "
                    "[[sensors]] entries, or an [array] table (see magcilia.io.array_file)")
    base_doc = _defaults(doc)
    cilia, names = [], []
    for i, entry in enumerate(cilia_entries):
        name = _name(f"{source}: cilia[{i}]", entry, f"c{i + 1}")
        if name in names:
            raise _fail(f"{source}: cilia[{i}].name", name, "a name no other cilium has")
        where = f"cilia[{i}] {name!r}"
        cilia.append(_cilium(doc, entry, where, source, base_doc))
        names.append(name)
    sensors, sensor_names = [], []
    for i, entry in enumerate(sensor_entries):
        if not isinstance(entry, dict):
            raise _fail(f"{source}: sensors[{i}]", entry, "a [[sensors]] table")
        name = _name(f"{source}: sensors[{i}]", entry, f"s{i + 1}")
        if name in sensor_names:
            raise _fail(f"{source}: sensors[{i}].name", name, "a name no other sensor has")
        sensors.append(sensor_from_dict({**entry, "name": name},
                                        f"{source}: sensors[{i}] {name!r}"))
        sensor_names.append(name)
    try:
        return CiliaArray(tuple(cilia), tuple(sensors), tuple(names))
    except v.MagciliaError as exc:
        raise v.MagciliaError(f"{source}: {exc}") from None


def is_array_file(path: str | os.PathLike[str]) -> bool:
    """Whether ``path`` is an array setup file (a TOML file with any of :data:`ARRAY_TABLES`):
    False for anything else (a preset name, a missing file, a single-cilium setup file)."""
    if not Path(path).is_file():
        return False
    doc = _read_document(path)
    return any(table in doc for table in ARRAY_TABLES)


def load_array(path: str | os.PathLike[str]) -> CiliaArray:
    """Read an array setup file (see the module for the format; bounded as setup files are).

    Returns
    -------
    CiliaArray
        The cilia (their base centres in the board frame, m) and sensors, SI.
    """
    return array_from_dict(_read_document(path), source=str(path))


def load_array_grid(path: str | os.PathLike[str]) -> ArrayGrid | None:
    """The ``[array]`` shorthand of an array file as an :class:`ArrayGrid` (None when the file
    lists its cilia and sensors instead)."""
    return grid_from_dict(_read_document(path), source=str(path))


def _mm(values: Any) -> list[str]:
    return [format_quantity(float(x), "mm", 15) for x in values]


def _figure(values: tuple[float, float, float], unit: str) -> Any:
    shown = [format_quantity(x, unit, 15) for x in values]
    return shown[0] if len(set(shown)) == 1 else shown


def sensor_to_dict(sensor: Magnetometer) -> dict[str, Any]:
    """A sensor as a ``[[sensors]]`` entry by its figures (unit-bearing strings; the rotation
    as plain numbers)."""
    out: dict[str, Any] = {"name": sensor.name,
                           "range": _figure(sensor.field_range, "gauss"),
                           "lsb": _figure(sensor.resolution, "gauss"),
                           "noise": _figure(sensor.noise, "gauss"),
                           "rate": format_quantity(sensor.rate, "Hz", 15),
                           "position": _mm(sensor.position)}
    if not np.array_equal(sensor.rotation, np.eye(3)):
        out["rotation"] = [[float(x) for x in row] for row in sensor.rotation]
    return out


def array_to_dict(array: CiliaArray) -> dict[str, Any]:
    """The array as a document of unit-bearing strings (inverse of :func:`array_from_dict`):
    the first cilium's tables as the file's defaults, each cilium's differing keys as its
    overrides, every sensor by its figures."""
    if not isinstance(array, CiliaArray):
        raise v.fail("array", type(array).__name__, "a magcilia CiliaArray")
    first = setup_to_dict(array.cilia[0])
    doc: dict[str, Any] = {t: e for t, e in first.items() if t != "placement"}
    cilia = []
    for setup, name, base in zip(array.cilia, array.names, array.bases, strict=True):
        own = setup_to_dict(setup)
        entry: dict[str, Any] = {"name": name, "base": _mm(base)}
        for table in CILIUM_TABLES:
            for k, value in own[table].items():
                if first[table].get(k) != value:
                    entry[k] = value
        if own["sensor"].get("depth") != first["sensor"].get("depth"):
            raise v.fail("array", f"cilium {name}", "cilia whose setups share the sensor depth "
                         "(an array file has one [sensor] table)")
        cilia.append(entry)
    doc["cilia"] = cilia
    doc["sensors"] = [sensor_to_dict(s) for s in array.sensors]
    return doc


def save_array(array: CiliaArray, path: str | os.PathLike[str]) -> None:
    """Write ``array`` as an array setup file (atomically; read back in memory first: an array
    that :func:`load_array` would refuse is an error and nothing is written)."""
    doc = array_to_dict(array)
    text = ("# magcilia array file: every quantity carries its unit (SI prefixes allowed)\n"
            + tomli_w.dumps(doc))
    where = v.printable(str(path))
    try:
        array_from_dict(tomllib.loads(text), source="array")
    except v.MagciliaError as exc:
        raise v.MagciliaError(f"{where}: not written, because the file could not be read "
                              f"back: {exc}") from None
    if len(text.encode("utf-8")) > MAX_SETUP_BYTES:
        raise v.MagciliaError(f"{where}: not written, because the file would be larger than "
                              f"{MAX_SETUP_BYTES} bytes (MAX_SETUP_BYTES)")
    write_text(path, text)


__all__ = ["ARRAY_TABLES", "MAX_ARRAY_ITEMS", "MAX_LOADS_BYTES", "MAX_LOAD_SETS", "ArrayGrid",
           "array_from_dict", "array_to_dict", "grid_from_dict", "is_array_file", "load_array",
           "load_array_grid", "read_loads", "save_array", "sensor_from_dict", "sensor_to_dict"]
