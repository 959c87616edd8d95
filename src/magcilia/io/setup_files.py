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
    layout = "paper"
    n_loops = 2
    dipoles_per_loop = 5
    ring = "mean"

The ``[model]`` table says what the dipole layout is (:class:`magcilia.Setup`'s ``layout``;
docs/convergence.md): ``layout = "paper"`` names the paper's model (mean rings, used as is by
every path: replication), ``layout = "converged"`` has the layout chosen within 0.5 % of the
exact body wherever a field is predicted (``n_loops``, ``dipoles_per_loop`` and ``ring`` are then
left out), and ``layout = "given"`` uses the keys as they are, with a warning wherever they are
more than 1 % from the exact body. Without ``layout``, keys given mean ``"given"``, and a file
without them (or without ``[model]``) is ``"converged"``.

An optional ``[priors]`` table holds manual measurements of the cilium as Gaussian priors of
the physical calibration (``magcilia calibrate --model physical``), value ± σ with units::

    [priors]
    height = "3.0 mm +- 0.2 mm"
    base_radius = "180 um ± 20 um"

(names among height, base_radius, x, y, z; read by :func:`load_priors`, ignored by
:func:`load_setup`).

A measured shape replaces ``height``, ``base_radius`` and ``tip_radius`` by two lists, linear in
between (``profile_s = ["0 mm", "1 mm", "3.2 mm"]``, ``profile_r = ["0.18 mm", "0.15 mm",
"0.03 mm"]``).

The tables of arrays (``[[cilia]]``, ``[[sensors]]``, ``[array]``; read by
:func:`magcilia.io.array_file.load_array`), ``[actuation]`` and ``[temperature]`` (the
temperature coefficients: :func:`magcilia.io.temperature_table.load_temperature`) are left to
their readers:
:func:`load_setup` reads the single setup of such a file.

Every quantity needs its unit; a missing table takes the paper's defaults (``[model]``: a
converged layout). Unknown keys and values
without units are errors that name the key.

Files come from people and other programs, so reading one is bounded: at most
:data:`MAX_SETUP_BYTES` bytes, tables and arrays nested at most :data:`MAX_NESTING` deep, a
profile of at most :data:`~magcilia.device.cilium.MAX_PROFILE_POINTS` points, and every number
within its registry limits (:mod:`magcilia.device.parameters`). Anything else is a one-line
:class:`~magcilia.MagciliaError` naming the file and the key, with the file's text escaped
(:func:`magcilia._validate.printable`) and long values cut short.
"""

from __future__ import annotations

import os
import tomllib
from collections.abc import Mapping
from pathlib import Path
from typing import Any

import tomli_w

from magcilia import _validate as v
from magcilia._atomic import write_text
from magcilia.device.cilium import MAX_PROFILE_POINTS, Cilium
from magcilia.device.parameters import PARAMETERS, Parameter
from magcilia.device.setup import PAPER_OPTIMIZED, Setup
from magcilia.io.sniff import recording_kind, swapped_recording
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
#: the keys of a dipole layout (left out of a converged setup's file: the rule chooses them)
_LAYOUT_KEYS = ("n_loops", "dipoles_per_loop", "ring")

#: largest setup file read, bytes (a setup is about 1 kB; a measured profile of
#: MAX_PROFILE_POINTS points about 0.5 MB)
MAX_SETUP_BYTES = 1_000_000
#: deepest nesting of tables and arrays in a setup file (a setup needs 2: tables of values and the
#: profile's lists); deeper documents are refused before anything walks them recursively
MAX_NESTING = 32


def _shown(value: object, limit: int = 60) -> str:
    """A value from a file for a message: its repr with control characters escaped, cut to
    ``limit`` characters."""
    try:
        text = repr(value)
    except (RecursionError, ValueError):  # pathological nesting or an enormous integer
        text = f"a {type(value).__name__}"
    text = v.printable(text)
    return text if len(text) <= limit else f"{text[:limit]}… ({len(text)} characters)"


def _key(text: object, limit: int = 40) -> str:
    """A key or table name from a file for a message: escaped, cut to ``limit`` characters."""
    out = v.printable(str(text))
    return out if len(out) <= limit else f"{out[:limit]}…"


def _fail(name: str, value: object, allowed: str) -> v.MagciliaError:
    """The package's error template for a value read from a file (escaped, cut short)."""
    return v.MagciliaError(f"{v.printable(name)} must be {allowed}; got {_shown(value)}")


def _depth(doc: object) -> int:
    """Nesting depth of a parsed TOML document (tables and arrays), without recursion."""
    deepest, stack = 0, [(doc, 0)]
    while stack:
        node, depth = stack.pop()
        if isinstance(node, dict | list):
            deepest = max(deepest, depth + 1)
            if deepest > MAX_NESTING:
                return deepest
            stack.extend((child, depth + 1)
                         for child in (node.values() if isinstance(node, dict) else node))
    return deepest


def setup_from_dict(doc: dict[str, Any], source: str = "setup") -> Setup:
    """Build a Setup from a parsed setup document (tables of unit-bearing strings)."""
    source = v.printable(source)
    if not isinstance(doc, dict):
        raise _fail(source, doc, "a document of [tables] of key = value lines")
    if _depth(doc) > MAX_NESTING:
        raise v.MagciliaError(f"{source}: tables or arrays nested more than {MAX_NESTING} deep "
                              "(MAX_NESTING); a setup file needs 2 levels: [table] and key = value")
    kwargs: dict[str, Any] = {}
    for table, entries in doc.items():
        if table == PRIORS_TABLE:
            priors_from_dict(entries, source)  # checked here too: a bad prior fails on load
            continue
        if table in OTHER_TABLES:  # read by load_array / the actuation reader, not here
            continue
        if table not in SCHEMA:
            raise _fail(f"{source}: table [{_key(table)}]", table,
                        "one of " + ", ".join(f"[{t}]" for t in SCHEMA))
        if not isinstance(entries, dict):
            raise _fail(f"{source}: [{table}]", entries, "a table of key = value lines")
        for key, value in entries.items():
            name = f"{source}: {table}.{key}"
            if key not in SCHEMA[table]:
                raise _fail(f"{source}: {table}.{_key(key)}", key,
                            "one of " + ", ".join(SCHEMA[table]))
            kwargs.update(_entry(name, key, SCHEMA[table][key], value))
    defaults = _unpack_position(PAPER_OPTIMIZED)
    if "layout" not in kwargs:  # no word on it: the keys given are this exact layout
        kwargs["layout"] = "given" if any(k in kwargs for k in _LAYOUT_KEYS) else "converged"
    if kwargs["layout"] == "converged":  # the rule chooses n, k and ring
        defaults = {k: val for k, val in defaults.items() if k not in _LAYOUT_KEYS}
    try:
        overrides = {**defaults, **kwargs}
        if any(key in kwargs for key in _PROFILE_KEYS):
            overrides = _with_profile(overrides, kwargs)
        return Setup.paper(**overrides)
    except v.MagciliaError as exc:
        raise v.MagciliaError(f"{source}: {exc}") from None


def _entry(name: str, key: str, p: Parameter | None, value: object) -> dict[str, Any]:
    """One checked ``key = value`` line of a known key, as keyword(s) for the Setup."""
    if key == "preset":
        if value not in _PRESETS:
            raise _fail(name, value, "one of " + ", ".join(repr(x) for x in _PRESETS))
        return {}
    if key in _PROFILE_KEYS:
        if not isinstance(value, list) or not value:
            raise _fail(name, value, 'a list of lengths, e.g. ["0 mm", "1.5 mm", "3 mm"]')
        if len(value) > MAX_PROFILE_POINTS:
            raise _fail(name, f"a list of {len(value)} lengths",
                        f"at most {MAX_PROFILE_POINTS} points (MAX_PROFILE_POINTS); resample "
                        "the measured shape")
        return {key: [parse_quantity(x, "length", f"{name}[{i}]") for i, x in enumerate(value)]}
    assert p is not None  # every other key of SCHEMA is a registry parameter
    if p.dimension is not None:
        return {p.name: p.check(parse_quantity(value, p.dimension, name), name)}
    if p.domain == "choice" and not isinstance(value, str):
        raise _fail(name, value, "one of " + ", ".join(repr(c) for c in p.choices))
    if p.domain in ("integer", "choice") or (isinstance(value, int | float)
                                             and not isinstance(value, bool)):
        try:
            return {p.name: p.check(value, name)}
        except v.MagciliaError as exc:  # the registry's message, with the value cut short
            raise v.MagciliaError(_cut(str(exc))) from None
    raise _fail(name, value, f"a number, e.g. {name.rsplit('.', 1)[-1]} = 1.0")


def _cut(message: str, limit: int = 400) -> str:
    """A message with escaped control characters, cut to ``limit`` characters."""
    message = v.printable(message)
    return message if len(message) <= limit else f"{message[:limit]}…"


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
                                 youngs_modulus=given.get("youngs_modulus"),
                                 youngs_modulus_sigma=given.get("youngs_modulus_sigma"))
    dropped = (*_PROFILE_SHAPED, "youngs_modulus", "youngs_modulus_sigma", *_PROFILE_KEYS)
    return {**{k: val for k, val in overrides.items() if k not in dropped}, "cilium": cilium}


def _unpack_position(d: dict[str, Any]) -> dict[str, Any]:
    out = {k: val for k, val in d.items() if k != "position"}
    out["x"], out["y"], out["z"] = d["position"]
    return out


def load_setup(path: str | os.PathLike[str]) -> Setup:
    """Read a setup TOML file (see the module docstring for the format and its limits)."""
    return setup_from_dict(_read_document(path), source=str(path))


#: tables of a setup file that other readers take (arrays: :mod:`magcilia.io.array_file`;
#: actuation) and :func:`setup_from_dict` leaves alone
OTHER_TABLES = ("cilia", "sensors", "array", "actuation", "temperature")

#: the setup file's optional table of priors, and the names it may hold
PRIORS_TABLE = "priors"
PRIOR_NAMES = ("height", "base_radius", "x", "y", "z")


def priors_from_dict(entries: object, source: str = "setup") -> dict[str, tuple[float, float]]:
    """A ``[priors]`` table (``name = "VALUE +- SIGMA"`` with length units; ``±`` also) as SI
    (value, sigma) pairs, m.

    Examples
    --------
    >>> priors_from_dict({"height": "3.0 mm +- 0.2 mm"})
    {'height': (0.003, 0.0002)}
    """
    source = v.printable(source)
    if not isinstance(entries, dict):
        raise _fail(f"{source}: [priors]", entries, 'a table of name = "VALUE +- SIGMA" lines')
    out: dict[str, tuple[float, float]] = {}
    for key, value in entries.items():
        if key not in PRIOR_NAMES:
            raise _fail(f"{source}: priors.{_key(key)}", key, "one of " + ", ".join(PRIOR_NAMES))
        text = value.replace("±", "+-") if isinstance(value, str) else None
        parts = text.split("+-") if text is not None else []
        if len(parts) != 2:
            raise _fail(f"{source}: priors.{key}", value,
                        'a value and its sigma with units, e.g. "3.0 mm +- 0.2 mm"')
        mu = parse_quantity(parts[0].strip(), "length", f"{source}: priors.{key}")
        sigma = parse_quantity(parts[1].strip(), "length", f"{source}: priors.{key} sigma")
        if not sigma > 0.0:
            raise _fail(f"{source}: priors.{key}", value, "a positive sigma (a zero-width prior "
                                                           "is a fixed value: use --fix)")
        out[key] = (mu, sigma)
    return out


def load_priors(path: str | os.PathLike[str]) -> dict[str, tuple[float, float]]:
    """The ``[priors]`` table of a setup file as SI (value, sigma) pairs ({} without one)."""
    doc = _read_document(path)
    if not isinstance(doc, dict) or PRIORS_TABLE not in doc:
        return {}
    return priors_from_dict(doc[PRIORS_TABLE], str(path))


def _read_document(path: str | os.PathLike[str]) -> dict[str, Any]:
    """A setup file's TOML document, read within the limits."""
    p = Path(path)
    where = v.printable(str(p))
    if p.is_file() and recording_kind(p) is not None:  # a recording given as the setup
        raise v.MagciliaError(swapped_recording(where))
    with p.open("rb") as f:  # a missing file is an OSError, as for every file magcilia reads
        raw = f.read(MAX_SETUP_BYTES + 1)
    if len(raw) > MAX_SETUP_BYTES:
        raise v.MagciliaError(f"setup file {where} is larger than {MAX_SETUP_BYTES} bytes "
                              "(MAX_SETUP_BYTES); a setup file is a few kB of TOML")
    try:
        text = raw.decode("utf-8")
    except UnicodeDecodeError as exc:
        raise v.MagciliaError(f"setup file {where} is not UTF-8 text (byte {exc.start}); give a "
                              "TOML text file") from None
    try:
        doc = tomllib.loads(text)
    except tomllib.TOMLDecodeError as exc:
        raise v.MagciliaError(f"setup file {where} is not valid TOML ({_cut(str(exc), 200)}); "
                              "fix the syntax") from None
    except RecursionError:  # tomllib recurses per level: a few hundred levels exhaust the stack
        raise v.MagciliaError(f"setup file {where}: tables or arrays nested too deep for the "
                              f"TOML reader (at most {MAX_NESTING} levels, MAX_NESTING)") from None
    except ValueError as exc:  # e.g. an integer of more than 4300 digits
        raise v.MagciliaError(f"setup file {where} is not valid TOML ({_cut(str(exc), 200)}); "
                              "fix the value") from None
    return doc


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
            if value is None or (c.profile is not None and p.name in _PROFILE_SHAPED) or (
                    setup.layout == "converged" and p.name in _LAYOUT_KEYS):
                continue
            out[key] = format_quantity(value, p.file_unit, 12) if p.dimension else value
        doc[table] = out
    return doc


def save_setup(setup: Setup, path: str | os.PathLike[str], *,
               tables: Mapping[str, Mapping[str, Any]] | None = None) -> None:
    """Write ``setup`` as a setup TOML file (atomically), with ``tables``: tables other readers
    take (:data:`OTHER_TABLES`, e.g. ``{"temperature": {...}}``), written as given.

    The document is read back in memory first: a setup that :func:`load_setup` would refuse
    (a sensor name other than a preset; a placement whose rounding to 12 digits moves the element
    into the cilium) is an error, and nothing is written."""
    if not isinstance(setup, Setup):
        raise v.fail("setup", type(setup).__name__, "a magcilia Setup")
    doc = setup_to_dict(setup)
    for name, table in (tables or {}).items():
        if name not in OTHER_TABLES:
            raise v.fail("save_setup table", name, "one of " + ", ".join(OTHER_TABLES))
        doc[name] = dict(table)
    text = ("# magcilia setup file: every quantity carries its unit (SI prefixes allowed)\n"
            + tomli_w.dumps(doc))
    try:
        setup_from_dict(tomllib.loads(text), source="setup")
    except v.MagciliaError as exc:
        raise v.MagciliaError(f"{v.printable(str(path))}: not written, because the file could "
                              f"not be read back: {exc}") from None
    if len(text.encode("utf-8")) > MAX_SETUP_BYTES:
        raise v.MagciliaError(f"{v.printable(str(path))}: not written, because the file would be "
                              f"larger than {MAX_SETUP_BYTES} bytes (MAX_SETUP_BYTES)")
    write_text(path, text)
