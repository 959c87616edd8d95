"""The tare's rest check: a window with a load step or a trend is not at rest; a window of the
simulated bench at rest is (noise, 1/f noise and drift included)."""

from __future__ import annotations

import numpy as np
import pytest

import magcilia as mc
from magcilia.acquire import Script, SimulatedSource
from magcilia.readout.tare import NOISE_RATIO, RestCheck, Tare, difference_noise, rest_check

SETUP = mc.Setup.paper(tip_radius=5e-5)


def _bench_readings(script: Script, seconds: float, rng: int = 0) -> np.ndarray:
    """Readings of the default live simulation (10 kHz, 10 samples per reading: 1 kHz), V."""
    src = SimulatedSource(SETUP, script, rate=10000.0, rng=rng, bias=3e-4, readout_noise=2e-5,
                          drift=2e-7)
    n = round(seconds * 10000)
    return src.read(n).data[0].reshape(-1, 10).mean(axis=1)


def test_windows_of_the_bench_at_rest_pass() -> None:
    """60 s of 0.5 s windows at rest (white and 1/f noise, 0.2 µV/s drift): none refused."""
    x = _bench_readings(Script.constant(0.0, "force"), 60.0)
    model = SETUP.sensor.output_noise_rms(0.1, 500.0)
    checks = [rest_check(w, model) for w in x.reshape(-1, 500)]
    assert all(c.at_rest for c in checks)
    assert max(float(c.noise / c.reference) for c in checks) < NOISE_RATIO


def test_the_simulations_load_step_in_the_window_is_not_at_rest() -> None:
    """The case of the issue: a tare window across the demo's push at 3 s (a step of half the
    range) has many times the rest noise; the reason names it."""
    step = Script.from_steps([(0.0, 0.0), (3.0, 1.0e-4)], "force")
    x = _bench_readings(step, 3.5)
    rest, window = x[2000:2500], x[2750:3250]  # 2.0–2.5 s, and 2.75–3.25 s across the step
    good = rest_check(rest)
    bad = rest_check(window, good.noise)
    assert good.at_rest
    assert not bad.at_rest and bad.noisy.all()
    assert bad.noise / good.noise > 10  # the issue saw 24×: 166 vs 6.8 µV
    assert "not at rest" in bad.reason and "× the rest noise" in bad.reason


def test_a_slow_push_is_a_trend_and_a_small_step_is_noise() -> None:
    rng = np.random.default_rng(4)
    n, sigma = 500, 1e-5
    white = rng.normal(0.0, sigma, n)
    # a ramp of 2 σ over the window: within the noise ratio, beyond 5 standard errors of a trend
    ramp = rest_check(white + np.linspace(0.0, 2 * sigma, n), sigma)
    assert not ramp.noisy.any() and ramp.trending.all() and not ramp.at_rest
    assert "trend" in ramp.reason
    step = rest_check(white + np.where(np.arange(n) < 400, 0.0, 4 * sigma), sigma)
    assert step.noisy.all() and not step.at_rest
    assert rest_check(white, sigma).at_rest


def test_the_false_refusal_rate_of_white_noise_is_tiny() -> None:
    """2000 windows of white noise (seeded): none refused (the thresholds are 5 σ tests)."""
    rng = np.random.default_rng(5)
    windows = rng.normal(0.0, 1.0, (2000, 200))
    assert all(rest_check(w, 1.0).at_rest for w in windows)


def test_channels_are_checked_each() -> None:
    rng = np.random.default_rng(6)
    b = rng.normal(0.0, 1e-8, (300, 3)) + np.array([2e-5, 0.0, 4e-5])
    b[150:, 1] += 2e-7  # a load on one channel only
    check = rest_check(b, unit="T", names=("s.x", "s.y", "s.z"))
    assert check.noisy.tolist() == [False, True, False]
    assert not check.at_rest and "on s.y" in check.reason
    assert rest_check(b[:150], unit="T").at_rest


def test_tares_carry_their_check() -> None:
    rng = np.random.default_rng(7)
    quiet = 1e-3 + rng.normal(0.0, 1e-5, 400)
    tare = Tare.from_readings(quiet, rest=1e-3, expected_noise=1e-5)
    assert tare.at_rest and isinstance(tare.check, RestCheck)
    assert tare.to_dict()["at_rest"] is True and "NOT AT REST" not in tare.report()
    loaded = Tare.from_readings(quiet + np.where(np.arange(400) < 200, 0.0, 1e-4), rest=1e-3)
    assert not loaded.at_rest
    assert "NOT AT REST" in loaded.report() and loaded.to_dict()["rest_check"]["reason"]
    # a Tare built by hand (no check) counts as at rest
    assert Tare(rest=0.0, mean=0.0, noise=1.0, count=2).at_rest
    # Readout.tare goes through Tare.from_readings: its baseline says whether it was at rest
    r = mc.Readout(SETUP, "force", span=(-2e-4, 2e-4), table_size=17)
    assert not r.tare(quiet + np.where(np.arange(400) < 200, 0.0, 1e-4)).baseline.at_rest


def test_difference_noise_moved_here_is_the_same_function() -> None:
    from magcilia.live.zero import difference_noise as live_difference_noise

    assert live_difference_noise is difference_noise
    white = np.random.default_rng(8).normal(0.0, 1e-5, 20000)
    assert difference_noise(white) == pytest.approx(1e-5, rel=0.05)


def test_readout_tare_under_load_is_noted(tmp_path: object, capsys: pytest.CaptureFixture[str]
                                          ) -> None:
    """``magcilia readout --tare`` on readings with a load step: the estimates are written and a
    note says the tare's window was not at rest."""
    from pathlib import Path

    from magcilia.cli import main
    from magcilia.mechanics import output_at

    folder = Path(str(tmp_path))
    rng = np.random.default_rng(9)
    setup = mc.Setup.paper(tip_radius=5e-5)
    force = np.where(np.arange(1000) < 250, 0.0, 5e-5)
    volts = output_at(setup, "force", force) + rng.normal(0.0, 5e-6, force.size)
    rec = folder / "rec.csv"
    rec.write_text("voltage_V\n" + "\n".join(f"{x:.9g}" for x in volts) + "\n")
    args = ["readout", "paper", str(rec), "--quantity", "force", "--span", "0:0.2",
            "--tip-radius", "0.05mm", "--out", str(folder / "out.csv")]
    assert main([*args, "--tare", "500"]) == 0
    out = capsys.readouterr().out
    assert "note: 500: tare:" in out and "NOT AT REST" in out
    assert main([*args, "--tare", "200", "--force"]) == 0  # the same --csv again
    assert "NOT AT REST" not in capsys.readouterr().out


def test_every_read_out_flags_its_estimates_after_a_tare_under_load() -> None:
    """A tare whose window was not at rest marks every estimate TARE_UNDER_LOAD (one rule,
    readout.protocol.tare_flags), at rest none."""
    import numpy as np

    import magcilia as mc
    from magcilia.readout.protocol import Flag

    setup = mc.Setup.paper(tip_radius=5e-5)
    r = mc.Readout(setup, quantity="force", span=(0.0, 1e-4), table_size=33)
    rng = np.random.default_rng(2)
    quiet = r.rest[0] + 1e-6 * rng.standard_normal(200)
    pushed = quiet + np.linspace(0.0, 2e-4, 200)  # a load step across the window
    at_rest = r.tare(quiet).read(r.rest)
    loaded = r.tare(pushed).read(r.rest)
    assert not at_rest.flags & Flag.TARE_UNDER_LOAD
    assert (loaded.flags & Flag.TARE_UNDER_LOAD).all()
    mag = mc.Magnetometer(field_range=1e-3, resolution=1e-10, noise=2e-8, rate=100.0, name="m")
    b = mc.BiaxialReadout(setup, mag, span=1e-4, table_size=(9, 16))
    base = b.rest + 2e-8 * rng.standard_normal((200, 3))
    base[:, 0] += np.linspace(0.0, 2e-6, 200)
    assert (b.tare(base).read(b.rest[None]).flags & Flag.TARE_UNDER_LOAD).all()
