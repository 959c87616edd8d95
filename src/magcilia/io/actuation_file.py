"""Actuation files: the ``[actuation]`` table of a TOML file ↔ :class:`magcilia.Actuation`.

The table sits in a setup file (``magcilia bend --setup SETUP`` reads it there) or in a file of
its own (``--actuation FILE``). Every quantity carries its unit. A uniform field (a Helmholtz
pair)::

    [actuation]
    field = ["0 G", "0 G", "50 G"]   # Bx, By, Bz in the board frame
    scale = 1.0                      # optional: the field times this (a coil current ratio)

or permanent magnets through magpylib (their fields add up), positions in the board frame (the
sensing element at the origin, +z up)::

    [[actuation.magnets]]
    kind = "cuboid"                          # cuboid, cylinder or sphere
    polarization = ["0 T", "0 T", "1 T"]     # J = μ0 M, T
    dimension = ["2 mm", "2 mm", "2 mm"]     # cuboid: x, y, z sides
    position = ["15 mm", "0 mm", "0 mm"]     # the magnet's centre

``dimension`` is ``["diameter", "height"]`` for a cylinder (axis along z) and one length, the
diameter, for a sphere. Unknown keys and values without units are one-line errors naming the file
and the key.
"""

from __future__ import annotations

import os
from typing import Any

import numpy as np

from magcilia import _validate as v
from magcilia.device.actuation import Actuation
from magcilia.io.setup_files import _read_document
from magcilia.units import parse_quantity

#: the table's name
TABLE = "actuation"
#: magnet kinds -> (magpylib class name, the dimension's number of lengths, what they are)
MAGNETS = {"cuboid": ("Cuboid", 3, "the x, y, z sides"),
           "cylinder": ("Cylinder", 2, "the diameter and the height (axis along z)"),
           "sphere": ("Sphere", 1, "the diameter")}
#: most magnets in one file
MAX_MAGNETS = 64


def _vector(where: str, value: object, dimension: str, count: int, example: str) -> list[float]:
    """A list of ``count`` unit strings of ``dimension`` -> SI floats."""
    allowed = f"a list of {count} values with units, e.g. {example}"
    if not isinstance(value, list) or len(value) != count:
        raise v.fail(where, v.short(value), allowed)
    try:
        return [parse_quantity(item, dimension, where) for item in value]
    except v.MagciliaError:
        raise v.fail(where, v.short(value), allowed) from None


def _magnet(where: str, entry: object) -> Any:
    import magpylib

    if not isinstance(entry, dict):
        raise v.fail(where, v.short(entry), "a table with kind, polarization, dimension, "
                                            "position")
    extra = sorted(set(entry) - {"kind", "polarization", "dimension", "position"})
    if extra:
        raise v.fail(f"{where}.{v.printable(str(extra[0]))}", "an unknown key",
                     "one of kind, polarization, dimension, position")
    kind = entry.get("kind")
    if kind not in MAGNETS:
        raise v.fail(f"{where}.kind", v.short(kind), "one of " + ", ".join(MAGNETS))
    name, count, words = MAGNETS[str(kind)]
    pol = _vector(f"{where}.polarization", entry.get("polarization"), "field", 3,
                  '["0 T", "0 T", "1 T"]')
    raw = entry.get("dimension")
    if count == 1 and not isinstance(raw, list):
        raw = [raw]
    dim = _vector(f"{where}.dimension", raw, "length", count,
                  f"{words} as " + str(["2 mm"] * count).replace("'", '"'))
    if min(dim) <= 0.0:
        raise v.fail(f"{where}.dimension", v.short(entry.get("dimension")),
                     f"positive lengths ({words})")
    pos = _vector(f"{where}.position", entry.get("position", ["0 mm"] * 3), "length", 3,
                  '["15 mm", "0 mm", "0 mm"]')
    cls = getattr(magpylib.magnet, name)
    if count == 1:
        return cls(polarization=tuple(pol), diameter=dim[0], position=tuple(pos))
    return cls(polarization=tuple(pol), dimension=tuple(dim), position=tuple(pos))


def actuation_from_dict(table: object, source: str = "actuation") -> Actuation:
    """The ``[actuation]`` table (parsed TOML) as an :class:`~magcilia.Actuation` (SI);
    ``source`` names the file in errors."""
    where = f"{v.printable(source)}: [actuation]"
    if not isinstance(table, dict):
        raise v.fail(where, v.short(table), "a table with field = [Bx, By, Bz] or "
                                           "[[actuation.magnets]]")
    extra = sorted(set(table) - {"field", "magnets", "scale"})
    if extra:
        raise v.fail(f"{where} {v.printable(str(extra[0]))}", "an unknown key",
                     "one of field, magnets, scale")
    if ("field" in table) == ("magnets" in table):
        raise v.fail(where, "both or neither of field/magnets",
                     'either field = ["0 G", "0 G", "50 G"] or [[actuation.magnets]] tables')
    scale = table.get("scale", 1.0)
    if isinstance(scale, bool) or not isinstance(scale, int | float) or not np.isfinite(scale):
        raise v.fail(f"{where} scale", v.short(scale), "a finite number (the field's factor)")
    if "field" in table:
        b = _vector(f"{where} field", table["field"], "field", 3, '["0 G", "0 G", "50 G"]')
        return Actuation.uniform(b).scaled(float(scale))
    magnets = table["magnets"]
    if not isinstance(magnets, list) or not magnets or len(magnets) > MAX_MAGNETS:
        raise v.fail(f"{where} magnets", v.short(magnets),
                     f"1 to {MAX_MAGNETS} [[actuation.magnets]] tables")
    sources = [_magnet(f"{where} magnets[{i}]", m) for i, m in enumerate(magnets)]
    return Actuation.magpylib(sources if len(sources) > 1 else sources[0], float(scale))


def read_actuation(path: str | os.PathLike[str]) -> Actuation | None:
    """The ``[actuation]`` table of a TOML file (a setup file or one of its own), or None when
    the file has none."""
    doc = _read_document(path)
    if TABLE not in doc:
        return None
    return actuation_from_dict(doc[TABLE], str(path))


def load_actuation(path: str | os.PathLike[str]) -> Actuation:
    """The ``[actuation]`` table of a TOML file; a one-line error when it has none.

    Examples
    --------
    >>> import tempfile, pathlib
    >>> p = pathlib.Path(tempfile.mkdtemp()) / "coil.toml"
    >>> _ = p.write_text('[actuation]\\nfield = ["0 G", "0 G", "5 mT"]\\n')
    >>> load_actuation(p).uniform_field.tolist()
    [0.0, 0.0, 0.005]
    """
    act = read_actuation(path)
    if act is None:
        raise v.fail(f"{v.printable(str(path))}", "a file without an [actuation] table",
                     'a TOML file with [actuation] field = ["0 G", "0 G", "50 G"] or '
                     "[[actuation.magnets]]")
    return act
