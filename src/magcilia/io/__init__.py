"""Files in and out: setup files, recordings, firmware headers.

* :mod:`.setup_files`: setup TOML files with unit-bearing values ↔ :class:`~magcilia.Setup`;
* :mod:`.array_file`: array files (``[[cilia]]``, ``[[sensors]]``, ``[array]``) ↔
  :class:`~magcilia.CiliaArray`;
* :mod:`.recordings`: recordings (CSV, MATLAB, TDMS, HDF5) reduced to a :class:`Measurement`;
  :mod:`.tdmsfile`, :mod:`.hdf5file`, :mod:`.matfile`, :mod:`.csvfile` the readers;
* :mod:`.quality`: the checks of a recording's samples before fitting (sparse conditions,
  outliers, duplicated blocks, garbled values: :class:`RecordingQuality`);
* :mod:`.recording_state`: what a recording says of itself (complete, planned angles) and a
  reader's notes;
* :mod:`.measurement`: :class:`Measurement`, the per-condition summary (tilt angle or load,
  azimuth; output or 3-axis field) that calibration fits;
* :mod:`.columns`: which column of a recording holds what, in which unit (:class:`Columns`);
* :mod:`.recording_file`: crash-safe TDMS recordings streamed in flushed chunks;
* :mod:`.firmware`: C headers and JSON of read-out approximations;
* :mod:`.results`: saved JSON results read back with one-line errors;
* :mod:`.export_recording`: recordings out to CSV, MATLAB (v5, v7.3), HDF5 and NetCDF
  (:func:`export`; the writers in :mod:`.export_formats`, the ``xarray.Dataset`` views in
  :mod:`.export_xarray`);
* :mod:`.presets`: the built-in setups by name (``paper``, ``paper-initial``, ``force-sensor``,
  ``array``), ``mc.presets``.
"""

from __future__ import annotations

from typing import TYPE_CHECKING

from magcilia._lazy import attach

if TYPE_CHECKING:
    from magcilia.io import presets
    from magcilia.io.array_file import array_from_dict, array_to_dict, load_array, save_array
    from magcilia.io.columns import Columns
    from magcilia.io.export_data import RecordingExport
    from magcilia.io.export_recording import export
    from magcilia.io.firmware import fixed_point_format, to_c_header, to_json
    from magcilia.io.quality import RecordingQuality
    from magcilia.io.recording_file import RecordingWriter, recording_properties
    from magcilia.io.recordings import (
        Measurement,
        check_quality,
        example_path,
        measurement_from_samples,
        read_measurements,
        read_recording,
        read_samples,
    )
    from magcilia.io.results import read_json
    from magcilia.io.setup_files import load_setup, save_setup, setup_from_dict, setup_to_dict

__all__ = [
    "Columns",
    "Measurement",
    "RecordingExport",
    "RecordingQuality",
    "RecordingWriter",
    "array_from_dict",
    "array_to_dict",
    "check_quality",
    "example_path",
    "export",
    "fixed_point_format",
    "load_array",
    "load_setup",
    "measurement_from_samples",
    "presets",
    "read_json",
    "read_measurements",
    "read_recording",
    "read_samples",
    "recording_properties",
    "save_array",
    "save_setup",
    "setup_from_dict",
    "setup_to_dict",
    "to_c_header",
    "to_json",
]

__getattr__, __dir__ = attach(__name__)
