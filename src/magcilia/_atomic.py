"""Write output files and folders atomically.

A single file is written to a temporary file beside the target, then renamed (:func:`atomic_path`,
:func:`write_text`, :func:`write_files` for several files of one command). An output folder is
filled under a hidden staging name beside the target and published with one rename
(:func:`staged_directory`): a crash or an error at any moment never leaves a half-written file
under the target's name, nor a half-filled or mixed output folder. Also the one JSON encoding of
results (NumPy values as plain numbers, NaN/inf as null) and figure saving.
"""

from __future__ import annotations

import contextlib
import ctypes
import errno
import io
import json
import math
import os
import re
import secrets
import shutil
import sys
import tempfile
import time
from collections.abc import Collection, Iterator, Mapping
from pathlib import Path
from typing import IO, Any

import numpy as np

from magcilia._errors import MagciliaError

if sys.platform != "win32":
    import fcntl


def _umask() -> int:
    mask = os.umask(0)
    os.umask(mask)
    return mask


def _make_folders(folder: Path, what: str) -> list[Path]:
    """Create ``folder`` and its missing parents; returns those created, deepest first. A
    one-line :class:`MagciliaError` naming ``what`` when that is not possible."""
    missing = []
    for p in (folder, *folder.parents):
        if os.path.lexists(p):
            if not p.is_dir():
                raise MagciliaError(f"cannot write {what}: {p} is a file, not a folder")
            break
        missing.append(p)
    try:
        folder.mkdir(parents=True, exist_ok=True)
    except OSError as exc:
        raise MagciliaError(f"cannot write {what}: cannot create the folder {folder}: "
                            f"{exc.strerror or exc}") from None
    return missing


@contextlib.contextmanager
def atomic_path(path: str | os.PathLike[str]) -> Iterator[Path]:
    """Yield a temporary path beside ``path``; on success it is renamed to ``path``.

    For writers that take a file name (``savefig``, ``np.savez``). On any exception the temporary
    file is removed and ``path`` is left as it was.
    """
    target = Path(path)
    _make_folders(target.parent, os.fspath(path))
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


def write_files(contents: Mapping[str, str | bytes] | Mapping[Path, str | bytes]) -> None:
    """Write several files together: text (UTF-8) or bytes, by path.

    Every file is first written in full to a temporary file beside its target; only when all of
    them are written are they renamed into place, so a failure while writing (a full disk, an
    unwritable folder) leaves every target as it was.
    """
    with contextlib.ExitStack() as stack:
        for path, data in contents.items():
            tmp = stack.enter_context(atomic_path(path))
            if isinstance(data, bytes):
                tmp.write_bytes(data)
            else:
                with tmp.open("w", encoding="utf-8", newline="\n") as fh:
                    fh.write(data)


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


def figure_format(path: str | os.PathLike[str], option: str = "--plot") -> str:
    """The matplotlib format of a figure file from its suffix (PNG without one); a
    :class:`MagciliaError` naming ``option`` for a suffix matplotlib cannot write."""
    from matplotlib.backend_bases import FigureCanvasBase

    suffix = Path(path).suffix.lstrip(".").lower() or "png"
    formats = FigureCanvasBase.get_supported_filetypes()
    if suffix not in formats:
        raise MagciliaError(f"{option} must be a figure file ({', '.join(sorted(formats))}); "
                            f"got {os.fspath(path)}")
    return suffix


def figure_bytes(fig: Any, path: str | os.PathLike[str], dpi: int = 150,
                 option: str = "--plot") -> bytes:
    """A matplotlib figure rendered in memory, in the format of ``path``'s suffix."""
    buf = io.BytesIO()
    fig.savefig(buf, dpi=dpi, format=figure_format(path, option))
    return buf.getvalue()


def save_figure(fig: Any, path: str | os.PathLike[str], dpi: int = 150) -> None:
    """Atomically save a matplotlib figure (format from the suffix, PNG without one)."""
    suffix = Path(path).suffix.lstrip(".") or "png"
    with atomic_path(path) as tmp:
        fig.savefig(tmp, dpi=dpi, format=suffix)


# --- output folders ------------------------------------------------------------------------------
#
# ``staged_directory(out)`` fills ``.OUT.magcilia-staging-PID-RANDOM`` beside ``out`` and publishes
# it with one rename. The running process holds an advisory lock (flock) on its staging folder, so
# the next run can tell a folder left by a killed run (unlocked: the kernel drops the lock of a
# dead process, SIGKILL included) from a live run's (locked), and removes only the former. What a
# crash (SIGKILL, power-off of the process) at each step leaves:
#
# 1. while the work runs and fills the staging folder: ``out`` untouched (absent, or the old
#    folder); the staging folder is removed by the next run.
# 2. publication of a new ``out``: one ``rename``; ``out`` is absent or complete.
# 3. replacing an existing ``out`` (``force``) on Linux: one ``renameat2(RENAME_EXCHANGE)`` swaps
#    the new folder in and the old one out to the staging name, in one step: ``out`` is the old
#    complete folder or the new complete folder, never a mix; the old one, left under the staging
#    name if the crash comes before its removal, is removed by the next run.
# 4. replacing elsewhere (no RENAME_EXCHANGE: other systems, some file systems): the old folder is
#    renamed aside to ``.OUT.magcilia-trash-PID-RANDOM`` (locked as well), then the new one in.
#    A crash between the two renames leaves ``out`` absent (the old folder under the trash name,
#    the new under the staging name; the next run removes both); never a mixed folder.

_STAGING = ".magcilia-staging-"
_TRASH = ".magcilia-trash-"
_LEFTOVER = re.compile(r"^\..+\.magcilia-(?:staging|trash)-(\d+)-[0-9a-f]+$")
#: a leftover folder whose lock is free but whose process id is alive (reused, or a run between
#: creating its folder and locking it) is removed only once it is this old (seconds)
STALE_AFTER = 60.0
#: without advisory locks (Windows) leftovers are removed only once they are this old (seconds)
STALE_AFTER_UNLOCKED = 86400.0

_AT_FDCWD = -100
_RENAME_EXCHANGE = 2


def _lock(path: Path) -> int | None:
    """An open descriptor of the folder ``path`` holding an exclusive advisory lock, or None when
    the lock is held by someone else (or locks are not available here)."""
    if sys.platform == "win32":
        return None
    try:
        fd = os.open(path, os.O_RDONLY | os.O_DIRECTORY)
    except OSError:
        return None
    try:
        fcntl.flock(fd, fcntl.LOCK_EX | fcntl.LOCK_NB)
    except OSError:
        os.close(fd)
        return None
    return fd


def _close(fd: int | None) -> None:
    if fd is not None:
        os.close(fd)


def _pid_alive(pid: int) -> bool:
    if sys.platform == "win32":
        return True  # os.kill(pid, 0) would send CTRL_C_EVENT there
    try:
        os.kill(pid, 0)
    except ProcessLookupError:
        return False
    except OSError:
        return True  # exists, owned by someone else
    return True


def remove_stale_staging(folder: str | os.PathLike[str]) -> list[Path]:
    """Remove the staging and trash folders that killed runs left in ``folder``; returns them.

    A folder is left over when no live process holds its lock and, in addition, its process id
    is not alive or it is older than :data:`STALE_AFTER` seconds. A concurrent run's folder is
    locked and never touched.
    """
    removed: list[Path] = []
    try:
        entries = list(os.scandir(folder))
    except OSError:
        return removed
    for entry in entries:
        match = _LEFTOVER.match(entry.name)
        if match is None or not entry.is_dir(follow_symlinks=False):
            continue
        path = Path(entry.path)
        try:
            age = time.time() - entry.stat(follow_symlinks=False).st_mtime
        except OSError:
            continue
        if sys.platform == "win32":
            if age > STALE_AFTER_UNLOCKED:
                shutil.rmtree(path, ignore_errors=True)
                removed.append(path)
            continue
        fd = _lock(path)
        if fd is None:
            continue  # a live run holds it
        try:
            if _pid_alive(int(match.group(1))) and age <= STALE_AFTER:
                continue
            shutil.rmtree(path, ignore_errors=True)
            removed.append(path)
        finally:
            os.close(fd)
    return removed


def _exchange(a: Path, b: Path) -> bool:
    """Swap the paths ``a`` and ``b`` in one step (Linux ``renameat2(RENAME_EXCHANGE)``); False
    where that is not available (other systems, old kernels, file systems without it)."""
    if not sys.platform.startswith("linux"):
        return False
    try:
        renameat2 = ctypes.CDLL(None, use_errno=True).renameat2
    except (OSError, AttributeError):
        return False
    renameat2.argtypes = [ctypes.c_int, ctypes.c_char_p, ctypes.c_int, ctypes.c_char_p,
                          ctypes.c_uint]
    renameat2.restype = ctypes.c_int
    if renameat2(_AT_FDCWD, os.fsencode(a), _AT_FDCWD, os.fsencode(b), _RENAME_EXCHANGE) == 0:
        return True
    err = ctypes.get_errno()
    if err in (errno.ENOSYS, errno.EINVAL, errno.EOPNOTSUPP, errno.ENOTSUP):
        return False
    raise OSError(err, os.strerror(err), os.fspath(b))


def _exists_message(out: Path) -> str:
    return f"{out} exists; pass --force to replace it, or choose another --out"


def _check_target(out: Path, target: Path, force: bool, names: Collection[str] | None) -> None:
    """Raise if ``target`` may not become (or be replaced by) a new output folder."""
    cwd = Path.cwd().resolve()
    if not target.name or target == cwd or target in cwd.parents:
        raise MagciliaError(f"--out must be a new folder, not the current folder or one above it; "
                            f"got {out}")
    if not os.path.lexists(target):
        return
    if not target.is_dir():
        raise MagciliaError(f"{out} is a file, not a folder; choose another --out")
    entries = list(os.scandir(target))
    if not entries:
        return  # an empty folder is replaced without --force
    if not force:
        raise MagciliaError(_exists_message(out))
    if names is None:
        return
    for entry in entries:
        if entry.name not in names or not entry.is_file(follow_symlinks=False):
            raise MagciliaError(
                f"{out} holds {entry.name!r}, which this command does not write; --force replaces "
                "only an earlier output folder of the command: remove it yourself, or choose "
                "another --out")


def _publish(staging: Path, target: Path, out: Path, force: bool,
             names: Collection[str] | None) -> None:
    """Move the complete ``staging`` folder to ``target`` (see the notes above)."""
    try:
        staging.rename(target)  # target absent, or an empty folder: one atomic step
    except OSError as exc:
        if exc.errno == errno.ENOTDIR:
            raise MagciliaError(f"{out} is a file, not a folder; choose another --out") from None
        if exc.errno not in (errno.ENOTEMPTY, errno.EEXIST):
            raise
        if not force:
            raise MagciliaError(_exists_message(out)) from None
    else:
        return
    _check_target(out, target, force, names)  # its content may have changed during the work
    if _exchange(staging, target):
        return  # the old folder is now under the staging name: the caller removes it
    trash = target.with_name(f".{target.name}{_TRASH}{os.getpid()}-{secrets.token_hex(4)}")
    fd = _lock(target)  # the lock follows the folder to its trash name
    try:
        target.rename(trash)
        try:
            staging.rename(target)
        except BaseException:
            with contextlib.suppress(OSError):
                trash.rename(target)
            raise
        shutil.rmtree(trash, ignore_errors=True)
    finally:
        _close(fd)


@contextlib.contextmanager
def staged_directory(out: str | os.PathLike[str], *, force: bool = False,
                     names: Collection[str] | None = None) -> Iterator[Path]:
    """A staging folder beside ``out``, published as ``out`` with one rename when the block
    succeeds; on any error it is removed and ``out`` is left as it was.

    Enter it before the work starts: it checks at once that ``out`` may be written (a one-line
    :class:`MagciliaError` otherwise) and removes staging folders left by killed runs.

    Parameters
    ----------
    out : path
        The output folder. It must not exist, or be an empty folder, unless ``force`` is given.
    force : bool
        Replace an existing ``out`` (atomically where the system allows, see the module notes).
    names : collection of str, optional
        The file names the caller may write: with ``force`` an existing ``out`` is replaced only
        if it holds nothing but such files (an earlier output), never another folder by mistake.
    """
    out = Path(out)
    target = out.resolve()  # a symbolic link names the folder it points to
    _check_target(out, target, force, names)
    created = _make_folders(target.parent, f"--out {out}")
    remove_stale_staging(target.parent)
    staging = target.with_name(f".{target.name}{_STAGING}{os.getpid()}-{secrets.token_hex(4)}")
    try:
        staging.mkdir()  # permissions from the umask, as a plain mkdir
    except OSError as exc:
        for p in created:
            with contextlib.suppress(OSError):
                p.rmdir()
        raise MagciliaError(f"cannot write --out {out}: {target.parent}: "
                            f"{exc.strerror or exc}") from None
    fd = _lock(staging)
    published = False
    try:
        yield staging
        _publish(staging, target, out, force, names)
        published = True
    finally:
        shutil.rmtree(staging, ignore_errors=True)  # after an exchange: the old folder
        _close(fd)
        if not published:
            for p in created:
                with contextlib.suppress(OSError):
                    p.rmdir()
