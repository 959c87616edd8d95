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
from magcilia.device.setup import PAPER_OPTIMIZED, Setup
from magcilia.units import format_quantity, parse_quantity

#: table -> key -> (dimension or None for a plain number/string, Setup keyword, unit for writing)
SCHEMA: dict[str, dict[str, tuple[str | None, str, str]]] = {
    "cilium": {
        "height": ("length", "height", "mm"),
        "base_radius": ("length", "base_radius", "mm"),
        "tip_radius": ("length", "tip_radius", "mm"),
        "youngs_modulus": ("pressure", "youngs_modulus", "MPa"),
        "profile_s": ("length", "profile_s", "mm"),
        "profile_r": ("length", "profile_r", "mm"),
    },
    "material": {
        "cobalt_mass": ("mass", "cobalt_mass", "mg"),
        "polymer_mass": ("mass", "polymer_mass", "mg"),
        "cobalt_density": ("density", "cobalt_density", "g/cm^3"),
        "polymer_density": ("density", "polymer_density", "g/cm^3"),
        "atom_density": ("number_density", "atom_density", "m^-3"),
        "moment_per_atom": ("moment_per_atom", "moment_per_atom", "muB"),
        "magnetization_scale": (None, "magnetization_scale", ""),
        "polymer_modulus": ("pressure", "polymer_modulus", "MPa"),
    },
    "placement": {
        "x": ("length", "x", "mm"),
        "y": ("length", "y", "mm"),
        "z": ("length", "z", "mm"),
    },
    "sensor": {
        "preset": (None, "", ""),
        "sensitivity": ("sensitivity", "sensitivity", "mV/V/gauss"),
        "bridge_voltage": ("voltage", "bridge_voltage", "V"),
        "depth": ("length", "depth", "mm"),
        "range": ("field", "field_range", "gauss"),
        "noise_density": ("noise_density", "noise_density", "nT/sqrt(Hz)"),
        "flicker_corner": ("frequency", "flicker_corner", "Hz"),
    },
    "amplifier": {
        "gain": (None, "gain", ""),
        "offset": ("voltage", "offset", "V"),
    },
    "model": {
        "n_loops": (None, "n_loops", ""),
        "dipoles_per_loop": (None, "dipoles_per_loop", ""),
        "ring": (None, "ring", ""),
    },
}
_PRESETS = ("HMC1021Z",)
_PROFILE_KEYS = ("profile_s", "profile_r")


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
            dimension, target, _ = SCHEMA[table][key]
            if key == "preset":
                v.choice(name, value, _PRESETS)
            elif key in _PROFILE_KEYS:
                if not isinstance(value, list) or not value:
                    raise v.fail(name, value, 'a list of lengths, e.g. ["0 mm", "1.5 mm", "3 mm"]')
                kwargs[target] = [parse_quantity(x, "length", f"{name}[{i}]")
                                  for i, x in enumerate(value)]
            elif dimension is not None:
                kwargs[target] = parse_quantity(value, dimension, name)
            elif key == "ring":
                kwargs[target] = v.choice(name, value, ("mean", "rms"))
            elif key in ("n_loops", "dipoles_per_loop"):
                kwargs[target] = v.integer(name, value, 1)
            else:
                kwargs[target] = v.real(name, value)
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
    clash = [key for key in ("height", "base_radius", "tip_radius") if key in given]
    if clash:
        raise v.fail(f"cilium.{clash[0]}", given[clash[0]],
                     "left out when a profile is given (the profile sets the shape)")
    cilium = Cilium.from_profile(given["profile_s"], given["profile_r"],
                                 youngs_modulus=given.get("youngs_modulus"))
    dropped = ("height", "base_radius", "tip_radius", "youngs_modulus", *_PROFILE_KEYS)
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
    values: dict[str, Any] = {
        **{f: getattr(setup.cilium, f) for f in ("height", "base_radius", "tip_radius",
                                                  "youngs_modulus")},
        **{f: getattr(setup.material, f) for f in ("cobalt_mass", "polymer_mass", "cobalt_density",
                                                    "polymer_density", "atom_density",
                                                    "moment_per_atom", "magnetization_scale",
                                                    "polymer_modulus")},
        **dict(zip("xyz", setup.position, strict=True)),
        **{f: getattr(setup.sensor, f) for f in ("sensitivity", "bridge_voltage", "depth",
                                                  "field_range", "noise_density", "flicker_corner",
                                                  "gain", "offset")},
        "n_loops": setup.n_loops, "dipoles_per_loop": setup.dipoles_per_loop, "ring": setup.ring,
        "profile_s": None, "profile_r": None,
    }
    c = setup.cilium
    if c.profile is not None:  # the measured shape replaces height and radii
        values["profile_s"] = [u * c.height for u in c.profile[0]]
        values["profile_r"] = [rho * c.base_radius for rho in c.profile[1]]
        values["height"] = values["base_radius"] = values["tip_radius"] = None
    doc: dict[str, dict[str, Any]] = {}
    for table, entries in SCHEMA.items():
        out: dict[str, Any] = {}
        for key, (dimension, target, unit) in entries.items():
            if key == "preset":
                out[key] = setup.sensor.name
                continue
            value = values[target]
            if value is None:
                continue
            if isinstance(value, list):
                out[key] = [format_quantity(x, unit, 12) for x in value]
            else:
                out[key] = format_quantity(value, unit, 12) if dimension is not None else value
        doc[table] = out
    return doc


def save_setup(setup: Setup, path: str | os.PathLike[str]) -> None:
    """Write ``setup`` as a setup TOML file (atomically)."""
    header = "# magcilia setup file: every quantity carries its unit (SI prefixes allowed)\n"
    write_text(path, header + tomli_w.dumps(setup_to_dict(setup)))
