"""The sensor's frequency response (magcilia.mechanics.response): the static limit against the
static map, single-mode closed forms for bandwidth and settling, fluids, the flow load."""

from __future__ import annotations

import math
from pathlib import Path

import numpy as np
import pytest

import magcilia as mc
from magcilia import MagciliaError
from magcilia.mechanics import WATER, Flow

ROOT = Path(__file__).resolve().parents[2]
SENSOR = mc.load_setup(ROOT / "examples" / "force-sensor.toml")
FREQ = np.geomspace(1.0, 5000.0, 200)


def _static_force_slope(setup: mc.Setup, force: float, h: float) -> float:
    """dV/dF of the static map, independently: two bends through the field model."""
    up, down = (float(setup.output(mc.bend(setup, force=force + d))[0]) for d in (h, -h))
    return (up - down) / (2 * h)


@pytest.mark.parametrize("force", [0.0, 5e-5])
def test_zero_hertz_is_the_static_sensitivity(force: float) -> None:
    r = mc.frequency_response(SENSOR, [0.0, 1e-3], fluid="water", force=force)
    reference = _static_force_slope(SENSOR, force, 1e-7)
    assert r.static_sensitivity == pytest.approx(reference, rel=1e-4)
    assert r.transfer[0] == pytest.approx(reference, rel=1e-4)
    assert r.transfer[1] == pytest.approx(reference, rel=1e-3)


def test_modal_model_agrees_with_the_static_map_at_rest() -> None:
    """Unscaled, the modes' gains and stiffnesses give the static slope to their truncation:
    the output per modal displacement (field model) and the modal compliances (finite
    elements) are independent of the large-deflection solver."""
    for kwargs in ({}, {"fluid": "water"}, {"load": "flow"}):
        r = mc.frequency_response(SENSOR, [1.0], **kwargs)  # type: ignore[arg-type]
        assert r.modal_sensitivity == pytest.approx(r.static_sensitivity, rel=0.01), kwargs


def test_lightly_damped_mode_follows_the_second_order_closed_forms() -> None:
    """In air the first mode dominates (ζ ≈ 0.003): the −3 dB bandwidth of a second-order
    low-pass, ω_b = ω_n √(1 − 2ζ² + √(4ζ⁴ − 4ζ² + 2)), and the 2 % settling time of its step,
    ln(1/(0.02 √(1 − ζ²))) / (ζ ω_n)."""
    r = mc.frequency_response(SENSOR, FREQ, fluid="air")
    f1, z = r.modes.frequencies[0], r.modes.damping_ratios[0]
    band = f1 * math.sqrt(1 - 2 * z**2 + math.sqrt(4 * z**4 - 4 * z**2 + 2))
    assert r.bandwidth == pytest.approx(band, rel=0.02)
    settle = math.log(1 / (0.02 * math.sqrt(1 - z**2))) / (z * 2 * math.pi * f1)
    assert r.settling_time == pytest.approx(settle, rel=0.03)
    # the resonance: a peak of about Q = 1/(2ζ) near f1, the phase through −90°
    k = int(np.argmax(r.magnitude))
    assert r.frequencies[k] == pytest.approx(f1, rel=0.03)
    fine = mc.frequency_response(SENSOR, [f1], fluid="air")
    assert fine.magnitude_db[0] == pytest.approx(20 * math.log10(1 / (2 * z)), abs=1.0)
    assert math.degrees(fine.phase[0]) == pytest.approx(-90.0, abs=5.0)


def test_vacuum_never_settles_and_water_settles_within_periods() -> None:
    vac = mc.frequency_response(SENSOR, FREQ)
    assert math.isinf(vac.settling_time) and "never" in vac.report()
    wet = mc.frequency_response(SENSOR, FREQ, fluid="water")
    period = 1 / wet.modes.frequencies[0]
    assert period < wet.settling_time < 5 * period
    assert wet.bandwidth < vac.bandwidth


def test_glycerol_is_overdamped_slow_and_finite() -> None:
    r = mc.frequency_response(SENSOR, FREQ, fluid="glycerol")
    assert r.modes.overdamped[0]
    assert np.all(np.isfinite(r.transfer))
    assert 0 < r.bandwidth < r.modes.frequencies[0]
    assert np.isfinite(r.settling_time) and r.settling_time > 1 / r.modes.frequencies[0]
    assert r.magnitude.max() <= abs(r.static_sensitivity)  # no resonance peak


def test_flow_response_reduces_to_the_static_flow_slope() -> None:
    r = mc.frequency_response(SENSOR, [0.0, 20.0, 200.0], load="flow", flow=0.05)
    h = 1e-4
    out = [float(SENSOR.output(mc.bend(SENSOR, flow=Flow.uniform(u, WATER)))[0])
           for u in (0.05 + h, 0.05 - h)]
    assert r.transfer[0] == pytest.approx((out[0] - out[1]) / (2 * h), rel=1e-3)
    assert r.unit == "V/(m/s)" and r.modes.fluid is WATER
    assert np.all(np.isfinite(r.transfer)) and r.bandwidth > 0


def test_sensor_bandwidth_is_a_first_order_low_pass() -> None:
    slow = mc.frequency_response(SENSOR, [1.0, 10.0], fluid="water", sensor_bandwidth=10.0)
    fast = mc.frequency_response(SENSOR, [1.0, 10.0], fluid="water")
    ratio = slow.transfer / fast.transfer
    np.testing.assert_allclose(ratio, 1 / (1 + 1j * np.array([1.0, 10.0]) / 10.0), rtol=1e-5)
    assert slow.bandwidth == pytest.approx(10.0, rel=0.1)  # the hair adds a little below f1


def test_bad_input_is_one_line() -> None:
    for kwargs, word in (({"load": "touch"}, "load"), ({"force": 1e-4, "load": "flow"}, "force"),
                         ({"flow": -1.0, "load": "flow"}, "flow"),
                         ({"sensor_bandwidth": 0.0}, "sensor_bandwidth")):
        with pytest.raises(MagciliaError, match=word) as info:
            mc.frequency_response(SENSOR, FREQ, **kwargs)  # type: ignore[arg-type]
        assert "\n" not in str(info.value)
    with pytest.raises(MagciliaError, match="frequencies"):
        mc.frequency_response(SENSOR, [-1.0])
    with pytest.raises(MagciliaError, match="tip_radius"):
        mc.frequency_response(mc.Setup.paper(), FREQ)


def test_result_protocol() -> None:
    r = mc.frequency_response(SENSOR, [0.0, 100.0], fluid="water")
    doc = r.to_dict()
    assert doc["unit"] == "V/N" and len(doc["transfer_real"]) == 2
    assert "bandwidth" in repr(r) and "static sensitivity" in r.report()
    assert r.table()[1]["frequency_Hz"] == 100.0


def test_bode_figure_draws_each_response(tmp_path: Path) -> None:
    from magcilia.report.dynamics import bode_figure

    curves = [mc.frequency_response(SENSOR, FREQ[::10], fluid=f) for f in ("air", "water")]
    fig = bode_figure(curves)
    assert len(fig.axes) == 2 and len(fig.axes[0].get_lines()) >= 2
    fig.savefig(tmp_path / "bode.png")
    assert (tmp_path / "bode.png").stat().st_size > 1000
