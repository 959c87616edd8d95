"""What a file looks like, cheaply (its suffix and first bytes): a recording or a setup file.

Used where one is read in place of the other, so that swapped arguments
(``magcilia readout run.tdms force-sensor``) say so ("SETUP looks like a recording",
"RECORDING looks like a setup") instead of failing on the content (issue 30 item 5).
"""

from __future__ import annotations

import os
import re
from pathlib import Path

#: the suffixes of the recordings magcilia reads (:data:`magcilia.io.recordings.READERS`)
RECORDING_SUFFIXES = {".csv": "CSV", ".txt": "CSV", ".mat": "MATLAB .mat", ".tdms": "TDMS",
                      ".h5": "HDF5", ".hdf5": "HDF5"}

#: the first bytes of binary recordings, whatever their suffix
MAGIC = ((b"TDSm", "TDMS"), (b"\x89HDF\r\n\x1a\n", "HDF5"), (b"MATLAB ", "MATLAB .mat"))

#: how many bytes are looked at
HEAD = 4096

#: a table header that only setup files (and the other magcilia TOML files) have
_SETUP_TABLE = re.compile(rb"^\s*\[\[?\s*(cilium|sensor|magnet|placement|array|cilia|sensors|"
                          rb"actuation|priors|layout)\s*\]", re.MULTILINE)


def _head(path: Path) -> bytes:
    try:
        with path.open("rb") as f:
            return f.read(HEAD)
    except OSError:
        return b""


def recording_kind(path: str | os.PathLike[str]) -> str | None:
    """The format a file looks like when it looks like a recording (``"TDMS"``, ``"CSV"``, ...):
    by its first bytes, else by a recording suffix; None otherwise."""
    p = Path(path)
    head = _head(p)
    for magic, kind in MAGIC:
        if head.startswith(magic):
            return kind
    if p.suffix.lower() == ".toml" or _SETUP_TABLE.search(head):
        return None
    return RECORDING_SUFFIXES.get(p.suffix.lower())


def looks_like_setup(path: str | os.PathLike[str]) -> bool:
    """Whether an existing file looks like a setup TOML file (a ``.toml`` suffix, or a table
    such as ``[cilium]`` in its first bytes) and not like a recording."""
    p = Path(path)
    if not p.is_file():
        return False
    head = _head(p)
    if any(head.startswith(magic) for magic, _ in MAGIC):
        return False
    return p.suffix.lower() == ".toml" or _SETUP_TABLE.search(head) is not None


def swapped_recording(path: str | os.PathLike[str]) -> str:
    """The message of a recording read as a setup file."""
    return (f"SETUP {os.fspath(path)} looks like a recording ({recording_kind(path)}), not a "
            "setup TOML file: were SETUP and RECORDING swapped? (SETUP: a setup file or a "
            "preset such as paper; RECORDING: the data file)")


def swapped_setup(path: str | os.PathLike[str]) -> str:
    """The message of a setup (file or preset name) read as a recording."""
    what = "a setup file" if Path(path).is_file() else "a preset name"
    return (f"RECORDING {os.fspath(path)} looks like a setup ({what}), not a recording: were "
            "SETUP and RECORDING swapped? (RECORDING: the data file, .csv/.mat/.tdms/.h5; "
            "SETUP: a setup file or a preset)")
