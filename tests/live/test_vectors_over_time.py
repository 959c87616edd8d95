"""Honest over time and replayable for every sensor (issue 26 items 3-6 for force vectors): a tare
under load of a 3-axis sensor or an array is flagged TARE_UNDER_LOAD (or refused while a good one
is in use) on every estimate, and says so in the views; ``live --record`` then ``live --source``
of a 3-axis or an array recording gives the live values within 1e-3 σ; ``readout FILE`` of such a
recording says what reads it; ``--record`` over an existing file needs ``--force``."""

from __future__ import annotations

import functools
import io
import json
import re
import time
from pathlib import Path

import numpy as np
import pytest
from rich.console import Console

import magcilia as mc
from magcilia.acquire import LoadScript, SimulatedFieldSource, single_cilium
from magcilia.cli import main
from magcilia.device.magnetometer import Magnetometer
from magcilia.live import LiveReadout
from magcilia.live.readouts import live_sensor
from magcilia.live.recorded import recorded_kind, recorded_readout
from magcilia.live.render import FLAG_NAMES, render
from magcilia.live.render_vector import VECTOR_FLAG_NAMES
from magcilia.live.replay import replay
from magcilia.readout.protocol import Flag

pytest.importorskip("nptdms")

PART = Magnetometer.preset("MMC5983MA")
SETUP = mc.Setup.paper(tip_radius=5e-5, youngs_modulus=2e6)
LOAD = np.array([2e-5, -1.5e-5])  # N
BIAS = [2e-5, 0.0, -3e-5]  # T: the Earth's field, tared away


@pytest.fixture(scope="module")
def biaxial() -> mc.BiaxialReadout:
    return mc.BiaxialReadout(SETUP, PART, span=4e-5, table_size=(17, 32))


@pytest.fixture(scope="module")
def small_array() -> mc.ArrayReadout:
    array = mc.CiliaArray.grid(SETUP, 2, 2, pitch=2e-3, sensor=PART)
    return mc.ArrayReadout(array, 4e-5, table_size=9)


def _vector(script: LoadScript, seed: int = 0, **kw: object) -> SimulatedFieldSource:
    return SimulatedFieldSource(PART, single_cilium(SETUP, PART), script, rng=seed, bias=BIAS,
                                drift=[1e-9, 0.0, -1e-9], **kw)  # type: ignore[arg-type]


def _array(readout: mc.ArrayReadout, script: LoadScript, seed: int = 0) -> SimulatedFieldSource:
    arr = readout.array
    return SimulatedFieldSource(arr.sensors, functools.partial(mc.field_for_loads, arr), script,
                                rng=seed, bias=BIAS)


def _run_to_end(live: LiveReadout) -> None:
    with live:
        deadline = time.monotonic() + 60.0  # only against a hang
        while live.running and time.monotonic() < deadline:
            time.sleep(0.01)


def _same_values(shown: object, replayed: object) -> float:
    """The largest |replayed − shown| / σ of two runs' estimates (the flags equal, the same
    estimates present); returns it."""
    a, b = shown, replayed
    np.testing.assert_array_equal(b.time, a.time)  # type: ignore[attr-defined]
    np.testing.assert_array_equal(b.flags, a.flags)  # type: ignore[attr-defined]
    good = np.isfinite(a.value)  # type: ignore[attr-defined]
    assert np.array_equal(good, np.isfinite(b.value)) and good.any()  # type: ignore[attr-defined]
    return float(np.max(np.abs(b.value[good] - a.value[good])  # type: ignore[attr-defined]
                        / a.sigma[good]))  # type: ignore[attr-defined]


# -- honest over time ------------------------------------------------------------------------------
def _lines(text: str) -> list[dict[str, object]]:
    """The read-out lines (those with a value) of ``--json-lines`` output."""
    return [d for d in (json.loads(x) for x in text.splitlines() if x.startswith("{"))
            if "value" in d]


def test_a_3_axis_tare_under_load_is_flagged_then_a_loaded_one_refused(
        biaxial: mc.BiaxialReadout) -> None:
    """The first tare is taken while the cilium is pushed back and forth: kept, every estimate
    flagged TARE_UNDER_LOAD (the terminal view names it); a tare at rest clears it; a tare asked
    for under load after that is refused and the good one stays."""
    def pushes(t: np.ndarray) -> np.ndarray:
        on = (np.mod(t, 0.2) < 0.1) & ((t < 0.6) | (t > 1.6))
        return np.where(on[:, None, None], LOAD, 0.0) * np.ones((t.size, 1, 2))
    source = _vector(LoadScript.from_function(1, pushes), realtime=True, speed=2.0)
    live = LiveReadout(source, biaxial, rate=50, tare_at_start=True, batch=0.02)
    with live:
        first = live.wait(30, timeout=30)  # the starting tare (0.5 s) and a little more
        assert live.zero.under_load and "TARE_UNDER_LOAD" in live.status.message
        tared = first.time >= live.zero.tared_at
        assert (first.flags[tared] & Flag.TARE_UNDER_LOAD).all()
        con = Console(width=110, record=True, file=io.StringIO())
        con.print(render(live.status, first, live.limits(), recent=live.history.last(0.1, 50)))
        assert "TARE UNDER LOAD 100%" in con.export_text()
        while live.history.total < 40:  # past 0.8 s: at rest until 1.6 s
            time.sleep(0.01)
        assert live.tare(wait=20.0) and not live.zero.under_load
        kept = live.zero.baseline
        while live.history.total < 85:  # past 1.7 s: the pushes again
            time.sleep(0.01)
        assert live.tare(wait=20.0)
        assert "tare refused" in live.status.message
        assert live.zero.baseline is kept and not live.zero.under_load
        after = live.wait(10, timeout=30)
    assert not (after.flags & Flag.TARE_UNDER_LOAD).any()
    assert next(e.text for e in live.events if e.kind == "tare").endswith("NOT AT REST")
    assert VECTOR_FLAG_NAMES[Flag.TARE_UNDER_LOAD] == "TARE UNDER LOAD"
    assert VECTOR_FLAG_NAMES[Flag.ZERO_DRIFT] == "ZERO DRIFT"


def test_every_cilium_of_an_array_tared_under_load_is_flagged(
        small_array: mc.ArrayReadout) -> None:
    def pushes(t: np.ndarray) -> np.ndarray:
        on = np.mod(t, 0.2) < 0.1
        return np.where(on[:, None, None], LOAD, 0.0) * np.ones((t.size, 4, 2))
    with LiveReadout(_array(small_array, LoadScript.from_function(4, pushes)), small_array,
                     rate=50, tare_at_start=True, batch=0.02) as live:
        s = live.wait(40, timeout=60)
    assert s.flags.shape == (40, 4)
    tared = s.time >= live.zero.tared_at  # (the tare's last block is read after it)
    assert tared.any() and (s.flags[tared] & Flag.TARE_UNDER_LOAD).all()
    assert not (s.flags[~tared] & Flag.TARE_UNDER_LOAD).any()


def test_the_dashboard_knows_the_zero_s_flags() -> None:
    """The badge tables of both scripts hold TARE UNDER LOAD (4096) and ZERO DRIFT (8192): a tare
    kept under load no longer shows "OK"."""
    static = Path(mc.__file__).parent / "live" / "static"
    scalar = (static / "dashboard.js").read_text()
    vectors = (static / "vectors.js").read_text()
    assert int(Flag.TARE_UNDER_LOAD) == 4096 and int(Flag.ZERO_DRIFT) == 8192
    assert '[4096, "TARE UNDER LOAD", "bad"]' in scalar and '[8192, "ZERO DRIFT", "warn"]' in scalar
    assert "TARE_UNDER_LOAD = 4096" in vectors and "ZERO_DRIFT = 8192" in vectors
    assert '[TARE_UNDER_LOAD, "TARE UNDER LOAD", "bad"]' in vectors


def _badge_table(script: str, start: str) -> dict[int, str]:
    """A dashboard script's badge table (``[bit, "NAME", "warn"|"bad"]`` rows after ``start``)
    as bit -> name (a bit written as a Flag's name resolved through Flag)."""
    body = script[script.index(start):]
    body = body[:body.index("]];") + 2]
    rows = re.findall(r'\[(\w+), "([A-Z ]+)", "(?:warn|bad)"\]', body)
    return {int(b) if b.isdigit() else int(Flag[b]): name for b, name in rows}


def test_the_dashboard_badges_are_the_terminal_s() -> None:
    """The scripts' badge tables (the one copy the browser needs) show the same bits under the
    same names as the terminal's tables, which come from Flag itself."""
    static = Path(mc.__file__).parent / "live" / "static"
    scalar = _badge_table((static / "dashboard.js").read_text(), "const FLAGS =")
    vectors = _badge_table((static / "vectors.js").read_text(), "V.FLAGS =")
    assert scalar == {int(f): name for f, name in FLAG_NAMES.items()}
    assert vectors == {int(f): name for f, name in VECTOR_FLAG_NAMES.items()}
    assert all(name == str(Flag(bit).name).replace("_", " ") for bit, name in vectors.items())


# -- replay ----------------------------------------------------------------------------------------
def test_a_replay_of_a_3_axis_sensor_gives_the_live_values(biaxial: mc.BiaxialReadout,
                                                           tmp_path: Path) -> None:
    """Recorded from the start (a second tare asked for during the run, at rest or refused),
    replayed through the same pipeline: times, flags, corrections and tares the same, values
    within 1e-3 σ; the stored read-out is the one recorded."""
    path = tmp_path / "vector.tdms"
    script = LoadScript.from_steps([(0.0, [0.0, 0.0]), (0.8, LOAD), (1.4, [0.0, 0.0])])
    with LiveReadout(_vector(script, seed=2), biaxial, rate=50, tare_at_start=True,
                     record=path, batch=0.02) as live:
        live.wait(60, timeout=30)
        live.tare(wait=20.0)
        live.wait(20, timeout=30)
    shown = live.history.since(0)[0]
    assert recorded_kind(path) == "vector"
    stored = recorded_readout(path)
    assert isinstance(stored, mc.BiaxialReadout) and stored.inputs == biaxial.inputs
    np.testing.assert_allclose(stored.rest, biaxial.rest, rtol=1e-12)
    again = replay(path)
    _run_to_end(again)
    replayed = again.history.since(0)[0]
    assert len(replayed) == len(shown) and replayed.value.shape[1:] == (2,)
    assert _same_values(shown, replayed) < 1e-3
    np.testing.assert_allclose(replayed.correction, shown.correction, rtol=0, atol=1e-15)
    taken = [e.text for e in live.events if e.kind == "tare"]
    assert [e.text for e in again.events if e.kind == "tare"] == taken and len(taken) == 2


def test_a_replay_of_an_array_gives_the_live_values(small_array: mc.ArrayReadout,
                                                    tmp_path: Path) -> None:
    path = tmp_path / "array.tdms"
    script = LoadScript.from_steps([(0.0, np.zeros((4, 2))), (0.7, [LOAD, -LOAD, LOAD / 2,
                                                                    [0.0, 1e-5]])])
    with LiveReadout(_array(small_array, script, seed=4), small_array, rate=50,
                     tare_at_start=True, record=path, batch=0.02) as live:
        live.wait(60, timeout=60)
    shown = live.history.since(0)[0]
    assert recorded_kind(path) == "array"
    again = replay(path)
    assert isinstance(again.readout, mc.ArrayReadout)
    assert again.sensor.names == small_array.array.names
    _run_to_end(again)
    replayed = again.history.since(0)[0]
    assert len(replayed) == len(shown) and replayed.value.shape[1:] == (4, 2)
    assert _same_values(shown, replayed) < 1e-3


def test_live_record_then_source_of_a_3_axis_sensor_through_the_cli(
        tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    """The done-when check for a 3-axis sensor: ``live --sensor … --record`` then ``live --source
    FILE``, force vector for force vector within 1e-3 σ; ``readout FILE`` says how to read it;
    a second ``--record FILE`` is refused without ``--force`` and leaves the file as it was."""
    rec = tmp_path / "vector.tdms"
    assert main(["live", "--sensor", "MMC5983MA", "--duration", "1", "--record", str(rec),
                 "--json-lines"]) == 0
    first = capsys.readouterr().out
    assert main(["live", "--source", str(rec), "--json-lines"]) == 0
    again = capsys.readouterr().out

    shown, replayed = _lines(first), {d["t"]: d for d in _lines(again)}
    assert len(shown) >= 60
    matched = 0
    for d in shown:
        r = replayed.get(d["t"])
        if r is None:
            continue
        matched += 1
        assert r["flags"] == d["flags"]
        if d["value"][0] is not None:  # type: ignore[index]
            diff = np.subtract(r["value"], d["value"])  # type: ignore[arg-type]
            assert np.all(np.abs(diff) < 1e-3 * np.asarray(d["sigma"]))
    assert matched >= len(shown) - 2
    code = main(["readout", str(rec), "--csv", str(tmp_path / "v.csv")])
    err = capsys.readouterr().err
    assert code == 2 and len(err.strip().splitlines()) == 1
    assert "3-axis sensor's force vectors" in err and "live --source" in err
    assert not (tmp_path / "v.csv").exists()


@pytest.mark.parametrize("command", ["live", "dashboard"])
def test_record_over_an_existing_file_needs_force(tmp_path: Path, command: str,
                                                  capsys: pytest.CaptureFixture[str]) -> None:
    rec = tmp_path / "kept.tdms"
    rec.write_bytes(b"an earlier recording")
    code = main([command, "--record", str(rec), "--port", "0"] if command == "dashboard" else
                [command, "--record", str(rec), "--duration", "1", "--json-lines"])
    err = capsys.readouterr().err
    assert code == 2 and err.strip().splitlines() == [
        f"magcilia: error: {rec} exists; pass --force to replace it, or choose another --record"]
    assert rec.read_bytes() == b"an earlier recording"


def test_a_3_axis_zero_that_drifts_under_a_held_load_is_flagged(
        biaxial: mc.BiaxialReadout) -> None:
    """Zero tracking learns the drift at rest; under a load held for seconds it cannot follow:
    σ grows with the drift not tracked and, beyond the noise of a reading, ZERO_DRIFT is set."""
    script = LoadScript.from_steps([(0.0, [0.0, 0.0]), (2.0, LOAD)])
    source = SimulatedFieldSource(PART, single_cilium(SETUP, PART), script, rng=5, bias=BIAS,
                                  drift=[3e-8, -3e-8, 3e-8])  # T/s: a reading's noise per s
    with LiveReadout(source, biaxial, rate=50, tare_at_start=True, tracking=5.0,
                     batch=0.02) as live:
        s = live.wait(300, timeout=60)
    rest = (s.time > 0.6) & (s.time < 1.9)
    late = s.time > 4.0
    assert not (s.flags[rest] & Flag.ZERO_DRIFT).any()
    assert (s.flags[late] & Flag.ZERO_DRIFT).all()
    assert np.median(s.sigma[late]) > 1.5 * np.median(s.sigma[rest])


def test_the_zero_s_channel_flags_reach_the_cilia_they_inform(
        small_array: mc.ArrayReadout, biaxial: mc.BiaxialReadout) -> None:
    """A channel's ZERO_DRIFT flags the cilia whose fit it informs (≥ its noise over their span,
    the array's rule for SATURATED and MISSING, recomputed here cilium by cilium); a tare under
    load (every channel) flags every cilium; one cilium gets all channels' flags."""
    sensor = live_sensor(small_array)
    c, c_n = small_array.rest.size, len(small_array.array)
    for ch in (0, 5, c - 1):
        bits = np.zeros(c, dtype=np.uint16)
        bits[ch] = Flag.ZERO_DRIFT
        out = sensor.zero_flags(bits)
        for k in range(c_n):
            dfield = np.abs(small_array.jacobian[ch, 2 * k:2 * k + 2]) * small_array.span[k]
            informed = bool(np.any(dfield >= small_array.sigma[ch]))
            assert bool(out[k] & Flag.ZERO_DRIFT) == informed
    assert (sensor.zero_flags(np.full(c, Flag.TARE_UNDER_LOAD, np.uint16))
            == Flag.TARE_UNDER_LOAD).all()
    one = live_sensor(biaxial)
    assert one.zero_flags(np.array([0, Flag.ZERO_DRIFT, 0], np.uint16)) == Flag.ZERO_DRIFT


def test_live_record_then_source_of_an_array_through_the_cli(
        small_array: mc.ArrayReadout, tmp_path: Path,
        capsys: pytest.CaptureFixture[str]) -> None:
    """The done-when check for an array (a 2 × 2 array file, to keep it short): every cilium's
    force vector of the replay within 1e-3 σ of the live run's, flags equal."""
    from magcilia.io.array_file import save_array

    setup, rec = tmp_path / "array.toml", tmp_path / "array.tdms"
    save_array(small_array.array, setup)
    assert main(["live", "--setup", str(setup), "--rate", "50", "--duration", "1", "--record",
                 str(rec), "--json-lines"]) == 0
    first = capsys.readouterr().out
    assert main(["live", "--source", str(rec), "--json-lines"]) == 0
    again = capsys.readouterr().out

    shown, replayed = _lines(first), {d["t"]: d for d in _lines(again)}
    assert len(shown) >= 40 and len(shown[-1]["value"]) == 4  # type: ignore[arg-type]
    matched = valued = 0
    for d in shown:
        r = replayed.get(d["t"])
        if r is None:
            continue
        matched += 1
        assert r["flags"] == d["flags"]
        value = np.array(d["value"], dtype=float)
        good = np.isfinite(value)
        if good.any():
            valued += 1
            diff = np.abs(np.array(r["value"], dtype=float) - value)[good]
            assert np.all(diff < 1e-3 * np.array(d["sigma"], dtype=float)[good])
    assert matched >= len(shown) - 2 and valued >= 20
