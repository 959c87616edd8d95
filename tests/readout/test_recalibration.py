"""In-use re-calibration: what each window kind determines (exact model windows), a simulated
drift tracked within 2σ, a read-out that stays on the true load where the plain one drifts away,
and pulse samples that never become force values."""

from __future__ import annotations

import math
import re
from typing import Any

import numpy as np
import pytest

import magcilia as mc
from magcilia.acquire import Script
from magcilia.acquire.simulated_coil import (
    ACTUATION_COLUMNS,
    CoilPulses,
    Drifts,
    SimulatedCoilSource,
)
from magcilia.readout.recalibration import NAMES, Recalibrator
from magcilia.readout.recalibration_stream import PulseTracker
from magcilia.readout.recalibration_windows import PulseWindow, RestWindow, StrapWindow

SETUP = mc.presets.load("force-sensor")
SPAN = (-5e-6, 5e-6)
SECONDS = 60.0
#: 1 s unloaded, then 4 s of a load, repeated, N
LOADS = sorted([(0.0, 0.0)] + [(5.0 * i + 1.0, f) for i, f in enumerate(
    [2e-6, -1e-6, 3e-6, 1.5e-6, -2e-6, 2.5e-6, 1e-6, -0.5e-6, 3e-6, 2e-6, -1.5e-6, 2.5e-6])]
    + [(5.0 * i, 0.0) for i in range(1, 12)])
DRIFT = {"sensitivity": -0.03, "magnetization": -0.05, "offset": 0.5e-3, "stiffness": 0.0}
WALK = {"offset": 2e-5, "sensitivity": 2e-3, "magnetization": 2e-3, "stiffness": 2e-3}


@pytest.fixture(scope="module")
def recalibrator() -> Recalibrator:
    return Recalibrator(SETUP, span=SPAN, hold=())


def _windows(rc: Recalibrator, theta: np.ndarray, kinds: str) -> list[Any]:
    """Noise-free windows of the model at ``theta`` = (o, s, m, k), 1 µV s.e. each."""
    out: list[Any] = []
    for i, kind in enumerate(kinds):
        if kind in "xyz":
            b = np.zeros(3)
            b["xyz".index(kind)] = 5e-4
            probe = PulseWindow((b[0], b[1], b[2]), 0.0, 1e-6, 0.0, 1e-6, float(i),
                                offset_free=True)
            step = rc.predict([probe], theta)[0][0]
            out.append(PulseWindow((b[0], b[1], b[2]), 0.0, 1e-6, step, 1e-6, float(i),
                                   offset_free=True))
        elif kind == "s":
            o = theta[0]
            out.append(StrapWindow(o + 1e-3, 1e-6, o - 1e-3, 1e-6, float(i)))
        else:
            level = rc.predict([RestWindow(0.0, 1e-6)], theta)[0][0]
            out.append(RestWindow(level, 1e-6, float(i)))
    return out


@pytest.mark.parametrize(("kinds", "determined"), [
    ("xx", {"sensitivity"}),  # the direct field; the hair's share too small to say M
    ("yy", {"magnetization"}),  # s·m²/k alone: the sensitivity held
    ("xyxy", {"sensitivity", "magnetization"}),  # M²/k, the stiffness held
    ("zz", set()),  # no couple on a straight hair, no direct field on a single x axis
    ("ss", {"offset"}),  # the strap: the offset, which no coil pulse sees
    ("xyxyssrr", set(NAMES)),  # rest levels ∝ M separate M from the stiffness
])
def test_what_each_window_kind_determines(recalibrator: Recalibrator, kinds: str,
                                          determined: set[str]) -> None:
    start = recalibrator.start()
    truth = np.array([{"offset": 1.2e-3, "sensitivity": 0.97, "magnetization": 0.95,
                       "stiffness": 1.04}[n] if n in determined else start.values[n]
                      for n in NAMES])  # what stays held is where it was
    windows = _windows(recalibrator, truth, kinds)
    state = recalibrator.update(windows)
    assert set(state.determined) == determined
    assert set(state.held) == set(NAMES) - determined and all(state.held.values())
    for i, name in enumerate(NAMES):
        if name in determined:
            assert state.values[name] == pytest.approx(truth[i], rel=1e-6, abs=1e-9)
            assert 0.0 < state.sigma[name] < (1e-5 if name == "offset" else 0.05)
        else:  # held where it was
            assert state.values[name] == recalibrator.start().values[name]


def test_g_is_the_model_and_z_exerts_no_couple(recalibrator: Recalibrator) -> None:
    """g against mc.bend + Setup.field directly (an independent finite difference of 2 G)."""
    s = SETUP.resolve_layout()
    rest = s.field(mc.bend(s, 0.0))[0, 0]
    for axis in range(2):
        b = np.zeros(3)
        b[axis] = 2e-4
        g = (s.field(mc.bend(s, 0.0, actuation=mc.Actuation.uniform(b)))[0, 0] - rest) / 2e-4
        assert recalibrator.g[axis] == pytest.approx(g, rel=1e-2)  # (1 G against 2 G)
        exact = recalibrator.response(b, recalibrator.rest_field)
        assert exact == pytest.approx(g * 2e-4, rel=1e-9)
    assert abs(recalibrator.g[2]) < 1e-12 and abs(recalibrator.g[1]) > 1e-4
    assert recalibrator.rest_field == pytest.approx(rest, rel=1e-12)


@pytest.fixture(scope="module")
def drifted_run(recalibrator: Recalibrator) -> dict[str, Any]:
    """60 s of the force-sensor cilium drifting (S −3 %, M −5 %, offset +0.5 mV), pulses every
    second, rest windows in the unloaded seconds; read with and without re-calibration."""
    source = SimulatedCoilSource(
        SETUP, Script.from_steps(LOADS, "force"), rng=3, readout_noise=2e-5, set_reset=10,
        pulses=CoilPulses(every=1.0, duration=0.1, amplitude=5e-4, start=0.5),
        drifts=Drifts(DRIFT["sensitivity"] / SECONDS, DRIFT["magnetization"] / SECONDS),
        drift=DRIFT["offset"] / SECONDS)
    tracker = PulseTracker(recalibrator, walk=WALK)
    o0 = SETUP.sensor.offset
    states, rows, masks, fields = [], [], [], []
    with source:
        for _ in range(int(SECONDS / 0.5)):
            block = source.read(500)
            applied = np.column_stack([block[c] for c in ACTUATION_COLUMNS])
            out, mask = tracker.push(block.time, block["output"], applied, block.setreset)
            assert block.setreset is not None
            masks.append(mask)
            fields.append(applied)
            off = (block.time % 5.0 >= 0.2) & (block.time % 5.0 < 1.0) & ~mask
            if off.sum() >= 100:
                tracker.rest(block.time[off], block["output"][off], block.setreset[off])
            states.append(tracker.state)
            p = block.setreset.astype(float)
            for i in range(0, 500, 100):
                part = slice(i, i + 100)
                if not mask[part].any():
                    rows.append((float(block.time[part].mean()),
                                 o0 + float(np.mean(p[part] * out[part])), tracker.state))
    return {"states": states, "rows": rows, "tracker": tracker, "mask": np.concatenate(masks),
            "applied": np.concatenate(fields)}


def _truth(name: str, t: float) -> float:
    change = DRIFT[name] * t / SECONDS
    return change if name == "offset" else 1.0 + change


def test_a_drift_is_tracked_within_2_sigma(drifted_run: dict[str, Any]) -> None:
    states = [s for s in drifted_run["states"] if s.time > 5.0]
    for name in NAMES:
        z = np.array([(s.values[name] - _truth(name, s.time)) / s.sigma[name] for s in states])
        assert np.mean(np.abs(z) <= 2.0) >= 0.9, (name, z)
        assert abs(z[-1]) <= 2.0, (name, z[-1])
    final = drifted_run["states"][-1]
    assert final.change("sensitivity") == pytest.approx(-0.03, abs=0.002)
    assert final.change("magnetization") == pytest.approx(-0.05, abs=0.01)
    assert final.change("offset") == pytest.approx(0.5e-3, abs=0.03e-3)
    assert re.fullmatch(r"recal 3 s ago: S −[23]\.\d±0\.\d %, M −[45]\.\d±0\.\d %, "
                        r"E [+−][0-4]\.\d±\d\.\d %, offset \+0\.[45]\d±0\.0\d mV",
                        final.status_text(final.time + 3.0)), final.status_text(final.time + 3)


def test_the_recalibrated_readout_stays_on_the_load_where_the_plain_one_drifts(
        drifted_run: dict[str, Any]) -> None:
    rows = drifted_run["rows"]
    t = np.array([r[0] for r in rows])
    level = np.array([r[1] for r in rows])
    truth = Script.from_steps(LOADS, "force").values(t)
    readout = mc.Readout(SETUP, "force", span=(-2e-5, 2e-5))
    readout = readout.tare(level[(t >= 0.2) & (t < 1.0)])
    plain = readout.read(level)
    fixed = [r[2].read(readout, np.array([r[1]]), offset=SETUP.sensor.offset) for r in rows]
    value = np.array([f[0][0] for f in fixed])
    sigma = np.array([f[1][0] for f in fixed])
    late = t > 5.0
    z_fixed = (value - truth) / sigma
    assert np.mean(np.abs(z_fixed[late]) <= 2.0) >= 0.95
    assert np.all(sigma[late] < 2e-6)  # a read-out, not an error bar the size of the span
    z_plain = (np.asarray(plain.value) - truth) / np.asarray(plain.sigma_noise)
    end = t > SECONDS - 20.0  # drifted away: many σ off, or beyond the span altogether
    assert np.all(~(np.abs(z_plain[end]) < 10.0))
    print(f"within 2σ after 5 s: recalibrated {np.mean(np.abs(z_fixed[late]) <= 2):.1%}, "
          f"plain {np.mean(np.abs(z_plain[late]) <= 2):.1%}")


def test_pulse_samples_are_masked_and_never_read(drifted_run: dict[str, Any]) -> None:
    applied, mask = drifted_run["applied"], drifted_run["mask"]
    pulsed = np.any(applied != 0.0, axis=1)
    assert pulsed.sum() > 0 and np.all(mask[pulsed])  # every pulse sample is masked
    assert mask.sum() < 1.5 * pulsed.sum()  # and little else (the hair's return)
    tracker = drifted_run["tracker"]
    assert tracker.updates > 50 and tracker.rejected < 0.3 * tracker.updates
    assert drifted_run["rows"]  # readings came only from unmasked windows (see the fixture)


def test_a_load_that_moves_during_a_pulse_is_left_out(recalibrator: Recalibrator) -> None:
    rate = 1000.0
    t = np.arange(3000) / rate
    applied = np.zeros((t.size, 3))
    applied[(t >= 1.0) & (t < 1.1), 0] = 5e-4
    volts = 1e-3 * (t >= 1.05) + 1e-6 * np.random.default_rng(0).standard_normal(t.size)
    tracker = PulseTracker(recalibrator)
    out, mask = tracker.push(t, volts, applied)
    assert tracker.rejected == 1 and tracker.updates == 0
    assert np.all(mask[(t >= 1.0) & (t < 1.12)]) and not mask[t < 1.0].any()
    assert np.all(np.abs(out[mask]) < 1e-5)  # held at the level before, never the pulse's


def test_bad_windows_are_one_line(recalibrator: Recalibrator) -> None:
    with pytest.raises(mc.MagciliaError, match="window σ must be positive"):
        recalibrator.update([RestWindow(0.1, 0.0)])
    with pytest.raises(mc.MagciliaError, match="tip_radius"):
        Recalibrator(mc.Setup.paper())
    state = recalibrator.start()
    assert state.windows == 0 and recalibrator.update([], state) is state
    assert math.isnan(state.chi2) and "held" in state.report()
