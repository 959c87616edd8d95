"""The serial protocol, its parser, the serial source and the device emulator.

Protocol tests feed bytes to :class:`FrameParser` directly; end-to-end tests run the real serial
path: a :class:`DeviceEmulator` writes frames to a pseudo-terminal and a :class:`SerialSource`
reads them with pyserial. Samples handed out are compared with a second, identically seeded
:class:`SimulatedSource` (noise-free sensor, so its draws do not depend on read sizes), to the ADC
step: a corrupt sample would show.
"""

from __future__ import annotations

import os
import re
import time
import zlib
from pathlib import Path

import numpy as np
import pytest
from cobs import cobs
from hypothesis import given
from hypothesis import strategies as st

import magcilia as mc
from magcilia._errors import AcquisitionError
from magcilia.acquire.emulator import VOLTS_PER_COUNT, DeviceEmulator
from magcilia.acquire.protocol import (
    FLAG_SET,
    FLAG_SETRESET_VALID,
    HEADER,
    MAX_ENCODED,
    MAX_RATE,
    MAX_VOLTS_PER_COUNT,
    MIN_RATE,
    MIN_VOLTS_PER_COUNT,
    VERSION,
    FrameParser,
    encode_frame,
)
from magcilia.acquire.serial import SerialSource
from magcilia.acquire.simulated import SimulatedSource
from magcilia.acquire.source import OUTPUT, Block, Channel, Source

pytestmark = pytest.mark.skipif(os.name != "posix", reason="the emulator needs a pseudo-terminal")

DOCS = Path(__file__).resolve().parents[2] / "docs" / "serial-protocol.md"
QUIET = mc.Setup.paper(noise_density=0.0)  # read-out noise only: draws independent of read sizes
NOISY = mc.Setup.paper()
VPC = 2.048 / 2**23
WRAP = 1 << 32
#: stall allowance of the end-to-end tests that expect no stall, s: long enough for a loaded
#: machine (the emulator's thread and the reader share it with everything else)
LOADED = 10.0


def frame(i: int, n: int = 32, c: int = 1, start: int = 0, **kw: object) -> bytes:
    """Frame number i of a steady stream (counts depend on the sample index)."""
    first = start + i * n
    counts = (np.arange(first, first + n)[:, None] * 7 + np.arange(c)) % 2**23
    return encode_frame(counts, sequence=i, first=first, rate=1000.0, volts_per_count=VPC,
                        **kw)


def stream(count: int, **kw: object) -> list[bytes]:
    return [frame(i, **kw) for i in range(count)]


def same(a: list, b: list) -> bool:
    return [(f.sequence, f.index, f.counts.tolist()) for f in a] == [
        (f.sequence, f.index, f.counts.tolist()) for f in b]


# -- the protocol ---------------------------------------------------------------------------------
@given(n=st.integers(1, 64), c=st.integers(1, 4), seed=st.integers(0, 2**32 - 1),
       sequence=st.integers(0, 2**33), first=st.integers(0, 2**33),
       rate=st.just(0.0) | st.floats(float(np.float32(MIN_RATE)), MAX_RATE, width=32),
       vpc=st.floats(float(np.float32(MIN_VOLTS_PER_COUNT)), MAX_VOLTS_PER_COUNT, width=32),
       setreset=st.sampled_from([None, 1, -1]))
def test_round_trip(n: int, c: int, seed: int, sequence: int, first: int, rate: float,
                    vpc: float, setreset: int | None) -> None:
    counts = np.random.default_rng(seed).integers(-2**31, 2**31, (n, c), dtype=np.int64)
    wire = encode_frame(counts, sequence=sequence, first=first, rate=rate, volts_per_count=vpc,
                        setreset=setreset)
    assert wire.endswith(b"\x00") and b"\x00" not in wire[:-1]
    parser = FrameParser()
    (got,) = parser.feed(wire)
    assert np.array_equal(got.counts, counts) and got.counts.shape == (n, c)
    assert (got.sequence, got.first, got.index) == (sequence % WRAP, first % WRAP, first % WRAP)
    assert (got.rate, got.volts_per_count) == (rate, vpc)
    assert got.setreset == (setreset or 0)
    np.testing.assert_array_equal(got.volts(), counts.T * vpc)
    assert (parser.frames, parser.corrupt, parser.pending) == (1, 0, 0)


def test_layout_is_the_documented_one() -> None:
    """The example frame of docs/serial-protocol.md, byte for byte; header, CRC, sample-major."""
    wire = encode_frame([1000, -1000, 123456], sequence=7, first=224, rate=1000.0,
                        volts_per_count=2.048 / 2**23, setreset=1)
    text = DOCS.read_text(encoding="utf-8")
    shown = re.search(r"on the wire \(42 bytes.*?\n(.*?)```", text, re.DOTALL)
    assert shown is not None and bytes.fromhex(shown.group(1)) == wire
    raw = cobs.decode(wire[:-1])
    assert HEADER.unpack_from(raw) == (VERSION, 1, FLAG_SETRESET_VALID | FLAG_SET, 1, 3, 0, 7,
                                       224, 1000.0, np.float32(2.048 / 2**23))
    assert int.from_bytes(raw[-4:], "little") == zlib.crc32(raw[:-4])
    two = cobs.decode(encode_frame([[1, 2], [3, 4]], sequence=0, first=0, rate=1.0,
                                   volts_per_count=1.0)[:-1])
    assert np.frombuffer(two, "<i4", 4, HEADER.size).tolist() == [1, 2, 3, 4]  # sample-major
    assert zlib.crc32(b"123456789") == 0xCBF43926  # the CRC the docs name


@given(st.lists(st.integers(1, 600), min_size=1, max_size=40))
def test_any_split_gives_the_same_frames(cuts: list[int]) -> None:
    data = b"".join(stream(12, c=2))
    whole = FrameParser().feed(data)
    assert len(whole) == 12
    parser, got, pos = FrameParser(), [], 0
    for cut in cuts:
        got += parser.feed(data[pos:pos + cut])
        pos += cut
    got += parser.feed(data[pos:])
    assert same(got, whole) and parser.corrupt == 0 and parser.pending == 0


def test_byte_by_byte() -> None:
    data = b"".join(stream(5, n=3))
    parser = FrameParser()
    got = [f for i in range(len(data)) for f in parser.feed(data[i:i + 1])]
    assert same(got, FrameParser().feed(data))


def test_garbage_before_and_between_frames_is_skipped_and_counted() -> None:
    frames = stream(6)
    junk = [b"\x13\x37garbage\xff" * 3 + b"\x00", b"\x01\x02\x00\x05\x06\x00"]
    data = junk[0] + frames[0] + frames[1] + junk[0] + frames[2] + junk[1] + b"".join(frames[3:])
    parser = FrameParser()
    got = parser.feed(data)
    assert same(got, FrameParser().feed(b"".join(frames)))
    assert parser.corrupt == 4 and parser.dropped == 0
    assert [f.corrupt for f in got] == [0, 0, 1, 2, 0, 0]  # the first frame reports no past
    # idle delimiters are no frames at all
    assert len(FrameParser().feed(b"\x00\x00" + frames[0] + b"\x00")) == 1


def test_midstream_start_is_quiet_and_reset_resynchronises() -> None:
    frames = stream(4)
    parser = FrameParser(midstream=True)
    assert len(parser.feed(frames[0][10:] + b"".join(frames[1:3]))) == 2
    assert parser.corrupt == 0
    parser.feed(frames[3][:7])
    parser.reset()
    assert parser.pending == 0
    (got,) = parser.feed(frame(3)[20:] + frame(9))  # the tail of a frame, then a later frame
    assert (got.gap, got.corrupt, got.index, parser.corrupt, parser.dropped) == (0, 0, 288, 0, 0)


@given(data=st.data())
def test_every_corrupted_frame_is_rejected(data: st.DataObject) -> None:
    frames = stream(3, n=8, c=2)
    bad = bytearray(frames[1])
    positions = data.draw(st.lists(st.integers(0, len(bad) - 2), min_size=1, max_size=4,
                                   unique=True))
    for pos in positions:
        bad[pos] = data.draw(st.integers(1, 255).filter(lambda b, old=bad[pos]: b != old))
    parser = FrameParser()
    got = parser.feed(frames[0] + bytes(bad) + frames[2])
    assert [f.sequence for f in got] == [0, 2]
    assert (parser.corrupt, parser.dropped, got[1].gap, got[1].corrupt) == (1, 8, 8, 1)
    assert np.array_equal(got[1].counts, FrameParser().feed(frames[2])[0].counts)


@pytest.mark.parametrize("damage", ["truncated", "extended", "version", "length", "flags", "vpc"])
def test_damaged_frames_of_each_kind_are_corrupt(damage: str) -> None:
    raw = bytearray(cobs.decode(frame(1)[:-1]))
    if damage == "truncated":
        raw = raw[:50]
    elif damage == "extended":
        raw += b"\x01\x02\x03\x04"
    else:  # a frame with a valid CRC but impossible contents
        body = raw[:-4]
        if damage == "version":
            body[0] = 2
        elif damage == "length":
            body[4] = 31
        elif damage == "flags":
            body[2] = 0x04
        else:
            body[20:24] = np.float32(-1.0).tobytes()
        raw = body + zlib.crc32(bytes(body)).to_bytes(4, "little")
    parser = FrameParser()
    got = parser.feed(frame(0) + cobs.encode(bytes(raw)) + b"\x00" + frame(2))
    assert [f.sequence for f in got] == [0, 2] and parser.corrupt == 1


def raw_frame(i: int, n: int = 32, c: int = 1, rate: float = 1000.0, vpc: float = VPC,
              first: int | None = None) -> bytes:
    """Frame number i of a steady stream with any header values, CRC-valid (no checks)."""
    first = i * n if first is None else first
    counts = np.arange(first * c, (first + n) * c, dtype="<i4") % 2**23
    body = HEADER.pack(VERSION, 1, 0, c, n, 0, i, first, rate, vpc) + counts.tobytes()
    return cobs.encode(body + zlib.crc32(body).to_bytes(4, "little")) + b"\x00"


@pytest.mark.parametrize(("field", "value"), [
    ("rate", 3.4e38), ("rate", -0.0), ("rate", -1000.0), ("rate", 1e-30), ("rate", 2e6),
    ("rate", float("nan")), ("rate", float("inf")), ("vpc", 3.4e38), ("vpc", 1e-30),
    ("vpc", float("nan")), ("vpc", -VPC),
])
def test_crc_valid_frames_outside_the_limits_are_corrupt(field: str, value: float) -> None:
    """Rates and steps no device has (the issue's 3.4e38 Hz, -0 Hz, 3.4e38 V per count): the
    frame is rejected and counted, its samples are a gap, and the parser says why."""
    bad = raw_frame(1, **{field: value})  # type: ignore[arg-type]
    parser = FrameParser()
    got = parser.feed(raw_frame(0) + bad + raw_frame(2))
    assert [f.sequence for f in got] == [0, 2] and got[1].gap == 32
    assert (parser.corrupt, parser.implausible, parser.dropped) == (1, 1, 32)
    assert parser.rejected is not None and ("Hz" in parser.rejected or "V per count"
                                            in parser.rejected)
    # the first frame of a session is held to the same limits
    alone = FrameParser()
    assert alone.feed(bad) == [] and alone.corrupt == 1


def test_a_format_change_mid_stream_is_corrupt_until_a_restart() -> None:
    """Within a session (no restart) the rate, the channels and the ADC step stay those of its
    first frame; a device that restarts (its sample index goes back) may announce new ones."""
    parser = FrameParser()
    got = parser.feed(raw_frame(0) + raw_frame(1, rate=2000.0) + raw_frame(2, vpc=2 * VPC)
                      + raw_frame(3, n=16, c=2, first=96) + raw_frame(4))
    assert [f.sequence for f in got] == [0, 4] and got[1].gap == 96
    assert (parser.corrupt, parser.implausible, parser.restarts) == (3, 3, 0)
    assert parser.rejected is not None and "format change" in parser.rejected
    (restarted,) = parser.feed(raw_frame(0, rate=2000.0))  # index 0 again: a new session
    assert restarted.rate == 2000.0 and parser.restarts == 1
    assert parser.feed(raw_frame(1, rate=2000.0))[0].gap == 0
    assert parser.feed(raw_frame(2)) == [] and parser.implausible == 4  # the old format: no more


@pytest.mark.parametrize(("kw", "match"), [
    ({"rate": 3.4e38}, "rate 3.4e"), ({"rate": 0.01}, "rate 0.01"),
    ({"volts_per_count": 3.4e38}, "V per count"),
])
def test_encode_frame_refuses_what_the_parser_would_reject(kw: dict[str, float],
                                                           match: str) -> None:
    args: dict[str, float] = {"rate": 1000.0, "volts_per_count": VPC, **kw}
    with pytest.raises(mc.MagciliaError, match=match):
        encode_frame([1], sequence=0, first=0, **args)


def test_other_frame_types_are_skipped_not_corrupt() -> None:
    body = bytearray(cobs.decode(frame(1)[:-1])[:-4])
    body[1] = 2
    other = cobs.encode(bytes(body) + zlib.crc32(bytes(body)).to_bytes(4, "little")) + b"\x00"
    parser = FrameParser()
    assert len(parser.feed(frame(0) + other + frame(2))) == 2
    assert (parser.skipped, parser.corrupt) == (1, 0)


def test_sequence_gaps_are_lost_samples() -> None:
    frames = stream(10, n=16)
    kept = [f for i, f in enumerate(frames) if i not in (2, 3, 7)]
    parser = FrameParser()
    got = parser.feed(b"".join(kept))
    assert [f.gap for f in got] == [0, 0, 32, 0, 0, 16, 0]
    assert (parser.dropped, parser.lost_frames) == (48, 3)
    assert [f.index for f in got] == [0, 16, 64, 80, 96, 128, 144]


def test_counters_wrap_around() -> None:
    start = WRAP - 40  # the sample index and the sequence number both wrap inside the stream
    frames = [encode_frame(np.full(16, i), sequence=WRAP - 2 + i, first=start + 16 * i,
                           rate=1000.0, volts_per_count=VPC) for i in range(6)]
    parser = FrameParser()
    got = parser.feed(b"".join(frames[:3]) + frames[4] + frames[5])
    assert [f.first for f in got] == [start, start + 16, start + 32, 24, 40]
    assert [f.index for f in got] == [start + 16 * i for i in (0, 1, 2, 4, 5)]
    assert [f.gap for f in got] == [0, 0, 0, 16, 0]
    assert (parser.dropped, parser.lost_frames, parser.restarts) == (16, 1, 0)


def test_a_device_restart_continues_the_count() -> None:
    parser = FrameParser()
    got = parser.feed(b"".join(stream(3, start=5000)) + b"".join(stream(2)))
    assert [f.index for f in got] == [5000, 5032, 5064, 5096, 5128]
    assert (parser.restarts, parser.dropped) == (1, 0)


def test_a_run_without_delimiter_is_bounded_and_counted_once() -> None:
    parser = FrameParser()
    junk = b"\x07" * (MAX_ENCODED // 3)
    for _ in range(5):
        assert parser.feed(junk) == []
    assert parser.pending <= MAX_ENCODED and parser.corrupt == 1
    assert len(parser.feed(junk + b"\x00" + frame(0))) == 1 and parser.corrupt == 1


@pytest.mark.parametrize(("counts", "kw"), [
    ([], {}),
    ([1.5, 2.0], {}),
    ([2**31], {}),
    (np.zeros((2, 256), dtype=int), {}),
    ([1], {"rate": -1.0}),
    ([1], {"volts_per_count": 0.0}),
    ([1], {"setreset": 2}),
    ([1], {"sequence": -1}),
], ids=["empty", "floats", "int32-overflow", "channels", "rate", "vpc", "setreset", "sequence"])
def test_encode_frame_errors_are_one_line(counts: object, kw: dict[str, object]) -> None:
    args: dict[str, object] = {"sequence": 0, "first": 0, "rate": 1000.0, "volts_per_count": VPC}
    args.update(kw)
    with pytest.raises(mc.MagciliaError, match=r"must be .*; got") as info:
        encode_frame(counts, **args)
    assert "\n" not in str(info.value)


# -- end to end: emulator -> pseudo-terminal -> pyserial -> SerialSource ---------------------------
def reference(setup: mc.Setup, angle: float, seed: int, stop: int, **kw: object) -> Block:
    """The first ``stop`` samples a SimulatedSource seeded like the emulator's gives."""
    with SimulatedSource(setup, angle, rng=seed, **kw) as sim:
        return sim.read(stop)


def device_indices(source: SerialSource, block: Block) -> np.ndarray:
    assert source.device_first is not None
    return source.device_first + np.rint(block.time * source.rate).astype(np.int64)


@pytest.mark.parametrize("angle", [0.0, 0.4, 1.0])
def test_means_match_the_simulated_sensor(angle: float) -> None:
    with (DeviceEmulator(SimulatedSource(NOISY, angle, rng=3), realtime=False) as device,
          SerialSource(device.port, stall=LOADED) as source):
        block = source.read(2000)
    assert source.rate == 1000.0 and source.channels == (Channel(OUTPUT, "V"),)
    assert source.name == f"serial:{device.port}" and source.realtime
    np.testing.assert_allclose(np.diff(block.time), 1e-3, rtol=1e-9)  # no gaps
    assert block.time[0] * 1000.0 == pytest.approx(block.first)
    # read-out noise 0.2 mV rms / sqrt(2000) and the sensor's 1/f noise: 5 sigma ~ 25 µV
    assert block[OUTPUT].mean() == pytest.approx(NOISY.output([angle])[0], abs=2.5e-5)
    assert source.counters.dropped == 0 and source.counters.corrupt == 0


def test_samples_are_the_simulated_ones_to_the_adc_step() -> None:
    with (DeviceEmulator(SimulatedSource(QUIET, 0.4, rng=5, set_reset=80), realtime=False,
                         samples_per_frame=48) as device,
          SerialSource(device.port, stall=LOADED) as source):
        source.read(100)
        block = source.read(3000)
    idx = device_indices(source, block)
    ref = reference(QUIET, 0.4, 5, int(idx[-1]) + 1, set_reset=80)
    np.testing.assert_allclose(block[OUTPUT], ref[OUTPUT][idx], rtol=0, atol=0.51 * VPC)
    assert ref.setreset is not None and np.array_equal(block.setreset, ref.setreset[idx])
    assert block.first == 100


def expected_losses(device: DeviceEmulator, source: SerialSource, block: Block
                    ) -> tuple[int, int]:
    """Samples in damaged frames and corrupt pieces inside the span the source delivered."""
    idx = device_indices(source, block)
    lo, hi = source.device_first, int(idx[-1])
    hit = [(f, n) for f, n in device.damaged if lo < f < hi]
    return sum(n for _, n in hit), len(hit) + sum(1 for j in device.junk if lo < j <= hi)


def test_corrupted_frames_are_dropped_exactly() -> None:
    with (DeviceEmulator(SimulatedSource(QUIET, 0.4, rng=7), realtime=False,
                         samples_per_frame=16, corrupt=0.01, rng=11) as device,
          SerialSource(device.port, stall=LOADED) as source):
        block = source.read(20000)
    dropped, corrupt = expected_losses(device, source, block)
    assert dropped >= 16 * 5  # the seed damages 7 or more frames in any span of 20000 samples
    c = source.counters
    assert (c.samples, c.dropped, c.corrupt) == (20000, dropped, corrupt)
    idx = device_indices(source, block)
    assert idx[-1] - idx[0] + 1 == 20000 + dropped  # the gaps show in the time
    ref = reference(QUIET, 0.4, 7, int(idx[-1]) + 1)
    np.testing.assert_allclose(block[OUTPUT], ref[OUTPUT][idx], rtol=0, atol=0.51 * VPC)
    assert block[OUTPUT].mean() == pytest.approx(QUIET.output([0.4])[0], abs=1e-5)


def test_garbage_bursts_cost_only_the_damaged_frames() -> None:
    with (DeviceEmulator(SimulatedSource(QUIET, 0.2, rng=1), realtime=False, garbage=0.05,
                         garbage_size=300, rng=2) as device,
          SerialSource(device.port, stall=LOADED) as source):
        block = source.read(10000)
    dropped, corrupt = expected_losses(device, source, block)
    assert dropped > 0 and corrupt >= dropped // 32
    assert (source.counters.dropped, source.counters.corrupt) == (dropped, corrupt)
    idx = device_indices(source, block)
    ref = reference(QUIET, 0.2, 1, int(idx[-1]) + 1)
    np.testing.assert_allclose(block[OUTPUT], ref[OUTPUT][idx], rtol=0, atol=0.51 * VPC)


def test_counters_wrap_around_end_to_end() -> None:
    # paced (50 kHz) so that the source opens before the device's counters wrap
    with (DeviceEmulator(SimulatedSource(QUIET, 0.3, rate=5e4, rng=4), first=WRAP - 1000,
                         sequence=WRAP - 20) as device,
          SerialSource(device.port, stall=LOADED) as source):
        block = source.read(4000)
    assert source.device_first is not None and source.device_first < WRAP
    np.testing.assert_allclose(np.diff(block.time), 2e-5, rtol=1e-6)
    assert source.counters.dropped == 0
    assert device_indices(source, block)[-1] > WRAP


def test_discard_drops_the_backlog_without_counting_it() -> None:
    with (DeviceEmulator(SimulatedSource(QUIET, 0.3, rng=4), realtime=False) as device,
          SerialSource(device.port, stall=LOADED) as source):
        before = source.read(100)
        time.sleep(0.05)  # the emulator fills the pseudo-terminal's buffer meanwhile
        source.discard()
        after = source.read(100)
    assert after.first > before.first + 100  # skipped, and the time says so
    assert after.time[0] * source.rate == pytest.approx(after.first)
    assert source.counters.dropped == 0 and source.counters.corrupt == 0


class TwoChannels(Source):
    """A ramp on the output and its negative on a second channel, 500 Hz."""

    def __init__(self) -> None:
        super().__init__()
        self.rate, self.realtime, self._i = 500.0, False, 0
        self.channels = (Channel(OUTPUT), Channel("aux"))

    def _open(self) -> None:
        return

    def _close(self) -> None:
        return

    def _read(self, n: int) -> Block:
        x = (self._i + np.arange(n)) * 1e-6
        self._i += n
        return Block(time=x, data=np.stack([x, -x]), channels=self.channels)


def test_channels_and_rate_come_from_the_frames() -> None:
    with (DeviceEmulator(TwoChannels(), realtime=False, volts_per_count=1e-6) as device,
          SerialSource(device.port, rate=501.0, stall=LOADED) as source):
        block = source.read(50)
    assert [c.name for c in source.channels] == [OUTPUT, "ch1"]
    assert source.rate == 501.0 and block.time[1] - block.time[0] == pytest.approx(1 / 501)
    np.testing.assert_allclose(block["ch1"], -block[OUTPUT], atol=1e-12)
    assert block.setreset is None
    assert source.metadata()["device_rate_Hz"] == 500.0


def one_line(info: pytest.ExceptionInfo[AcquisitionError], port: str, *words: str) -> str:
    text = str(info.value)
    assert "\n" not in text and port in text, text
    for word in words:
        assert word in text, text
    return text


def test_a_rate_far_from_the_devices_is_refused() -> None:
    with DeviceEmulator(TwoChannels(), realtime=False) as device:
        with pytest.raises(AcquisitionError) as info:
            SerialSource(device.port, rate=1000.0, stall=LOADED).open()
        one_line(info, device.port, "500 Hz", "rate=1000 Hz")


def test_a_stall_longer_than_stall_is_a_one_line_error() -> None:
    with (DeviceEmulator(SimulatedSource(NOISY, 0.3, rng=0)) as device,
          SerialSource(device.port, stall=1.0) as source):
        source.read(50)
        device.stall(60.0)  # cut short when the emulator closes
        with pytest.raises(AcquisitionError) as info:
            source.read(2000)
    one_line(info, device.port, "stopped sending", "1 s")


def test_garbage_only_is_a_stall_too() -> None:
    with (DeviceEmulator(SimulatedSource(NOISY, 0.3, rng=0), realtime=False, corrupt=1.0,
                         rng=0) as device,
          pytest.raises(AcquisitionError) as info):
        SerialSource(device.port, stall=0.3).open()
    one_line(info, device.port, "stopped sending valid frames", "corrupt")


@pytest.mark.parametrize("rate", [3.4e38, -0.0])
def test_a_device_announcing_an_absurd_rate_is_a_one_line_error(rate: float) -> None:
    with (DeviceEmulator(SimulatedSource(NOISY, 0.3, rng=0), rate=rate) as device,
          pytest.raises(AcquisitionError) as info):
        SerialSource(device.port, stall=0.5).open()
    one_line(info, device.port, "within the protocol's limits", "Hz")


def test_unplugging_is_a_one_line_error() -> None:
    with (DeviceEmulator(SimulatedSource(NOISY, 0.3, rng=0)) as device,
          SerialSource(device.port, stall=LOADED) as source):
        source.read(20)
        device.unplug()
        with pytest.raises(AcquisitionError) as info:
            source.read(2000)
    one_line(info, device.port, "vanished", "unplugged")


def test_a_port_that_does_not_exist_is_a_one_line_error(tmp_path: Path) -> None:
    port = str(tmp_path / "ttyMISSING")
    with pytest.raises(AcquisitionError) as info:
        SerialSource(port).read(10)
    one_line(info, port, "does not exist", "python -m serial.tools.list_ports")


def test_a_busy_port_is_a_one_line_error() -> None:
    with (DeviceEmulator(SimulatedSource(NOISY, 0.3, rng=0)) as device,
          SerialSource(device.port, stall=LOADED)):
        with pytest.raises(AcquisitionError) as info:
            SerialSource(device.port).open()
        one_line(info, device.port, "busy")


@pytest.mark.parametrize(("kw", "match"), [
    ({"port": ""}, "port must be"),
    ({"port": "/dev/x", "stall": 0.0}, "stall must be"),
    ({"port": "/dev/x", "baudrate": 0}, "baudrate must be"),
    ({"port": "/dev/x", "rate": -5.0}, "rate must be"),
    ({"port": "/dev/x", "rate": 3.4e38}, "rate must be a sample rate from 0.1 Hz"),
])
def test_serial_source_arguments(kw: dict[str, object], match: str) -> None:
    with pytest.raises(mc.MagciliaError, match=match):
        SerialSource(**kw)


def test_emulator_defaults_and_arguments() -> None:
    assert VOLTS_PER_COUNT == VPC
    with pytest.raises(mc.MagciliaError, match="corrupt must be a probability"):
        DeviceEmulator(SimulatedSource(NOISY), corrupt=1.5)
    with pytest.raises(mc.MagciliaError, match="source must be"):
        DeviceEmulator("sim")
