"""Figures of arrays (report/array.py), checked in both styles as the CLI's figures are."""

from __future__ import annotations

import importlib.util
from pathlib import Path

import numpy as np
import pytest

import magcilia as mc
from magcilia._atomic import save_figure
from magcilia.device.magnetometer import Magnetometer
from magcilia.report import style
from magcilia.report.array import array_figure, plot_array_map, plot_crosstalk

_spec = importlib.util.spec_from_file_location(
    "magcilia_test_figures", Path(__file__).with_name("test_figures.py"))
assert _spec is not None and _spec.loader is not None
_figures = importlib.util.module_from_spec(_spec)
_spec.loader.exec_module(_figures)

PART = Magnetometer(field_range=5e-3, resolution=1.5e-7, noise=3e-7, rate=100.0, name="3-axis")


@pytest.fixture(scope="module")
def readout() -> mc.ArrayReadout:
    setup = mc.Setup.paper(tip_radius=5e-5, youngs_modulus=1e6, position=(0.0, 0.0, 0.0))
    return mc.ArrayReadout(mc.CiliaArray.grid(setup, 4, 4, 2e-3, sensor=PART), 2e-5,
                           table_size=9)


@pytest.mark.parametrize("kind", ["screen", "paper"])
def test_array_figure_passes_the_checks(readout: mc.ArrayReadout, kind: str,
                                        tmp_path: Path) -> None:
    array = readout.array
    forces = np.random.default_rng(0).uniform(-1.0, 1.0, (16, 2)) * 1.2e-5
    change = mc.field_for_loads(array, forces) - array.field()
    with style.use(kind):
        fig = array_figure(array, readout.crosstalk(), change, forces)
        assert _figures.problems(fig) == []
        save_figure(fig, tmp_path / "array.png", dpi=style.dpi())
        full = plot_crosstalk(readout.crosstalk(), full=True)
        assert _figures.problems(full.get_figure()) == []
        bare = plot_array_map(array)
        assert _figures.problems(bare.get_figure()) == []
    assert (tmp_path / "array.png").read_bytes()[:4] == b"\x89PNG"
    quivers = [c for c in fig.axes[0].collections if type(c).__name__ == "Quiver"]
    assert len(quivers) == 2  # field and loads


def test_plot_functions_draw_on_the_given_axes(readout: mc.ArrayReadout) -> None:
    from magcilia import plot

    fig, axes = plot.new_figure(2, 1)
    assert plot.plot_array_map(readout.array, ax=axes[0, 0]) is axes[0, 0]
    assert plot.plot_crosstalk(readout.crosstalk(), ax=axes[0, 1]) is axes[0, 1]
    assert axes[0, 1].images and _figures.problems(fig) == []
