"""MATLAB ``.mat`` files (v4, v5/7 and v7.3) read safely: a structure check, then the parser in a
child process with memory and time limits.

**Why MATLAB files are parsed in a child process.** ``scipy.io.loadmat`` (C/Cython) crashes the
interpreter (SIGSEGV/SIGBUS) on some damaged files and HDF5 (under ``h5py``) is a large C library
with a long history of such crashes; no check in Python can prove a file safe for either. The CSV
and TDMS readers run in-process: TDMS is pure Python and NumPy; CSV bytes reach pandas' C
tokenizer only after a byte-level check (digits, separators, the letters of nan/inf/set/reset,
bounded lines), with Python's csv module for everything else, and the fuzz suites run both. A
``.mat`` file is therefore (1) checked in-process by a small pure-Python scan of its container
(empty, unknown header, elements running past the end of the file, damaged zlib streams, and the
declared and the real inflated size of every compressed variable we read, counted in bounded pieces
against :data:`MAX_DECOMPRESSED`: a 6.5 MB file that inflates to 6.25 GiB is refused after 2 s in
constant memory, one that declares its size at once), then (2) parsed by SciPy or h5py in a fresh
interpreter (``python -P -c``, importing only NumPy and SciPy or h5py, never magcilia) whose address
space is capped (``RLIMIT_AS``, Linux: :data:`MAT_MEMORY_LIMIT` above what the interpreter uses at
start; elsewhere only the scan of step 1 bounds them) and whose run time is capped
(:data:`MAT_TIMEOUT_S`); the arrays come back through a temporary ``.npz`` file read without
pickles. A crash, a kill or a timeout of the child is one error line (``x.mat: the MATLAB reader
crashed on this file (signal 11, SIGSEGV); it is damaged or not a MAT file``). The price is the
start of that interpreter, paid once per file read: for a recording of the bundled example's size
(66,000 samples × 3 columns, 1.6 MB) ``read_samples`` takes 0.22–0.27 s (v5, plain or compressed)
and 0.11–0.18 s (v7.3) against 1–4 ms for ``loadmat``/h5py in-process (medians of 9, 2-core AMD EPYC
Linux VM); a 6.6-million-sample compressed file (64 MB) takes about 2 s against 0.6 s. A forking or
persistent worker would be cheaper but forks a threaded process (the live read-out) or leaves a
process behind; a pure-Python MAT parser would be a second implementation of SciPy's and still
leaves HDF5.
"""

from __future__ import annotations

import contextlib
import inspect
import json
import os
import signal
import struct
import subprocess
import sys
import zlib
from collections.abc import Callable
from pathlib import Path
from typing import IO, Any

import numpy as np
from numpy.typing import NDArray

from magcilia import _validate as v
from magcilia._atomic import scratch_directory
from magcilia._errors import MagciliaError, require
from magcilia._validate import printable

F64 = NDArray[np.float64]

#: Most bytes one compressed MATLAB variable may inflate to (a column of MAX_SAMPLES is 400 MB).
MAX_DECOMPRESSED = 1 << 30
#: Address space the MATLAB reader's child process may add to what it uses at start (Linux).
MAT_MEMORY_LIMIT = 4 << 30
#: Longest time the MATLAB reader's child process may take, s.
MAT_TIMEOUT_S = 120.0

_HDF5_SIGNATURE = b"\x89HDF\r\n\x1a\n"
_MI_MATRIX, _MI_COMPRESSED = 14, 15
_V4_ITEMSIZE = {0: 8, 1: 4, 2: 4, 3: 2, 4: 2, 5: 1}  # MAT v4 precision code P -> bytes


def _gib(n: int) -> str:
    return f"{n / (1 << 30):g} GiB"


def _mat_kind(path: Path, f: IO[bytes], size: int) -> str:
    """Which MAT format the file holds: ``"hdf5"`` (7.3: an HDF5 superblock at byte 0, 512, 1024
    or 2048), ``"v4"`` or ``"v5"`` (5, 6 and 7; SciPy's tests); anything else is an error."""
    if size == 0:
        raise MagciliaError(f"{path}: the file is empty (0 bytes); not a MATLAB .mat file")
    for offset in (0, 512, 1024, 2048):  # an HDF5 superblock (v7.3, or plain HDF5)
        f.seek(offset)
        if f.read(8) == _HDF5_SIGNATURE:
            return "hdf5"
    f.seek(0)
    head = f.read(128)
    if len(head) >= 4 and 0 in head[:4]:  # v4: a zero in the first 4 bytes (as SciPy decides)
        if head.count(0) == len(head):
            raise MagciliaError(f"{path}: cannot read as a MATLAB .mat file (it starts with "
                                f"{len(head)} zero bytes: damaged)")
        return "v4"
    if len(head) == 128 and head[126:128] in (b"IM", b"MI"):
        major = head[125] if head[126:128] == b"IM" else head[124]  # as SciPy reads it
        if major == 1:
            return "v5"
        if major == 2:
            raise MagciliaError(f"{path}: cannot read as a MATLAB .mat file (a MATLAB 7.3 header "
                                "without HDF5 data: truncated or damaged)")
    raise MagciliaError(f"{path}: cannot read as a MATLAB .mat file (no MAT-file header: not a "
                        "MAT file, or damaged at the start)")


def _small_tag(buf: bytes, pos: int, endian: str) -> tuple[int, bytes, int] | None:
    """The MAT v5 sub-element at ``pos`` of ``buf``: (type, data, next position), or None when
    ``buf`` ends first."""
    if pos + 8 > len(buf):
        return None
    mdtype, nbytes = struct.unpack_from(endian + "II", buf, pos)
    if mdtype >> 16:  # small data element: the data sits in the tag's second word
        n = mdtype >> 16
        return mdtype & 0xFFFF, buf[pos + 4:pos + 4 + min(n, 4)], pos + 8
    end = pos + 8 + nbytes
    return (mdtype, buf[pos + 8:end], end + (-nbytes % 8)) if end <= len(buf) else None


def _matrix_name(buf: bytes, endian: str) -> str | None:
    """The variable name of a MAT v5 matrix element whose body starts ``buf`` (flags, dims, name
    sub-elements), or None when ``buf`` is too short to tell."""
    pos, data = 0, b""
    for _ in range(3):
        tag = _small_tag(buf, pos, endian)
        if tag is None:
            return None
        _, data, pos = tag
    return data.decode("latin-1")


def _inflated(f: IO[bytes], start: int, nbytes: int, limit: int) -> tuple[bytes, int]:
    """Inflate the zlib stream of ``nbytes`` at ``start`` in bounded pieces: (the first 64 KiB,
    the total inflated size, at most ``limit + 1``). Raises ``zlib.error``."""
    inflate = zlib.decompressobj()
    f.seek(start)
    prefix, total, left = b"", 0, nbytes
    while left > 0 and total <= limit and not inflate.eof:
        piece = f.read(min(left, 1 << 20))
        if not piece:
            break
        left -= len(piece)
        while piece and total <= limit:
            out = inflate.decompress(piece, 1 << 22)
            if len(prefix) < 1 << 16:
                prefix += out[:(1 << 16) - len(prefix)]
            total += len(out)
            piece = inflate.unconsumed_tail
    return prefix, total


def _check_compressed(path: Path, f: IO[bytes], pos: int, nbytes: int, endian: str,
                      columns: tuple[str, ...]) -> None:
    """A compressed MAT v5 variable at ``pos`` (``nbytes`` of zlib data) that we read must
    declare and inflate to at most :data:`MAX_DECOMPRESSED` bytes; its name is read first, and
    variables we do not read are skipped, as SciPy does."""
    try:
        prefix, total = _inflated(f, pos + 8, nbytes, 1 << 16)
        name = _matrix_name(prefix[8:], endian)
        if name is not None and name not in columns:
            return
        declared = struct.unpack(endian + "I", prefix[4:8])[0] if len(prefix) >= 8 else 0
        if declared <= MAX_DECOMPRESSED:
            prefix, total = _inflated(f, pos + 8, nbytes, MAX_DECOMPRESSED)
    except zlib.error as exc:
        raise MagciliaError(f"{path}: cannot read as a MATLAB .mat file (the compressed "
                            f"variable at byte {pos} is damaged: {exc})") from None
    what = (f"declares {declared:,} bytes, more than" if declared > MAX_DECOMPRESSED
            else "inflates to more than" if total > MAX_DECOMPRESSED else "")
    if what:
        raise MagciliaError(
            f"{path}: variable {printable(name or '?')} (byte {pos}, {nbytes:,} bytes "
            f"compressed) {what} MAX_DECOMPRESSED = {_gib(MAX_DECOMPRESSED)}; the file is "
            "damaged or hostile, or raise magcilia.io.matfile.MAX_DECOMPRESSED for a genuine "
            "large recording"
        )


def _scan_mat_v5(path: Path, f: IO[bytes], size: int, columns: tuple[str, ...]) -> None:
    """Walk the top-level elements of a MAT v5 file without parsing them: each must lie inside
    the file, and each compressed variable we read (named in ``columns``, or whose name
    cannot be told) must inflate cleanly to at most :data:`MAX_DECOMPRESSED` bytes (counted in
    bounded pieces, nothing is kept)."""
    f.seek(126)
    endian = "<" if f.read(2) == b"IM" else ">"
    pos = 128
    while pos < size:
        f.seek(pos)
        tag = f.read(8)
        if len(tag) < 8:
            raise MagciliaError(f"{path}: cannot read as a MATLAB .mat file ({len(tag)} stray "
                                f"bytes at the end, byte {pos}: truncated or damaged)")
        mdtype, nbytes = struct.unpack(endian + "II", tag)
        if mdtype not in (_MI_MATRIX, _MI_COMPRESSED):
            raise MagciliaError(f"{path}: cannot read as a MATLAB .mat file (element of type "
                                f"{mdtype} at byte {pos}, expected a variable: damaged)")
        if nbytes > size - pos - 8:
            raise MagciliaError(f"{path}: cannot read as a MATLAB .mat file (the variable at "
                                f"byte {pos} declares {nbytes:,} bytes, {size - pos - 8:,} "
                                "remain: truncated or damaged)")
        if mdtype == _MI_COMPRESSED:
            _check_compressed(path, f, pos, nbytes, endian, columns)
        pos += 8 + nbytes


def _scan_mat_v4(path: Path, f: IO[bytes], size: int) -> None:
    """Walk the variables of a MAT v4 file: each one's declared data must lie inside the file
    (SciPy allocates what a header declares before reading it)."""
    f.seek(0)
    mopt = struct.unpack("<i", f.read(4))[0]
    endian = ">" if mopt < 0 or mopt > 5000 else "<"
    pos = 0
    while pos + 20 <= size:
        f.seek(pos)
        mopt, rows, cols, imagf, namlen = struct.unpack(endian + "5i", f.read(20))
        itemsize = _V4_ITEMSIZE.get(mopt % 100 // 10)
        if itemsize is None or min(rows, cols, namlen) < 0:
            return  # SciPy says what is wrong
        nbytes = 20 + namlen + rows * cols * itemsize * (2 if imagf else 1)
        if nbytes > size - pos:
            raise MagciliaError(f"{path}: cannot read as a MATLAB .mat file (the variable at "
                                f"byte {pos} declares {nbytes:,} bytes, {size - pos:,} remain: "
                                "truncated or damaged)")
        pos += nbytes


#: HDF5 filters built into the library or h5py (deflate, shuffle, Fletcher32, SZIP, N-bit,
#: scale-offset, LZF); any other would be a plugin loaded from outside the file
H5_FILTERS = {1: "deflate", 2: "shuffle", 3: "fletcher32", 4: "szip", 5: "nbit",
              6: "scaleoffset", 32000: "lzf"}


def h5_dataset_problem(obj: Any) -> str | None:  # pragma: no cover (runs in the child process)
    """What keeps an HDF5 dataset from being read as data of its own file (the HDF5 and MATLAB
    v7.3 readers' child processes run this before reading a value; self-contained but for
    :data:`H5_FILTERS`, sent with it: :func:`h5_child_helpers`): its values kept in another file
    (external storage), gathered from other datasets or files (a virtual dataset), decoded by a
    filter that is not built in (a plugin loaded from elsewhere), or not
    written (a contiguous dataset never written, chunks never allocated: they would read as the
    fill value). None for a dataset that is whole and its own."""
    import math

    plist = obj.id.get_create_plist()
    fill = obj.fillvalue.item() if hasattr(obj.fillvalue, "item") else obj.fillvalue
    if plist.get_external_count():
        files = {str(plist.get_external(i)[0], "utf-8", "replace") if isinstance(
            plist.get_external(i)[0], bytes) else str(plist.get_external(i)[0])
            for i in range(plist.get_external_count())}
        return (f"keeps its values in another file (HDF5 external storage: "
                f"{', '.join(sorted(files))[:120]}); magcilia reads only what is inside the "
                "file: store the values in it (h5py: f.create_dataset(name, data=values))")
    if obj.is_virtual:
        return ("is a virtual dataset (its values are gathered from other datasets or files); "
                "magcilia reads only what is inside the file: store the values in it")
    for i in range(plist.get_nfilters()):
        code, _, _, name = plist.get_filter(i)
        if code not in H5_FILTERS:
            label = str(name, "utf-8", "replace") if isinstance(name, bytes) else str(name)
            return (f"is decoded by HDF5 filter {code} ({label[:40] or 'unnamed'}), a plugin "
                    "that magcilia does not load; store it uncompressed or with gzip")
    if obj.size and obj.id.get_storage_size() == 0:
        return ("was never written (no storage allocated: it would read as the fill value "
                f"{fill!r}); the recording is empty or was cut before its first write")
    if obj.chunks is not None and obj.size:
        try:
            allocated = obj.id.get_num_chunks()
        except (AttributeError, RuntimeError, ValueError):  # an HDF5 without the call
            return None
        total = math.prod(-(-n // c) for n, c in zip(obj.shape, obj.chunks, strict=True))
        if allocated < total:
            return (f"was only partly written: {allocated} of its {total} chunks hold data (the "
                    f"others would read as the fill value {fill!r}); the recording "
                    "was cut short: keep the part written (h5py: resize the dataset to it)")
    return None


def h5_reaches_outside(file: Any, path: str) -> bool:  # pragma: no cover (in the child)
    """Whether following ``path`` (absolute in ``file``) crosses an external link, soft links
    followed here one component at a time (so that HDF5 itself never traverses a link to find
    out; a chain of more than 32 soft links counts as outside). Self-contained, for the child
    processes."""
    import posixpath

    import h5py

    todo = [p for p in path.split("/") if p]
    here, hops = "", 0
    while todo:
        name = todo.pop(0)
        link = file.get(f"{here}/{name}", getlink=True)
        if isinstance(link, h5py.ExternalLink):
            return True
        if isinstance(link, h5py.SoftLink):
            hops += 1
            if hops > 32:
                return True
            target = posixpath.normpath(posixpath.join(here or "/", str(link.path)))
            todo = [p for p in target.split("/") if p] + todo
            here = ""
            continue
        here = f"{here}/{name}"
    return False


def forget_h5_plugins(h5py: Any) -> None:  # pragma: no cover (runs in the child process)
    """Forget HDF5's plugin search paths, so that no filter is loaded from outside the file."""
    try:
        while h5py.h5pl.size():
            h5py.h5pl.remove(0)
    except (AttributeError, RuntimeError, ValueError):
        pass


def _mat_child() -> None:  # pragma: no cover (runs in the child process)
    """The MATLAB reader's child process (see the module docstring): its source is sent with
    ``python -P -c``, so it is self-contained and imports nothing from magcilia.

    argv: file, output .npz, memory limit (bytes), kind ("v4", "v5", "hdf5"), largest variable
    (bytes), the variable names to read (comma-separated). Prints one JSON line: ``found`` (the
    names in the file), ``saved`` (written to the .npz), ``problems`` (name -> what is wrong),
    ``error`` (why the file could not be read, "memory" for a MemoryError, or null).
    """
    import contextlib
    import json
    import os
    import sys
    import warnings
    from pathlib import Path

    path, out, memory, kind = sys.argv[1], sys.argv[2], int(sys.argv[3]), sys.argv[4]
    max_bytes, wanted = int(sys.argv[5]), sys.argv[6].split(",")
    found: list[str] = []
    problems: dict[str, str] = {}
    saved: list[str] = []
    error = None
    try:
        import numpy as np

        if kind == "hdf5":
            import h5py
        else:
            from scipy.io import loadmat, whosmat
        with contextlib.suppress(ImportError, OSError, ValueError):  # Linux: cap the memory
            import resource

            used = int(Path("/proc/self/statm").read_text().split()[0]) * os.sysconf(
                "SC_PAGE_SIZE")
            soft, hard = resource.getrlimit(resource.RLIMIT_AS)
            cap = used + memory if hard == resource.RLIM_INFINITY else min(used + memory, hard)
            if soft == resource.RLIM_INFINITY or soft > cap:
                resource.setrlimit(resource.RLIMIT_AS, (cap, hard))
        arrays: dict[str, Any] = {}
        numeric = ("double", "single", "logical", "int8", "uint8", "int16", "uint16", "int32",
                   "uint32", "int64", "uint64")
        if kind == "hdf5":
            forget_h5_plugins(h5py)
            with h5py.File(path, "r") as mat:
                found = [str(k) for k in mat if not str(k).startswith("#")]
                for k in wanted:
                    if k not in found:
                        continue
                    if not isinstance(mat.get(k, getlink=True), h5py.HardLink):
                        problems[k] = "is a link, not a numeric vector"
                        continue
                    obj = mat[k]
                    cls = obj.attrs.get("MATLAB_class", b"")
                    cls = cls.decode("latin-1") if isinstance(cls, bytes) else str(cls)
                    if not isinstance(obj, h5py.Dataset):
                        problems[k] = f"is a MATLAB {cls or 'group'}, not a numeric vector"
                    elif cls and cls not in numeric:
                        problems[k] = f"is a MATLAB {cls} array, not a numeric vector"
                    elif obj.attrs.get("MATLAB_empty", 0):
                        arrays[k] = np.zeros(0)
                    elif obj.dtype.names:
                        problems[k] = ("is complex; save its real part" if "imag" in
                                       obj.dtype.names else "is a compound, not numbers")
                    elif obj.dtype.kind not in "biuf":
                        problems[k] = f"holds HDF5 type {obj.dtype}, not numbers"
                    elif obj.size * obj.dtype.itemsize > max_bytes:
                        problems[k] = (f"holds {obj.size * obj.dtype.itemsize:,} bytes, more "
                                       f"than MAX_DECOMPRESSED = {max_bytes:,}; raise magcilia."
                                       "io.matfile.MAX_DECOMPRESSED for a genuine recording")
                    elif (problem := h5_dataset_problem(obj)) is not None:
                        problems[k] = problem
                    else:
                        arrays[k] = np.asarray(obj[()]).T  # MATLAB's dimensions are reversed
        else:
            with warnings.catch_warnings(record=True) as caught:
                warnings.simplefilter("always")
                listing = whosmat(path)
                found = [str(name) for name, _, _ in listing]
                classes = {str(name): str(cls) for name, _, cls in listing}
                for k in wanted:
                    if found.count(k) > 1:
                        problems[k] = (f"appears {found.count(k)} times; keep one, it is "
                                       "ambiguous which to use")
                read = [k for k in wanted if k in found and k not in problems]
                mat = loadmat(path, squeeze_me=True, variable_names=read) if read else {}
            if caught:
                raise ValueError(str(caught[0].message).splitlines()[0])
            for k in read:
                value = np.asarray(mat.get(k))
                if value.dtype.kind == "c":
                    problems[k] = "is complex; save its real part"
                elif value.dtype.kind not in "biuf":
                    problems[k] = f"is a MATLAB {classes.get(k, '?')} array, not a numeric vector"
                else:
                    arrays[k] = value
        if arrays:
            np.savez(out, **arrays)
            saved = sorted(arrays)
    except MemoryError:
        error = "memory"
    except Exception as exc:  # noqa: BLE001 (the parent turns it into one line)
        error = f"{type(exc).__name__}: {exc}"
    sys.stdout.write(json.dumps({"found": found[:100], "n_found": len(found), "saved": saved,
                                 "problems": problems, "error": error}) + "\n")


def h5_child_helpers() -> str:
    """The source of the HDF5 checks the child processes share (:data:`H5_FILTERS`,
    :func:`h5_dataset_problem`, :func:`h5_reaches_outside`, :func:`forget_h5_plugins`), to send
    with a child's program."""
    return ("from __future__ import annotations\n\n" + f"H5_FILTERS = {H5_FILTERS!r}\n\n"
            + inspect.getsource(h5_dataset_problem)
            + "\n" + inspect.getsource(h5_reaches_outside) + "\n"
            + inspect.getsource(forget_h5_plugins) + "\n")


def _mat_child_code() -> str:
    """The child's program: the HDF5 checks, :func:`_mat_child`'s source and a call."""
    return h5_child_helpers() + inspect.getsource(_mat_child) + "\n_mat_child()\n"


def run_child(path: Path, code: str, args: list[str], *, reader: str, what: str,
              load: Callable[[Path, dict[str, Any]], dict[str, NDArray[Any]]]
              ) -> tuple[dict[str, Any], dict[str, NDArray[Any]]]:
    """Parse ``path`` in a limited child process (see the module docstring); the MATLAB and the
    HDF5 readers share it.

    Parameters
    ----------
    path : Path
        The file.
    code : str
        The child's program. Its ``sys.argv[1:]`` is ``path`` (resolved), the ``.npz`` file to
        write the arrays to, the memory limit in bytes, then ``args``; it prints its report as
        one JSON line, ``"error": "memory"`` when it ran out of memory.
    reader, what : str
        For messages: ``"MATLAB"`` and ``"a MAT file"``, ``"HDF5"`` and ``"an HDF5 file"``.
    load : callable
        ``load(npz_path, report) -> arrays``, called while the ``.npz`` file exists.

    Returns
    -------
    report, arrays
        The child's report (any ``"error"`` but memory left to the caller) and ``load``'s arrays.
    """
    if not sys.executable:
        raise MagciliaError(f"{path}: cannot start the {reader} reader (no Python interpreter: "
                            "sys.executable is empty)")
    env = {**os.environ, "OPENBLAS_NUM_THREADS": "1", "OMP_NUM_THREADS": "1",
           "MKL_NUM_THREADS": "1"}
    with scratch_directory("magcilia-reader") as tmp:  # a killed run's: removed by the next
        out = Path(tmp) / "arrays.npz"
        argv = [sys.executable, "-P", "-c", code, str(path.resolve()), str(out),
                str(int(MAT_MEMORY_LIMIT)), *args]
        try:
            proc = subprocess.run(argv, stdin=subprocess.DEVNULL, capture_output=True,
                                  timeout=MAT_TIMEOUT_S, env=env, cwd=tmp, check=False)
        except subprocess.TimeoutExpired:
            raise MagciliaError(
                f"{path}: the {reader} reader took longer than MAT_TIMEOUT_S = "
                f"{MAT_TIMEOUT_S:g} s and was stopped; the file is damaged, or raise "
                "magcilia.io.matfile.MAT_TIMEOUT_S for a genuine large file") from None
        except OSError as exc:
            raise MagciliaError(f"{path}: cannot start the {reader} reader "
                                f"({printable(str(exc))})") from exc
        report: dict[str, Any] | None = None
        lines = proc.stdout.decode("utf-8", "replace").strip().splitlines()
        if proc.returncode == 0 and lines:
            with contextlib.suppress(ValueError):
                report = json.loads(lines[-1])
        memory = (f"{path}: reading this file needs more than MAT_MEMORY_LIMIT = "
                  f"{_gib(MAT_MEMORY_LIMIT)} of memory; the file is damaged, or raise "
                  "magcilia.io.matfile.MAT_MEMORY_LIMIT for a genuine large file")
        if not isinstance(report, dict):
            if b"MemoryError" in proc.stderr:
                raise MagciliaError(memory)
            rc = proc.returncode
            if rc < 0:
                how = f"signal {-rc}"
                with contextlib.suppress(ValueError):
                    how = f"signal {-rc}, {signal.Signals(-rc).name}"
                raise MagciliaError(f"{path}: the {reader} reader crashed on this file ({how}); "
                                    f"it is damaged or not {what}")
            last = (proc.stderr.decode("utf-8", "replace").strip().splitlines() or [""])[-1]
            raise MagciliaError(f"{path}: the {reader} reader failed on this file (exit code "
                                f"{rc}{': ' + printable(last[:160]) if last else ''}); it is "
                                f"damaged or not {what}")
        if report.get("error") == "memory":
            raise MagciliaError(memory)
        return report, load(out, report)


def _run_mat_child(path: Path, kind: str, columns: tuple[str, ...]
                   ) -> tuple[dict[str, Any], dict[str, NDArray[Any]]]:
    """Parse ``path`` in a child process (see the module docstring): its report and arrays."""
    def load(out: Path, report: dict[str, Any]) -> dict[str, NDArray[Any]]:
        if not report.get("saved") or report.get("error"):
            return {}
        with np.load(out, allow_pickle=False) as npz:
            return {k: npz[k] for k in npz.files if k in columns}

    report, arrays = run_child(path, _mat_child_code(),
                               [kind, str(int(MAX_DECOMPRESSED)), ",".join(columns)],
                               reader="MATLAB", what="a MAT file", load=load)
    if report.get("error"):
        raise MagciliaError(f"{path}: cannot read as a MATLAB .mat file "
                            f"({printable(str(report['error'])[:200])})")
    return report, arrays


def read_mat(path: Path, columns: tuple[str, ...], required: tuple[str, ...],
             alternatives: tuple[str, ...] = (), instead: tuple[str, ...] = ()
             ) -> dict[str, F64]:
    """The variables ``columns`` of a MATLAB file (see the module docstring), as float64 vectors.

    Parameters
    ----------
    path : Path
        The ``.mat`` file (v4, v5/7 or v7.3).
    columns : tuple of str
        The variables to read (others are skipped unread).
    required : tuple of str
        Those that must be there.
    alternatives : tuple of str
        Variables that together stand in for the last required one (the three field components
        for the voltage): it may be missing where any of them is there.
    instead : tuple of str
        Variables that stand in for the first required one (a load or a coil's applied field
        in place of the angle): it may be missing where any of them is there.

    Raises
    ------
    MagciliaError
        One line naming the file and what is wrong (the parser's crash included).
    """
    size = path.stat().st_size
    with path.open("rb") as f:
        kind = _mat_kind(path, f, size)
        if kind == "v5":
            _scan_mat_v5(path, f, size, columns)
        elif kind == "v4":
            _scan_mat_v4(path, f, size)
    if kind == "hdf5":
        require("h5py", package="h5py", extra="hdf5", purpose="Reading MATLAB v7.3 .mat files")
    report, arrays = _run_mat_child(path, kind, columns)
    problems = report.get("problems") or {}
    if problems:
        name, problem = next(iter(problems.items()))
        fix = "" if ";" in str(problem) else f"; save {name} as a real numeric vector"
        raise MagciliaError(f"{path}: variable {printable(str(name))} "
                            f"{printable(str(problem))}{fix}")
    missing = [k for k in required if k not in arrays]
    if instead and required and any(k in arrays for k in instead):
        missing = [k for k in missing if k != required[0]]
    if alternatives and missing[-1:] == list(required[-1:]) and any(
            k in arrays for k in alternatives):
        missing = missing[:-1]  # (which of them are missing: the column mapping says)
    if missing:
        found = [str(n) for n in report.get("found", []) if not str(n).startswith("__")]
        shown = ", ".join(v.short(n, 40) for n in found[:12]) or "none"
        more = f", … ({len(found)} in all)" if len(found) > 12 else ""
        raise MagciliaError(f"{path}: missing variable(s) {', '.join(missing)} (found: "
                            f"{shown}{more}); save vectors named {' and '.join(required)}"
                            + (f" (or {', '.join(alternatives)} in place of {required[-1]})"
                               if alternatives else ""))
    out: dict[str, F64] = {}
    for key, value in arrays.items():
        arr = np.squeeze(value)
        if arr.ndim > 1:
            raise MagciliaError(f"{path}: variable {key} is a {'×'.join(map(str, arr.shape))} "
                                "matrix; save a vector (one value per sample)")
        out[key] = arr.astype(np.float64).ravel()
    return out
