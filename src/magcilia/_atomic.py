"""Write output files and folders atomically, and leave nothing behind.

A file is written to a hidden *partial* file beside the target, then renamed (:func:`partial_file`;
on it :func:`atomic_path`, :func:`write_text`, :func:`write_files`). An output folder is filled
under a hidden *staging* name beside it and published with one rename (:func:`staged_directory`):
a crash at any moment never leaves a half-written file under the target's name, nor a mixed
output folder. Also the one JSON encoding of results (NaN/inf as null) and figure saving.

Temporary names. Every temporary file or folder this module makes is named

    .NAME.magcilia-KIND-PID-HEX[SUFFIX]        (:func:`temporary_name`)

beside what it stands for: NAME the target's name (its stem for a file), KIND ``partial`` (a
file being written), ``staging`` (a folder being filled), ``trash`` (an old folder being
replaced) or ``scratch`` (a private work folder in the system's temporary folder,
:func:`scratch_directory`), PID the process writing it, HEX 8 random hex digits and, for a
partial file, the target's suffix (so that writers that look at it still see ``.csv``). The
process holds an advisory lock (``flock``) on each while it lives; the kernel drops the lock when
the process dies, SIGKILL included. :func:`remove_leftovers` removes those that killed runs left:
no live process holds its lock, and its process id is dead or it is older than
:data:`STALE_AFTER`. Every :func:`partial_file`, :func:`staged_directory` and
:func:`scratch_directory` calls it on its folder first, so the next run that writes there cleans
up after a killed one. Any other writer follows the same convention through a
:class:`PartialFile` (``record --force``'s recording: :class:`PartialFile` itself, after
:func:`remove_leftovers` on its folder, and :meth:`PartialFile.publish` once the new file may
replace the old one).

``--force``. A command replaces only what it wrote itself: :func:`foreign_entry` finds anything
else in an output folder (the command's own file names, its sub-folders of its own names, and
this module's leftovers are its own), :func:`check_own`, :func:`staged_directory` and
:func:`clear_output` refuse a folder that holds it, in one line naming it.
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
from collections.abc import Collection, Iterator, Mapping, Sequence
from pathlib import Path
from typing import IO, Any

import numpy as np

from magcilia._errors import MagciliaError

if sys.platform != "win32":
    import fcntl


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



# --- temporary names, locks and leftovers (see the module notes) --------------------------------

#: what a temporary name stands for: a file being written, a folder being filled, an old folder
#: being replaced, a private work folder (the module notes)
KINDS = ("partial", "staging", "trash", "scratch")
_LEFTOVER = re.compile(rf"^\..+\.magcilia-({'|'.join(KINDS)})-(\d+)-[0-9a-f]+(?:\.[^.]*)?$")
#: a leftover whose lock is free but whose process id is alive (reused, or a run between
#: creating it and locking it) is removed only once it is this old (seconds)
STALE_AFTER = 60.0
#: without advisory locks (Windows) leftovers are removed only once they are this old (seconds)
STALE_AFTER_UNLOCKED = 86400.0


def temporary_name(target: str | os.PathLike[str], kind: str) -> Path:
    """A fresh temporary name beside ``target``: ``.NAME.magcilia-KIND-PID-HEX`` for a folder,
    ``.STEM.magcilia-partial-PID-HEX.SUFFIX`` for a file (``kind`` one of :data:`KINDS`)."""
    path, tag = Path(target), f"magcilia-{kind}-{os.getpid()}-{secrets.token_hex(4)}"
    if kind == "partial":
        return path.with_name(f".{path.stem}.{tag}{path.suffix}")
    return path.with_name(f".{path.name}.{tag}")


def is_temporary(name: str) -> bool:
    """Whether a file or folder name is one of this module's temporary names."""
    return _LEFTOVER.match(name) is not None


def _lock(path: Path, folder: bool = True) -> int | None:
    """An open descriptor of ``path`` (a folder, or a file) holding an exclusive advisory lock,
    or None when the lock is held by someone else (or locks are not available here)."""
    if sys.platform == "win32":
        return None
    flags = os.O_RDONLY | (os.O_DIRECTORY if folder else os.O_NOFOLLOW | os.O_NONBLOCK)
    try:
        fd = os.open(path, flags)
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


def pid_alive(pid: int) -> bool:
    """Whether a process ``pid`` exists (ours or another user's); always True on Windows, where
    ``os.kill(pid, 0)`` would send it CTRL_C_EVENT (callers there rely on locks, ages or a
    process sentinel instead)."""
    if sys.platform == "win32":
        return True
    try:
        os.kill(pid, 0)
    except ProcessLookupError:
        return False
    except OSError:
        return True  # exists, owned by someone else
    return True


def remove_leftovers(folder: str | os.PathLike[str]) -> list[Path]:
    """Remove the temporary files and folders that killed runs left in ``folder``; returns them.

    One is left over when no live process holds its lock and, in addition, its process id is not
    alive or it is older than :data:`STALE_AFTER` seconds (without locks, on Windows: older than
    :data:`STALE_AFTER_UNLOCKED`). A concurrent run's are locked and never touched; names that
    are not this module's (:func:`temporary_name`) are never touched.
    """
    removed: list[Path] = []
    try:
        entries = list(os.scandir(folder))
    except OSError:
        return removed
    for entry in entries:
        match = _LEFTOVER.match(entry.name)
        if match is None:
            continue
        is_folder = match.group(1) != "partial"
        path = Path(entry.path)
        try:
            if not (entry.is_dir(follow_symlinks=False) if is_folder
                    else entry.is_file(follow_symlinks=False)):
                continue
            age = time.time() - entry.stat(follow_symlinks=False).st_mtime
        except OSError:
            continue
        fd = _lock(path, is_folder)  # None on Windows: the age alone decides there
        if fd is None and (sys.platform != "win32" or age <= STALE_AFTER_UNLOCKED):
            continue  # a live run holds it
        try:
            if fd is not None and pid_alive(int(match.group(2))) and age <= STALE_AFTER:
                continue
            if is_folder:
                shutil.rmtree(path, ignore_errors=True)
            else:
                with contextlib.suppress(OSError):
                    path.unlink()
            removed.append(path)
        finally:
            _close(fd)
    return removed


# --- files -----------------------------------------------------------------------------------

class PartialFile:
    """A hidden file beside ``target`` that this process writes and holds locked (made by
    :func:`partial_file`; the module notes give its name).

    Attributes
    ----------
    path : Path
        The file to write (created empty, permissions from the umask).
    target : Path
        What it becomes on :meth:`publish`.
    published : bool
        Whether :meth:`publish` renamed it to ``target``.
    """

    def __init__(self, target: Path) -> None:
        self.target = target
        self.published = False
        while True:  # a fresh name (the umask sets the permissions)
            self.path = temporary_name(target, "partial")
            with contextlib.suppress(FileExistsError):
                fd = os.open(self.path, os.O_WRONLY | os.O_CREAT | os.O_EXCL, 0o666)
                break
        self._fd: int | None = None
        try:
            if sys.platform == "win32":
                raise OSError("an open file cannot be renamed there; no locks anyway")
            fcntl.flock(fd, fcntl.LOCK_EX | fcntl.LOCK_NB)  # new: nobody else holds it
            self._fd = fd
        except OSError:  # no locks here: the process id and the age protect it
            os.close(fd)

    def publish(self) -> None:
        """Rename the file to ``target`` in one step (replacing a file there). A writer that
        keeps it open goes on writing the same file, now under the target's name."""
        self.path.replace(self.target)
        self.published = True

    def discard(self) -> None:
        """Remove the file unless it was published."""
        if not self.published:
            with contextlib.suppress(OSError):
                self.path.unlink()

    def close(self) -> None:
        """Drop the lock (the file, if not published, becomes a leftover for the next run)."""
        _close(self._fd)
        self._fd = None


@contextlib.contextmanager
def partial_file(path: str | os.PathLike[str]) -> Iterator[PartialFile]:
    """A :class:`PartialFile` beside ``path``: write ``.path``, call ``.publish()`` when it may
    replace ``path``; on leaving the block it is removed unless published (on an error too).

    It creates the missing folders of ``path`` (a one-line :class:`MagciliaError` when that is
    not possible) and first removes the leftovers of killed runs there
    (:func:`remove_leftovers`). A kill at any moment leaves ``path`` as it was (or published)
    and the partial file to the next run.
    """
    target = Path(path)
    _make_folders(target.parent, os.fspath(path))
    remove_leftovers(target.parent)
    try:
        part = PartialFile(target)
    except OSError as exc:
        raise MagciliaError(f"cannot write {os.fspath(path)}: {exc.strerror or exc}") from None
    try:
        yield part
    finally:
        part.discard()
        part.close()


@contextlib.contextmanager
def atomic_path(path: str | os.PathLike[str]) -> Iterator[Path]:
    """Yield a temporary path beside ``path``; on success it is renamed to ``path``.

    For writers that take a file name (``savefig``, ``np.savez``). On any exception the temporary
    file is removed and ``path`` is left as it was (:func:`partial_file`).
    """
    with partial_file(path) as part:
        yield part.path
        part.publish()


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


@contextlib.contextmanager
def scratch_directory(name: str = "work") -> Iterator[Path]:
    """A private (0700), locked work folder in the system's temporary folder, removed on
    leaving; one that a killed process left is removed by the next call."""
    parent = Path(tempfile.gettempdir())
    remove_leftovers(parent)
    path = temporary_name(parent / name, "scratch")
    path.mkdir(mode=0o700)
    fd = _lock(path)
    try:
        yield path
    finally:
        shutil.rmtree(path, ignore_errors=True)
        _close(fd)


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
# ``staged_directory(out)`` fills the staging folder ``.OUT.magcilia-staging-PID-HEX`` beside
# ``out`` and publishes it with one rename. What a crash (SIGKILL, power-off of the process) at
# each step leaves:
#
# 1. while the work runs and fills the staging folder: ``out`` untouched (absent, or the old
#    folder); the staging folder is removed by the next run.
# 2. publication of a new ``out``: one ``rename``; ``out`` is absent or complete.
# 3. replacing an existing ``out`` (``force``) on Linux: one ``renameat2(RENAME_EXCHANGE)`` swaps
#    the new folder in and the old one out to the staging name, in one step: ``out`` is the old
#    complete folder or the new complete folder, never a mix; the old one, left under the staging
#    name if the crash comes before its removal, is removed by the next run.
# 4. replacing elsewhere (no RENAME_EXCHANGE: other systems, some file systems): the old folder is
#    renamed aside to ``.OUT.magcilia-trash-PID-HEX`` (locked as well), then the new one in.
#    A crash between the two renames leaves ``out`` absent (the old folder under the trash name,
#    the new under the staging name; the next run removes both); never a mixed folder.

_AT_FDCWD = -100
_RENAME_EXCHANGE = 2


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




def foreign_entry(folder: str | os.PathLike[str], names: Collection[str],
                  folders: Collection[str] = ()) -> str | None:
    """The first entry of ``folder`` (by name; a path relative to it) that a command writing the
    files ``names`` did not write, or None. With ``folders``, a sub-folder is the command's own
    when it holds only files of those names (at least one); this module's temporary names
    (:func:`is_temporary`) are always its own. None for a missing folder."""
    try:
        entries = sorted(os.scandir(folder), key=lambda e: e.name)
    except (FileNotFoundError, NotADirectoryError):
        return None
    for entry in entries:
        if is_temporary(entry.name):
            continue
        if entry.name in names and entry.is_file(follow_symlinks=False):
            continue
        if folders and entry.is_dir(follow_symlinks=False):
            inner = foreign_entry(entry.path, folders)
            if inner is not None:
                return f"{entry.name}/{inner}"
            with os.scandir(entry.path) as it:
                if any(not is_temporary(e.name) for e in it):
                    continue
            return f"{entry.name}/"  # empty: not something the command writes
        return entry.name
    return None


def check_own(folder: str | os.PathLike[str], names: Collection[str], folders: Collection[str] = (),
              *, out: str | os.PathLike[str] | None = None) -> None:
    """Raise a one-line :class:`MagciliaError` naming the first entry of ``folder`` that is not
    the command's own (:func:`foreign_entry`; ``out``, default ``folder``, names the folder)."""
    bad = foreign_entry(folder, names, folders)
    if bad is not None:
        raise MagciliaError(
            f"{os.fspath(out if out is not None else folder)} holds {bad!r}, which this command "
            "does not write; it replaces only its own earlier output (--force too): move that "
            "away, or choose another --out")


def clear_output(folder: str | os.PathLike[str], names: Sequence[str],
                 folders: Collection[str] = (), *, out: str | os.PathLike[str] | None = None,
                 ) -> None:
    """Remove from ``folder`` what a command wrote there, and nothing else (``--force`` of an
    output folder that is filled in place, such as a batch's).

    Its own are the files ``names``, the sub-folders holding only files named ``folders``, and
    the leftovers of killed runs (:func:`foreign_entry`). A folder that holds anything else is
    refused before anything is removed: a one-line :class:`MagciliaError` naming it (as
    ``out``, default ``folder``). The sub-folders go first, then the files, the first of
    ``names`` (a manifest) last, so a crash part way leaves a folder the command still
    recognises. The folder itself stays, empty unless a live run is writing into it.
    """
    folder = Path(folder)
    check_own(folder, names, folders, out=out)
    remove_leftovers(folder)
    entries = sorted(os.scandir(folder), key=lambda e: e.name) if folder.is_dir() else []
    for entry in entries:
        if folders and entry.is_dir(follow_symlinks=False) and not is_temporary(entry.name):
            sub = Path(entry.path)
            remove_leftovers(sub)
            with os.scandir(sub) as it:
                own = [Path(e.path) for e in it
                       if e.name in folders and e.is_file(follow_symlinks=False)]
            for path in own:
                path.unlink()
            sub.rmdir()  # a file added meanwhile stays, and so does the folder: an OSError
    for name in reversed(names):
        path = folder / name
        if path.is_file() and not path.is_symlink():
            path.unlink()


def exists_message(out: str | os.PathLike[str], option: str = "--out") -> str:
    """The one message of an existing output, file or folder, given without ``--force``."""
    return f"{os.fspath(out)} exists; pass --force to replace it, or choose another {option}"




def _check_target(out: Path, target: Path, force: bool, names: Collection[str],
                  folders: Collection[str]) -> None:
    """Raise if ``target`` may not become (or be replaced by) a new output folder."""
    cwd = Path.cwd().resolve()
    if not target.name or target == cwd or target in cwd.parents:
        raise MagciliaError(f"--out must be a new folder, not the current folder or one above it; "
                            f"got {out}")
    if not os.path.lexists(target):
        return
    if not target.is_dir():
        raise MagciliaError(f"{out} is a file, not a folder; choose another --out")
    with os.scandir(target) as it:
        if not any(True for _ in it):
            return  # an empty folder is replaced without --force
    if not force:
        raise MagciliaError(exists_message(out))
    check_own(target, names, folders, out=out)


def _publish(staging: Path, target: Path, out: Path, force: bool, names: Collection[str],
             folders: Collection[str]) -> None:
    """Move the complete ``staging`` folder to ``target`` (see the notes above)."""
    try:
        staging.rename(target)  # target absent, or an empty folder: one atomic step
    except OSError as exc:
        if exc.errno == errno.ENOTDIR:
            raise MagciliaError(f"{out} is a file, not a folder; choose another --out") from None
        if exc.errno not in (errno.ENOTEMPTY, errno.EEXIST):
            raise
        if not force:
            raise MagciliaError(exists_message(out)) from None
    else:
        return
    _check_target(out, target, force, names, folders)  # it may have changed during the work
    if _exchange(staging, target):
        return  # the old folder is now under the staging name: the caller removes it
    trash = temporary_name(target, "trash")
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
def staged_directory(out: str | os.PathLike[str], *, names: Collection[str],
                     force: bool = False, folders: Collection[str] = ()) -> Iterator[Path]:
    """A staging folder beside ``out``, published as ``out`` with one rename when the block
    succeeds; on any error it is removed and ``out`` is left as it was.

    Enter it before the work starts: it checks at once that ``out`` may be written (a one-line
    :class:`MagciliaError` otherwise) and removes the leftovers of killed runs beside it.

    Parameters
    ----------
    out : path
        The output folder. It must not exist, or be an empty folder, unless ``force`` is given.
    names : collection of str
        The file names the command writes into it.
    force : bool
        Replace an existing ``out`` (atomically where the system allows, see the notes above),
        only if it holds nothing but the command's own files (:func:`foreign_entry`): never a
        folder of other files by mistake.
    folders : collection of str
        With sub-folders: the file names of the command's own sub-folders.
    """
    out = Path(out)
    target = out.resolve()  # a symbolic link names the folder it points to
    _check_target(out, target, force, names, folders)
    created = _make_folders(target.parent, f"--out {out}")
    remove_leftovers(target.parent)
    staging = temporary_name(target, "staging")
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
        _publish(staging, target, out, force, names, folders)
        published = True
    finally:
        shutil.rmtree(staging, ignore_errors=True)  # after an exchange: the old folder
        _close(fd)
        if not published:
            for p in created:
                with contextlib.suppress(OSError):
                    p.rmdir()
