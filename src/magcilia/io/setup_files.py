"""Setup files: human-edited TOML with unit-bearing values ↔ :class:`magcilia.Setup`.

Example (the paper's setup, shipped as ``examples/paper.toml``)::

    [cilium]
    height = "3.2613 mm"
    base_radius = "0.1801 mm"
    tip_radius = "0 mm"

    [material]
    cobalt_mass = "30 mg"
    polymer_mass = "30 mg"

    [placement]
    x = "1.4727 mm"
    y = "1.9891 mm"
    z = "0.3804 mm"

    [sensor]
    preset = "HMC1021Z"
    bridge_voltage = "7.5 V"

    [amplifier]
    gain = 1.0
    offset = "0 V"

    [model]
    n_loops = 2
    dipoles_per_loop = 5
    ring = "mean"

A measured shape replaces ``height``, ``base_radius`` and ``tip_radius`` by two lists, linear in
between (``profile_s = ["0 mm", "1 mm", "3.2 mm"]``, ``profile_r = ["0.18 mm", "0.15 mm",
"0.03 mm"]``).

Every quantity needs its unit; a missing table takes the paper's defaults. Unknown keys and values
without units are errors that name the key.
"""

from __future__ import annotations

import os
import tomllib
from pathlib import Path
from typing import Any

import tomli_w

from magcilia import _validate as v
from magcilia._atomic import write_text
from magcilia.device.cilium import Cilium
from magcilia.device.parameters import PARAMETERS, Parameter
from magcilia.device.setup import PAPER_OPTIMIZED, Setup
from magcilia.units import format_quantity, parse_quantity

#: table -> key -> the registry's parameter, or None for the keys that only files have: the
#: sensor preset and the measured profile's two lists (see the module docstring)
SCHEMA: dict[str, dict[str, Parameter | None]] = {}
for _p in PARAMETERS.values():
    if _p.file is not None:
        SCHEMA.setdefault(_p.file[0], {})[_p.file[1]] = _p
SCHEMA["cilium"].update(profile_s=None, profile_r=None)
SCHEMA["sensor"] = {"preset": None, **SCHEMA["sensor"]}
_PRESETS = ("HMC1021Z",)
_PROFILE_KEYS = ("profile_s", "profile_r")
#: what a measured profile sets, so that files leave it out
_PROFILE_SHAPED = ("height", "base_radius", "tip_radius")


def setup_from_dict(doc: dict[str, Any], source: str = "setup") -> Setup:
    """Build a Setup from a parsed setup document (tables of unit-bearing strings)."""
    kwargs: dict[str, Any] = {}
    for table, entries in doc.items():
        if table not in SCHEMA:
            raise v.fail(f"{source}: table [{table}]", table,
                         "one of " + ", ".join(f"[{t}]" for t in SCHEMA))
        if not isinstance(entries, dict):
            raise v.fail(f"{source}: [{table}]", entries, "a table of key = value lines")
        for key, value in entries.items():
            name = f"{source}: {table}.{key}"
            if key not in SCHEMA[table]:
                raise v.fail(name, key, "one of " + ", ".join(SCHEMA[table]))
            p = SCHEMA[table][key]
            if key == "preset":
                v.choice(name, value, _PRESETS)
            elif key in _PROFILE_KEYS:
                if not isinstance(value, list) or not value:
                    raise v.fail(name, value, 'a list of lengths, e.g. ["0 mm", "1.5 mm", "3 mm"]')
                kwargs[key] = [parse_quantity(x, "length", f"{name}[{i}]")
                               for i, x in enumerate(value)]
            elif p is not None and p.dimension is not None:
                kwargs[p.name] = parse_quantity(value, p.dimension, name)
            elif p is not None and p.domain in ("integer", "choice"):
                kwargs[p.name] = p.check(value, name)
            elif p is not None:
                kwargs[p.name] = v.real(name, value)
    try:
        overrides = {**_unpack_position(PAPER_OPTIMIZED), **kwargs}
        if any(key in kwargs for key in _PROFILE_KEYS):
            overrides = _with_profile(overrides, kwargs)
        return Setup.paper(**overrides)
    except v.MagciliaError as exc:
        raise v.MagciliaError(f"{source}: {exc}") from None


def _with_profile(overrides: dict[str, Any], given: dict[str, Any]) -> dict[str, Any]:
    """Replace height/base_radius/tip_radius by a Cilium built from profile_s and profile_r (the
    caller prefixes errors with the file name)."""
    if not all(key in given for key in _PROFILE_KEYS):
        raise v.fail("cilium.profile_s / profile_r", "only one of them",
                     "both lists (arc lengths from the base and radii, same count)")
    clash = [key for key in _PROFILE_SHAPED if key in given]
    if clash:
        raise v.fail(f"cilium.{clash[0]}", given[clash[0]],
                     "left out when a profile is given (the profile sets the shape)")
    cilium = Cilium.from_profile(given["profile_s"], given["profile_r"],
                                 youngs_modulus=given.get("youngs_modulus"))
    dropped = (*_PROFILE_SHAPED, "youngs_modulus", *_PROFILE_KEYS)
    return {**{k: val for k, val in overrides.items() if k not in dropped}, "cilium": cilium}


def _unpack_position(d: dict[str, Any]) -> dict[str, Any]:
    out = {k: val for k, val in d.items() if k != "position"}
    out["x"], out["y"], out["z"] = d["position"]
    return out


def load_setup(path: str | os.PathLike[str]) -> Setup:
    """Read a setup TOML file (see the module docstring for the format)."""
    p = Path(path)
    try:
        text = p.read_text(encoding="utf-8")
    except UnicodeDecodeError:
        raise v.fail(f"setup file {p}", "binary data", "UTF-8 TOML text") from None
    try:
        doc = tomllib.loads(text)
    except tomllib.TOMLDecodeError as exc:
        raise v.MagciliaError(f"setup file {p} is not valid TOML ({exc}); fix the syntax") from None
    return setup_from_dict(doc, source=str(p))


def setup_to_dict(setup: Setup) -> dict[str, dict[str, Any]]:
    """The setup as a document of unit-bearing strings (inverse of :func:`setup_from_dict`)."""
    c = setup.cilium
    doc: dict[str, dict[str, Any]] = {}
    for table, entries in SCHEMA.items():
        out: dict[str, Any] = {}
        for key, p in entries.items():
            if p is None:  # the keys only files have
                if key == "preset":
                    out[key] = setup.sensor.name
                elif c.profile is not None:  # the measured shape replaces height and radii
                    scale, knots = (c.height, c.profile[0]) if key == "profile_s" else (
                        c.base_radius, c.profile[1])
                    out[key] = [format_quantity(k * scale, "mm", 12) for k in knots]
                continue
            value = setup.value(p.name)
            if value is None or (c.profile is not None and p.name in _PROFILE_SHAPED):
                continue
            out[key] = format_quantity(value, p.file_unit, 12) if p.dimension else value
        doc[table] = out
    return doc


def save_setup(setup: Setup, path: str | os.PathLike[str]) -> None:
    """Write ``setup`` as a setup TOML file (atomically)."""
    header = "# magcilia setup file: every quantity carries its unit (SI prefixes allowed)\n"
    write_text(path, header + tomli_w.dumps(setup_to_dict(setup)))
