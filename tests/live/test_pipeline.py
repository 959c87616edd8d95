"""The streaming read-out: estimates against the simulated truth, tare, set/reset, flags, faults
and recordings made while watching."""

from __future__ import annotations

import math
import time
from pathlib import Path
from typing import Any

import numpy as np
import pytest

import magcilia as mc
from magcilia._errors import MagciliaError
from magcilia.acquire import Script, SimulatedSource
from magcilia.io.recording_file import recording_properties
from magcilia.io.recordings import read_samples
from magcilia.live import EVENTS, LiveReadout
from magcilia.readout.inverse import ReadoutFlag

#: a given modulus, taken as exact: σ is the noise's, which the spread of the estimates checks
#: (the presets' assumed modulus adds the force scale: test_sigma_carries_the_force_scale)
SETUP = mc.Setup.paper(tip_radius=5e-5, youngs_modulus=3.4e6)
SPAN = (-3e-4, 3e-4)


@pytest.fixture(scope="module")
def readout() -> mc.Readout:
    return mc.Readout(SETUP, "force", span=SPAN)


def _event(live: LiveReadout, kind: str, timeout: float = 60.0) -> Any:
    """The first event of ``kind`` (waits for it; ``timeout`` s only guards against a hang).

    Events are kept, so a state that lasts a few hundred ms is seen however late this thread
    looks (a loaded machine), unlike a poll of the status."""
    deadline = time.monotonic() + timeout
    while True:
        found = [e for e in live.events if e.kind == kind]
        if found:
            return found[0]
        if time.monotonic() > deadline:
            pytest.fail(f"no {kind!r} event within {timeout} s ({live.status.report()})")
        time.sleep(0.01)


def _source(value: float = 0.0, **kw: object) -> SimulatedSource:
    options: dict[str, object] = {"rate": 10000.0, "rng": 0, "readout_noise": 2e-5}
    options.update(kw)
    return SimulatedSource(SETUP, Script.constant(value, "force"), **options)  # type: ignore[arg-type]


def test_estimates_follow_the_simulated_force_with_honest_sigma(readout: mc.Readout) -> None:
    """After a tare the read-out recovers a 0.1 mN load; the σ it states matches the spread of
    its estimates (the tare measured the noise of one reading)."""
    source = _source(0.0)
    with LiveReadout(source, readout, rate=1000, tare_at_start=True, tracking=None) as live:
        live.wait(600)  # the tare takes the first 500 readings
        assert live.status.tared
        source.set_value(1e-4)
        s = live.wait(3000)
    # the step reaches the published values after the read-out's latency (longer on a busy
    # machine): the 2000 readings from 50 after the first loaded one
    first = int(np.argmax(s.value > 5e-5))
    assert s.value[first] > 5e-5 and first + 2050 <= len(s)
    value, sigma = s.value[first + 50:first + 2050], s.sigma[first + 50:first + 2050]
    assert (s.flags[first + 50:first + 2050] == 0).all()
    assert np.mean(value) == pytest.approx(1e-4, abs=3 * np.median(sigma) / np.sqrt(50))
    assert np.std(value) == pytest.approx(np.median(sigma), rel=0.25)
    assert live.status.state == "stopped"


def test_sigma_carries_the_force_scale() -> None:
    """With the presets' assumed modulus the live σ holds the force scale too: the noise's σ
    and |F| σ_E/E in quadrature, and the limits say so."""
    setup = mc.Setup.paper(tip_radius=5e-5)
    assumed = mc.Readout(setup, "force", span=(-6e-5, 6e-5))
    source = SimulatedSource(setup, Script.constant(2e-5, "force"), rate=10000.0, rng=0,
                             readout_noise=2e-5)
    with LiveReadout(source, assumed, rate=1000, tracking=None) as live:
        s = live.wait(500)
        limits = live.limits()
    rel = setup.youngs_modulus_uncertainty
    noise = float(np.std(s.value))
    assert np.median(s.sigma) == pytest.approx(math.hypot(noise, rel * 2e-5), rel=0.05)
    assert "± σ includes the force scale from an assumed modulus ±27 %" in limits.report()
    assert limits.to_dict()["scale_note"] == setup.modulus.note()


def test_sigma_before_a_tare_includes_the_benchs_own_noise(readout: mc.Readout) -> None:
    """Amplifier and ADC noise (0.2 mV per sample) are not in the sensor model; before a tare
    the read-out measures them from the spread of successive readings."""
    source = _source(1e-4, readout_noise=2e-4)
    with LiveReadout(source, readout, rate=1000, tracking=None) as live:
        live.wait(1500)
        s = live.wait(2000)
    assert not live.status.tared
    assert np.median(s.sigma) == pytest.approx(np.std(s.value), rel=0.25)


def test_tare_removes_a_bias_and_is_noted(readout: mc.Readout) -> None:
    with LiveReadout(_source(0.0, bias=4e-4), readout, rate=1000, tracking=None) as live:
        before = live.wait(200)
        assert not live.status.tared
        assert np.nanmedian(before.value) < -5e-5  # the bias reads as a force
        assert live.tare(wait=5.0)
        after = live.wait(1000)
    assert abs(np.median(after.value)) < 3 * np.median(after.sigma) / np.sqrt(100)
    assert [e.kind for e in live.events] == ["start", "tare"]
    assert after.correction[-1] == pytest.approx(-4e-4, abs=2e-5)


def test_set_reset_readings_are_free_of_the_bias(readout: mc.Readout) -> None:
    """Demodulated windows cancel the bias without a tare."""
    source = _source(1e-4, bias=4e-4, set_reset=5)
    with LiveReadout(source, readout, rate=1000, tracking=None) as live:
        s = live.wait(1000)
    assert np.median(s.value) == pytest.approx(1e-4, rel=0.05)


def test_saturated_windows_are_flagged(readout: mc.Readout) -> None:
    with LiveReadout(_source(0.0, bias=0.1), readout, rate=1000) as live:
        s = live.wait(100)
    assert (s.flags & ReadoutFlag.SATURATED).all()
    assert np.isnan(s.value).all()


def test_readings_outside_the_span_say_what_to_check(readout: mc.Readout) -> None:
    with LiveReadout(_source(0.0, bias=0.02), readout, rate=1000) as live:
        live.wait(1100)
        status = live.status
    assert "outside the read-out's output range" in status.message


def test_a_missing_channel_names_the_channels_there(readout: mc.Readout) -> None:
    with pytest.raises(MagciliaError, match=r"channel must be a channel of sim \(it has output"):
        LiveReadout(_source(), readout, channel="ch3").start()


def test_the_output_rate_cannot_exceed_the_source_rate(readout: mc.Readout) -> None:
    with pytest.raises(MagciliaError, match="at most the source's sample rate"):
        LiveReadout(_source(rate=500.0), readout, rate=1000).start()


def test_the_latency_is_measured_per_sample(readout: mc.Readout) -> None:
    """A real-time source: each value's latency (its chunk's arrival to its publication) is
    measured; how small it is lives in benchmarks/bench_live.py (a speed, not a test)."""
    with LiveReadout(_source(realtime=True), readout, rate=1000) as live:
        s = live.wait(300)
        status = live.status
    assert np.all(np.isfinite(s.latency)) and np.all(s.latency >= 0)
    assert np.all(s.published - s.received == pytest.approx(s.latency, abs=1e-9))
    assert status.latency_median >= 0 and status.latency_p99 >= status.latency_median
    assert np.all(np.diff(s.time) > 0)
    assert np.diff(s.time) == pytest.approx(1e-3)


def test_an_unplugged_source_is_reported_and_recovers(readout: mc.Readout, tmp_path: Path,
                                                       unplugged: Any) -> None:
    source = unplugged(SETUP, Script.constant(1e-4, "force"), rate=10000.0, rng=0,
                       realtime=True, good=40, down=0.3)
    live = LiveReadout(source, readout, rate=1000, reconnect=0.1, tracking=None)
    with live:
        path = live.start_recording(directory=tmp_path)
        assert "vanished" in _event(live, "disconnected").text
        _event(live, "reconnected")
        after = live.wait(200)
        assert live.status.message == ""
    assert np.median(after.value) == pytest.approx(1e-4, rel=0.1)
    kinds = [e.kind for e in live.events]
    assert kinds[:2] == ["start", "recording"] and "disconnected" in kinds
    assert kinds.index("reconnected") > kinds.index("disconnected")
    # the recording went on through it: one file, a gap in time, the events in it
    from nptdms import TdmsFile

    tdms = TdmsFile.read(path)
    t = tdms["recording"]["time_s"][:]
    assert np.max(np.diff(t)) > 0.2
    codes = tdms["events"]["event_code"][:].astype(int).tolist()
    assert EVENTS["disconnected"] in codes and EVENTS["reconnected"] in codes
    assert recording_properties(path)["complete"] is True


def test_recording_while_watching_holds_samples_values_and_events(readout: mc.Readout,
                                                                  tmp_path: Path) -> None:
    source = _source(5e-5, set_reset=5, realtime=True)
    with LiveReadout(source, readout, rate=1000, tare_seconds=0.1) as live:
        path = live.start_recording(tmp_path / "watch.tdms")
        live.wait(100)
        live.tare(wait=2.0)
        live.wait(100)
        assert live.stop_recording() == path
        assert live.stop_recording() is None
        live.wait(50)
    cols = read_samples(path, required=("voltage_V",))
    from nptdms import TdmsFile

    tdms = TdmsFile.read(path)
    group = tdms["readout"]
    n_raw = cols["voltage_V"].size
    assert n_raw >= 2000 and n_raw % live.factor == 0
    assert len(group["value"]) == n_raw // live.factor
    assert group["value"].properties["unit_string"] == "N"
    np.testing.assert_allclose(group["readout_time_s"][:],
                               cols["time_s"].reshape(-1, live.factor).mean(axis=1))
    assert set(np.unique(tdms["recording"]["setreset"][:])) == {-1, 1}
    codes = tdms["events"]["event_code"][:].astype(int).tolist()
    assert EVENTS["tare"] in codes
    props = recording_properties(path)
    assert props["complete"] is True and props["live"] is True
    assert '"quantity": "force"' in props["readout"]


def test_a_failing_disk_stops_the_recording_not_the_readout(readout: mc.Readout,
                                                            tmp_path: Path,
                                                            monkeypatch: pytest.MonkeyPatch
                                                            ) -> None:
    with LiveReadout(_source(realtime=True), readout, rate=1000) as live:
        path = live.start_recording(tmp_path / "full.tdms")
        live.wait(600)  # one chunk on disk
        writer = live._writer
        assert writer is not None

        def full(*_: object, **__: object) -> None:
            raise MagciliaError(f"{path}: writing failed (No space left on device)")

        monkeypatch.setattr(writer, "write", full)
        live.wait(50)
        status = live.status
        assert status.recording is None and "No space left" in status.message
        assert live.running
        live.wait(50)
    assert recording_properties(path)["complete"] is False


def test_a_serial_device_that_stops_sending_is_reported_and_recovers(
        readout: mc.Readout) -> None:
    """End to end over a pseudo-terminal: the device emulator stalls for 2.5 s; the read-out
    says the device stopped, reopens the port and reads on when frames come again."""
    from magcilia.acquire.emulator import DeviceEmulator
    from magcilia.acquire.serial import SerialSource

    sim = SimulatedSource(SETUP, Script.constant(1e-4, "force"), rate=2000.0, rng=0,
                          readout_noise=2e-5)
    with DeviceEmulator(sim, samples_per_frame=20) as device:
        # stalls of 1 s: a loaded machine does not starve the emulator that long by chance
        live = LiveReadout(SerialSource(device.port, stall=1.0), readout, rate=200,
                           stall=1.0, reconnect=0.1, tare_at_start=False, tracking=None)
        with live:
            first = live.wait(100, timeout=60)  # the port's rate is known at once
            assert [e.kind for e in live.events] == ["start"]
            device.stall(2.5)
            assert "stopped sending" in _event(live, "disconnected").text
            _event(live, "reconnected")
            after = live.wait(100, timeout=60)
    assert live.rate == 200.0 and live.factor == 10
    for s in (first, after):
        assert np.median(s.value) == pytest.approx(1e-4, rel=0.1)
    assert [e.kind for e in live.events].count("reconnected") >= 1


@pytest.mark.parametrize(("source_rate", "rate", "factor"), [(1000.0, 100.0, 10),
                                                             (10000.0, 3000.0, 3)])
def test_windows_are_whole_whatever_the_batch(readout: mc.Readout, source_rate: float,
                                              rate: float, factor: int) -> None:
    """A batch shorter than a window still reads whole windows; the output rate is the source's
    over a whole factor."""
    with LiveReadout(_source(1e-4, rate=source_rate), readout, rate=rate, batch=0.001) as live:
        s = live.wait(30)
    assert live.factor == factor and live.rate == pytest.approx(source_rate / factor)
    assert np.diff(s.time) == pytest.approx(1 / live.rate)
