"""Converged layouts remembered across processes, so that loading a setup file starts at once.

A setup without a layout (``layout = "converged"``) has it chosen by
:func:`magcilia.model.convergence.converged_layout`, which compares candidate layouts with the
exact body's field (magpylib: about 0.5 s to import, and as long again for the first reference in
a fresh process). Every command that loads such a file paid this at start-up for a result of three
numbers. They are kept here, one small JSON file per question, in the user's cache folder:

- ``$MAGCILIA_CACHE_DIR`` if set, else ``$XDG_CACHE_HOME/magcilia``, else ``~/.cache/magcilia``;
  ``MAGCILIA_CACHE_DIR=""`` (empty) turns the cache off.
- The key is a SHA-256 of everything the answer depends on: the geometry and placement, the probe
  (points, tilts, slices of the reference), the rule's arguments, and the stamps (size, mtime) of
  the modules that compute it — an edited model recomputes, as numba's caches do.
- A file that cannot be read, parsed or written is ignored (recomputed; a read-only home works);
  writes are atomic (:func:`magcilia._atomic.write_text`), so concurrent processes never see half
  a file.
"""

from __future__ import annotations

import hashlib
import json
import os
from pathlib import Path
from typing import Any

#: the modules whose code decides a converged layout (their stamps are part of the key)
_MODULES = ("convergence", "exact", "pose", "kernels", "body", "compiled")


def folder() -> Path | None:
    """The cache folder (not created here), or None when the cache is off."""
    given = os.environ.get("MAGCILIA_CACHE_DIR")
    if given is not None:
        return Path(given).expanduser() if given else None
    base = os.environ.get("XDG_CACHE_HOME") or str(Path("~/.cache").expanduser())
    return Path(base) / "magcilia"


def _stamps() -> list[tuple[str, int, int]]:
    here = Path(__file__).resolve().parent
    out = []
    for name in _MODULES:
        try:
            st = (here / f"{name}.py").stat()
        except OSError:
            continue
        out.append((name, st.st_size, st.st_mtime_ns))
    return out


def key(parts: tuple[object, ...]) -> str:
    """The file name (hex digest) of a question: ``parts`` (floats, ints, strings, bytes) with
    the package version and the deciding modules' stamps."""
    from magcilia._version import __version__

    h = hashlib.sha256()
    for part in (__version__, *_stamps(), *parts):
        h.update(part if isinstance(part, bytes) else repr(part).encode())
        h.update(b"\x00")
    return h.hexdigest()


def load(name: str) -> dict[str, Any] | None:
    """The stored answer of ``name`` (a :func:`key`), or None."""
    where = folder()
    if where is None:
        return None
    try:
        data = json.loads((where / "layouts" / f"{name}.json").read_text(encoding="utf-8"))
    except (OSError, ValueError):
        return None
    return data if isinstance(data, dict) else None


def store(name: str, data: dict[str, Any]) -> None:
    """Remember ``data`` (JSON-able) as the answer of ``name``; silently not, where the folder
    cannot be written."""
    from magcilia._atomic import write_text
    from magcilia._errors import MagciliaError

    where = folder()
    if where is None:
        return
    try:
        (where / "layouts").mkdir(parents=True, exist_ok=True)
        write_text(where / "layouts" / f"{name}.json", json.dumps(data))
    except (OSError, ValueError, MagciliaError):
        pass
