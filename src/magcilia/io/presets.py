"""The built-in setups by name (``mc.presets``): what ``--setup NAME`` gives on the command line.

========================  =======================================================================
name                      what :func:`load` returns
========================  =======================================================================
``paper``                 :class:`~magcilia.Setup`: the paper's sensor, Table I optimized values
                          (:meth:`Setup.paper <magcilia.Setup.paper>`)
``paper-initial``         :class:`~magcilia.Setup`: Table I's initial values
                          (:meth:`Setup.paper_initial <magcilia.Setup.paper_initial>`)
``force-sensor``          :class:`~magcilia.Setup`: the paper's cilium with a 0.05 mm tip radius
                          and a converged dipole layout (``examples/force-sensor.toml``): a tip
                          force and a flow have a finite compliance
``array``                 :class:`~magcilia.CiliaArray`: the 4 × 4 array over 16 MMC5983MA
                          sensors of ``examples/array.toml`` (a copy ships with the package)
========================  =======================================================================

>>> import magcilia as mc
>>> mc.presets.NAMES
('paper', 'paper-initial', 'force-sensor', 'array')
>>> len(mc.presets.load("array").cilia)
16
>>> try:
...     mc.presets.load("forse-sensor")
... except mc.MagciliaError as exc:
...     print(exc)  # doctest: +NORMALIZE_WHITESPACE
unknown preset 'forse-sensor'; did you mean 'force-sensor'?
(presets: paper, paper-initial, force-sensor, array)
"""

from __future__ import annotations

import difflib
from collections.abc import Callable
from importlib import resources
from pathlib import Path

from magcilia._errors import MagciliaError
from magcilia.device.array import CiliaArray
from magcilia.device.setup import Setup
from magcilia.io.array_file import load_array

__all__ = ["NAMES", "file", "load", "setup", "unknown_preset_message"]


def _force_sensor() -> Setup:
    return Setup.paper(tip_radius=5e-5, layout="converged")


#: the presets read from a file that ships with magcilia (a copy of ``examples/NAME.toml``)
_FILES = {"array": "array.toml"}


def file(name: str) -> Path | None:
    """The bundled file of a file-backed preset (``array``: the copy of ``examples/array.toml``),
    None for the presets built in code (``paper``, ``paper-initial``, ``force-sensor``)."""
    if name not in NAMES:
        raise MagciliaError(unknown_preset_message(str(name)))
    stem = _FILES.get(name)
    return None if stem is None else _bundled(stem)


def _bundled(stem: str) -> Path:
    return Path(str(resources.files("magcilia") / "data" / "presets" / stem))


def _array() -> CiliaArray:
    return load_array(_bundled(_FILES["array"]))


_BUILDERS: dict[str, Callable[[], Setup | CiliaArray]] = {
    "paper": Setup.paper,
    "paper-initial": Setup.paper_initial,
    "force-sensor": _force_sensor,
    "array": _array,
}

#: the preset names, in the order the help and the errors list them
NAMES: tuple[str, ...] = tuple(_BUILDERS)


def unknown_preset_message(name: str) -> str:
    """The one-line error of a name that is not a preset: the closest name (difflib) and the
    list, e.g. ``unknown preset 'forse-sensor'; did you mean 'force-sensor'? (presets: paper,
    paper-initial, force-sensor, array)``."""
    close = difflib.get_close_matches(name, NAMES, n=1)
    hint = f"; did you mean {close[0]!r}?" if close else ""
    return f"unknown preset {name!r}{hint} (presets: {', '.join(NAMES)})"


def load(name: str) -> Setup | CiliaArray:
    """The preset ``name``: a new :class:`~magcilia.Setup` (``paper``, ``paper-initial``,
    ``force-sensor``) or :class:`~magcilia.CiliaArray` (``array``), SI; see the module's table.

    Raises
    ------
    MagciliaError
        ``name`` is not a preset: one line with the closest name and the list.
    """
    builder = _BUILDERS.get(name) if isinstance(name, str) else None
    if builder is None:
        raise MagciliaError(unknown_preset_message(str(name)))
    return builder()


def setup(name: str) -> Setup:
    """A single-cilium preset (``paper``, ``paper-initial``, ``force-sensor``) as a
    :class:`~magcilia.Setup`; ``array`` and unknown names raise a one-line
    :class:`MagciliaError`."""
    value = load(name)
    if not isinstance(value, Setup):
        raise MagciliaError(f"preset {name!r} is a cilia array, not one cilium's setup; read it "
                            f"with magcilia.presets.load({name!r}) or `magcilia array --setup "
                            f"{name}`")
    return value
