"""One meaning per option name across the CLI (issue 26 item 7): the table of meanings is checked
against every command's click parameters, the deprecated spellings of this release still work
with one warning line, and ``--setup`` takes a preset or a file by one rule."""

from __future__ import annotations

import itertools
import json
import re
from pathlib import Path
from typing import Any

import click
import pytest

import magcilia as mc
from magcilia.cli import cli, main
from magcilia.cli._common import Physical
from magcilia.cli._options import (
    SETUP_RULE,
    RenamedOption,
    _LegacySetupArgument,
    _SetupOption,
)

ROOT = Path(__file__).resolve().parents[2]

#: option name -> (its one meaning, the parameter shapes it may have). A shape is what
#: :func:`shape` reads off a click parameter; a command that gives a name another shape (``--force``
#: as a number, ``--out`` as a file, ``--span`` as a repeatable NAME=LOW:HIGH) fails the check, and
#: a new name must be added here with its meaning.
MEANINGS: dict[str, tuple[str, set[tuple[Any, ...]]]] = {
    "--accuracy": ("target angle accuracy", {("physical", "angle")}),
    "--actuation": ("a TOML file with an [actuation] table", {("file",)}),
    "--actuation-field": ("a uniform actuation field BX,BY,BZ", {("text",)}),
    "--actuation-scale": ("factor on the actuation field", {("float",)}),
    "--angles": ("a tilt-angle grid START:STOP:STEP", {("text",)}),
    "--annotate": ("a folder for annotated figures", {("folder",)}),
    "--at": ("arc length of a point load", {("physical", "length")}),
    "--azimuth": ("azimuth of the load's plane", {("physical", "angle")}),
    "--azimuths": ("tilt directions on offer", {("text",)}),
    "--bandwidth": ("noise band F_LOW:F_HIGH", {("text",)}),
    "--bias": ("the DC bias model", {("choice", frozenset({"offset", "polynomial", "none"}))}),
    "--bias-degree": ("degree of the polynomial bias", {("int",)}),
    "--biaxial": ("read a force vector from a 3-axis sensor", {("flag",)}),
    "--bound": ("a search bound NAME=LOW:HIGH (repeatable)", {("text", "multiple")}),
    "--budget": ("number of planned readings", {("int",)}),
    "--c-header": ("a C header file to write", {("file",)}),
    "--calibration": ("result.json (or folder) of magcilia calibrate", {("path",)}),
    "--channel": ("the source's channel", {("text",)}),
    "--channels": ("values per line or frame of a serial device", {("int",)}),
    "--coil": ("a coil sequence of applied fields (gauss) or its CSV file", {("text",)}),
    "--coil-constant": ("field per coil output volt, G/V per axis", {("text",)}),
    "--coil-output": ("the analog outputs driving the coil", {("text",)}),
    "--coil-sense": ("the analog inputs reading the coil currents", {("text",)}),
    "--coil-sense-constant": ("field per coil sense volt, G/V per axis", {("text",)}),
    "--columns": ("role -> column mapping of a recording", {("text",)}),
    "--corners": ("interior corner points", {("int",)}),
    "--crosstalk": ("print the crosstalk table", {("flag",)}),
    "--crosstalk-plot": ("a crosstalk figure file", {("file",)}),
    "--count": ("how many modes", {("int",)}),
    "--csv": ("a CSV file to write (the command's table)", {("file",)}),
    "--data": ("a recording to read", {("file",)}),
    "--decimal": ("CSV decimal mark", {("choice", frozenset({".", ","}))}),
    "--delimiter": ("CSV delimiter", {("choice", frozenset({"auto", ",", ";", "tab",
                                                            "whitespace"}))}),
    "--designs": ("designs screened", {("int",)}),
    "--devices": ("devices drawn per design (Monte Carlo)", {("int",)}),
    "--direction": ("force direction from +z", {("physical", "angle")}),
    "--duration": ("how long to run", {("physical", "time")}),
    "--dynamic": ("read with the dynamic read-out (the hair's modes)", {("flag",)}),
    "--edge": ("readings beyond the span", {("choice", frozenset({"extrapolate", "clip",
                                                                  "blank"}))}),
    "--edge-tolerance": ("how far beyond the span", {("text",)}),
    "--elements": ("beam elements of the mode solver", {("int",)}),
    "--every": ("write every N-th reading", {("int",)}),
    "--fields": ("the fields of a serial device's lines or frames", {("text",)}),
    "--figures": ("write figures (on/off)", {("flag",)}),
    "--fit": ("the fitted parameters NAME,NAME,...", {("text",)}),
    "--fit-scale": ("fit the magnetization scale", {("flag",)}),
    "--format": ("what a serial device sends",
                 {("choice", frozenset({"magcilia", "ascii", "floats"}))}),
    "--gravity": ("the modal model with the hair's own weight", {("flag",)}),
    "--fix": ("hold a parameter NAME=VALUE (repeatable)", {("text", "multiple")}),
    "--fixed-point": ("fixed-point C functions", {("flag",)}),
    "--flow": ("a flow speed", {("text",)}),
    "--flow-azimuth": ("direction of the flow", {("physical", "angle")}),
    "--fluid": ("the fluid", {("choice", frozenset({"air", "water",
                                                          "glycerol"}))}),
    "--force": ("replace an existing output (overwrite)", {("flag",)}),
    "--force-vector": ("a point force as a vector FX,FY,FZ", {("text",)}),
    "--grid": ("points of a fitting grid", {("int",)}),
    "--group": ("HDF5/TDMS group of a recording", {("text",)}),
    "--host": ("address to listen on", {("text",)}),
    "--identifiability": ("print the identifiability table instead", {("flag",)}),
    "--json": ("print JSON to stdout", {("flag",)}),
    "--json-file": ("a JSON file to write", {("file",)}),
    "--json-lines": ("stream JSON lines to stdout", {("flag",)}),
    "--line": ("two points on the tape", {("text",)}),
    "--loads": ("a CSV of loads to read", {("file",)}),
    "--lsl": ("publish the live values as a Lab Streaming Layer stream", {("text",)}),
    "--manual": ("click the points by hand", {("flag",)}),
    "--map-points": ("grid points of the x-y map", {("int",)}),
    "--max-field": ("rated |B| at the element", {("physical", "field")}),
    "--measure": ("what each planned reading measures", {("choice", frozenset({"output",
                                                                              "field"}))}),
    "--metrics": ("print the array metrics", {("flag",)}),
    "--max-settling": ("longest settling time of a design", {("physical", "time")}),
    "--min-bandwidth": ("lowest −3 dB bandwidth of a design", {("physical", "frequency")}),
    "--min-force": ("minimum detectable force", {("physical", "force")}),
    "--min-range": ("least range of a design", {("text",)}),
    "--model": ("the calibration model", {("choice", frozenset({"paper", "physical", "both"}))}),
    "--modulus": ("Young's modulus override VALUE[:SIGMA]", {("text",)}),
    "--name": ("C identifier prefix", {("text",)}),
    "--nan-policy": ("NaN samples", {("choice", frozenset({"raise", "omit"}))}),
    "--no-figures": ("write figures (on/off)", {("flag",)}),
    "--no-tare": ("skip the starting tare", {("flag",)}),
    "--noise": ("sigma of one reading", {("text",)}),
    "--objective": ("the design objective", {("choice", frozenset({"force-range",
                                                                   "flow-sensitivity",
                                                                   "robust"}))}),
    "--open": ("open a browser tab", {("flag",)}),
    "--out": ("the output folder", {("folder",)}),
    "--pitches": ("array pitches START:STOP:STEP", {("text",)}),
    "--plot": ("a figure file to write", {("file",)}),
    "--points": ("values per sweep", {("int",)}),
    "--polish": ("rounds of polishing", {("int",)}),
    "--port": ("TCP port", {("int",)}),
    "--posterior": ("sample the posterior", {("flag",)}),
    "--prior": ("a Gaussian prior NAME=VALUE:SIGMA (repeatable)", {("text", "multiple")}),
    "--prior-from": ("a ring-down JSON whose modulus is a prior", {("file", "multiple")}),
    "--quantity": ("what a read-out estimates", {("choice", frozenset({"angle", "force",
                                                                       "flow"}))}),
    "--markdown": ("print Markdown", {("flag",)}),
    "--quiet": ("no progress bar", {("flag",)}),
    "--random": ("N sets of random loads", {("int",)}),
    "--range": ("a tilt range START:STOP", {("text",)}),
    "--rate": ("read-out samples per second", {("physical", "frequency")}),
    "--readout-csv": ("a read-out CSV file to write", {("file",)}),
    "--recalibrate": ("in-use re-calibration period (coil pulses)", {("physical", "time")}),
    "--record": ("a recording file to write", {("file",)}),
    "--record-dir": ("a folder for recordings", {("folder",)}),
    "--reference": ("angle reference", {("choice", frozenset({"vertical", "detect"}))}),
    "--refine": ("designs refined", {("int",)}),
    "--restarts": ("independent global searches", {("int",)}),
    "--samples": ("samples per angle", {("int",)}),
    "--saturation": ("samples beyond range", {("choice", frozenset({"raise", "omit", "keep"}))}),
    "--scheduler": ("a Dask scheduler", {("text",)}),
    "--second-mode": ("fit a second mode of a ring-down", {("flag",)}),
    "--seed": ("a random seed", {("int",)}),
    "--self-test": ("the start-up self-test each device is read after",
                    {("choice", frozenset({"none", "coil"}))}),
    "--sensor": ("a 3-axis magnetometer part (preset name)",
                 {("choice", frozenset(n.lower() for n in mc.MAGNETOMETERS))}),
    "--sensor-noise": ("RMS noise of a 3-axis sensor", {("text",)}),
    "--sensors": ("sensor parts to choose among (comma-separated)", {("text",)}),
    "--set-reset": ("set/reset pulses every N samples", {("int",)}),
    "--sim-dynamics": ("the simulated hair moves through its modes", {("flag",)}),
    "--settle": ("time dropped after each tilt", {("physical", "time")}),
    "--setup": ("the sensor setup: a preset name or a setup file (SETUP_RULE)",
                {("setup",), ("setup", "multiple")}),
    "--setup-out": ("a setup TOML file to write", {("file",)}),
    "--shear-height": ("height of a linear shear flow", {("text",)}),
    "--si": ("outputs in SI units", {("flag",)}),
    "--size-sigma": ("1 σ of a size parameter NAME=SIGMA (repeatable)", {("text", "multiple")}),
    "--sobol-base": ("Sobol base sample", {("int",)}),
    "--sobol-measure": ("Sobol output", {("choice", frozenset({"rms", "shape", "cost"}))}),
    "--source": ("the data source (sim, serial:PORT, nidaq:..., a file)", {("text",)}),
    "--source-rate": ("the source's sample rate", {("physical", "frequency")}),
    "--span": ("the read-out's range (LO:HI, or the largest |F| of a force vector)",
               {("text",)}),
    "--speed": ("flow speed of an objective", {("physical", "speed")}),
    "--stimulus": ("what moves the cilium in a planned calibration",
                   {("choice", frozenset({"tilt", "coil"}))}),
    "--start": ("where a ring-down starts", {("physical", "time")}),
    "--starts": ("local fits per search", {("int",)}),
    "--style": ("figure style", {("choice", frozenset({"screen", "paper"}))}),
    "--suspect": ("flagged samples", {("choice", frozenset({"keep", "omit", "raise"}))}),
    "--sweep": ("a parameter sweep span NAME=LOW:HIGH (repeatable)", {("text", "multiple")}),
    "--table-size": ("entries of a lookup table", {("int",)}),
    "--tare": ("tare on the first readings", {("text",)}),
    "--temperature": ("the simulated temperature: constant or a ramp", {("text",)}),
    "--tare-file": ("tare on a separate recording", {("file",)}),
    "--tolerance": ("fabrication tolerances NAME=VALUE,...", {("text",)}),
    "--timeout": ("seconds to reach a scheduler", {("float",)}),
    "--tip-force": ("a point force on the cilium (at the tip unless --at)",
                    {("physical", "force")}),
    "--tilt": ("a rigid tilt angle", {("physical", "angle")}),
    "--no-field": ("leave out the field (on/off)", {("flag",)}),
    "--tip-radius": ("tip radius override", {("text",)}),
    "--tracking": ("zero-tracking time constant", {("physical", "time")}),
    "--window": ("time shown on the plots", {("physical", "time")}),
    "--workers": ("worker processes", {("int",)}),
    "--to": ("the format of an export", {("choice", frozenset({"csv", "mat", "h5", "nc"}))}),
    "--mat-version": ("the MATLAB file version", {("choice", frozenset({"5", "7.3"}))}),
}
#: a meaning of one command's option that an issue names as public (kept out of MEANINGS, so
#: that no other command takes the name in that meaning): (command, option) -> (meaning, shapes)
PUBLIC_MEANINGS: dict[tuple[str, str], tuple[str, set[tuple[Any, ...]]]] = {
    # issue 30: `magcilia export RECORDING --to FORMAT --out FILE`
    ("export", "--out"): ("the one file the export writes", {("file",)}),
    # issue 30: `magcilia show SETUP --out FILE.html|.png`
    ("show", "--out"): ("the one file the 3-D view draws", {("file",)}),
}

#: the deprecated spellings of this release: (command, old) -> new
DEPRECATED = {
    ("bend", "--force"): "--tip-force",
    ("readout", "--out"): "--csv",
    ("record", "--out"): "--record",
    ("record", "--rate"): "--source-rate",
    ("sensitivity", "--span"): "--sweep",
    ("plan", "--sensor"): "--measure",
    ("optimise", "--sensor"): "--sensors",
}
#: the commands that still take the positional SETUP of earlier releases (deprecated)
# (modes: issue 28 names its spelling `magcilia modes SETUP`; it works, with the same one line)
# (show: issue 30 names `magcilia show SETUP`; likewise)
POSITIONAL_SETUP = {"field", "bend", "readout", "design", "sensitivity", "approximate", "plan",
                    "array", "optimise", "modes", "show"}


def shape(param: click.Option) -> tuple[Any, ...]:
    """What a parameter is, as far as its meaning shows: a flag, a folder or file, a choice of
    values, a physical value of a dimension, a number, or text; and whether it repeats."""
    t = param.type
    if isinstance(param, _SetupOption):
        kind: tuple[Any, ...] = ("setup",)
    elif param.is_flag and not param.count:
        kind = ("flag",)
    elif isinstance(t, click.Path):
        kind = ("folder",) if not t.file_okay else ("file",) if not t.dir_okay else ("path",)
    elif isinstance(t, click.Choice):
        kind = ("choice", frozenset(str(c).lower() for c in t.choices))
    elif isinstance(t, Physical):
        kind = ("physical", t.dimension)
    elif isinstance(t, click.IntRange) or t is click.INT:
        kind = ("int",)
    elif isinstance(t, click.FloatRange) or t is click.FLOAT:
        kind = ("float",)
    else:
        kind = ("text",)
    return kind + (("multiple",) if param.multiple else ())


def commands(group: click.Group = cli, path: str = "") -> dict[str, click.Command]:
    """Every leaf command by its path (``batch calibrate``)."""
    found: dict[str, click.Command] = {}
    for name, command in group.commands.items():
        full = f"{path} {name}".strip()
        if isinstance(command, click.Group):
            found.update(commands(command, full))
        else:
            found[full] = command
    return found


COMMANDS = commands()


@pytest.mark.parametrize("name", sorted(COMMANDS))
def test_every_option_has_its_one_meaning(name: str) -> None:
    for param in COMMANDS[name].params:
        if not isinstance(param, click.Option):
            continue
        for opt in [*param.opts, *param.secondary_opts]:
            assert opt in MEANINGS, (f"{name} {opt}: a new option name; add its one meaning to "
                                     "MEANINGS (or reuse a name with the same meaning)")
            meaning, shapes = PUBLIC_MEANINGS.get((name, opt), MEANINGS[opt])
            assert shape(param) in shapes, (f"{name} {opt} is {shape(param)}, but {opt} means "
                                            f"{meaning!r} ({shapes}) everywhere")


def test_every_command_that_writes_a_recording_replaces_it_only_with_force() -> None:
    """``--force`` means overwrite across the CLI: each command with ``--record FILE`` takes it
    (``record``, ``live``, ``dashboard``)."""
    def options(command: click.Command) -> set[str]:
        return {o for p in command.params if isinstance(p, click.Option) for o in p.opts}
    recording = {name for name, c in COMMANDS.items() if "--record" in options(c)}
    assert recording == {"record", "live", "dashboard"}
    for name in recording:
        assert "--force" in options(COMMANDS[name]), name


def test_the_check_fails_on_a_second_meaning() -> None:
    """A command that adds ``--force`` as a number, or ``--out`` as a file, is caught."""
    as_number = click.Option(["--force"], type=Physical.of("force"))
    as_file = click.Option(["--out"], type=click.Path(dir_okay=False))
    assert shape(as_number) not in MEANINGS["--force"][1]
    assert shape(as_file) not in MEANINGS["--out"][1]


def test_the_deprecated_spellings_are_the_listed_ones() -> None:
    found = {}
    positional = set()
    for name, command in COMMANDS.items():
        current = {o for p in command.params if isinstance(p, click.Option)
                   for o in [*p.opts, *p.secondary_opts]}
        for param in command.params:
            if isinstance(param, RenamedOption):
                for old in param.old_opts:
                    assert old not in current, f"{name} {old}: both a new and an old spelling"
                    found[(name, old)] = max(param.opts, key=len)
            if isinstance(param, _LegacySetupArgument):
                positional.add(name)
    assert found == DEPRECATED
    assert positional == POSITIONAL_SETUP
    # every other command with a setup takes it as --setup only
    for name, command in COMMANDS.items():
        args = [p.name for p in command.params if isinstance(p, click.Argument)
                and not isinstance(p, _LegacySetupArgument)]
        assert not any("setup" in (a or "") for a in args), name


def _run(capsys: pytest.CaptureFixture[str], argv: list[str]) -> tuple[int, str, str]:
    code = main(argv)
    captured = capsys.readouterr()
    return code, captured.out, captured.err


def _warnings(err: str) -> list[str]:
    return [line for line in err.splitlines() if "is deprecated" in line]


def _line(command: str, old: str, new: str) -> str:
    return (f"magcilia: warning: {command} {old} is deprecated; use {new} (removed in the next "
            "release)")


@pytest.fixture
def recording(tmp_path: Path) -> Path:
    path = tmp_path / "rec.csv"
    path.write_text("voltage_V\n0.0030\n0.0031\n0.0032\n")
    return path


@pytest.mark.parametrize(("old", "new"), [
    (["bend", "force-sensor", "--force", "0.02", "--json"],
     ["bend", "--setup", "force-sensor", "--tip-force", "0.02", "--json"]),
    (["field", "paper", "paper-initial", "--angles", "0:10:10", "--json"],
     ["field", "--setup", "paper", "--setup", "paper-initial", "--angles", "0:10:10", "--json"]),
    (["design", "force-sensor", "--json"], ["design", "--setup", "force-sensor", "--json"]),
    (["approximate", "paper", "--corners", "1", "--json"],
     ["approximate", "--setup", "paper", "--corners", "1", "--json"]),
    (["array", "examples/array.toml", "--json"], ["array", "--setup", "examples/array.toml",
                                                  "--json"]),
    (["plan", "paper", "--budget", "6", "--sensor", "field", "--json", "--quiet"],
     ["plan", "--setup", "paper", "--budget", "6", "--measure", "field", "--json", "--quiet"]),
], ids=["bend", "field", "design", "approximate", "array", "plan"])
def test_old_spellings_give_what_the_new_ones_give(old: list[str], new: list[str],
                                                   monkeypatch: pytest.MonkeyPatch,
                                                   capsys: pytest.CaptureFixture[str]) -> None:
    monkeypatch.chdir(ROOT)  # examples/array.toml, read only
    code, out_new, err_new = _run(capsys, new)
    assert code == 0 and _warnings(err_new) == [], err_new
    code, out_old, err_old = _run(capsys, old)
    assert code == 0, err_old
    assert out_old == out_new
    command = old[0]
    expected = [_line(command, "SETUP (positional)", "--setup SETUP")]
    for (cmd, o), n in DEPRECATED.items():
        if cmd == command and o in old:
            expected.insert(0, _line(command, o, n))
    assert _warnings(err_old) == expected  # once each, even for two positional setups


def test_readout_out_is_csv(recording: Path, tmp_path: Path,
                            capsys: pytest.CaptureFixture[str]) -> None:
    args = ["--quantity", "force", "--span", "0:0.2"]
    old, new = tmp_path / "old.csv", tmp_path / "new.csv"
    code, _, err = _run(capsys, ["readout", "--setup", "force-sensor", str(recording), *args,
                                 "--csv", str(new)])
    assert code == 0 and _warnings(err) == []
    code, _, err = _run(capsys, ["readout", "force-sensor", str(recording), *args,
                                 "--out", str(old)])
    assert code == 0
    assert old.read_text() == new.read_text()
    assert _warnings(err) == [_line("readout", "--out", "--csv"),
                              _line("readout", "SETUP (positional)", "--setup SETUP")]


def test_record_out_and_rate(tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    base = ["record", "--source", "sim", "--angles", "0:10:10", "--samples", "20", "--quiet"]
    code, _, err = _run(capsys, [*base, "--rate", "2000", "--out", str(tmp_path / "a.tdms")])
    assert code == 0 and (tmp_path / "a.tdms").is_file()
    assert _warnings(err) == [_line("record", "--rate", "--source-rate"),
                              _line("record", "--out", "--record")]
    code, _, err = _run(capsys, [*base, "--source-rate", "2000", "--record",
                                 str(tmp_path / "b.tdms")])
    assert code == 0 and (tmp_path / "b.tdms").is_file() and _warnings(err) == []
    props = [mc.io.recording_properties(tmp_path / n) for n in ("a.tdms", "b.tdms")]
    assert props[0]["samples"] == props[1]["samples"] == 40


@pytest.mark.parametrize(("argv", "command", "old", "message"), [
    (["sensitivity", "--setup", "paper", "--out", "{tmp}/s", "--span", "w=0:1", "--span",
      "x=0:1"], "sensitivity", "--span", "--sweep must be NAME=LOW:HIGH with NAME one of"),
    (["optimise", "--sensor", "HMC1021Z,NOPE", "--designs", "16"], "optimise", "--sensor",
     "sensor must be HMC1021Z"),
])
def test_an_old_spelling_reaches_the_new_option(argv: list[str], command: str, old: str,
                                                message: str, tmp_path: Path,
                                                capsys: pytest.CaptureFixture[str]) -> None:
    """The value given to the old spelling is the one the command checks (here: refuses), and a
    repeated old option warns once."""
    code, _, err = _run(capsys, [a.replace("{tmp}", str(tmp_path)) for a in argv])
    assert code == 2 and message in err
    assert _warnings(err) == [_line(command, old, DEPRECATED[(command, old)])]
    assert err.splitlines()[-1].startswith("magcilia: error: ") and len(err.splitlines()) == 2


@pytest.mark.parametrize("argv", [
    ["bend", "--setup", "force-sensor", "--force", "0.02", "--tip-force", "0.02"],
    ["bend", "force-sensor", "--setup", "force-sensor", "--tip-force", "0.02"],
    ["bend", "force-sensor", "paper", "--tip-force", "0.02"],
])
def test_a_value_given_twice_is_one_line(argv: list[str],
                                         capsys: pytest.CaptureFixture[str]) -> None:
    code, out, err = _run(capsys, argv)
    assert code == 2 and out == ""
    assert err.splitlines()[-1].startswith("magcilia: error: ")
    assert "Traceback" not in err


def test_a_missing_setup_is_a_usage_error(capsys: pytest.CaptureFixture[str]) -> None:
    code, _, err = _run(capsys, ["bend", "--tip-force", "0.02"])
    assert code == 2 and err == ("magcilia: error: Missing option '--setup'. (see magcilia bend "
                                 "--help)\n")


@pytest.mark.parametrize(("name", "line"), [
    ("forse-sensor", ("unknown preset 'forse-sensor'; did you mean 'force-sensor'? (presets: "
                      "paper, paper-initial, force-sensor, array)")),
    ("paper_initial", ("unknown preset 'paper_initial'; did you mean 'paper-initial'? (presets: "
                       "paper, paper-initial, force-sensor, array)")),
    ("zzz", "unknown preset 'zzz' (presets: paper, paper-initial, force-sensor, array)"),
])
def test_a_preset_typo_is_one_line_with_a_suggestion(name: str, line: str,
                                                     capsys: pytest.CaptureFixture[str]) -> None:
    for argv in (["bend", "--setup", name, "--tip-force", "0.02"],
                 ["live", "--setup", name, "--duration", "0.1", "--json-lines"]):
        code, out, err = _run(capsys, argv)
        assert code == 2 and out == "" and err == f"magcilia: error: {line}\n"
    with pytest.raises(mc.MagciliaError) as info:
        mc.presets.load(name)
    assert str(info.value) == line


def test_presets_in_the_api() -> None:
    assert mc.presets.NAMES == ("paper", "paper-initial", "force-sensor", "array")
    assert mc.presets.load("paper").params() == mc.Setup.paper().params()
    assert mc.presets.load("paper-initial").params() == mc.Setup.paper_initial().params()
    assert (mc.presets.setup("force-sensor").params()
            == pytest.approx(mc.load_setup(ROOT / "examples" / "force-sensor.toml").params()))
    array = mc.presets.load("array")
    assert isinstance(array, mc.CiliaArray)
    example = mc.load_array(ROOT / "examples" / "array.toml")
    assert mc.io.array_to_dict(array) == mc.io.array_to_dict(example)
    # the bundled copy is the example, byte for byte (edit both together)
    bundled = mc.presets.file("array")
    assert bundled is not None
    assert bundled.read_bytes() == (ROOT / "examples" / "array.toml").read_bytes()
    assert mc.presets.file("paper") is None
    with pytest.raises(mc.MagciliaError, match="preset 'array' is a cilia array"):
        mc.presets.setup("array")


def test_the_setup_rule(tmp_path: Path, monkeypatch: pytest.MonkeyPatch,
                        capsys: pytest.CaptureFixture[str]) -> None:
    """A bare name is a preset, anything with a suffix or a path separator is a file."""
    monkeypatch.chdir(tmp_path)
    mc.save_setup(mc.Setup.paper(tip_radius=5e-5, layout="converged"), tmp_path / "mine")
    code, _, err = _run(capsys, ["bend", "--setup", "mine", "--tip-force", "0.02"])
    assert code == 2 and err == ("magcilia: error: unknown preset 'mine' (presets: paper, "
                                 "paper-initial, force-sensor, array); to read the file 'mine', "
                                 "write ./mine\n")
    code, by_file, _ = _run(capsys, ["bend", "--setup", "./mine", "--tip-force", "0.02",
                                     "--json"])
    assert code == 0
    code, by_preset, _ = _run(capsys, ["bend", "--setup", "force-sensor", "--tip-force", "0.02",
                                       "--json"])
    assert code == 0
    tip = [json.loads(t)["tip_mm"] for t in (by_file, by_preset)]
    assert tip[0] == pytest.approx(tip[1], rel=1e-9)
    # the array preset where one cilium is read is refused in one line
    code, _, err = _run(capsys, ["bend", "--setup", "array", "--tip-force", "0.02"])
    assert code == 2 and err.count("\n") == 1 and "preset 'array' is a cilia array" in err


def test_the_help_says_the_rule(capsys: pytest.CaptureFixture[str]) -> None:
    assert main(["bend", "--help"]) == 0
    text = "".join(capsys.readouterr().out.split())  # as wrapped for any terminal width
    assert "".join(f"--setup SETUP The sensor setup: {SETUP_RULE}.".split()) in text
    assert "--force" not in text.replace("--force-vector", "") and "--tip-force" in text


def _readme_commands() -> list[list[str]]:
    """The ``magcilia CMD ...`` lines of the README's shell blocks and inline code, as words."""
    text = (ROOT / "README.md").read_text(encoding="utf-8")
    found = []
    for line in re.findall(r"magcilia ([a-z]+(?: [^`\n|]*)?)", text):
        words = re.sub(r"[\[\]]", " ", line.split("#")[0]).split()
        if words and words[0] in COMMANDS:
            found.append(words)
    return found


#: positional arguments a command takes besides the deprecated positional SETUP (readout's
#: RECORDING: alone, a recording of `magcilia live --record`, which stores its setup)
OTHER_POSITIONALS = {"readout": 1}


def test_the_readme_uses_the_new_spellings() -> None:
    commands = _readme_commands()
    assert len(commands) > 30
    for words in commands:
        name, rest = words[0], words[1:]
        leading = list(itertools.takewhile(lambda w: not w.startswith("-") and w != "\\", rest))
        assert not (name in POSITIONAL_SETUP and len(leading) > OTHER_POSITIONALS.get(name, 0)), (
            f"README: magcilia {' '.join(words)} (use --setup)")
        for (command, old), new in DEPRECATED.items():
            assert not (command == name and old in rest), (
                f"README: magcilia {' '.join(words)} ({old} is now {new})")
