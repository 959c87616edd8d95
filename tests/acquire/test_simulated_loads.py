"""The simulated 3-axis sensor and array: scripted tip forces, the exact forward model, each part's
noise and LSB, drift and bias, deterministic with a seed."""

from __future__ import annotations

import math

import numpy as np
import pytest

import magcilia as mc
from magcilia.acquire import LoadScript, SimulatedFieldSource, single_cilium
from magcilia.acquire.simulated_loads import DEMO_STEPS
from magcilia.device.magnetometer import Magnetometer

PART = Magnetometer.preset("MMC5983MA")
SETUP = mc.Setup.paper(tip_radius=5e-5)


def test_load_scripts_hold_each_step_and_refuse_bad_ones() -> None:
    script = LoadScript.from_steps([(0.0, [0.0, 0.0]), (1.0, [1e-5, 2e-5])])
    loads = script.loads(np.array([0.0, 0.99, 1.0, 5.0]))
    assert loads.shape == (4, 1, 2)
    assert loads[:, 0, 1].tolist() == [0.0, 0.0, 2e-5, 2e-5]
    assert LoadScript.constant([[1e-5, 0.0], [0.0, 1e-5]]).cilia == 2
    for steps in ([(0.5, [0.0, 0.0])], [(0.0, [0.0, 0.0]), (0.0, [1.0, 0.0])]):
        with pytest.raises(mc.MagciliaError, match="steps"):
            LoadScript.from_steps(steps)
    with pytest.raises(mc.MagciliaError, match="loads"):
        LoadScript.constant([1e-5, 0.0, 0.0])
    bad = LoadScript.from_function(2, lambda t: np.zeros((t.size, 3, 2)))
    with pytest.raises(mc.MagciliaError, match="load script"):
        bad.loads(np.zeros(2))


def test_the_demo_pushes_in_changing_directions_between_rests() -> None:
    amplitude = 1e-5
    script = LoadScript.demo(3, amplitude)
    t = np.arange(0.0, 96.0 * 2, 0.25)
    loads = script.loads(t)
    mag = np.hypot(loads[..., 0], loads[..., 1])
    levels = sorted({round(f, 6) for _, f in DEMO_STEPS})
    assert sorted(set(np.round(mag[:, 0] / amplitude, 6))) == levels
    assert np.allclose(mag[:, 0], mag[:, 1])  # every cilium pushed alike …
    pushes = mag[:, 0] > 0
    angle = np.degrees(np.arctan2(loads[pushes, 0, 1], loads[pushes, 0, 0]))
    assert len(np.unique(np.round(angle, 3))) >= 8  # … in directions that change
    neighbour = np.degrees(np.arctan2(loads[pushes, 1, 1], loads[pushes, 1, 0]))
    assert np.allclose((neighbour - angle) % 360.0, 22.5)
    assert np.allclose(loads[: t.size // 2], loads[t.size // 2:])  # the pattern repeats (96 s)


def test_single_cilium_is_the_elastica_and_the_setups_field() -> None:
    field = single_cilium(SETUP, PART)
    force = np.array([[3e-5, -4e-5]])
    expected = SETUP.field(mc.bend(SETUP, 5e-5), azimuth=math.atan2(-4e-5, 3e-5))
    assert np.allclose(field(force), expected, rtol=1e-12, atol=1e-15)
    assert np.allclose(field(np.zeros((1, 2))), SETUP.field(mc.bend(SETUP)))


def test_the_parts_report_noisy_quantised_readings_deterministically() -> None:
    calls: list[int] = []

    def model(loads: np.ndarray) -> np.ndarray:
        calls.append(1)
        return np.full((1, 3), 1e-4) + loads[0, 0]

    script = LoadScript.from_steps([(0.0, [0.0, 0.0]), (0.5, [1e-6, 0.0])])
    reads = []
    for _ in range(2):
        source = SimulatedFieldSource(PART, model, script, rng=3, drift=1e-8, bias=2e-5)
        with source:
            reads.append(source.read(100))
    a, b = reads
    assert np.array_equal(a.data, b.data)  # the seed repeats the samples
    assert [c.name for c in a.channels] == [f"{PART.name}.{k}" for k in "xyz"]
    assert np.allclose(a.data / PART.resolution[0], np.round(a.data / PART.resolution[0]))
    before = a.data[:, :50] - (1.2e-4 + 1e-8 * a.time[:50])
    assert np.std(before) == pytest.approx(PART.noise[0], rel=0.25)
    assert np.mean(a.data[:, 50:]) - np.mean(a.data[:, :50]) == pytest.approx(1e-6, abs=2e-8)
    assert sum(calls) == 4  # two distinct loads per run: each solved once


def test_a_field_model_of_the_wrong_shape_is_named() -> None:
    source = SimulatedFieldSource(PART, lambda loads: np.zeros(3), LoadScript.constant([0, 0]))
    with pytest.raises(mc.MagciliaError, match="field model"):
        source.open()
