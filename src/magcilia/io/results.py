"""Saved results: JSON documents written by the CLI (``result.json``, ``sensitivity.json``, …),
read back with one-line errors. The result classes rebuild themselves with ``from_dict``."""

from __future__ import annotations

import json
from pathlib import Path
from typing import Any

from magcilia._errors import MagciliaError


def read_json(path: str | Path, *, default_name: str, hint: str) -> tuple[Path, dict[str, Any]]:
    """The file read and its JSON object: ``path``, or ``path / default_name`` when ``path`` is
    a folder.

    Parameters
    ----------
    path : str or Path
        The file, or the ``--out`` folder that holds it.
    default_name : str
        The file's name inside a folder, e.g. ``"result.json"``.
    hint : str
        What to give instead, appended to the error messages.
    """
    p = Path(path)
    if p.is_dir():
        p = p / default_name
    try:
        doc = json.loads(p.read_text(encoding="utf-8"))
    except FileNotFoundError:
        raise MagciliaError(f"{p}: no such file; {hint}") from None
    except (UnicodeDecodeError, ValueError) as exc:
        raise MagciliaError(f"{p}: not a JSON document ({type(exc).__name__}: {exc}); "
                            f"{hint}") from None
    if not isinstance(doc, dict):
        raise MagciliaError(f"{p}: not a JSON object; {hint}")
    return p, doc
