"""``magcilia.plot``: every exported plot function draws on the axes it is given and on a new
figure without one, returns the axes, and passes the reviewer's checks of test_figures; the
package does not import matplotlib until something is drawn."""

from __future__ import annotations

import importlib.util
import subprocess
import sys
from collections.abc import Callable
from pathlib import Path
from types import ModuleType
from typing import Any

import numpy as np
import pytest
from matplotlib.axes import Axes
from matplotlib.figure import Figure

import magcilia as mc
from magcilia import plot
from magcilia.acquire.photo import measure_tilt
from magcilia.io.recordings import example_path


def _checks() -> ModuleType:
    """``test_figures.py`` beside this file, for its ``problems`` (the tests folder is not a
    package)."""
    name = "magcilia_test_figures"
    if name not in sys.modules:
        spec = importlib.util.spec_from_file_location(name,
                                                      Path(__file__).with_name("test_figures.py"))
        assert spec is not None and spec.loader is not None
        module = importlib.util.module_from_spec(spec)
        sys.modules[name] = module
        spec.loader.exec_module(module)
    return sys.modules[name]


ANGLES = np.radians(np.arange(0.0, 86.0, 5.0))


@pytest.fixture(scope="module")
def result() -> mc.CalibrationResult:
    initial = mc.Setup.paper_initial()
    data = mc.read_measurements(example_path(), sensor=initial.sensor)
    return mc.calibrate(data, initial=initial, rng=0, starts=64)


@pytest.fixture(scope="module")
def study() -> mc.SensitivityStudy:
    data = mc.read_measurements(example_path())
    return mc.sensitivity_study(mc.Setup.paper(), data, points=5, map_points=7)


@pytest.fixture(scope="module")
def inputs(result: mc.CalibrationResult, study: mc.SensitivityStudy) -> dict[str, Any]:
    """Positional arguments of each exported plot function (all but ``ax``)."""
    setups = [mc.Setup.paper(), mc.Setup.paper_initial()]
    tapered = mc.Setup.paper(tip_radius=5e-5)
    photo = np.full((120, 160), 0.4)
    photo[20:100, 78:82] = 0.95  # a vertical tape
    return {
        "plot_fit": (result,),
        "plot_initial": (result,),
        "plot_residuals": (result,),
        "plot_field_vs_tilt": (ANGLES, [s.field(ANGLES) for s in setups], ["a", "b"]),
        "plot_output_vs_tilt": (ANGLES, [s.output(ANGLES) for s in setups], ["a", "b"]),
        "plot_sweep_curves": (study.sweeps["height"],),
        "plot_sweep_measure": (study.sweeps["n_loops"],),
        "plot_xy_map": (study.xy_map,),
        "plot_sobol": (mc.sobol_indices(mc.Setup.paper(), n_base=32, rng=0),),
        "plot_shapes": (mc.bend_sweep(tapered, forces=[1e-5, 1e-4]),),
        "plot_measurement": (measure_tilt(photo), photo),
        "plot_pareto": (mc.optimise_design(tapered, n=32, refine=4, min_force=1e-5, rng=0,
                                           workers=1, points=31),),
    }


ONE_AXES = ("plot_fit", "plot_initial", "plot_residuals", "plot_field_vs_tilt",
            "plot_output_vs_tilt", "plot_sweep_curves", "plot_sweep_measure", "plot_xy_map",
            "plot_sobol", "plot_shapes", "plot_measurement", "plot_pareto")


def test_every_plot_function_is_covered() -> None:
    exported = {n for n in plot.__all__ if n.startswith("plot_")}
    assert exported == {*ONE_AXES, "plot_design", "plot_pairs",  # plot_pairs: test_posterior
                        "plot_array_map", "plot_crosstalk"}  # test_array_figures


@pytest.mark.parametrize("name", ONE_AXES)
def test_draws_on_the_given_axes_and_on_a_new_figure(name: str, inputs: dict[str, Any]) -> None:
    function: Callable[..., Axes] = getattr(plot, name)
    fig, axes = plot.new_figure()
    ax = function(*inputs[name], ax=axes[0, 0])
    assert ax is axes[0, 0]
    assert ax.has_data()
    assert _checks().problems(fig) == []
    new = function(*inputs[name])
    assert isinstance(new, Axes) and new is not ax and new.has_data()
    assert isinstance(new.figure, Figure) and _checks().problems(new.figure) == []


def test_plot_design_takes_three_axes_or_none() -> None:
    metrics = mc.design_metrics(mc.Setup.paper(tip_radius=5e-5), points=21)
    fig, axes = plot.new_figure(ncols=3)
    drawn = plot.plot_design(metrics, axes[0])
    assert list(drawn) == list(axes[0]) and all(a.has_data() for a in drawn)
    new = plot.plot_design(metrics)
    assert len(new) == 3 and new[0].figure is not fig


def test_paper_style_is_one_column_wide_and_serif(result: mc.CalibrationResult) -> None:
    import matplotlib

    with plot.style("paper"):
        fig = plot.fit_figure(result)
        assert matplotlib.rcParams["font.family"] == ["serif"]
        wide, _ = plot.new_figure(ncols=2)
    assert fig.get_figwidth() == pytest.approx(3.5)
    assert wide.get_figwidth() == pytest.approx(7.2)
    assert matplotlib.rcParams["font.family"] != ["serif"]  # restored after the block
    with (pytest.raises(mc.MagciliaError, match="style must be one of screen, paper; got 'print'"),
          plot.style("print")):
        pass


def test_fig8_is_in_field_units_with_volts_on_the_right(result: mc.CalibrationResult) -> None:
    ax = plot.plot_fit(result)
    b, sem = plot.measured_field(result)
    line = next(c for c in ax.containers).lines[0]
    assert np.allclose(line.get_ydata(), b / 1e-4)  # gauss
    assert np.allclose(b * result.setup.sensor.scale + result.values["offset"],
                       result.data.volts)  # the constant bias of the default fit
    secondary = ax.child_axes[0]
    assert "mV" in secondary.get_ylabel()
    lo, hi = ax.get_ylim()
    volts = result.data.volts * 1e3
    assert hi - lo < 1.3 * np.ptp(volts) / 1e3 / result.setup.sensor.scale / 1e-4  # data fill
    assert np.all(sem > 0)


def test_importing_magcilia_does_not_import_matplotlib() -> None:
    code = ("import sys, magcilia, magcilia.plot; "
            "sys.exit('matplotlib' in sys.modules)")
    assert subprocess.run([sys.executable, "-c", code], check=False).returncode == 0
