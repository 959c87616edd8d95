"""``SimulatedSource(..., dynamics=True)``: the simulated hair moves through its bending modes."""

from __future__ import annotations

import numpy as np
import pytest

import magcilia as mc
from magcilia.acquire import Script, SimulatedSource
from magcilia.mechanics import output_at

SETUP = mc.presets.load("force-sensor")
RATE = 10_000.0
STEPS = Script.from_steps([(0.0, 0.0), (0.01, 8e-6), (0.03, -4e-6)], "force")


def _read(dynamics: bool, sizes: tuple[int, ...] = (600,), script: Script = STEPS) -> np.ndarray:
    with SimulatedSource(SETUP, script, rate=RATE, rng=4, dynamics=dynamics,
                         fluid=mc.AIR) as source:
        return np.concatenate([source.read(n).data[0] for n in sizes])


def test_the_hair_rings_on_steps_as_the_forward_model_says() -> None:
    """The same noise (one seed) on the static and the moving hair: their difference is the
    forward model's output less the static one's, sample for sample."""
    moving, still = _read(True), _read(False)
    t = np.arange(600) / RATE
    loads = STEPS.values(t)
    want = mc.simulate_response(SETUP.resolve_layout(), loads, RATE, fluid=mc.AIR).output \
        - output_at(SETUP.resolve_layout(), "force", loads)
    scale = np.ptp(output_at(SETUP, "force", [0.0, 8e-6]))
    assert np.allclose(moving - still, want, rtol=0, atol=1e-4 * scale)
    assert np.max(np.abs(want[100:300])) > 0.5 * scale  # it rings by about the step itself


def test_reads_in_blocks_continue_the_motion() -> None:
    assert np.allclose(_read(True, (600,)), _read(True, (17, 250, 333)), rtol=0, atol=1e-15)


def test_set_value_steps_ring_too() -> None:
    with SimulatedSource(SETUP, Script.constant(0.0, "force"), rate=RATE, rng=0,
                         dynamics=True, readout_noise=0.0) as source:
        source.read(10)
        source.set_value(5e-6)
        ringing = source.read(200).data[0]
    assert np.ptp(ringing[100:]) > 0.5 * np.ptp(output_at(SETUP, "force", [0.0, 5e-6]))


def test_metadata_and_bad_fluid() -> None:
    source = SimulatedSource(SETUP, STEPS, rate=RATE, dynamics=True, fluid=mc.WATER)
    meta = source.metadata()
    assert meta["dynamics"] is True and meta["fluid"] == "water"
    assert SimulatedSource(SETUP, STEPS).metadata()["dynamics"] is False
    with pytest.raises(mc.MagciliaError, match="fluid must be"):
        SimulatedSource(SETUP, STEPS, dynamics=True, fluid="air")  # type: ignore[arg-type]
