"""The pure parts of the live read-out: averaging windows, tare/zero tracking, the History ring."""

from __future__ import annotations

import dataclasses
import threading

import numpy as np
import pytest

from magcilia._errors import MagciliaError
from magcilia.io.recordings import reading
from magcilia.live import Averager, History, LiveSamples, Zero
from magcilia.live.history import COLUMNS
from magcilia.live.zero import difference_noise


def test_averages_are_window_means() -> None:
    t = np.arange(40) / 1e4
    x = np.random.default_rng(0).normal(size=40)
    w = Averager(10).push(t, x, np.zeros(40, bool))
    np.testing.assert_allclose(w.volts, x.reshape(4, 10).mean(axis=1))
    np.testing.assert_allclose(w.time, t.reshape(4, 10).mean(axis=1))
    assert not w.beyond.any()


def test_a_window_is_beyond_range_if_any_sample_is() -> None:
    beyond = np.zeros(30, bool)
    beyond[13] = True
    w = Averager(10).push(np.arange(30.0), np.zeros(30), beyond)
    assert w.beyond.tolist() == [False, True, False]


def test_samples_must_fill_whole_windows() -> None:
    with pytest.raises(MagciliaError, match="multiple of the window"):
        Averager(10).push(np.arange(15.0), np.zeros(15), np.zeros(15, bool))


def test_set_reset_windows_match_the_recordings_reading() -> None:
    """A window holding both polarities gives (mean set − mean reset)/2 + offset, the same as a
    recording's reading of those samples."""
    rng = np.random.default_rng(1)
    sr = np.tile(np.repeat(np.array([1, -1], np.int8), 5), 4)  # 5 set, 5 reset per window
    offset, bias, signal = 2e-3, 7e-4, 3e-4
    x = sr * signal + offset + bias + rng.normal(0, 1e-5, sr.size)
    w = Averager(10, offset=offset).push(np.arange(40.0), x, np.zeros(40, bool), sr)
    expected = [reading(x[i:i + 10], sr[i:i + 10])[0] + offset for i in range(0, 40, 10)]
    np.testing.assert_allclose(w.volts, expected)
    np.testing.assert_allclose(w.volts, offset + signal, atol=2e-5)  # the bias is gone


def test_a_window_of_one_polarity_pairs_with_the_last_other_mean() -> None:
    """Pulses every 20 samples, windows of 10: each window sees one polarity and holds the
    other's last mean, across calls."""
    avg = Averager(10)
    sr = np.repeat(np.array([1, -1, 1, -1], np.int8), 20)
    x = np.where(sr > 0, 1.0, -1.0) * np.repeat([1.0, 1.0, 2.0, 2.0], 20)
    first = avg.push(np.arange(40.0), x[:40], np.zeros(40, bool), sr[:40])
    assert np.isnan(first.volts[:2]).all()  # no reset mean yet
    np.testing.assert_allclose(first.volts[2:], 1.0)
    second = avg.push(np.arange(40.0, 80.0), x[40:], np.zeros(40, bool), sr[40:])
    np.testing.assert_allclose(second.volts, [1.5, 1.5, 2.0, 2.0])
    avg.reset()
    assert np.isnan(avg.push(np.arange(10.0), x[:10], np.zeros(10, bool), sr[:10]).volts).all()


def test_tare_zeroes_the_mean_and_measures_the_noise() -> None:
    zero = Zero(rest=3.2e-3, tau=None)
    readings = 3.5e-3 + np.random.default_rng(2).normal(0, 1e-5, 500)
    zero.tare(readings, at=1.0)
    assert readings.mean() + zero.correction == pytest.approx(3.2e-3)
    assert zero.noise == pytest.approx(1e-5, rel=0.1)
    assert zero.tared_at == 1.0
    with pytest.raises(MagciliaError, match="at least 2 finite"):
        zero.tare(np.array([np.nan, 1.0]), at=2.0)


def test_zero_tracking_follows_slow_drift_but_not_a_load() -> None:
    """Drift of 10 µV over 100 s is followed within a few µV (tau 10 s); a load of 20 noise
    sigma is left alone."""
    rng = np.random.default_rng(3)
    zero = Zero(rest=0.0, tau=10.0, band=3.0)
    dt, noise = 1e-3, 2e-6
    zero.tare(rng.normal(0, noise, 500), at=0.0)
    t = np.arange(100_000) * dt
    drift = 1e-7 * t
    x = drift + rng.normal(0, noise, t.size)
    for i in range(0, t.size, 5):
        zero.track(x[i:i + 5], dt)
    assert zero.correction + drift[-1] == pytest.approx(0.0, abs=2.5e-6)
    assert zero.drift == pytest.approx(zero.correction, abs=1e-6)
    before = zero.correction
    loaded = drift[-1] + 20 * noise + rng.normal(0, noise, 5000)
    for i in range(0, loaded.size, 5):
        zero.track(loaded[i:i + 5], dt)
    assert zero.correction == pytest.approx(before, abs=1e-8)


def test_no_tracking_before_a_tare_or_when_off() -> None:
    zero = Zero(rest=0.0, tau=1.0)
    zero.track(np.full(5, 1e-6), 1e-3)
    assert zero.correction == 0.0
    off = Zero(rest=0.0, tau=None)
    off.tare(np.array([0.0, 1e-6]), at=0.0)
    c = off.correction
    off.track(np.full(5, 1e-6), 1e-3)
    assert off.correction == c


def _columns(start: int, m: int) -> np.ndarray:
    cols = np.zeros((len(COLUMNS), m))
    cols[0] = np.arange(start, start + m)
    return cols


def test_history_hands_each_view_what_it_has_not_seen() -> None:
    h = History("force", "N", 10)
    h.append(_columns(0, 4))
    a, cursor_a, lost = h.since(0)
    assert a.time.tolist() == [0, 1, 2, 3] and cursor_a == 4 and lost == 0
    h.append(_columns(4, 3))
    b, cursor_b, _ = h.since(cursor_a)
    assert b.time.tolist() == [4, 5, 6] and cursor_b == 7
    h.append(_columns(7, 8))  # a view at cursor 7 lost nothing, one at 0 lost 5
    assert h.since(7)[0].time.tolist() == list(range(7, 15))
    assert h.since(0)[2] == 5
    assert h.since(7, limit=3)[0].time.tolist() == [12, 13, 14]
    assert h.last(0.004, 1000.0).time.tolist() == [11, 12, 13, 14]


def test_history_keeps_the_newest_of_an_oversized_append() -> None:
    h = History("angle", "rad", 4)
    h.append(_columns(0, 9))
    assert h.total == 9 and h.since(0)[0].time.tolist() == [5, 6, 7, 8]


def test_history_wait_wakes_on_append() -> None:
    h = History("angle", "rad", 8)
    timer = threading.Timer(0.05, h.append, args=(_columns(0, 1),))
    timer.start()
    assert h.wait(0, 60.0)  # wakes on the append; 60 s only guards against a hang
    timer.join()
    assert not h.wait(1, 0.01)


def test_live_samples_are_frozen_arrays_in_column_order() -> None:
    assert tuple(f.name for f in dataclasses.fields(LiveSamples))[2:] == COLUMNS
    s = History("force", "N", 4).since(0)[0]
    with pytest.raises(ValueError, match="read-only"):
        s.value[...] = 1.0
    assert s.report() == "no force samples"


def test_difference_noise_ignores_slow_signals_and_steps() -> None:
    rng = np.random.default_rng(4)
    white = rng.normal(0, 1e-5, 4000)
    ramp = np.linspace(0, 1e-3, 4000) + np.where(np.arange(4000) > 2000, 5e-4, 0.0)
    assert difference_noise(white) == pytest.approx(1e-5, rel=0.05)
    assert difference_noise(white + ramp) == pytest.approx(1e-5, rel=0.05)
    assert np.isnan(difference_noise(np.array([1.0, np.nan, 2.0])))
