"""Honest over time: a tare under load is refused (or, as the first tare, kept and flagged),
zero tracking follows a slow drift for ten minutes or flags it, per channel, and σ includes what
the zero may have drifted. Seeded simulations, run faster than real time (no wall clock)."""

from __future__ import annotations

import time

import numpy as np
import pytest

import magcilia as mc
from magcilia._errors import MagciliaError
from magcilia.acquire import Script, SimulatedSource
from magcilia.cli._live import demo_script
from magcilia.live import LiveReadout
from magcilia.live.zero import Zero
from magcilia.readout.protocol import Flag

SETUP = mc.Setup.paper(tip_radius=5e-5)
SPAN = (-3e-4, 3e-4)


def _run(live: LiveReadout, outputs: int, timeout: float = 120.0) -> None:
    """Let a read-out of a source that is not paced produce ``outputs`` values (the timeout
    only guards against a hang)."""
    deadline = time.monotonic() + timeout
    while live.history.total < outputs:
        if time.monotonic() > deadline or not live.running:
            pytest.fail(f"{live.history.total} of {outputs} outputs ({live.status.report()})")
        time.sleep(0.005)


# -- Zero -------------------------------------------------------------------------------------
def test_zero_follows_a_drift_without_lag_and_knows_its_rate() -> None:
    rng = np.random.default_rng(1)
    zero = Zero(rest=0.0, tau=30.0)
    noise, dt, rate = 5e-6, 1e-3, 2e-7
    assert zero.tare(rng.normal(0.0, noise, 500), at=0.5, dt=dt)
    t = 0.5
    for _ in range(1200):  # 120 s in batches of 0.1 s
        x = rate * (t + dt * np.arange(1, 101)) + rng.normal(0.0, noise, 100)
        t += 0.1
        zero.track(x, dt, at=t)
    assert zero.rate == pytest.approx(rate, rel=0.1)
    assert abs(zero.correction + rate * t) < 3 * zero.sigma + 1e-7
    assert zero.sigma < noise / 10 and zero.flags == 0


def test_zero_flags_drift_it_cannot_follow_and_sigma_grows() -> None:
    """A load that never returns to rest: the correction holds, σ grows with the time since the
    last rest × the drift rate, and ZERO_DRIFT is raised once σ exceeds the noise."""
    rng = np.random.default_rng(2)
    zero = Zero(rest=0.0, tau=30.0)
    noise, dt, rate = 5e-6, 1e-3, 2e-7
    zero.tare(rng.normal(0.0, noise, 500), at=0.5, dt=dt)
    t = 0.5
    for _ in range(600):  # 60 s at rest: the rate is learned
        t += 0.1
        zero.track(rate * t + rng.normal(0.0, noise, 100), dt, at=t)
    held, sigmas = zero.correction, []
    for _ in range(1200):  # then loaded by 50 noise σ for 120 s
        t += 0.1
        zero.track(rate * t + 50 * noise + rng.normal(0.0, noise, 100), dt, at=t)
        sigmas.append(zero.sigma)
    assert zero.correction == held  # the load is not tracked away
    assert sigmas[-1] > sigmas[100] > sigmas[0]
    assert sigmas[-1] == pytest.approx(rate * 120.0, rel=0.15)  # the drift not yet tracked
    assert zero.flags & Flag.ZERO_DRIFT
    assert zero.total_noise(noise) == pytest.approx(np.hypot(noise, zero.sigma))
    for _ in range(50):  # back at rest: recognised around the predicted zero, flag cleared
        t += 0.1
        zero.track(rate * t + rng.normal(0.0, noise, 100), dt, at=t)
    assert zero.flags == 0
    assert abs(zero.correction + rate * t) < 3 * noise / 10


def test_zero_tracks_each_channel() -> None:
    """Three field channels (T) drifting at different rates, one of them loaded: each follows
    its own drift; the loaded one holds."""
    rng = np.random.default_rng(3)
    rest = np.array([2e-5, 0.0, 4e-5])
    rates = np.array([1e-10, -2e-10, 0.0])
    noise = 1e-8
    zero = Zero(rest, tau=20.0, unit="T", names=("s.x", "s.y", "s.z"))
    zero.tare(rest + 1e-6 + rng.normal(0.0, noise, (300, 3)), at=0.3, dt=1e-3)
    t = 0.3
    for _ in range(600):
        t += 0.1
        b = rest + 1e-6 + rates * t + rng.normal(0.0, noise, (100, 3))
        b[:, 2] += 0.0 if t < 20 else 5e-7  # channel z loaded from 20 s on
        zero.track(b, 1e-3, at=t)
    truth = -(1e-6 + rates * t)
    np.testing.assert_allclose(zero.correction[:2], truth[:2], atol=3e-9)
    assert zero.channel_flags[:2].tolist() == [0, 0]
    np.testing.assert_allclose(zero.rate[:2], rates[:2], rtol=0.2)
    with pytest.raises(MagciliaError, match=r"shape \(m, 3\)"):
        zero.track(np.zeros(5), 1e-3)


def test_zero_refuses_a_tare_under_load_while_a_good_one_is_in_use() -> None:
    rng = np.random.default_rng(4)
    zero = Zero(rest=1e-3, tau=30.0)
    quiet = 1.3e-3 + rng.normal(0.0, 5e-6, 500)
    assert zero.tare(quiet, at=0.5, dt=1e-3) and zero.notice == "" and zero.flags == 0
    before = zero.correction
    step = 1.3e-3 + rng.normal(0.0, 5e-6, 500) + np.where(np.arange(500) < 250, 0.0, 2e-4)
    assert not zero.tare(step, at=1.0, dt=1e-3)
    assert zero.correction == before and zero.flags == 0
    assert zero.notice.startswith("tare refused: the window was not at rest (noise")
    assert "the previous tare stays" in zero.notice


def test_a_first_tare_under_load_is_kept_and_flagged_until_a_good_one() -> None:
    rng = np.random.default_rng(5)
    zero = Zero(rest=1e-3, tau=30.0)
    step = 1.3e-3 + rng.normal(0.0, 5e-6, 500) + np.where(np.arange(500) < 250, 0.0, 2e-4)
    assert zero.tare(step, at=0.5, dt=1e-3)
    assert zero.under_load and zero.flags & Flag.TARE_UNDER_LOAD
    assert "TARE_UNDER_LOAD" in zero.notice
    assert zero.tare(1.3e-3 + rng.normal(0.0, 5e-6, 500), at=1.0, dt=1e-3)
    assert not zero.under_load and zero.flags == 0 and zero.notice == ""


def test_zero_state_round_trips() -> None:
    rng = np.random.default_rng(6)
    zero = Zero(rest=[0.0, 1e-5], tau=10.0, unit="T")
    zero.tare(rng.normal(0.0, 1e-8, (200, 2)), at=0.2, dt=1e-3)
    zero.track(rng.normal(0.0, 1e-8, (100, 2)), 1e-3, at=0.3)
    back = Zero.from_state(zero.state())
    b = rng.normal(0.0, 1e-8, (100, 2))
    zero.track(b, 1e-3, at=0.4)
    back.track(b, 1e-3, at=0.4)
    np.testing.assert_array_equal(back.correction, zero.correction)
    np.testing.assert_array_equal(back.sigma, zero.sigma)
    with pytest.raises(MagciliaError, match="zero-tracking state"):
        Zero.from_state({"rest": [0.0]})


# -- the live read-out --------------------------------------------------------------------------
def _pushing(after: float) -> Script:
    """Rest until ``after`` s, then pushed on and off every 0.1 s: every tare window after it
    holds load steps, whenever it is taken."""
    def value(t: np.ndarray) -> np.ndarray:
        return np.where((t >= after) & (np.mod(t - after, 0.2) < 0.1), 1e-4, 0.0)
    return Script.from_function(value, "force")


def test_a_tare_during_load_steps_is_refused_and_said() -> None:
    readout = mc.Readout(SETUP, "force", span=SPAN)
    source = SimulatedSource(SETUP, _pushing(2.0), rate=2000.0, rng=0, readout_noise=2e-5,
                             bias=3e-4)
    with LiveReadout(source, readout, rate=200, tare_at_start=True, history=100) as live:
        _run(live, 600)  # 3 s: the first tare (0–0.5 s, at rest) taken
        correction = live.zero.correction
        assert live.zero.baseline is not None and live.zero.baseline.at_rest
        assert live.tare(wait=30.0)  # the request is answered …
        status = live.status
    assert status.message.startswith("tare refused: the window was not at rest")  # … refused
    assert live.zero.correction == pytest.approx(correction, abs=1e-5)  # the old one stays
    assert [e.text.startswith("tare refused") for e in live.events if e.kind == "tare"] == [
        False, True]
    assert not (live.history.since(0)[0].flags & Flag.TARE_UNDER_LOAD).any()


def test_a_first_tare_under_load_flags_every_estimate() -> None:
    readout = mc.Readout(SETUP, "force", span=SPAN)
    source = SimulatedSource(SETUP, _pushing(0.0), rate=2000.0, rng=0, readout_noise=2e-5,
                             bias=3e-4)
    with LiveReadout(source, readout, rate=200, tare_at_start=True, history=100) as live:
        _run(live, 400)
        status = live.status
    s = live.history.since(0)[0]
    after = s.time > s.time[0] + 0.6  # after the tare
    assert (s.flags[after] & Flag.TARE_UNDER_LOAD).all()
    assert "tare taken under load" in status.message
    # the flag is a warning: the estimates are still there
    assert np.isfinite(s.value[after & ((s.flags & ~np.uint16(Flag.TARE_UNDER_LOAD)) == 0)]).all()


def test_ten_minutes_of_the_drifting_simulation_stay_within_2_sigma_at_rest() -> None:
    """The issue's run, faster than real time: the default simulation's pushes and its drift of
    0.2 µV/s (120 µV in 10 min, ~40 noise σ of a reading), read at 10 Hz. In every minute the
    mean of the readings at rest (0.3 s away from steps) lies within 2σ of the scripted 0, or
    they are flagged ZERO_DRIFT. Before this, tracking froze and rest read 16σ off."""
    readout = mc.Readout(SETUP, "force", span=SPAN)
    script = demo_script("force", 2.4e-4)
    source = SimulatedSource(SETUP, script, rate=1000.0, rng=0, bias=3e-4, readout_noise=2e-5,
                             drift=2e-7)
    with LiveReadout(source, readout, rate=10, batch=0.5, tare_at_start=True,
                     history=700) as live:
        _run(live, 6000)
    s = live.history.since(0)[0]
    t = s.time - s.time[0] + 0.05
    truth = script.values(t)
    edges = np.array([0.0, 3.0, 5.0, 7.0, 9.0, 10.0, 12.0])
    far = np.min(np.abs(np.mod(t, 12.0)[:, None] - edges[None, :]), axis=1) > 0.3
    rest = (truth == 0.0) & far
    drifted = (s.correction[-1] - s.correction[10]) / (t[-1] - t[10])
    assert drifted == pytest.approx(-2e-7, rel=0.1)  # zero tracking followed the drift
    for minute in range(10):
        m = rest & (t >= 60 * minute) & (t < 60 * (minute + 1))
        flagged = (s.flags[m] & Flag.ZERO_DRIFT) != 0
        good = m.copy()
        good[m] = ~flagged
        if good.sum() < 10:
            continue  # flagged: the read-out said it could not follow
        mean, sigma = float(np.mean(s.value[good])), float(np.median(s.sigma[good]))
        assert abs(mean) < 2 * sigma, (minute, mean, sigma)
