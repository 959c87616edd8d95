"""Reading recordings: CSV/MAT/TDMS round trips, per-angle statistics, set/reset, bad files."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest
from scipy.io import savemat

import magcilia as mc
from magcilia.io.recordings import measurement_from_samples

ANG = np.repeat([0.0, 10.0, 20.0], 4)
VOLT = np.array([1.0, 1.2, 0.8, 1.0, 2.0, 2.1, 1.9, 2.0, 2.9, 3.1, 3.0, 3.0]) * 1e-3


def _write_csv(path: Path, header: str, rows: list[str]) -> Path:
    path.write_text(header + "\n" + "\n".join(rows) + "\n")
    return path


def test_per_angle_mean_and_standard_error(tmp_path: Path) -> None:
    path = _write_csv(tmp_path / "r.csv", "angle_deg,voltage_V",
                      [f"{a},{v}" for a, v in zip(ANG, VOLT, strict=True)])
    m = mc.read_measurements(path)
    np.testing.assert_allclose(m.angles, np.radians([0, 10, 20]))
    np.testing.assert_allclose(m.volts, [1e-3, 2e-3, 3e-3])
    expected_sem = VOLT[:4].std(ddof=1) / 2.0
    assert m.sem[0] == pytest.approx(expected_sem)
    assert m.counts.tolist() == [4, 4, 4]
    assert m.source == str(path)


def test_csv_with_comments_time_and_shuffled_rows(tmp_path: Path) -> None:
    order = np.random.default_rng(0).permutation(ANG.size)
    rows = [f"{ANG[i]},{VOLT[i]},{i * 1e-3}" for i in order]
    path = _write_csv(tmp_path / "r.csv", "# bench 3\nangle_deg,voltage_V,time_s", rows)
    np.testing.assert_allclose(mc.read_measurements(path).volts, [1e-3, 2e-3, 3e-3])


@pytest.mark.parametrize("suffix", [".mat", ".tdms"])
def test_binary_formats_round_trip(tmp_path: Path, suffix: str) -> None:
    path = tmp_path / f"r{suffix}"
    if suffix == ".mat":
        savemat(path, {"angle_deg": ANG, "voltage_V": VOLT})
    else:
        nptdms = pytest.importorskip("nptdms")
        with nptdms.TdmsWriter(path) as writer:
            writer.write_segment([nptdms.ChannelObject("run", "angle_deg", ANG),
                                  nptdms.ChannelObject("run", "voltage_V", VOLT)])
    m = mc.read_measurements(path)
    np.testing.assert_allclose(m.volts, [1e-3, 2e-3, 3e-3])


def test_set_reset_readings_remove_the_offset() -> None:
    rng = np.random.default_rng(1)
    true = np.array([1e-3, 2e-3])
    offset = 5e-3  # bridge offset: same sign after set and reset
    ang = np.repeat([0.0, 30.0], 200)
    sr = np.tile(np.repeat([1, -1], 100), 2)
    volts = np.repeat(true, 200) * sr + offset + rng.normal(0, 1e-5, 400)
    m = measurement_from_samples(ang, volts, setreset=sr)
    assert m.set_reset
    np.testing.assert_allclose(m.volts, true, atol=5e-6)
    assert np.all(m.sem < 2e-6)


def test_nan_policy_omit_counts_and_drops() -> None:
    volts = VOLT.copy()
    volts[5] = np.nan
    m = measurement_from_samples(ANG, volts, nan_policy="omit")
    assert m.nonfinite.tolist() == [0, 1, 0]
    assert m.counts.tolist() == [4, 3, 4]


def test_saturation_policies() -> None:
    volts = VOLT.copy()
    volts[0] = 0.5  # beyond ±6 gauss × 75 V/T = ±45 mV
    with pytest.raises(mc.MagciliaError, match="beyond the sensor's linear range"):
        measurement_from_samples(ANG, volts)
    m = measurement_from_samples(ANG, volts, saturation="omit")
    assert m.saturated.tolist() == [1, 0, 0] and m.counts.tolist() == [3, 4, 4]
    kept = measurement_from_samples(ANG, volts, saturation="keep")
    assert kept.saturated[0] == 1 and kept.counts[0] == 4


@pytest.mark.parametrize(
    ("content", "match"),
    [
        ("angle,voltage_V\n0,1\n", "missing column 'angle_deg'"),
        ("angle_deg,voltage_V\n0,abc\n10,2\n", "row 2, column voltage_V: 'abc' is not a number"),
        ("angle_deg,voltage_V\n0,1e-3\n0,2e-3\n", "1 usable angle"),
        ("angle_deg,voltage_V\n0,1e-3\n10,1e-3\n", "all readings are equal"),
        ("angle_deg,voltage_V\n0,nan\n10,1e-3\n", "sample 1 is not finite"),
        ("angle_deg,voltage_V\n0,inf\n10,1e-3\n", "sample 1 is not finite"),
        ("", "the file is empty"),
        ("angle_deg,voltage_V\n0,1e-3\n10\n", "row 3 has 1 fields"),
        ("angle_deg,voltage_V,setreset\n0,1e-3,up\n10,1e-3,set\n", "'up' is not set/reset"),
    ],
    ids=["missing-column", "text", "single-angle", "all-equal", "nan", "inf", "empty",
         "truncated", "bad-setreset"],
)
def test_bad_csv_files(tmp_path: Path, content: str, match: str) -> None:
    path = tmp_path / "bad.csv"
    path.write_text(content)
    with pytest.raises(mc.MagciliaError, match=match) as info:
        mc.read_measurements(path)
    assert "\n" not in str(info.value)
    assert str(path) in str(info.value)


def test_bad_mat_and_unknown_files(tmp_path: Path) -> None:
    mat = tmp_path / "r.mat"
    savemat(mat, {"theta": ANG, "v": VOLT})
    with pytest.raises(mc.MagciliaError, match=r"missing variable\(s\) angle_deg, voltage_V"):
        mc.read_measurements(mat)
    junk = tmp_path / "j.mat"
    junk.write_bytes(b"not a mat file at all")
    with pytest.raises(mc.MagciliaError, match="cannot read as a MATLAB"):
        mc.read_measurements(junk)
    with pytest.raises(mc.MagciliaError, match="file type must be one of"):
        mc.read_measurements(tmp_path / "r.xlsx")
    with pytest.raises(mc.MagciliaError, match="no such file"):
        mc.read_measurements(tmp_path / "absent.csv")
