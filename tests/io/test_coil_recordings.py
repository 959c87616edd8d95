"""Coil recordings (issue 29, item 1): actuation_x/y/z_T columns beside voltage_V or the field
columns, no angle, in every reader format; samples the sensor's checks flag are dropped and
counted."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest

import magcilia as mc
from magcilia.calibration.experiments import CoilExperiment, experiment
from magcilia.constants import GAUSS
from magcilia.io.recordings import Measurement

RNG = np.random.default_rng(29)
APPLIED = np.array([[3e-4, 0.0, 0.0], [0.0, 3e-4, 0.0], [-3e-4, 0.0, 0.0], [0.0, 0.0, 3e-4],
                    [2e-4, -2e-4, 1e-4]])
REPEAT = 12
B = np.repeat(APPLIED, REPEAT, axis=0)
VOLT = 75.0 * (B[:, 0] + 4e-5) + 0.01 + RNG.normal(0.0, 1e-5, B.shape[0])
FIELD = B + np.array([4e-5, 6e-5, 1e-5]) + RNG.normal(0.0, 1e-8, B.shape)
COLS = ("actuation_x_T", "actuation_y_T", "actuation_z_T")


def _csv(path: Path, header: list[str], columns: list[np.ndarray]) -> Path:
    lines = [",".join(header)] + [",".join(repr(float(c[i])) for c in columns)
                                  for i in range(columns[0].size)]
    path.write_text("\n".join(lines) + "\n", encoding="utf-8")
    return path


def _check(m: Measurement, field: bool = False) -> None:
    assert m.is_coil and m.loads is None
    assert isinstance(experiment(m), CoilExperiment)
    order = np.lexsort(APPLIED.T[::-1])
    got = np.lexsort(m.actuation.T[::-1])
    np.testing.assert_allclose(m.actuation[got], APPLIED[order], rtol=1e-12, atol=1e-18)
    np.testing.assert_array_equal(m.counts, REPEAT)
    np.testing.assert_array_equal(m.angles, 0.0)
    for i, b in enumerate(m.actuation):
        at = np.all(np.isclose(B, b, rtol=0, atol=1e-15), axis=1)
        if field:
            np.testing.assert_allclose(m.fields[i], FIELD[at].mean(axis=0), rtol=1e-12)
            np.testing.assert_allclose(m.field_sem[i], FIELD[at].std(axis=0, ddof=1)
                                       / np.sqrt(REPEAT), rtol=1e-6)
        else:
            np.testing.assert_allclose(m.volts[i], VOLT[at].mean(), rtol=1e-12)
            np.testing.assert_allclose(m.sem[i], VOLT[at].std(ddof=1) / np.sqrt(REPEAT),
                                       rtol=1e-6)


def test_csv_output_and_field(tmp_path: Path) -> None:
    _check(mc.read_measurements(_csv(tmp_path / "c.csv", [*COLS, "voltage_V"],
                                     [*B.T, VOLT])))
    m = mc.read_measurements(_csv(tmp_path / "f.csv", [*COLS, "field_x_T", "field_y_T",
                                                       "field_z_T"], [*B.T, *FIELD.T]))
    _check(m, field=True)
    back = Measurement.from_dict(m.to_dict())
    np.testing.assert_array_equal(back.actuation, m.actuation)
    assert "applied fields (coil)" in m.report()


def test_mapped_units_mat_h5_tdms(tmp_path: Path) -> None:
    from scipy.io import savemat

    mapping = "actuation_x=Bx[mT],actuation_y=By[mT],actuation_z=Bz[mT],voltage=V[V]"
    mat = tmp_path / "m.mat"
    savemat(mat, {"Bx": B[:, 0] * 1e3, "By": B[:, 1] * 1e3, "Bz": B[:, 2] * 1e3, "V": VOLT})
    _check(mc.read_measurements(mat, columns=mapping))
    h5py = pytest.importorskip("h5py")
    h5 = tmp_path / "r.h5"
    with h5py.File(h5, "w") as f:
        for k, col in zip(COLS, B.T, strict=True):
            f.create_dataset(k, data=col)
        f.create_dataset("voltage_V", data=VOLT)
    _check(mc.read_measurements(h5))
    nptdms = pytest.importorskip("nptdms")
    tdms = tmp_path / "t.tdms"
    with nptdms.TdmsWriter(tdms) as writer:
        writer.write_segment([nptdms.ChannelObject("a", k, col) for k, col in
                              zip(COLS, B.T, strict=True)]
                             + [nptdms.ChannelObject("a", "voltage_V", VOLT)])
    _check(mc.read_measurements(tdms))


def test_saturating_and_flipping_samples_are_dropped_and_counted(tmp_path: Path) -> None:
    strong = np.array([[7e-4, 0.0, 0.0]] * 5 + [[0.0, 0.0, 2.5e-3]] * 5)  # > 6 G, > 20 G
    b = np.concatenate([B, strong])
    volt = np.concatenate([VOLT, 75.0 * strong[:, 0] + 0.01])
    m = mc.read_measurements(_csv(tmp_path / "s.csv", [*COLS, "voltage_V"], [*b.T, volt]))
    _check(m)
    assert "10 coil sample(s) dropped" in " ".join(m.notes())
    assert "2 applied field(s) left with no usable sample" in m.report()
    # a 3-axis part: judged on its own reading (a flip field of 20 G)
    sensor = mc.Sensor(field_range=30 * GAUSS)
    f = np.concatenate([FIELD, strong])
    m3 = mc.read_measurements(_csv(tmp_path / "s3.csv", [*COLS, "field_x_T", "field_y_T",
                                                         "field_z_T"], [*b.T, *f.T]),
                              sensor=sensor)
    assert "5 coil sample(s) dropped" in " ".join(m3.notes())  # only the 25 G ones


@pytest.mark.parametrize(("header", "match"), [
    (["actuation_x_T", "actuation_y_T", "voltage_V"], "missing applied-field column"),
    (["angle_deg", *COLS, "voltage_V"], "an angle column beside the applied-field columns"),
    (["force_N", *COLS, "voltage_V"], "a force column beside the applied-field columns"),
])
def test_bad_coil_columns(tmp_path: Path, header: list[str], match: str) -> None:
    cols = [np.ones(B.shape[0]) for _ in header]
    with pytest.raises(mc.MagciliaError, match=match) as exc:
        mc.read_measurements(_csv(tmp_path / "bad.csv", header, cols))
    assert "\n" not in str(exc.value)


def test_applied_field_in_wrong_unit(tmp_path: Path) -> None:
    with pytest.raises(mc.MagciliaError, match="must be in tesla"):
        mc.read_measurements(_csv(tmp_path / "g.csv", [*COLS, "voltage_V"],
                                  [B[:, 0] * 1e6, B[:, 1], B[:, 2], VOLT]))
