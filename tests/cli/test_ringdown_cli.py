"""``magcilia ringdown`` and ``calibrate --prior-from``, in-process: a recording (CSV, TDMS)
of a simulated flick in air gives the modulus with σ; bad recordings are one line, exit 2."""

from __future__ import annotations

import json
import math
from pathlib import Path
from typing import Any

import numpy as np
import pytest

import magcilia as mc
from magcilia.analysis.ringdown_fit import damped_sinusoid
from magcilia.cli import main
from magcilia.io import presets

E_TRUE = 0.5e6
SETUP = presets.setup("force-sensor").replace(youngs_modulus=E_TRUE)
RATE = 10_000.0


def _samples(fluid: str = "air", seed: int = 0) -> tuple[np.ndarray, np.ndarray]:
    """Times (s) and output (V): rest, a flick held 50 ms, then the first mode rings down."""
    m = mc.modes(SETUP, fluid)
    fn, zeta = float(m.frequencies[0]), float(m.damping_ratios[0])
    gamma = zeta * 2 * math.pi * fn
    t = np.arange(int((0.15 + min(10.0 / gamma, 2.0)) * RATE)) / RATE
    rest, tilted = SETUP.output(np.radians([0.0, 2.0]))  # a flick: the tip ~0.1 mm aside
    amp = float(tilted - rest)
    ring = damped_sinusoid(t - 0.15, fn * math.sqrt(1 - zeta**2), gamma, amp)
    y = np.where(t < 0.1, 0.0, np.where(t < 0.15, amp, ring))
    return t, rest + y + np.random.default_rng(seed).normal(0.0, 0.01 * abs(amp), t.size)


def _csv(path: Path, t: np.ndarray, y: np.ndarray) -> Path:
    rows = zip(t.tolist(), y.tolist(), strict=True)
    path.write_text("time_s,voltage_V\n" + "".join(f"{a!r},{b!r}\n" for a, b in rows))
    return path


def _run(capsys: pytest.CaptureFixture[str], *args: str) -> tuple[int, str, str]:
    code = main(["ringdown", *args])
    out = capsys.readouterr()
    return code, out.out, out.err


def test_ringdown_json_gives_the_modulus(tmp_path: Path,
                                         capsys: pytest.CaptureFixture[str]) -> None:
    rec = _csv(tmp_path / "flick.csv", *_samples())
    code, out, err = _run(capsys, str(rec), "--setup", "force-sensor", "--fluid", "air", "--json")
    assert code == 0, err
    doc = json.loads(out)
    assert doc["kind"] == "ringdown" and doc["units"] == "SI" and doc["fluid"] == "air"
    assert abs(doc["youngs_modulus_Pa"] - E_TRUE) < 2 * doc["youngs_modulus_sigma_Pa"]
    assert doc["prior"]["name"] == "youngs_modulus"
    assert doc["calibrate_option"].startswith("--prior youngs_modulus=0.5")
    # the report: MPa at the edge, the damping ratio with σ, the prior's option
    code, out, _ = _run(capsys, str(rec), "--setup", "force-sensor", "--fluid", "air")
    assert code == 0
    assert "MPa" in out and "damping ratio" in out and "--prior youngs_modulus=" in out


def test_tdms_recording_and_size_sigma_from_the_setup_file(
        tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    pytest.importorskip("nptdms")
    from magcilia.io.recording_file import RecordingWriter

    t, y = _samples(seed=1)
    with RecordingWriter(tmp_path / "flick.tdms", metadata={"rate_Hz": RATE}) as rec:
        rec.write(t, y)
    setup = tmp_path / "s.toml"
    mc.save_setup(SETUP, setup)
    height = SETUP.cilium.height * 1e3
    setup.write_text(setup.read_text() + f'\n[priors]\nheight = "{height!r} mm +- 0.05 mm"\n')
    code, out, err = _run(capsys, str(tmp_path / "flick.tdms"), "--setup", str(setup),
                          "--fluid", "air", "--json")
    assert code == 0, err
    doc = json.loads(out)
    assert doc["dominant"] == "height"
    assert abs(doc["youngs_modulus_Pa"] - E_TRUE) < 2 * doc["youngs_modulus_sigma_Pa"]
    code, out, err = _run(capsys, str(tmp_path / "flick.tdms"), "--setup", str(setup),
                          "--fluid", "air", "--size-sigma", "height=0.01", "--json")
    assert json.loads(out)["youngs_modulus_sigma_Pa"] < doc["youngs_modulus_sigma_Pa"] / 3


@pytest.mark.parametrize(("make", "args", "words"), [
    (lambda t, y: (t, np.clip(y, None, np.quantile(y, 0.995))), (), "clipped"),
    (lambda t, y: (t[:1620], y[:1620]), (), "periods"),
    (lambda t, y: (t, y[0] + 1e-5 * np.random.default_rng(0).normal(size=t.size)), (),
     "no free oscillation"),
    (lambda t, y: (t, y), ("--fluid", "water", "--setup", "force-sensor"), None),
    (lambda t, y: (t, y), ("--size-sigma", "height=0.05"), "--size-sigma"),
    (lambda t, y: (t, y), ("--setup", "force-sensor", "--size-sigma", "width=0.05"),
     "--size-sigma"),
    (lambda t, y: (t, y), ("--source-rate", "100"), "not the file's"),
    (lambda t, y: (t, y), ("--start", "9"), "start must be a time within"),
    (lambda t, y: (t, y), ("--second-mode",), "no second mode"),
], ids=["clipped", "short", "noise", "wrong-fluid", "sigma-without-setup", "sigma-name",
        "rate-mismatch", "start-beyond", "no-second-mode"])
def test_bad_input_is_one_line_exit_2(tmp_path: Path, capsys: pytest.CaptureFixture[str],
                                      make: Any, args: tuple[str, ...],
                                      words: str | None) -> None:
    rec = _csv(tmp_path / "flick.csv", *make(*_samples()))
    code, out, err = _run(capsys, str(rec), *args)
    if words is None:  # an air ring-down read as water: a modulus, not a crash
        assert code == 0, err
        return
    assert code == 2 and not out
    assert words in err and err.count("\n") == 1 and "Traceback" not in err


def test_missing_rate_and_columns_are_one_line(tmp_path: Path,
                                               capsys: pytest.CaptureFixture[str]) -> None:
    _, y = _samples()
    path = tmp_path / "v.csv"
    path.write_text("voltage_V\n" + "".join(f"{b!r}\n" for b in y.tolist()))
    code, _, err = _run(capsys, str(path))
    assert code == 2 and "--source-rate" in err and err.count("\n") == 1
    code, out, err = _run(capsys, str(path), "--source-rate", "10kHz", "--json")
    assert code == 0 and json.loads(out)["rate_Hz"] == RATE
    code, _, err = _run(capsys, str(path), "--source-rate", "10kHz", "--channel", "field_x")
    assert code == 2 and "field_x_T" in err and err.count("\n") == 1


def test_calibrate_takes_the_prior_from_the_ringdown_json(
        tmp_path: Path, capsys: pytest.CaptureFixture[str],
        monkeypatch: pytest.MonkeyPatch) -> None:
    """The JSON's prior reaches the physical calibration (the fit itself is stubbed here: the
    joint fit with the prior is tested in tests/analysis/test_ringdown.py)."""
    import magcilia.cli.calibrate as cal
    from magcilia.io import example_path

    rec = _csv(tmp_path / "flick.csv", *_samples())
    _, out, _ = _run(capsys, str(rec), "--setup", "force-sensor", "--fluid", "air", "--json")
    (tmp_path / "ringdown.json").write_text(out)
    doc = json.loads(out)
    seen: dict[str, Any] = {}

    class StopError(Exception):
        pass

    def calibrate(*args: Any, **kwargs: Any) -> None:
        seen.update(kwargs)
        raise StopError

    monkeypatch.setattr(cal, "calibrate", calibrate)
    with pytest.raises(StopError):
        cal.command.main(["--model", "physical", str(example_path()), "--out",
                          str(tmp_path / "cal"), "--prior-from", str(tmp_path / "ringdown.json")],
                         standalone_mode=False)
    assert seen["priors"] == {"youngs_modulus": (doc["prior"]["value"], doc["prior"]["sigma"])}
    assert not (tmp_path / "cal").exists()


@pytest.mark.parametrize(("text", "words"), [
    ("{", "not JSON"), ('{"kind": "calibration"}', "not a ring-down"),
    ('{"kind": "ringdown"}', "no modulus"),
    ('{"kind": "ringdown", "prior": {"name": "youngs_modulus", "value": -1, "sigma": 1}}',
     "positive value"),
])
def test_calibrate_prior_from_bad_files(tmp_path: Path, capsys: pytest.CaptureFixture[str],
                                        text: str, words: str) -> None:
    from magcilia.io import example_path

    bad = tmp_path / "r.json"
    bad.write_text(text)
    out = tmp_path / "cal"
    code = main(["calibrate", str(example_path()), "--out", str(out), "--quiet", "--model",
                 "physical", "--prior-from", str(bad)])
    err = capsys.readouterr().err
    assert code == 2 and words in err and err.count("\n") == 1
    assert not out.exists()
    code = main(["calibrate", str(example_path()), "--out", str(out), "--quiet", "--prior-from",
                 str(bad)])
    assert code == 2 and not out.exists()
