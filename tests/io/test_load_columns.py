"""Load recordings (issue 14, item 1): ``force_N`` or ``flow_m_per_s`` columns in place of the
angle, any force or speed unit by mapping or name, reduced per (azimuth, load); errors."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest

from magcilia._errors import MagciliaError
from magcilia.io.columns import Columns
from magcilia.io.recordings import FLUID_NAMES, Measurement, example_path, read_measurements
from magcilia.mechanics.drag import FLUIDS


def _write(path: Path, header: str, rows: list[tuple[float, ...]]) -> Path:
    path.write_text(header + "\n" + "\n".join(",".join(f"{x:.12g}" for x in r) for r in rows)
                    + "\n")
    return path


def _samples(loads: list[float], azimuths: list[float]) -> tuple[list[tuple[float, ...]],
                                                                   np.ndarray]:
    """Three samples per (azimuth, load), fields known: means (c, 3) in T, rows shuffled."""
    rng = np.random.default_rng(3)
    rows, means = [], []
    for az in azimuths:
        for f in loads:
            b = np.array([40e-6 + f * 1.0, -3e-6 + az * 1e-8, 20e-6])
            means.append(b)
            for d in (-1e-7, 0.0, 1e-7):
                rows.append((az, f, *(b + d)))
    order = rng.permutation(len(rows))
    return [rows[i] for i in order], np.array(means)


def test_force_recording_in_millinewton_round_trip(tmp_path: Path) -> None:
    loads_mn = [0.0, 0.005, 0.01, 0.02]
    rows, means = _samples(loads_mn, [0.0, 90.0])
    path = _write(tmp_path / "force.csv", "azimuth_deg,F [mN],Bx,By,Bz", rows)
    m = read_measurements(path, columns="force=F,field_x=Bx[T],field_y=By[T],field_z=Bz[T]")
    assert m.load_kind == "force" and m.speeds is None
    np.testing.assert_allclose(m.forces, np.tile(loads_mn, 2) * 1e-3, rtol=1e-12)
    np.testing.assert_array_equal(m.angles, 0.0)
    np.testing.assert_allclose(np.degrees(m.azimuths), np.repeat([0.0, 90.0], 4))
    np.testing.assert_allclose(m.fields, means, rtol=0, atol=1e-15)
    np.testing.assert_array_equal(m.counts, 3)
    back = Measurement.from_dict(m.to_dict())
    np.testing.assert_array_equal(back.forces, m.forces)
    assert "8 loads: forces 0..0.02 mN toward azimuth 0, 90 deg" in m.report()


def test_flow_recording_default_names_and_fluid(tmp_path: Path) -> None:
    rng = np.random.default_rng(0)
    speeds = [0.0, 0.05, 0.1]
    rows = [(u, v) for u in speeds
            for v in (0.01 + 0.1 * u + rng.normal(0, 1e-4) for _ in range(4))]
    path = _write(tmp_path / "flow.csv", "flow_m_per_s,voltage_V", rows)
    m = read_measurements(path, fluid="air")
    assert m.load_kind == "flow" and m.fluid == "air" and m.metadata["fluid"] == "air"
    np.testing.assert_allclose(m.speeds, speeds)
    np.testing.assert_allclose(m.volts, [np.mean([r[1] for r in rows if r[0] == u])
                                         for u in speeds])
    # a speed unit spelled in the name
    path2 = _write(tmp_path / "flow2.csv", "flow_mm_per_s,voltage_V",
                   [(u * 1e3, v) for u, v in rows])
    m2 = read_measurements(path2, columns={"flow": "flow_mm_per_s"})
    np.testing.assert_allclose(m2.speeds, speeds, rtol=1e-12)
    assert m2.fluid == "water"


def test_old_files_keep_their_meaning() -> None:
    m = read_measurements(example_path())
    assert m.loads is None and m.forces is None and m.speeds is None
    assert "force_N" not in m.to_dict() and "speed_m_per_s" not in m.to_dict()
    assert m.load_kind is None


def test_fluids_match_the_mechanics() -> None:
    assert set(FLUID_NAMES) == set(FLUIDS)


def test_load_column_errors(tmp_path: Path) -> None:
    both = _write(tmp_path / "both.csv", "force_N,flow_m_per_s,voltage_V",
                  [(0.0, 0.0, 1.0), (1e-5, 0.1, 1.1)])
    with pytest.raises(MagciliaError, match="both a force column") as info:
        read_measurements(both)
    assert "\n" not in str(info.value)
    tilt_and_load = _write(tmp_path / "tl.csv", "angle_deg,force_N,voltage_V",
                           [(0.0, 0.0, 1.0), (10.0, 1e-5, 1.1)])
    with pytest.raises(MagciliaError, match=r"an angle column .* beside the force column"):
        read_measurements(tilt_and_load)
    flow = _write(tmp_path / "flow.csv", "flow_m_per_s,voltage_V", [(0.0, 1.0), (0.1, 1.1)])
    with pytest.raises(MagciliaError, match="fluid must be one of 'air', 'water'"):
        read_measurements(flow, fluid="honey")
    with pytest.raises(MagciliaError, match="speed unit"):
        Columns(flow="U[mN]")


@pytest.mark.parametrize(("header", "value", "match"), [
    ("force_N,voltage_V", 2e6, r"sample 3 has force_N=2e\+06, beyond ±MAX_LOAD = 1e\+06"),
    ("flow_m_per_s,voltage_V", -8e298, r"sample 3 has flow_m_per_s=-8e\+298, beyond ±MAX_LOAD"),
])
def test_a_load_beyond_max_load_is_an_error(tmp_path: Path, header: str, value: float,
                                            match: str) -> None:
    """A load in the wrong unit or garbage (found by the fuzz: a damaged exponent made grouping by
    rounding overflow) is one error line naming the sample, not a warning."""
    rows = [(0.0, 1e-3), (1e-5, 2e-3), (value, 3e-3), (2e-5, 4e-3)]
    with pytest.raises(MagciliaError, match=match):
        read_measurements(_write(tmp_path / "far.csv", header, rows), suspect="keep")
