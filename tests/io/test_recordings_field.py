"""Recordings with tilt azimuths and 3-axis field data (issue 14): every format reads
``azimuth_deg`` and ``field_x_T``, ``field_y_T``, ``field_z_T``; samples are reduced per
condition (azimuth, angle), ordered by azimuth then angle; the rules of one observable per
recording; today's files read exactly as before."""

from __future__ import annotations

import hashlib
import json
from pathlib import Path
from typing import Any

import numpy as np
import pytest
from scipy.io import savemat

import magcilia as mc
from magcilia.acquire.synthetic import FieldRecording, synthetic_field_recording
from magcilia.cli import main
from magcilia.io import csvfile, reduction
from magcilia.io.columns import Columns
from magcilia.io.csvfile import write_samples_csv
from magcilia.io.recordings import measurement_from_samples, read_samples

RNG = np.random.default_rng(14)
ANGLES_DEG = np.array([-30.0, -10.0, 0.0, 15.0, 40.0])
AZIMUTHS_DEG = np.array([90.0, 0.0, -45.0])  # visited in this order, read back sorted
PER = 7  # samples per condition


def _samples(rng: np.random.Generator = RNG) -> dict[str, np.ndarray]:
    """Raw samples, azimuth by azimuth (90, 0, −45), angles in a scrambled order, with the field
    of a smooth made-up law plus noise (T) and a voltage (V) for the output variant."""
    az = np.repeat(AZIMUTHS_DEG, ANGLES_DEG.size * PER)
    ang = np.tile(np.repeat(ANGLES_DEG[[3, 0, 4, 1, 2]], PER), AZIMUTHS_DEG.size)
    a, z = np.radians(ang), np.radians(az)
    clean = np.column_stack([4e-5 + 1e-5 * np.sin(a) * np.cos(z), 5e-5 + 1e-5 * np.sin(a)
                             * np.sin(z), 8e-6 + 2e-5 * (1 - np.cos(a))])
    field = clean + rng.normal(0.0, 1e-7, clean.shape)
    volts = 75.0 * field[:, 0]
    return {"angle_deg": ang, "azimuth_deg": az, "field_x_T": field[:, 0],
            "field_y_T": field[:, 1], "field_z_T": field[:, 2], "voltage_V": volts}


SAMPLES = _samples()
FIELD_KEYS = ("field_x_T", "field_y_T", "field_z_T")
FIELD_COLUMNS = {k: SAMPLES[k] for k in ("angle_deg", "azimuth_deg", *FIELD_KEYS)}


def _expected(cols: dict[str, np.ndarray], keys: tuple[str, ...] = FIELD_KEYS
              ) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
    """Per-condition azimuth and angle (rad, sorted by azimuth then angle), means and standard
    errors (shape (c, len(keys))) and counts, computed plainly."""
    az = cols.get("azimuth_deg", np.zeros_like(cols["angle_deg"]))
    pairs = sorted(set(zip(az.tolist(), cols["angle_deg"].tolist(), strict=True)))
    means, sems, counts = [], [], []
    for z, a in pairs:
        at = (az == z) & (cols["angle_deg"] == a)
        values = np.column_stack([cols[k][at] for k in keys])
        means.append(values.mean(axis=0))
        sems.append(values.std(axis=0, ddof=1) / np.sqrt(at.sum()))
        counts.append(int(at.sum()))
    zs, angs = (np.radians([p[i] for p in pairs]) for i in (0, 1))
    return zs, angs, np.array(means), np.array(sems), np.array(counts)


def _check_field(m: mc.Measurement, cols: dict[str, np.ndarray] = FIELD_COLUMNS,
                 rtol: float = 1e-12) -> None:
    zs, angs, means, sems, counts = _expected(cols)
    assert m.observable == "field" and len(m) == zs.size
    np.testing.assert_allclose(m.azimuths, zs, rtol=1e-15, atol=1e-15)
    np.testing.assert_allclose(m.angles, angs, rtol=1e-15, atol=1e-15)
    assert m.fields is not None and m.field_sem is not None
    np.testing.assert_allclose(m.fields, means, rtol=rtol)
    np.testing.assert_allclose(m.field_sem, sems, rtol=1e-8)
    np.testing.assert_array_equal(m.counts, counts)
    assert np.isnan(m.volts).all() and np.isnan(m.sem).all()
    assert not m.set_reset and not m.saturated.any() and not m.nonfinite.any()


def _text(m: mc.Measurement) -> str:
    """``to_dict()`` as text (NaN voltages of field data compare equal)."""
    return json.dumps(m.to_dict(), sort_keys=True)


def _one_line(info: pytest.ExceptionInfo[Any], path: Path | None = None) -> str:
    text = str(info.value)
    assert "\n" not in text
    assert path is None or str(path) in text
    return text


# -- every format -------------------------------------------------------------------------------
def _csv(path: Path, cols: dict[str, np.ndarray]) -> Path:
    return write_samples_csv(path, cols)


def _csv_careful(path: Path, cols: dict[str, np.ndarray]) -> Path:
    """A CSV that the fast reader gives up on (a comment between the rows)."""
    write_samples_csv(path, cols)
    lines = path.read_text().splitlines(keepends=True)
    path.write_text("".join([*lines[:5], "# moved the holder\n", *lines[5:]]))
    return path


def _mat(path: Path, cols: dict[str, np.ndarray]) -> Path:
    savemat(path, cols)
    return path


def _mat73(path: Path, cols: dict[str, np.ndarray]) -> Path:
    pytest.importorskip("h5py")
    import importlib.util
    import sys

    name = "magcilia_fuzz_corpus"
    if name not in sys.modules:
        spec = importlib.util.spec_from_file_location(
            name, Path(__file__).parents[1] / "fuzz" / "corpus.py")
        assert spec is not None and spec.loader is not None
        module = importlib.util.module_from_spec(spec)
        sys.modules[name] = module
        spec.loader.exec_module(module)
    sys.modules[name].write_mat73(path, cols)
    return path


def _tdms(path: Path, cols: dict[str, np.ndarray]) -> Path:
    nptdms = pytest.importorskip("nptdms")
    with nptdms.TdmsWriter(path) as writer:
        writer.write_segment([nptdms.ChannelObject("recording", k, a) for k, a in cols.items()])
    return path


def _h5(path: Path, cols: dict[str, np.ndarray]) -> Path:
    h5py = pytest.importorskip("h5py")
    with h5py.File(path, "w") as f:
        for k, a in cols.items():
            f[k] = a
    return path


WRITERS = {"csv": (".csv", _csv), "csv-careful": (".csv", _csv_careful), "mat": (".mat", _mat),
           "mat73": (".mat", _mat73), "tdms": (".tdms", _tdms), "hdf5": (".h5", _h5)}


@pytest.mark.parametrize("fmt", sorted(WRITERS))
def test_every_format_reads_azimuths_and_field_columns(tmp_path: Path, fmt: str) -> None:
    suffix, write = WRITERS[fmt]
    path = write(tmp_path / f"r{suffix}", FIELD_COLUMNS)
    m = mc.read_measurements(path)
    _check_field(m)
    assert np.degrees(m.azimuths[[0, -1]]).tolist() == [-45.0, 90.0]  # sorted by azimuth
    cols = read_samples(path)
    assert set(cols) == {"angle_deg", "azimuth_deg", *FIELD_KEYS}
    for k, values in FIELD_COLUMNS.items():
        np.testing.assert_array_equal(cols[k], values)
    # the same Measurement from the arrays
    same = measurement_from_samples(
        FIELD_COLUMNS["angle_deg"], azimuth_deg=FIELD_COLUMNS["azimuth_deg"],
        field=np.column_stack([FIELD_COLUMNS[k] for k in FIELD_KEYS]), source=str(path))
    assert _text(same) == _text(m)


@pytest.mark.parametrize("fmt", sorted(WRITERS))
def test_every_format_reads_outputs_at_several_azimuths(tmp_path: Path, fmt: str) -> None:
    suffix, write = WRITERS[fmt]
    cols = {k: SAMPLES[k] for k in ("angle_deg", "azimuth_deg", "voltage_V")}
    m = mc.read_measurements(write(tmp_path / f"r{suffix}", cols))
    zs, angs, means, sems, counts = _expected(cols, ("voltage_V",))
    assert m.observable == "output" and m.fields is None and m.field_sem is None
    np.testing.assert_array_equal(m.azimuths, zs)
    np.testing.assert_array_equal(m.angles, angs)
    np.testing.assert_allclose(m.volts, means[:, 0], rtol=1e-12)
    np.testing.assert_allclose(m.sem, sems[:, 0], rtol=1e-8)
    np.testing.assert_array_equal(m.counts, counts)


def test_conditions_are_ordered_by_azimuth_then_angle() -> None:
    ang = np.array([10.0, -5.0, 10.0, 30.0, -5.0, 30.0, 0.0])
    az = np.array([270.0, 270.0, -90.0, 0.0, 0.0, 270.0, 0.0])
    b = np.column_stack([np.arange(7.0), np.zeros(7), np.ones(7)]) * 1e-6
    m = measurement_from_samples(ang, field=b, azimuth_deg=az)
    got = list(zip(np.degrees(m.azimuths).round(9).tolist(), m.angles_deg.round(9).tolist(),
                   strict=True))
    # −90 and 270 deg are the same direction but kept as given: two conditions
    assert got == [(-90.0, 10.0), (0.0, -5.0), (0.0, 0.0), (0.0, 30.0), (270.0, -5.0),
                   (270.0, 10.0), (270.0, 30.0)]
    np.testing.assert_array_equal(m.fields[:, 0] * 1e6, [2, 4, 6, 3, 1, 0, 5])


def test_interleaved_samples_and_any_block_size_give_one_result(
        tmp_path: Path, monkeypatch: pytest.MonkeyPatch) -> None:
    """The conditions may come back (the holder returned to an azimuth): the reduction does not
    depend on the order of the samples nor on where the blocks are cut."""
    order = np.random.default_rng(1).permutation(SAMPLES["angle_deg"].size)
    shuffled = {k: a[order] for k, a in FIELD_COLUMNS.items()}
    path = _csv(tmp_path / "s.csv", shuffled)
    whole = mc.read_measurements(path)
    _check_field(whole, shuffled, rtol=1e-12)
    monkeypatch.setattr(reduction, "REDUCE_SAMPLES", 4)
    monkeypatch.setattr(csvfile, "CSV_BLOCK_ROWS", 9)
    pieces = mc.read_measurements(path)
    assert pieces.angles.tolist() == whole.angles.tolist()
    assert pieces.azimuths.tolist() == whole.azimuths.tolist()
    np.testing.assert_allclose(pieces.fields, whole.fields, rtol=1e-13)
    np.testing.assert_allclose(pieces.field_sem, whole.field_sem, rtol=1e-9)
    np.testing.assert_array_equal(pieces.counts, whole.counts)


def test_field_means_on_a_large_background_keep_their_digits() -> None:
    """The earth's field is a large common offset: the two-pass moments keep the small
    variations (as for voltages)."""
    ang = np.repeat([0.0, 20.0], 1000)
    noise = np.random.default_rng(3).normal(0.0, 1e-9, (2000, 3))
    b = np.array([4.0e-5, -2.0e-5, 5.0e-5]) + 1e-8 * (ang[:, None] / 20.0) + noise
    m = measurement_from_samples(ang, field=b)
    np.testing.assert_allclose(np.diff(m.fields, axis=0)[0], 1e-8 + noise[1000:].mean(axis=0)
                               - noise[:1000].mean(axis=0), rtol=1e-6)
    np.testing.assert_allclose(m.field_sem, np.full((2, 3), 1e-9 / np.sqrt(1000)), rtol=0.1)


# -- the column mapping -------------------------------------------------------------------------
def test_mapped_names_and_units(tmp_path: Path) -> None:
    """uT, gauss and mT fields and an azimuth in rad become T and deg; a header's own unit
    counts."""
    gauss = 1e-4
    path = write_samples_csv(tmp_path / "lab.csv", {
        "Tilt": SAMPLES["angle_deg"], "Phi": np.radians(SAMPLES["azimuth_deg"]),
        "Bx [uT]": SAMPLES["field_x_T"] / 1e-6, "By": SAMPLES["field_y_T"] / gauss,
        "Bz_mT": SAMPLES["field_z_T"] / 1e-3})
    m = mc.read_measurements(path, columns="angle=Tilt[deg],azimuth=Phi[rad],field_x=Bx,"
                                           "field_y=By[gauss],field_z=Bz_mT")
    _check_field(m, rtol=1e-12)
    cols = read_samples(path, columns={"angle": "Tilt[deg]", "azimuth": "Phi[rad]",
                                       "field_x": "Bx", "field_y": "By[G]", "field_z": "Bz_mT"})
    np.testing.assert_allclose(cols["azimuth_deg"], SAMPLES["azimuth_deg"], rtol=1e-13,
                               atol=1e-12)
    np.testing.assert_allclose(cols["field_y_T"], SAMPLES["field_y_T"], rtol=1e-13)
    assert Columns.parse("field_x=Bx[nT]").spec("field_x") == ("Bx", "nT")


@pytest.mark.parametrize(
    ("mapping", "match"),
    [("field_x=Bx[deg]", r"columns field_x must be NAME\[unit\] with a field unit \(T, mT, uT"),
     ("azimuth=Phi[mV]", r"columns azimuth must be NAME\[unit\] with an angle unit"),
     ("azimuth=angle_deg", r"columns azimuth must be a column other than the angle's")])
def test_bad_field_and_azimuth_mappings(mapping: str, match: str) -> None:
    with pytest.raises(mc.MagciliaError, match=match) as info:
        Columns.parse(mapping)
    _one_line(info)


def test_a_field_column_without_a_unit_is_refused(tmp_path: Path) -> None:
    path = write_samples_csv(tmp_path / "r.csv", {"angle_deg": [0.0, 1.0], "Bx": [1.0, 2.0],
                                                  "By": [1.0, 2.0], "Bz": [1.0, 2.0]})
    with pytest.raises(mc.MagciliaError, match=r"column 'Bx' \(field_x\) has no unit; give it "
                                                r"in the mapping, e\.g\. --columns "
                                                r"field_x=Bx\[T\]") as info:
        mc.read_measurements(path, columns="field_x=Bx,field_y=By,field_z=Bz")
    _one_line(info, path)


# -- the rules ----------------------------------------------------------------------------------
@pytest.mark.parametrize("fmt", ["csv", "csv-careful", "mat", "tdms", "hdf5"])
@pytest.mark.parametrize(
    ("drop", "add", "match"),
    [((), {"voltage_V": SAMPLES["voltage_V"]},
      (r"both a voltage \w+ \(voltage_V\) and field \w+s \(field_x_T, field_y_T, field_z_T\); a "
      r"recording holds one observable, .*: split the file into one recording of each")),
     (("field_y_T", "field_z_T"), {},
      (r"missing field \w+\(s\) field_y_T, field_z_T \((header|found): .*\); 3-axis data need "
      r"all three \w+s field_x_T, field_y_T, field_z_T")),
     ((), {"setreset": np.tile([1.0, -1.0], SAMPLES["angle_deg"].size // 2 + 1)[:105]},
      (r"a set/reset \w+ \(setreset\) beside the 3-axis field \w+s; set/reset differences are "
      r"for the single-axis AMR output")),
     (FIELD_KEYS, {}, r"missing \w+(\(s\))? '?voltage_V'? .*field_x_T, field_y_T, field_z_T")],
    ids=["both", "partial", "setreset", "neither"])
def test_one_observable_per_recording(tmp_path: Path, fmt: str, drop: tuple[str, ...],
                                      add: dict[str, np.ndarray], match: str) -> None:
    suffix, write = WRITERS[fmt]
    cols = {k: a for k, a in FIELD_COLUMNS.items() if k not in drop} | add
    path = write(tmp_path / f"r{suffix}", cols)
    with pytest.raises(mc.MagciliaError, match=match) as info:
        mc.read_measurements(path)
    _one_line(info, path)
    with pytest.raises(mc.MagciliaError, match=match):
        read_samples(path)


def test_a_strict_voltage_requirement_refuses_field_files(tmp_path: Path) -> None:
    """``readout`` asks for voltage_V itself: a 3-axis file is not read as something else."""
    path = _csv(tmp_path / "f.csv", FIELD_COLUMNS)
    with pytest.raises(mc.MagciliaError, match=r"missing column 'voltage_V'") as info:
        read_samples(path, required=("voltage_V",))
    _one_line(info, path)


@pytest.mark.parametrize(
    ("column", "value", "match"),
    [("field_y_T", np.nan, (r"sample 9 is not finite \(angle_deg=-30.0, azimuth_deg=90.0, "
                           r"field_x_T=.*, field_y_T=nan, field_z_T=.*\); clean the file or pass "
                           r"nan_policy='omit'")),
     ("azimuth_deg", np.inf, r"sample 9 is not finite \(angle_deg=-30.0, azimuth_deg=inf"),
     ("azimuth_deg", 400.0, (r"sample 9 has azimuth_deg=400, beyond ±360 deg; azimuth_deg must "
                            r"be the tilt direction in degrees")),
     ("azimuth_deg", -1e300, r"sample 9 has azimuth_deg=-1e\+300, beyond ±360 deg")])
def test_bad_samples(tmp_path: Path, column: str, value: float, match: str) -> None:
    cols = {k: a.copy() for k, a in FIELD_COLUMNS.items()}
    cols[column][8] = value
    path = _csv(tmp_path / "r.csv", cols)
    with pytest.raises(mc.MagciliaError, match=match) as info:
        mc.read_measurements(path)
    _one_line(info, path)


def test_nan_policy_omit_counts_field_and_azimuth_samples(tmp_path: Path) -> None:
    cols = {k: a.copy() for k, a in FIELD_COLUMNS.items()}
    cols["field_z_T"][[0, 1]] = [np.nan, np.inf]  # condition (90, 15): 2 of 7 dropped
    cols["azimuth_deg"][2] = np.nan  # no condition at all
    at = (cols["azimuth_deg"] == 0.0) & (cols["angle_deg"] == 40.0)
    cols["field_x_T"][at] = np.nan  # a condition left with no usable sample
    m = mc.read_measurements(_csv(tmp_path / "r.csv", cols), nan_policy="omit")
    assert len(m) == ANGLES_DEG.size * AZIMUTHS_DEG.size - 1
    i = int(np.flatnonzero(np.isclose(np.degrees(m.azimuths), 90.0)
                           & np.isclose(m.angles_deg, 15.0))[0])
    assert m.counts[i] == PER - 3 and m.nonfinite[i] == 2
    keep = np.isfinite(cols["field_z_T"]) & np.isfinite(cols["azimuth_deg"]) & np.isfinite(
        cols["field_x_T"])
    _check_field_subset(m, {k: a[keep] for k, a in cols.items()})
    assert m.metadata["dropped"] == {"no_angle": 1, "angles_deg": [40.0], "samples": PER,
                                     "azimuths_deg": [0.0]}
    text = m.report()
    assert "1 without a finite angle or azimuth" in text
    assert f"{PER} at 1 condition(s) left with no usable sample (40 at 0 deg)" in text


def _check_field_subset(m: mc.Measurement, cols: dict[str, np.ndarray]) -> None:
    _zs, _angs, means, _sems, counts = _expected(cols)
    np.testing.assert_allclose(m.fields, means, rtol=1e-12)
    np.testing.assert_array_equal(m.counts, counts)


def test_field_data_are_not_range_checked() -> None:
    """The AMR range (±6 gauss) applies to voltages; a 3-axis sensor's 0.5 mT is read."""
    b = np.repeat([[5e-4, 0.0, 0.0], [1e-3, 0.0, 0.0]], 3, axis=0)
    m = measurement_from_samples(np.repeat([0.0, 10.0], 3), field=b, saturation="raise")
    assert not m.saturated.any() and m.fields[:, 0].tolist() == [5e-4, 1e-3]
    with pytest.raises(mc.MagciliaError, match="beyond the sensor's linear range"):
        measurement_from_samples(np.repeat([0.0, 10.0], 3), 75.0 * b[:, 0])


@pytest.mark.parametrize(
    ("kwargs", "match"),
    [({"field": np.zeros((4, 3)), "voltage": np.zeros(4)},
      r"samples must be one observable: voltage .* or field .*; got 'both voltage and field'"),
     ({}, r"got 'neither voltage nor field'"),
     ({"field": np.zeros((4, 2))}, r"field must be shape \(samples, 3\)"),
     ({"field": np.zeros((4, 3)), "setreset": np.ones(4)}, r"setreset must be left out"),
     ({"field": np.zeros((3, 3))}, r"columns must be of equal length; got 'lengths 4, 3'"),
     ({"field": np.ones((4, 3)), "azimuth_deg": [0, 0, 90]}, r"lengths 4, 3, 4")])
def test_measurement_from_samples_checks_its_arguments(kwargs: dict[str, Any],
                                                        match: str) -> None:
    with pytest.raises(mc.MagciliaError, match=match) as info:
        measurement_from_samples([0.0, 0.0, 10.0, 10.0], **kwargs)
    _one_line(info)


def test_a_constant_field_and_one_condition_are_refused() -> None:
    with pytest.raises(mc.MagciliaError, match=r"all field readings are equal \(B = \(1e-05, 0, "
                                               r"2e-05\) T\)"):
        measurement_from_samples([0.0, 10.0], field=[[1e-5, 0.0, 2e-5]] * 2)
    with pytest.raises(mc.MagciliaError, match=r"1 usable condition\(s\) \(azimuth, angle\)"):
        measurement_from_samples([0.0, 0.0], field=[[1e-5, 0, 0], [2e-5, 0, 0]],
                                 azimuth_deg=[90.0, 90.0])
    with pytest.raises(mc.MagciliaError, match=r"sample 1 has field_x_T=1e\+308, beyond "
                                               r"±MAX_FIELD_T = 100 T; the field columns must "
                                               r"be in tesla"):  # (before its sum overflows)
        measurement_from_samples([0.0, 0.0, 5.0], field=[[1e308, 0, 0], [1e308, 0, 0],
                                                         [0, 0, 0]])
    with pytest.raises(mc.MagciliaError, match=r"sample 2 has field_y_T=40000, beyond "):
        measurement_from_samples([0.0, 5.0], field=[[0, 4e-5, 0], [0, 4e4, 0]])  # nT as T


# -- today's files ------------------------------------------------------------------------------
#: sha256 of the bundled example's ``Measurement.to_dict()`` (without its source and the
#: azimuths), as the reader before issue 14 gave it (the recording regenerated from the exact
#: body in issue 24: the same reader's digest of the new file)
EXAMPLE_DIGEST = "72465543a8a8f3490843248985590cd9e41a8267e0f8a1da3f543c3693efbc45"


def test_the_bundled_example_reads_bit_for_bit_as_before(tmp_path: Path) -> None:
    m = mc.read_measurements(mc.io.example_path())
    d = m.to_dict()
    assert d.pop("azimuth_rad") == [0.0] * len(m)
    d.pop("source")
    assert d["metadata"].pop("quality")["flagged"] == 0  # (checked: nothing flagged)
    assert hashlib.sha256(json.dumps(d, sort_keys=True).encode()).hexdigest() == EXAMPLE_DIGEST
    assert m.observable == "output" and m.single_azimuth
    assert m.report().startswith(f"{m.source}: 33 angles 0..85 deg, 66000 samples")
    assert repr(m).startswith("Measurement(33 angles, angles=0…85 deg, output=")
    # an azimuth column of zeros changes nothing
    cols = read_samples(mc.io.example_path())
    zeros = write_samples_csv(tmp_path / "z.csv", {**cols, "azimuth_deg": np.zeros(66000)})
    same = mc.read_measurements(zeros).to_dict()
    same.pop("source")
    same.pop("azimuth_rad")
    same["metadata"].pop("quality")
    assert same == d


# -- the Measurement ----------------------------------------------------------------------------
def test_a_field_measurement_reports_and_round_trips(tmp_path: Path) -> None:
    m = mc.read_measurements(_csv(tmp_path / "f.csv", FIELD_COLUMNS))
    back = mc.Measurement.from_dict(json.loads(json.dumps(m.to_dict())))
    assert _text(back) == _text(m) and back.observable == "field"
    assert m.report() == (f"{m.source}: 15 conditions: 3 azimuths (-45, 0, 90 deg) × angles "
                          "-30..40 deg, 3-axis field, 105 samples")
    text = repr(m)
    assert text.startswith("Measurement(15 conditions, azimuths=-45, 0, 90 deg, angles=-30…40 "
                           "deg, |B|=") and len(text) <= 120
    header, rows = m._display_table()
    assert header[:3] == ("azimuth (deg)", "angle (deg)", "B_x (µT)") and len(rows) == 15
    assert rows[0][:2] == ["-45", "-30"]
    assert "B_z (µT)" in m._repr_html_()
    df = m.to_dataframe()
    assert list(df.columns) == ["angle_rad", "azimuth_rad", "field_x_T", "field_y_T",
                                "field_z_T", "sem_field_x_T", "sem_field_y_T", "sem_field_z_T",
                                "count", "saturated", "nonfinite"]
    np.testing.assert_array_equal(df[["field_x_T", "field_y_T", "field_z_T"]].to_numpy(),
                                  m.fields)
    np.testing.assert_array_equal(df["sem_field_z_T"].to_numpy(), m.field_sem[:, 2])
    np.testing.assert_array_equal(df["azimuth_rad"].to_numpy(), m.azimuths)


def test_one_nonzero_azimuth_is_said(tmp_path: Path) -> None:
    at90 = FIELD_COLUMNS["azimuth_deg"] == 90.0
    m = mc.read_measurements(_csv(tmp_path / "a.csv", {
        "angle_deg": SAMPLES["angle_deg"][at90], "azimuth_deg": SAMPLES["azimuth_deg"][at90],
        "voltage_V": SAMPLES["voltage_V"][at90]}))
    assert m.single_azimuth and "5 angles -30..40 deg at azimuth 90 deg" in m.report()
    assert "azimuths=90 deg" in repr(m)


# -- consumers that need one path of single-axis outputs ----------------------------------------
def test_paper_calibration_and_sensitivity_refuse_other_data(tmp_path: Path) -> None:
    field = mc.read_measurements(_csv(tmp_path / "f.csv", FIELD_COLUMNS))
    with pytest.raises(mc.MagciliaError, match=(
            r"f\.csv: calibrate\(\.\.\., model='paper'\) needs a single-axis output at azimuth "
            r"0; got 3-axis field data at azimuths -45, 0, 90 deg; use calibrate\(\.\.\., "
            r"model='physical'\)")) as info:
        mc.calibrate(field, rng=0)
    _one_line(info)
    volts = mc.read_measurements(_csv(tmp_path / "v.csv", {
        k: SAMPLES[k] for k in ("angle_deg", "azimuth_deg", "voltage_V")}))
    with pytest.raises(mc.MagciliaError, match=r"got azimuths -45, 0, 90 deg; use calibrate"):
        mc.calibrate(volts, rng=0)
    from magcilia.analysis.measures import data_angles

    with pytest.raises(mc.MagciliaError, match=r"the sensitivity analysis \(data=, CLI: --data\) "
                                               r"needs a single-axis output at azimuth 0"):
        data_angles(volts)


def test_the_cli_refuses_field_data_in_one_line(tmp_path: Path,
                                                capsys: pytest.CaptureFixture[str]) -> None:
    path = _csv(tmp_path / "f.csv", FIELD_COLUMNS)
    assert main(["calibrate", str(path), "--out", str(tmp_path / "fit"), "--quiet"]) == 2
    err = capsys.readouterr().err
    assert err.startswith("magcilia: error: ") and err.count("\n") == 1
    assert "needs a single-axis output at azimuth 0" in err
    assert not (tmp_path / "fit").exists()
    assert main(["sensitivity", "paper", "--data", str(path), "--out", str(tmp_path / "s"),
                 "--quiet"]) == 2
    assert "needs a single-axis output at azimuth 0" in capsys.readouterr().err


# -- the synthetic generator --------------------------------------------------------------------
def test_synthetic_field_recordings_follow_the_model(tmp_path: Path) -> None:
    setup = mc.Setup.paper()
    angles, azimuths = np.radians([-20.0, 0.0, 35.0]), np.radians([0.0, 120.0])
    rec = synthetic_field_recording(setup, angles, azimuths, samples_per_angle=400, noise=2e-7,
                                    background=(1e-6, -2e-6, 3e-6), rng=5)
    assert isinstance(rec, FieldRecording) and rec.field.shape == (2400, 3)
    again = synthetic_field_recording(setup, angles, azimuths, samples_per_angle=400,
                                      noise=2e-7, background=(1e-6, -2e-6, 3e-6), rng=5)
    np.testing.assert_array_equal(again.field, rec.field)
    m = mc.read_measurements(rec.write_csv(tmp_path / "syn.csv"))
    assert (tmp_path / "syn.csv").read_text().startswith("# SYNTHETIC")
    truth = np.concatenate([setup.field(angles, azimuth=float(z)) for z in azimuths])
    truth = truth + [1e-6, -2e-6, 3e-6]
    np.testing.assert_allclose(m.fields, truth, atol=5 * 2e-7 / np.sqrt(400))
    np.testing.assert_allclose(m.field_sem, 2e-7 / np.sqrt(400), rtol=0.2)
    np.testing.assert_allclose(np.degrees(m.azimuths), np.repeat([0.0, 120.0], 3), rtol=1e-15)
    with pytest.raises(mc.MagciliaError, match=r"background must be 3 components"):
        synthetic_field_recording(setup, angles, background=(0.0, 0.0))
    with pytest.raises(mc.MagciliaError, match=r"azimuths must be at least one value"):
        synthetic_field_recording(setup, angles, azimuths=[])


def test_write_samples_csv_checks_its_columns(tmp_path: Path) -> None:
    with pytest.raises(mc.MagciliaError, match="of equal length"):
        write_samples_csv(tmp_path / "x.csv", {"a": [1.0], "b": [1.0, 2.0]})
    with pytest.raises(mc.MagciliaError, match="names without commas"):
        write_samples_csv(tmp_path / "x.csv", {"a,b": [1.0]})
    assert not (tmp_path / "x.csv").exists()


@pytest.mark.parametrize(
    ("kwargs", "match"),
    [({"fields": np.zeros((2, 2)), "field_sem": np.zeros((2, 2))},
      r"Measurement fields must be shape \(2, 3\): one row \(B_x, B_y, B_z\) per angle"),
     ({"fields": np.zeros((2, 3))}, r"field_sem must be both fields and field_sem, or neither"),
     ({"azimuths": np.zeros(3)}, r"Measurement azimuths must be shape \(2,\)"),
     ({"azimuths": [np.nan, 0.0]}, r"Measurement azimuths must be finite angles in rad"),
     ({"volts": np.zeros(3)}, r"Measurement volts must be shape \(2,\): one value per angle")])
def test_a_measurement_checks_its_shapes(kwargs: dict[str, Any], match: str) -> None:
    base: dict[str, Any] = {"angles": np.zeros(2), "volts": np.zeros(2), "sem": np.zeros(2),
                            "counts": np.ones(2, np.int64), "saturated": np.zeros(2, np.int64),
                            "nonfinite": np.zeros(2, np.int64)}
    with pytest.raises(mc.MagciliaError, match=match) as info:
        mc.Measurement(**(base | kwargs))
    _one_line(info)
