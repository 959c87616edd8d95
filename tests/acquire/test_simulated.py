"""The simulated source and the background reader: determinism, the signal against the model,
the noise against the sensor model, set/reset, scripts, pacing, and overruns that are counted."""

from __future__ import annotations

import math
import time

import numpy as np
import pytest

import magcilia as mc
from magcilia._errors import AcquisitionError
from magcilia.acquire import (
    OUTPUT,
    BackgroundReader,
    Block,
    Channel,
    RingBuffer,
    Script,
    SimulatedSource,
    Source,
)

SETUP = mc.Setup.paper()
TAPERED = mc.Setup.paper(tip_radius=5e-5, n_loops=16, dipoles_per_loop=4)  # 0.5 % off


def test_reads_are_deterministic_and_continuous() -> None:
    with SimulatedSource(SETUP, 0.3, rng=5) as one:
        whole = one.read(3000)
    with SimulatedSource(SETUP, 0.3, rng=5) as two:
        parts = Block.concatenate([two.read(1000), two.read(1500), two.read(500)])
    np.testing.assert_array_equal(whole.data, parts.data)
    np.testing.assert_allclose(whole.time, np.arange(3000) / 1000.0)
    assert whole.channels == (Channel(OUTPUT, "V"),) and whole.first == 0
    assert two.counters.samples == 3000 and two.counters.dropped == 0


def test_signal_is_the_model_and_noise_is_the_sensors() -> None:
    n, rate = 2**15, 1000.0
    with SimulatedSource(SETUP, 0.4, rate=rate, readout_noise=0.0, rng=1) as quiet:
        block = quiet.read(n)
    volts = block[OUTPUT]
    expected = SETUP.sensor.output_noise_rms(rate / n, rate / 2)
    assert np.std(volts) == pytest.approx(expected, rel=0.1)
    assert np.mean(volts) == pytest.approx(SETUP.output([0.4])[0], abs=5 * expected)
    with SimulatedSource(SETUP, 0.4, readout_noise=2e-4, rng=2) as noisy:
        assert np.std(noisy.read(n)[OUTPUT]) == pytest.approx(math.hypot(2e-4, expected),
                                                              rel=0.05)


def test_bias_drift_and_set_reset() -> None:
    bias, drift = 5e-3, 1e-4
    with SimulatedSource(SETUP, 0.2, bias=bias, drift=drift, readout_noise=0.0, rng=3,
                         set_reset=100) as src:
        block = src.read(4000)
    sr = block.setreset
    assert sr is not None and sr[0] == 1 and sr[100] == -1 and sr[200] == 1
    volts, clean, offset = block[OUTPUT], SETUP.output([0.2])[0], SETUP.sensor.offset
    # set minus reset removes bias and offset; the drift leaves half its change over one half
    # period (reset samples come 0.1 s after their set samples): the field signal is left
    mean, _, _ = mc.io.recordings.reading(volts, sr.astype(float))
    assert mean == pytest.approx(clean - offset - drift * 0.1 / 2, abs=1e-6)
    assert np.mean(volts) == pytest.approx(offset + bias + drift * 2.0, abs=2e-5)


def test_scripts() -> None:
    steps = Script.from_steps([(0.0, 0.0), (0.5, 0.6)])
    with SimulatedSource(SETUP, steps, readout_noise=0.0, rng=0) as src:
        block = src.read(1000)
    before, after = block[OUTPUT][:500], block[OUTPUT][500:]
    np.testing.assert_allclose([before.mean(), after.mean()], SETUP.output([0.0, 0.6]),
                               atol=2e-6)
    force = Script.from_function(lambda t: 1e-4 * np.sin(2 * np.pi * t), "force")
    with SimulatedSource(TAPERED, force, readout_noise=0.0, rng=0) as src:
        t = src.read(1000)
    exact = TAPERED.output(mc.bend_sweep(TAPERED, forces=1e-4 * np.sin(2 * np.pi * t.time[::97])))
    assert np.std(t[OUTPUT]) > 1e-4  # it moves
    np.testing.assert_allclose(t[OUTPUT][::97], exact, atol=5 * SETUP.sensor.output_noise_rms(
        0.5, 500.0))
    src = SimulatedSource(SETUP, 0.1, rng=0)
    src.read(100)
    src.set_value(0.5)
    assert src.script.values(np.array([0.05, 0.15])).tolist() == [0.1, 0.5]


def test_script_and_source_errors() -> None:
    with pytest.raises(mc.MagciliaError, match="quantity must be one of"):
        Script("pressure")
    with pytest.raises(mc.MagciliaError, match="steps must be"):
        Script.from_steps([(1.0, 0.1)])
    with pytest.raises(mc.MagciliaError, match=r"setup must be a magcilia\.Setup"):
        SimulatedSource("paper")  # type: ignore[arg-type]
    with pytest.raises(mc.MagciliaError, match="rate must be a positive frequency"):
        SimulatedSource(SETUP, rate=0.0)


@pytest.mark.parametrize("speed", [1.0, 4.0])
def test_realtime_pacing_never_runs_ahead_of_the_clock(speed: float) -> None:
    """A paced source cannot deliver a sample before its time (index / (rate x speed) after it
    opened); a loaded machine can only make it later, so this lower bound holds anywhere."""
    t0 = time.monotonic()  # before the source opens: its clock starts later, never earlier
    with SimulatedSource(SETUP, 0.1, rate=2000.0, realtime=True, speed=speed, rng=0) as src:
        block = src.read(400)
        took = time.monotonic() - t0
    assert took >= 399 / (2000.0 * speed)  # the last sample's time (index / (rate x speed))
    np.testing.assert_array_equal(block.time, np.arange(400) / 2000.0)  # times are the rate's
    with pytest.raises(mc.MagciliaError, match="speed must be a positive"):
        SimulatedSource(SETUP, speed=0.0)


def test_ring_buffer_counts_what_it_overwrites() -> None:
    ch = (Channel(OUTPUT),)
    buf = RingBuffer(1, 10)
    for start in (0, 6, 12):
        t = np.arange(start, start + 6, dtype=float)
        buf.write(Block(t, t[None, :], ch, first=start))
    assert buf.overruns == 8 and len(buf) == 10
    out = buf.read(4, timeout=0.0, channels=ch)
    assert out is not None and out.time.tolist() == [8.0, 9.0, 10.0, 11.0] and out.first == 8
    assert buf.read(7, timeout=0.01, channels=ch) is None  # only 6 left
    assert buf.clear() == 6 and len(buf) == 0


class _Ramp(Source):
    """A device that never waits (``realtime``) and sends its sample index, as fast as it goes."""

    def __init__(self) -> None:
        super().__init__()
        self.rate, self.channels, self.name, self._i = 1000.0, (Channel(OUTPUT),), "ramp", 0

    def _open(self) -> None:
        return

    def _close(self) -> None:
        return

    def _read(self, n: int) -> Block:
        idx = self._i + np.arange(n)
        self._i += n
        return Block(idx / self.rate, idx[None, :].astype(float), self.channels, int(idx[0]))


def test_background_reader_counts_overruns_of_a_slow_consumer() -> None:
    src = _Ramp()  # a device does not wait for a consumer that falls behind
    with BackgroundReader(src, seconds=0.5, chunk=100) as reader:  # a ring of 500 samples
        first = reader.read(100)
        while src.counters.samples < first.first + 20_000:  # the consumer looks away meanwhile
            time.sleep(0.001)
        later = reader.read(100)
    assert reader.overruns >= 20_000 - 100 - 500 - 100
    skipped = later.first - (first.first + 100)
    assert skipped > 0 and later.data[0, 0] == later.first  # the gap shows in the sample index
    assert reader.counters.dropped == reader.overruns


class _Failing(Source):
    def __init__(self, fail_after: int, hang: bool = False) -> None:
        super().__init__()
        self.rate, self.channels, self.name = 1000.0, (Channel(OUTPUT),), "test-device"
        self.fail_after, self.hang, self.calls = fail_after, hang, 0

    def _open(self) -> None:
        return

    def _close(self) -> None:
        return

    def _read(self, n: int) -> Block:
        self.calls += 1
        if self.calls > self.fail_after:
            if self.hang:
                time.sleep(0.5)
            else:
                raise AcquisitionError("test-device: unplugged")
        t = np.arange(n) / self.rate
        return Block(t, np.zeros((1, n)), self.channels)


def test_background_reader_hands_errors_and_stalls_to_the_consumer() -> None:
    with BackgroundReader(_Failing(2), chunk=10, stall=0.2) as reader:
        reader.read(20)
        with pytest.raises(AcquisitionError, match="test-device: unplugged"):
            reader.read(10)
    with BackgroundReader(_Failing(1, hang=True), chunk=10, stall=0.1) as reader:
        reader.read(10)
        with pytest.raises(AcquisitionError, match=r"no samples for 0\.1 s"):
            reader.read(10)
