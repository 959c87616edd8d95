"""Write output files atomically: to a temporary file beside the target, then rename.

A crash or an error half-way never leaves a half-written file under the target's name, nor a
half-filled output folder (:func:`staged_directory`). Also the
one JSON encoding of results (NumPy values as plain numbers, NaN/inf as null) and figure saving.
"""

from __future__ import annotations

import contextlib
import json
import math
import os
import shutil
import tempfile
from collections.abc import Iterator
from pathlib import Path
from typing import IO, Any

import numpy as np

from magcilia._errors import MagciliaError


def _umask() -> int:
    mask = os.umask(0)
    os.umask(mask)
    return mask


@contextlib.contextmanager
def atomic_path(path: str | os.PathLike[str]) -> Iterator[Path]:
    """Yield a temporary path beside ``path``; on success it is renamed to ``path``.

    For writers that take a file name (``savefig``, ``np.savez``). On any exception the temporary
    file is removed and ``path`` is left as it was.
    """
    target = Path(path)
    target.parent.mkdir(parents=True, exist_ok=True)
    fd, tmp = tempfile.mkstemp(prefix=f".{target.stem}-", suffix=target.suffix, dir=target.parent)
    os.close(fd)
    tmp_path = Path(tmp)
    tmp_path.chmod(0o666 & ~_umask())  # mkstemp makes 0600 files; outputs follow the umask
    try:
        yield tmp_path
        tmp_path.replace(target)
    except BaseException:
        tmp_path.unlink(missing_ok=True)
        raise


@contextlib.contextmanager
def atomic_open(path: str | os.PathLike[str], mode: str = "w", **kwargs: Any) -> Iterator[IO[Any]]:
    """Open a temporary file for writing; it replaces ``path`` only when the block succeeds."""
    with atomic_path(path) as tmp, tmp.open(mode, **kwargs) as fh:
        yield fh


def write_text(path: str | os.PathLike[str], text: str) -> None:
    """Atomically write ``text`` (UTF-8) to ``path``."""
    with atomic_open(path, "w", encoding="utf-8", newline="\n") as fh:
        fh.write(text)


def jsonable(obj: Any) -> Any:
    """``obj`` with NumPy arrays and scalars as plain lists and numbers, NaN/inf as None (JSON
    null) and dict keys as strings, recursively."""
    if isinstance(obj, dict):
        return {str(k): jsonable(v) for k, v in obj.items()}
    if isinstance(obj, list | tuple):
        return [jsonable(v) for v in obj]
    if isinstance(obj, np.ndarray):
        return jsonable(obj.tolist())
    if isinstance(obj, np.generic):
        return jsonable(obj.item())
    if isinstance(obj, float) and not math.isfinite(obj):
        return None
    return obj


def json_text(data: Any) -> str:
    """Indented JSON of ``data`` (see :func:`jsonable`), ending in a newline."""
    return json.dumps(jsonable(data), indent=2, allow_nan=False) + "\n"


def write_json(path: str | os.PathLike[str], data: Any) -> None:
    """Atomically write ``data`` as JSON (NaN becomes null)."""
    write_text(path, json_text(data))


def save_figure(fig: Any, path: str | os.PathLike[str], dpi: int = 150) -> None:
    """Atomically save a matplotlib figure (format from the suffix, PNG without one)."""
    suffix = Path(path).suffix.lstrip(".") or "png"
    with atomic_path(path) as tmp:
        fig.savefig(tmp, dpi=dpi, format=suffix)


@contextlib.contextmanager
def staged_directory(out: Path) -> Iterator[Path]:
    """A temporary folder beside ``out``; its files move into ``out`` only when the block
    succeeds (a failure leaves ``out`` as it was)."""
    out.parent.mkdir(parents=True, exist_ok=True)
    tmp = Path(tempfile.mkdtemp(prefix=f".{out.name}-", dir=out.parent))
    try:
        yield tmp
        if out.exists() and not out.is_dir():
            raise MagciliaError(f"{out}: a file of that name exists; give a folder to write into")
        out.mkdir(exist_ok=True)
        for item in tmp.iterdir():
            item.replace(out / item.name)
    finally:
        shutil.rmtree(tmp, ignore_errors=True)
