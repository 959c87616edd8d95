"""Design metrics: noise-limited detection thresholds, sensitivities, ranges (saturation and
fold), the table and the figure."""

from __future__ import annotations

import math
from pathlib import Path

import numpy as np
import pytest

import magcilia as mc
from magcilia.mechanics import AIR, Flow
from magcilia.report.design import design_figure
from magcilia.report.mechanics import plot_shapes

BANDWIDTH = (0.5, 50.0)


@pytest.fixture(scope="module")
def tapered() -> mc.Setup:
    return mc.Setup.paper(height=3e-3, base_radius=2e-4, tip_radius=5e-5, youngs_modulus=2.0e6,
                          position=(1.4727e-3, 1.9891e-3, 0.3804e-3), n_loops=12,
                          dipoles_per_loop=4)


@pytest.fixture(scope="module")
def metrics(tapered: mc.Setup) -> mc.DesignMetrics:
    return mc.design_metrics(tapered, bandwidth=BANDWIDTH, points=61)


def test_noise_and_detection_thresholds(tapered: mc.Setup, metrics: mc.DesignMetrics) -> None:
    noise = 75.0 * tapered.sensor.noise_rms(*BANDWIDTH)
    assert metrics.noise == pytest.approx(noise, rel=1e-12)
    # dV/dF by an independent central difference of bent outputs
    h = 1e-9
    slope = float(np.diff(tapered.output(mc.bend_sweep(tapered, forces=[-h, h])))[0]) / (2 * h)
    assert metrics.force.sensitivity == pytest.approx(slope, rel=1e-5)
    assert metrics.force.minimum == pytest.approx(noise / abs(slope), rel=1e-5)
    h_angle = 1e-5
    slope_angle = float(np.diff(tapered.output([-h_angle, h_angle]))[0]) / (2 * h_angle)
    assert metrics.angle.sensitivity == pytest.approx(slope_angle, rel=1e-6)
    assert metrics.angle.minimum == pytest.approx(noise / abs(slope_angle), rel=1e-6)


def test_minimum_detectable_speed_solves_the_noise_equation(tapered: mc.Setup,
                                                            metrics: mc.DesignMetrics) -> None:
    u = metrics.flow.minimum
    assert 0.0 < u < metrics.flow.range
    v0 = tapered.output([0.0])[0]
    change = tapered.output(mc.bend(tapered, flow=Flow.uniform(u)))[0] - v0
    assert abs(change) == pytest.approx(metrics.noise, rel=1e-6)
    # drag grows faster than linearly: the zero-load slope overestimates the threshold
    assert u < metrics.noise / abs(metrics.flow.sensitivity)
    # air, 800 times lighter, needs a much faster flow
    in_air = mc.design_metrics(tapered, fluid=AIR, bandwidth=BANDWIDTH, points=31)
    assert in_air.flow.minimum > 10 * u


def test_range_ends_at_the_rated_range() -> None:
    # 1 mm beside the element the total field passes the HMC1021Z's 6 gauss (its datasheet's
    # range of the total applied field) near 35 deg, before B_x does (near 52 deg)
    s = mc.Setup.paper(position=(-1e-3, 0.0, 0.0))
    m = mc.design_metrics(s, bandwidth=BANDWIDTH, points=41)
    assert m.angle.reached and m.angle.limited_by.startswith("sensor range (|B| 6 gauss")
    b = s.field([m.angle.range])[0]
    assert float(np.linalg.norm(b)) == pytest.approx(6e-4, rel=1e-3)
    assert abs(b[0]) < 6e-4
    assert m.force.limited_by.startswith("not available") and math.isnan(m.force.sensitivity)
    assert math.isnan(m.flow.minimum)
    # right above the element |B| is beyond the rated range at rest: no range at all
    above = mc.design_metrics(mc.Setup.paper(position=(0.0, 0.0, 0.0)), bandwidth=BANDWIDTH,
                              points=21)
    assert above.angle.range == 0.0 and above.angle.reached
    assert "at zero load" in above.angle.limited_by


def test_a_range_the_sweep_does_not_reach_is_a_lower_bound(metrics: mc.DesignMetrics) -> None:
    # at the paper's placement the field stays far below 6 gauss and the output never turns:
    # the sweep ends first, and the range is only known to be at least its end
    force = metrics.force
    assert not force.reached and force.limited_by.startswith("not reached: the sweep ends")
    assert force.range == pytest.approx(force.curve[-1, 0], rel=1e-12)
    assert f"≥ {force.range * 1e3:.4g} mN" in metrics.report()
    assert force.to_dict()["range_reached"] is False


def test_range_ends_at_a_fold() -> None:
    s = mc.Setup.paper(position=(1e-3, 0.0, 0.0))
    m = mc.design_metrics(s, bandwidth=BANDWIDTH, points=41)
    assert m.angle.limited_by.startswith("fold")
    r = mc.Readout(s, quantity="angle", span=(0.0, math.radians(85.0)))
    assert r.fold is not None
    assert m.angle.range == pytest.approx(r.fold, abs=math.radians(1.0))


def test_table_and_dict(metrics: mc.DesignMetrics) -> None:
    text = metrics.report()
    assert "mV/mN" in text and "m/s" in text and "deg" in text
    assert len(text.splitlines()) == 6  # noise, header, 3 quantities, the force scale
    assert text.splitlines()[-1].startswith(metrics.setup.modulus.note())
    d = metrics.to_dict()
    assert set(d["metrics"]) == {"force", "flow", "angle"}
    cone = mc.design_metrics(mc.Setup.paper(), bandwidth=BANDWIDTH, points=21)
    assert "not available" in cone.report()


def test_figures(metrics: mc.DesignMetrics, tapered: mc.Setup, tmp_path: Path) -> None:
    fig = design_figure(metrics)
    assert len(fig.axes) == 3
    fig.savefig(tmp_path / "d.png")
    cone = mc.design_metrics(mc.Setup.paper(), bandwidth=BANDWIDTH, points=21)
    design_figure(cone).savefig(tmp_path / "c.png")
    from magcilia.report.figures import new_figure

    _fig2, axes = new_figure()
    ax = plot_shapes(mc.bend_sweep(tapered, forces=[1e-5, 1e-4]), axes[0, 0], ["a", "b"])
    assert len(ax.lines) == 5
    assert (tmp_path / "d.png").stat().st_size > 1000


def test_bad_input(tapered: mc.Setup) -> None:
    with pytest.raises(mc.MagciliaError, match="fluid must be a magcilia Fluid"):
        mc.design_metrics(tapered, fluid="water")  # type: ignore[arg-type]
    with pytest.raises(mc.MagciliaError, match="points must be an integer"):
        mc.design_metrics(tapered, points=3)
