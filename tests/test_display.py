"""Notebook display: every setup and result class has a one-line ``repr`` (display units, at most
``REPR_WIDTH`` characters), a well-formed, escaped ``_repr_html_`` and, where it is a table, a
``to_dataframe()`` with SI unit suffixes on its columns."""

from __future__ import annotations

import importlib.util
import math
from html.parser import HTMLParser
from pathlib import Path
from typing import Any

import numpy as np
import pytest

import magcilia as mc
from magcilia._display import REPR_WIDTH, column, html_table, one_line, si
from magcilia.io import measurement_from_samples

_spec = importlib.util.spec_from_file_location(
    "magcilia_test_results", Path(__file__).with_name("test_results.py"))
assert _spec is not None and _spec.loader is not None
_results = importlib.util.module_from_spec(_spec)
_spec.loader.exec_module(_results)

SETUP = mc.Setup.paper()
FACTORIES: dict[str, Any] = {
    **_results.FACTORIES,
    "Setup": lambda: SETUP,
    "Cilium": lambda: SETUP.cilium,
    "Material": lambda: SETUP.material,
    "Sensor": lambda: SETUP.sensor,
    "Fluid": lambda: mc.WATER,
    "Flow": lambda: mc.Flow.uniform(0.1),
    "Centreline": lambda: SETUP.centreline([0.1, 0.2]),
}


@pytest.fixture(scope="module", params=sorted(FACTORIES))
def shown(request: pytest.FixtureRequest) -> Any:
    return FACTORIES[request.param]()


class _Checker(HTMLParser):
    """Records start/end tags; fails on a tag closed out of order or left open."""

    VOID = frozenset({"br", "hr", "img", "meta", "col"})

    def __init__(self) -> None:
        super().__init__()
        self.stack: list[str] = []
        self.tags: list[str] = []
        self.text: list[str] = []

    def handle_starttag(self, tag: str, attrs: Any) -> None:
        self.tags.append(tag)
        if tag not in self.VOID:
            self.stack.append(tag)

    def handle_endtag(self, tag: str) -> None:
        assert self.stack and self.stack[-1] == tag, f"</{tag}> closes {self.stack[-1:]}"
        self.stack.pop()

    def handle_data(self, data: str) -> None:
        self.text.append(data)


def _parse(text: str) -> _Checker:
    checker = _Checker()
    checker.feed(text)
    checker.close()
    assert checker.stack == [], f"unclosed tags {checker.stack}"
    return checker


def test_repr_is_one_short_line(shown: Any) -> None:
    text = repr(shown)
    assert "\n" not in text and len(text) <= REPR_WIDTH, text
    assert text.startswith(f"{type(shown).__name__}(") and text.endswith(")")
    assert "array(" not in text and "dtype" not in text  # no dataclass dump


def test_repr_html_is_well_formed(shown: Any) -> None:
    checker = _parse(shown._repr_html_())
    assert {"div", "table", "tr", "td"} <= set(checker.tags)
    assert type(shown).__name__ in "".join(checker.text)


def test_repr_shows_display_units() -> None:
    assert "height=3.26 mm" in repr(SETUP) and "n×k=2×5" in repr(SETUP)
    assert "HMC1021Z 75 V/T" in repr(SETUP)
    fit = FACTORIES["CalibrationResult"]()
    text = repr(fit)
    assert f"{len(fit.data)} angles" in text and "V²" in text and "rms=" in text
    # the dataclass dump it replaces ran to thousands of characters
    assert len(text) <= REPR_WIDTH


def test_text_from_files_cannot_inject_html() -> None:
    evil = '<script>alert("x")</script><b>'
    m = measurement_from_samples([0.0, 0.0, 10.0, 10.0], [1e-3, 1.1e-3, 2e-3, 2.1e-3],
                                 source=evil)
    page = m._repr_html_()
    assert "<script>" not in page and "<b><" not in page
    assert "&lt;script&gt;" in page
    checker = _parse(page)
    assert "script" not in checker.tags
    assert evil in "".join(checker.text)  # shown as text, whole


def test_one_line_drops_what_does_not_fit() -> None:
    items = [(f"item{i}", "x" * 20) for i in range(10)]
    text = one_line("Thing", items)
    assert len(text) <= REPR_WIDTH and text.endswith(", …)") and text.startswith("Thing(item0=")
    assert one_line("T", [("a", "line\nbreak")]) == "T(a=line break)"


def test_html_table_cuts_long_tables() -> None:
    page = html_table("T", [("a", "1")], (("x",), [(str(i),) for i in range(50)]), rows=5)
    checker = _parse(page)
    assert checker.tags.count("tr") == 1 + 1 + 5 + 1  # item, header, 5 rows, "… more"
    assert "45 more rows" in page


@pytest.mark.parametrize(("value", "unit", "text"), [
    (4.1e-6, "V", "4.1 µV"), (5.49e-10, "V²", "5.49e-10 V²"), (0.0, "V", "0 V"),
    (999.96e-6, "V", "1 mV"), (1.5e3, "Pa", "1.5 kPa"), (math.inf, "V", "inf V"),
])
def test_si_prefixes(value: float, unit: str, text: str) -> None:
    assert si(value, unit) == text


def test_column_names_spell_units_in_ascii() -> None:
    assert column("force", "N") == "force_N"
    assert column("flow", "m/s") == "flow_m_per_s"
    assert column("n_loops", "") == "n_loops"
    assert column("density", "kg/m^3") == "density_kg_per_m3"


# -- to_dataframe ------------------------------------------------------------------------------
def test_measurement_dataframe_round_trips() -> None:
    m = FACTORIES["Measurement"]()
    df = m.to_dataframe()
    assert list(df.columns) == ["angle_rad", "azimuth_rad", "output_V", "sem_V", "count",
                                "saturated", "nonfinite"]
    np.testing.assert_array_equal(df["angle_rad"].to_numpy(), m.angles)
    np.testing.assert_array_equal(df["output_V"].to_numpy(), m.volts)
    np.testing.assert_array_equal(df["sem_V"].to_numpy(), m.sem)
    np.testing.assert_array_equal(df["count"].to_numpy(), m.counts)
    back = measurement_from_samples(np.degrees(df["angle_rad"].to_numpy()),
                                    df["output_V"].to_numpy())
    np.testing.assert_allclose(back.volts, m.volts, rtol=0, atol=0)


def test_calibration_dataframe_holds_the_fit() -> None:
    fit = FACTORIES["CalibrationResult"]()
    df = fit.to_dataframe().set_index("parameter")
    assert list(df.columns) == ["unit", "initial", "fitted", "stderr", "lower", "upper"]
    assert set(df.index) == set(fit.values)
    for name, value in fit.values.items():
        assert df.loc[name, "fitted"] == value
        assert df.loc[name, "unit"] == mc.device.parameters.PARAMETERS[name].unit
        se = fit.stderr.get(name, math.nan)
        assert df.loc[name, "stderr"] == se or (math.isnan(se) and math.isnan(df.loc[name,
                                                                                      "stderr"]))
    assert df.loc["height", "unit"] == "m"


def test_readout_dataframe_names_quantity_and_unit() -> None:
    tapered = mc.Setup.paper(tip_radius=5e-5, n_loops=16, dipoles_per_loop=4)
    r = mc.Readout(tapered, quantity="force", span=(0.0, 1e-4), table_size=17)
    result = r.read(r.table.output_range[0] + np.array([0.2, 0.5, 9.0])
                    * (r.table.output_range[1] - r.table.output_range[0]))
    df = result.to_dataframe()
    assert list(df.columns) == ["force_N", "sigma_N", "sigma_noise_N", "sigma_calibration_N",
                                "sigma_edge_N", "sigma_scale_N", "flags"]
    np.testing.assert_array_equal(df["force_N"].to_numpy(), result.value)
    np.testing.assert_array_equal(df["flags"].to_numpy(), result.flags)


@pytest.mark.parametrize(("name", "columns"), [
    ("OATResult", ["x_m", "rms_change_V", "shape_change_V"]),
    ("SobolResult", ["parameter", "S1", "S1_conf", "ST", "ST_conf"]),
    ("PlacementTolerance", ["coordinate", "tolerance_m", "worst_angle_rad",
                            "tolerance_with_noise_m"]),
    ("PiecewiseLinear", ["angle_rad", "output_V", "slope_V_per_rad"]),
    ("LookupTable", ["output_V", "angle_rad"]),
    ("PlacementMap", ["x_m", "y_m", "rms_change_V"]),
    ("DesignMetrics", ["quantity", "unit", "sensitivity", "minimum", "range", "range_reached",
                       "limited_by"]),
    ("BentShape", ["s_m", "angle_rad", "x_m", "z_m"]),
    ("ForceVectorResult", ["fx_N", "fy_N", "magnitude_N", "direction_rad", "sigma_fx_N",
                           "sigma_fy_N", "sigma_magnitude_N", "sigma_direction_rad",
                           "cov_xy_N2", "chi2", "flags"]),
    ("SpatialBentShape", ["s_m", "x_m", "y_m", "z_m", "tx", "ty", "tz"]),
    ("SweepResult", ["angle_rad", "output_V", "sem_V", "samples", "saturated"]),
    ("LiveSamples", ["time_s", "raw_V", "angle_rad", "sigma_rad", "flags", "correction_V",
                     "received_s", "published_s"]),
])
def test_dataframe_columns(name: str, columns: list[str]) -> None:
    result = FACTORIES[name]()
    df = result.to_dataframe()
    assert list(df.columns) == columns
    assert len(df) > 0


def test_table_dataframes_round_trip_values() -> None:
    oat = FACTORIES["OATResult"]()
    df = oat.to_dataframe()
    np.testing.assert_array_equal(df["x_m"].to_numpy(), oat.values)
    np.testing.assert_array_equal(df["rms_change_V"].to_numpy(), oat.rms_change)
    sob = FACTORIES["SobolResult"]()
    assert sob.to_dataframe().to_dict("records") == sob.table()
    pl = FACTORIES["PiecewiseLinear"]()
    df = pl.to_dataframe()
    np.testing.assert_array_equal(df["angle_rad"].to_numpy(), pl.knots)
    np.testing.assert_allclose(pl(df["angle_rad"].to_numpy()), df["output_V"].to_numpy(),
                               rtol=1e-12, atol=1e-15)
    lut = FACTORIES["LookupTable"]()
    df = lut.to_dataframe()
    np.testing.assert_array_equal(df["output_V"].to_numpy(), lut.x)
    np.testing.assert_array_equal(df["angle_rad"].to_numpy(), lut.y)
    study = FACTORIES["SensitivityStudy"]()
    df = study.to_dataframe()
    assert list(df["parameter"]) == list(study.sweeps)
    assert list(df["max_rms_change_V"]) == [r["max_rms_change_V"] for r in study.table()]
    cov = FACTORIES["ParameterCovariance"]()
    df = cov.to_dataframe()
    assert list(df.columns) == list(df.index) == list(cov.correlation_names)
    np.testing.assert_array_equal(df.to_numpy(), cov.correlation)


def test_long_texts_keep_their_end() -> None:
    path = "/a/very/long/folder/name/that/goes/on/and/on/recording_2024.csv"
    text = one_line("M", [("", "3 angles"), ("source", path)])
    assert text.endswith("on/and/on/recording_2024.csv)") and "…" in text
    assert len(text) <= REPR_WIDTH
