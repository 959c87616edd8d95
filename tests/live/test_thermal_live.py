"""The live read-out of a source with a temperature channel (issue #29 item 4 follow-up): each
sample brought to the reference temperature before the zero, the readings finished by the
ThermalReadout (modulus, σ, TEMPERATURE_OUTSIDE), the recording keeping the temperature."""

from __future__ import annotations

import io
import json
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest

import magcilia as mc
from magcilia.acquire import Script, SimulatedSource
from magcilia.cli import main
from magcilia.device.temperature import TemperatureModel, TemperatureProfile
from magcilia.io.recordings import read_samples
from magcilia.io.setup_files import save_setup
from magcilia.live import LiveReadout
from magcilia.live.readouts import live_sensor
from magcilia.live.render import render
from magcilia.readout.protocol import Flag

OUTSIDE = int(Flag.TEMPERATURE_OUTSIDE)
SPAN = (-4e-5, 4e-5)  # N
RAMP = (293.15, 313.15, 4.0)  # K, K, s


def text_of(renderable: object) -> str:
    console = pytest.importorskip("rich.console").Console(record=True, width=100,
                                                          file=io.StringIO(), color_system=None)
    console.print(renderable)
    return console.export_text()


@pytest.fixture(scope="module")
def setup() -> mc.Setup:
    preset = mc.presets.load("force-sensor")  # the modulus taken as known: σ is the noise's
    return preset.replace(youngs_modulus=preset.youngs_modulus, youngs_modulus_sigma=0.0)


def _run(setup: mc.Setup, readout: object, record: Path | None = None) -> mc.live.LiveSamples:
    """A 4 s ramp at rest (10 kHz, as fast as it computes), read at 1 kHz, tared on the first
    0.5 s: the 3000 readings after the tare."""
    model = TemperatureModel()
    source = SimulatedSource(setup, Script.constant(0.0, "force"), rate=10000.0, rng=0,
                             readout_noise=2e-5, temperature=TemperatureProfile.ramp(*RAMP),
                             thermal=model)
    with LiveReadout(source, readout, rate=1000, tare_at_start=True, tracking=None,
                     record=record) as live:
        live.wait(600)
        assert live.status.tared
        samples = live.wait(3000)
        shown = text_of(render(live.status, live.history.last(10.0, live.rate),
                               live.limits(), width=100))
    assert live.status.state == "stopped"
    if isinstance(readout, mc.ThermalReadout):  # the view: the temperature and the flag
        assert "temperature: " in shown and "— OUTSIDE the calibrated range" in shown
        assert "TEMPERATURE OUTSIDE 100%" in shown
        assert "temperature 3" in live.status.report()
    else:
        assert "temperature" not in shown
    return samples


def test_a_ramp_at_rest_reads_zero_within_2_sigma(setup: mc.Setup, tmp_path: Path) -> None:
    """At rest through a 20 K ramp the compensated force lies within 2σ of the truth (0) in
    ≥ 95 % of the readings, and at the hot end where the plain read-out is off by more than
    its σ; beyond the calibrated range (to 303.15 K, the tare's start within it) the readings
    are flagged TEMPERATURE_OUTSIDE, from one reading on, their values kept; the recording
    keeps the temperature column."""
    plain = mc.Readout(setup, quantity="force", span=SPAN, table_size=65)
    thermal = mc.ThermalReadout(plain, TemperatureModel(), calibrated_range=(293.15, 303.15))
    s = _run(setup, thermal, tmp_path / "run.tdms")
    assert np.isfinite(s.value).all()
    inside = np.abs(s.value) <= 2.0 * s.sigma
    assert inside.mean() >= 0.95
    hot = slice(-300, None)  # the hottest 10 %
    assert inside[hot].mean() >= 0.95
    outside = (s.flags & OUTSIDE) != 0
    assert outside[-1] and not outside[0]
    first = int(np.argmax(outside))
    assert outside[first:].all() and not outside[:first].any()
    assert (s.flags & ~np.uint16(OUTSIDE) == 0).all()
    cols = read_samples(tmp_path / "run.tdms", ("voltage_V",), temperature=True)
    assert cols["temperature_K"][0] == pytest.approx(293.15, abs=1e-3)
    assert cols["temperature_K"][-1] > 305.0
    raw = _run(setup, plain)  # the same run read without the compensation
    off = np.abs(np.mean(raw.value[hot]))
    assert off > 3.0 * np.median(raw.sigma[hot])
    assert abs(np.mean(s.value[hot])) < 0.2 * off


def test_the_live_view_of_a_thermal_readout(setup: mc.Setup) -> None:
    """It reads the output and temperature_K, one value per reading, the wrapped read-out's
    span and setup; a source without a temperature channel is a one-line error."""
    plain = mc.Readout(setup, quantity="force", span=SPAN, table_size=65)
    sensor = live_sensor(mc.ThermalReadout(plain))
    assert sensor.kind == "scalar" and sensor.inputs == ("output", "temperature_K")
    assert sensor.thermal is not None and sensor.readout is plain
    source = SimulatedSource(setup, Script.constant(0.0, "force"), rate=10000.0, rng=0)
    with pytest.raises(mc.MagciliaError, match="temperature_K"):
        LiveReadout(source, mc.ThermalReadout(plain), rate=1000).start()


def _cli(*args: str, cwd: Path) -> subprocess.CompletedProcess[str]:
    return subprocess.run([sys.executable, "-m", "magcilia", "live", *args], cwd=cwd, text=True,
                          capture_output=True, timeout=120, check=False)


def test_live_temperature_option(tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    """``live --source sim --temperature START:END`` ramps over --duration and reads the
    output compensated, with the setup file's [temperature] coefficients and calibrated range:
    the readings beyond it are flagged, those within not, nothing else (the tare saw the
    compensated output at rest). The option's errors are one line, exit 2."""
    setup = tmp_path / "warm.toml"
    save_setup(mc.presets.load("force-sensor"), setup, tables={
        "temperature": {"calibrated_range": "20 degC:21 degC"}})
    out = _cli("--setup", str(setup), "--quantity", "force", "--source", "sim",
               "--temperature", "20degC:22degC", "--duration", "1.2s", "--json-lines",
               "--every", "10", cwd=tmp_path)
    assert out.returncode == 0, out.stderr
    rows = [json.loads(line) for line in out.stdout.splitlines()]
    flags = np.array([r["flags"] for r in rows if "flags" in r])
    assert flags.size > 50 and (flags & ~OUTSIDE == 0).all()
    assert flags[-1] & OUTSIDE and not flags[0] & OUTSIDE
    for args, word in ((("--temperature", "293K:313K"), "--duration"),
                       (("--temperature", "293K", "--source", "serial:/dev/null"), "sim only"),
                       (("--temperature", "293K", "--dynamic"), "--dynamic"),
                       (("--temperature", "293K", "--sensor", "MMC5983MA"), "3-axis")):
        assert main(["live", "--setup", "force-sensor", *args]) == 2  # (refused before it runs)
        err = capsys.readouterr().err
        assert err.count("\n") == 1 and word in err, err
