"""The live read-out of force vectors: a 3-axis sensor and an array through the same pipeline as
a single output (History shapes, frames, recording, JSON lines, the CLI), against simulated
sources whose fields come from the exact forward model (the elastica), not the read-outs' tables.
"""

from __future__ import annotations

import functools
import io
import json
import math
from pathlib import Path
from typing import Any

import numpy as np
import pytest

import magcilia as mc
from magcilia.acquire import LoadScript, SimulatedFieldSource, single_cilium
from magcilia.cli import main
from magcilia.device.magnetometer import Magnetometer
from magcilia.io.array_file import load_array
from magcilia.io.recording_file import recording_properties
from magcilia.live import History, LiveReadout
from magcilia.live.frames import VECTOR_COLUMNS, decimate, decode_frame, encode_frame
from magcilia.live.readouts import live_sensor, protocol_view
from magcilia.live.render_vector import current_vectors, grid_of
from magcilia.live.streams import stream_json_lines
from magcilia.readout.protocol import Flag, SensorReadout

ROOT = Path(__file__).resolve().parents[2]
ARRAY = ROOT / "examples" / "array.toml"
PART = Magnetometer.preset("MMC5983MA")
#: E taken as exact: σ is the noise's alone, which the spread of the estimates can check
SETUP = mc.Setup.paper(tip_radius=5e-5, youngs_modulus=2e6)
LOAD = np.array([2e-5, -1.5e-5])  # N


@pytest.fixture(scope="module")
def biaxial() -> mc.BiaxialReadout:
    return mc.BiaxialReadout(SETUP, PART, span=4e-5, table_size=(33, 64))


def _vector_source(script: LoadScript, seed: int = 0, **kw: object) -> SimulatedFieldSource:
    return SimulatedFieldSource(PART, single_cilium(SETUP, PART), script, rng=seed,
                                bias=[2e-5, 0.0, -3e-5], **kw)  # type: ignore[arg-type]


# -- the protocol's view --------------------------------------------------------------------------
def test_every_read_out_follows_the_protocol_unchanged(biaxial: mc.BiaxialReadout) -> None:
    view = protocol_view(biaxial)
    assert isinstance(view, SensorReadout)
    assert view.inputs == tuple(f"{PART.name}.{a}" for a in "xyz")
    truth = SETUP.field(mc.bend(SETUP, float(np.hypot(*LOAD))),
                        azimuth=math.atan2(LOAD[1], LOAD[0]))
    out = view.read(np.repeat(truth, 3, axis=0))
    assert out.value.shape == (3, 2) and out.sigma.shape == (3, 2) and out.flags.shape == (3,)
    assert np.allclose(out.value, LOAD, atol=1e-3 * 4e-5) and out.unit == "N"
    tared = view.tare(np.repeat(view.rest[None] + 1e-6, 4, axis=0) + np.array([[0, 0, 1e-8],
                                                                              [0, 1e-8, 0],
                                                                              [1e-8, 0, 0],
                                                                              [0, 0, 0]]))
    assert tared.baseline is not None and view.baseline is None  # a copy, the original kept
    scalar = protocol_view(mc.Readout(SETUP, "force", span=(-1e-4, 1e-4)))
    assert scalar.inputs == ("output",) and scalar.rest.shape == (1,)
    with pytest.raises(mc.MagciliaError, match="readout"):
        protocol_view(SETUP)


# -- the History ---------------------------------------------------------------------------------
def test_the_history_keeps_vector_shapes_across_the_ring() -> None:
    h = History("force", "N", 5, {"value": (3, 2), "sigma": (3, 2), "flags": (3,),
                                  "raw": (9,), "correction": (9,)}, ("a", "b", "c"))
    for start in (0, 4):  # 4 then 4 more: the second append wraps the ring
        m = 4
        t = np.arange(start, start + m, dtype=np.float64)
        h.append({"time": t, "raw": np.zeros((m, 9)),
                  "value": t[:, None, None] * np.ones((m, 3, 2)), "sigma": np.ones((m, 3, 2)),
                  "flags": np.full((m, 3), Flag.NEAR_ZERO), "correction": np.zeros((m, 9)),
                  "received": t, "published": t + 1e-3})
    s, cursor, lost = h.since(0)
    assert cursor == 8 and lost == 3 and s.time.tolist() == [3, 4, 5, 6, 7]
    assert s.value.shape == (5, 3, 2) and s.flags.shape == (5, 3) and s.raw.shape == (5, 9)
    assert s.value[:, 1, 0].tolist() == [3, 4, 5, 6, 7] and s.kind == "array"
    assert s.magnitude.shape == (5, 3) and s.good.all()  # NEAR_ZERO keeps a value
    assert "array samples (3 cilia)" in s.report()
    frame = s.to_dataframe()
    assert len(frame) == 15 and {"force_x_N", "sigma_y_N", "cilium"} <= set(frame.columns)


# -- the pipeline ---------------------------------------------------------------------------------
def test_a_simulated_3_axis_sensor_reads_its_scripted_load_within_sigma(
        biaxial: mc.BiaxialReadout) -> None:
    """A seeded simulation (the elastica, the part's noise and LSB, the Earth's field tared
    away): at steady state the mean of the estimates lies within the σ of a mean (its noise and
    the tare's shared error), and the stated σ matches the spread of the estimates."""
    script = LoadScript.from_steps([(0.0, [0.0, 0.0]), (1.0, LOAD)])
    with LiveReadout(_vector_source(script), biaxial, rate=50, tare_at_start=True,
                     tracking=None) as live:
        s = live.wait(150, timeout=60)
        assert live.status.tared and np.shape(live.status.correction) == (3,)
    assert s.value.shape == (150, 2) and s.raw.shape == (150, 3)
    steady = s.time > 1.2
    n = int(steady.sum())
    assert n > 80 and (s.flags[steady] == 0).all()
    mean = s.value[steady].mean(axis=0)
    sigma = np.median(s.sigma[steady], axis=0)
    tare_readings = 25  # 0.5 s at 50 Hz
    assert np.all(np.abs(mean - LOAD) < 3 * sigma * math.sqrt(1 / n + 1 / tare_readings))
    assert np.all(np.abs(s.value[steady].std(axis=0) / sigma - 1) < 0.4)
    r = current_vectors(s, window=1.0)
    assert r.magnitude[0] == pytest.approx(np.hypot(*LOAD), rel=0.02)
    assert math.degrees(r.direction[0]) == pytest.approx(-36.87, abs=2.0)
    assert live.limits().span == (0.0, 4e-5)


def test_force_vectors_are_recorded_with_their_channels(biaxial: mc.BiaxialReadout,
                                                        tmp_path: Path) -> None:
    from nptdms import TdmsFile

    script = LoadScript.from_steps([(0.0, [0.0, 0.0]), (0.6, LOAD)])
    with LiveReadout(_vector_source(script, realtime=True, speed=4.0), biaxial, rate=50,
                     tare_at_start=True) as live:
        path = live.start_recording(tmp_path / "vector.tdms")
        live.wait(65, timeout=30)
        live.stop_recording()
    f = TdmsFile.read(path)
    raw = f["recording"]
    assert {f"{PART.name}.{a}" for a in "xyz"} <= {c.name for c in raw.channels()}
    assert "voltage_V" not in {c.name for c in raw.channels()}
    group = f["readout"]
    names = {c.name for c in group.channels()}
    assert {"value_x", "value_y", "sigma_x", "sigma_y", "flags"} <= names
    assert f"raw_T[{PART.name}.z]" in names and f"correction_T[{PART.name}.x]" in names
    assert len(group["value_x"][:]) >= 65
    assert np.nanmedian(group["value_x"][-20:]) == pytest.approx(LOAD[0], rel=0.05)
    assert np.nanmedian(group["value_y"][-20:]) == pytest.approx(LOAD[1], rel=0.05)
    meta = recording_properties(path)
    assert meta["kind"] == "vector" and json.loads(meta["inputs"])[0] == f"{PART.name}.x"


def test_frames_carry_every_force_vector() -> None:
    h = History("force", "N", 10, {"value": (2, 2), "sigma": (2, 2), "flags": (2,)})
    m = 6
    value = np.stack([np.full((m, 2), 1e-5), np.full((m, 2), -2e-5)], axis=1)
    value[1, 0] = np.nan  # a reading without a value: left out of its bin's mean
    h.append({"time": np.arange(m) * 0.01, "raw": np.zeros(m), "value": value,
              "sigma": np.full((m, 2, 2), 1e-6), "flags": np.zeros((m, 2), np.uint16),
              "correction": np.zeros(m), "received": np.zeros(m), "published": np.zeros(m)})
    s = h.since(0)[0]
    cols = decimate(s, 3)
    assert cols.shape == (1 + 2 * len(VECTOR_COLUMNS), 2)
    assert np.allclose(cols[1:3], 1e-5) and np.allclose(cols[6:8], -2e-5)
    header, back = decode_frame(encode_frame(7, cols, received=1.0, sent=2.0, bin_seconds=0.03,
                                             cilia=2))
    assert header["cilia"] == 2 and header["frame"] == 7 and np.array_equal(back, cols)


# -- the views ------------------------------------------------------------------------------------
def test_json_lines_of_a_3_axis_sensor_are_force_vectors(biaxial: mc.BiaxialReadout) -> None:
    out = io.StringIO()
    script = LoadScript.constant(LOAD)
    with LiveReadout(_vector_source(script, realtime=True, speed=4.0), biaxial, rate=50,
                     tare_at_start=True) as live:
        stream_json_lines(live, out, seconds=0.5)
    lines = [json.loads(x) for x in out.getvalue().splitlines()]
    samples = [x for x in lines if "value" in x]
    assert samples and all(set(x) == {"t", "value", "sigma", "flags", "unit"} for x in samples)
    x = samples[-1]
    assert len(x["value"]) == 2 and len(x["sigma"]) == 2 and isinstance(x["flags"], int)
    assert x["unit"] == "N"


def test_the_array_setup_streams_one_vector_per_cilium(capsys: pytest.CaptureFixture[str]) -> None:
    """``magcilia live --setup examples/array.toml --json-lines``: 16 force vectors per line in
    the file's order (never one cilium), flags one per cilium."""
    code = main(["live", "--setup", str(ARRAY), "--rate", "50", "--duration", "1.2",
                 "--json-lines"])
    assert code == 0
    lines = [json.loads(x) for x in capsys.readouterr().out.splitlines()]
    samples = [x for x in lines if "value" in x]
    assert len(samples) >= 20
    names = load_array(ARRAY).names
    for x in samples:
        assert len(x["value"]) == len(names) == 16 and len(x["flags"]) == 16
        assert all(len(v) == 2 for v in x["value"]) and x["unit"] == "N"
    assert [x["t"] for x in samples] == sorted(x["t"] for x in samples)
    tared = [x for x in samples if not any(f & Flag.OUTSIDE_SPAN for f in x["flags"])]
    assert tared and all(v[0] is not None for v in tared[-1]["value"])


def test_options_of_one_output_are_refused_for_an_array(
        capsys: pytest.CaptureFixture[str]) -> None:
    assert main(["live", "--setup", str(ARRAY), "--quantity", "angle", "--duration", "1",
                 "--json-lines"]) == 2
    err = capsys.readouterr().err
    assert err.startswith("magcilia: error: --quantity") and "array" in err


def test_sensor_noise_without_sensor_is_refused_for_an_array_too(
        capsys: pytest.CaptureFixture[str]) -> None:
    """--sensor-noise belongs to --sensor: an array setup (whose parts know their noise) does
    not ignore it silently."""
    assert main(["live", "--setup", str(ARRAY), "--sensor-noise", "2mG", "--duration", "1",
                 "--json-lines"]) == 2
    err = capsys.readouterr().err
    assert err.startswith("magcilia: error: --sensor-noise") and err.count("\n") == 1


def test_the_array_view_places_the_cilia_as_on_the_board() -> None:
    arr = load_array(ARRAY)
    sensor = live_sensor(mc.ArrayReadout(arr, 2e-5))
    rows, _, n_rows, n_cols = grid_of(sensor.positions)
    assert (n_rows, n_cols) == (4, 4)
    top = [arr.names[c] for c in np.flatnonzero(rows == 0)]
    assert sorted(top) == ["r4c1", "r4c2", "r4c3", "r4c4"]  # +y up: the last row on top
    assert sensor.value_shape == (16, 2) and sensor.flags_shape == (16,)
    assert sensor.inputs[:3] == tuple(f"{arr.sensors[0].name}.{a}" for a in "xyz")


def test_the_array_source_uses_the_exact_forward_map() -> None:
    arr = load_array(ARRAY)
    loads = np.zeros((16, 2))
    loads[5] = [1e-5, 5e-6]
    source = SimulatedFieldSource(arr.sensors, functools.partial(mc.field_for_loads, arr),
                                  LoadScript.constant(loads), rng=0)
    assert np.allclose(source.fields(loads[None])[0], mc.field_for_loads(arr, loads))
    with source:
        block = source.read(4)
    assert block.data.shape == (48, 4) and source.rate == arr.sensors[0].rate


# -- the pure parts, per channel ------------------------------------------------------------------
def test_windows_average_and_demodulate_every_channel() -> None:
    from magcilia.live import Averager

    t = np.arange(40.0)
    x = np.stack([np.arange(40.0), -np.arange(40.0), np.full(40, 5.0)], axis=-1)
    w = Averager(10).push(t, x, np.zeros(40, bool))
    assert w.volts.shape == (4, 3) and w.volts[:, 0].tolist() == [4.5, 14.5, 24.5, 34.5]
    sr = np.where((np.arange(40) // 5) % 2 == 0, 1, -1).astype(np.int8)
    bridge = np.array([1e-3, -2e-3, 0.0])
    offset = np.array([0.1, 0.2, 0.3])
    raw = sr[:, None] * bridge + offset  # the bridge flips with the pulses, the offset does not
    w = Averager(10, offset=np.zeros(3)).push(t, raw, np.zeros(40, bool), sr)
    assert np.allclose(w.volts, bridge)


def test_zero_tracking_of_channels_follows_a_drift_and_never_a_load() -> None:
    from magcilia.live import Zero

    rest = np.array([1e-5, -2e-5, 3e-5])
    zero = Zero(rest, tau=1.0, band=3.0)
    rng = np.random.default_rng(0)
    zero.tare(rest + 4e-8 * rng.standard_normal((25, 3)), 0.0)
    assert zero.correction.shape == (3,) and zero.noise.shape == (3,)
    drift = np.array([2e-9, 0.0, -1e-9])  # T per batch: within the band
    for k in range(200):
        zero.track(rest + drift * k + 4e-8 * rng.standard_normal((10, 3)), 0.02)
    assert np.allclose(zero.correction, -drift * 199, atol=3e-8)
    before = zero.correction.copy()
    load = np.array([0.0, 5e-7, 0.0])  # one channel beyond its band: it holds, the others follow
    zero.track(rest + drift * 200 + load + np.zeros((10, 3)), 0.02)
    assert zero.correction[1] == before[1]
    assert np.allclose(zero.correction[[0, 2]], -drift[[0, 2]] * 200, atol=3e-8)


def test_the_terminal_view_of_vectors_and_of_an_array() -> None:
    pytest.importorskip("rich")
    from rich.console import Console

    from magcilia.acquire.source import Counters
    from magcilia.live import Limits, LiveStatus
    from magcilia.live.render import render

    status = LiveStatus("running", "", Counters(100, 0, 0), 0, 100, 50.0, True,
                        np.zeros(3), np.zeros(3), np.full(3, 4e-8), None, 1e-3, 2e-3, "T")
    limits = Limits("force", "N", (0.0, 4e-5), (0.0, 4e-5), 1e-7, "span")

    def text(samples: object, **kw: object) -> str:
        console = Console(record=True, width=120, force_terminal=False)
        console.print(render(status, samples, limits, [], **kw))  # type: ignore[arg-type]
        return console.export_text()

    m = 50
    t = np.arange(m) / 50.0
    h = History("force", "N", m, {"value": (2,), "sigma": (2,), "raw": (3,),
                                  "correction": (3,)})
    h.append({"time": t, "raw": np.zeros((m, 3)), "value": np.tile([0.0, 2e-5], (m, 1)),
              "sigma": np.full((m, 2), 1e-6), "flags": np.zeros(m), "correction": np.zeros((m, 3)),
              "received": t, "published": t})
    out = text(h.since(0)[0])
    assert "|F|: 0.0200 ± 0.001 mN" in out and "toward +90.0°" in out and "↑" in out
    assert "Fx +0.0000 ± 0.001 mN" in out and "Fy last 10 s" in out
    assert "3 channels" in out and "all 6 readings good" in out  # the last 0.1 s

    names = ("a", "b", "c", "d")
    positions = np.array([[0.0, 0.0], [1e-3, 0.0], [0.0, 1e-3], [1e-3, 1e-3]])
    h = History("force", "N", m, {"value": (4, 2), "sigma": (4, 2), "flags": (4,)}, names)
    value = np.zeros((m, 4, 2))
    value[:, 3] = [-1e-5, 0.0]
    flags = np.zeros((m, 4))
    flags[:, 1] = Flag.ABOVE_SPAN
    h.append({"time": t, "raw": np.zeros(m), "value": value, "sigma": np.full((m, 4, 2), 1e-6),
              "flags": flags, "correction": np.zeros(m), "received": t, "published": t})
    out = text(h.since(0)[0], names=names, positions=positions, chosen=3)
    rows = [line for line in out.splitlines() if " a " in f" {line} " or "c " in line]
    top = next(line for line in out.splitlines() if "c " in line and "d " in line)
    assert top.index("c ") < top.index("d ") and "←" in top  # +y up: c and d on top
    assert rows and "cilium d |F|: 0.0100" in out and "ABOVE SPAN" in out
    assert "n/p next/previous cilium" in out


def test_a_3_axis_source_that_vanishes_is_reopened_and_read_on(
        biaxial: mc.BiaxialReadout) -> None:
    from magcilia._errors import AcquisitionError

    class Vanishing(SimulatedFieldSource):
        """Fails its 30th read and its first reopening, then works again."""

        reads = 0
        opens = 0

        def _open(self) -> None:
            self.opens += 1
            if self.opens == 2:
                raise AcquisitionError("sim: no such device (unplugged)")
            super()._open()

        def _read(self, n: int) -> Any:
            self.reads += 1
            if self.reads == 30:
                raise AcquisitionError("sim: device vanished")
            return super()._read(n)

    source = Vanishing(PART, single_cilium(SETUP, PART), LoadScript.constant(LOAD), rng=0,
                       realtime=True, speed=4.0)
    with LiveReadout(source, biaxial, rate=50, reconnect=0.05, tare_at_start=False) as live:
        live.wait(28, timeout=30)
        after = live.wait(40, timeout=30)  # across the gap
        kinds = [e.kind for e in live.events]
    assert "disconnected" in kinds and "reconnected" in kinds
    assert after.value.shape == (40, 2) and live.status.state == "stopped"
