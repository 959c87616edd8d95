"""One output policy for files and folders (issue 30 item 6): an existing file given to any output
option is left byte-identical without ``--force`` (exit 2, one line naming it and ``--force``),
replaced with it, and an input given as an output is refused even with ``--force``."""

from __future__ import annotations

from pathlib import Path

import click
import pytest

from magcilia.cli import main
from magcilia.cli._outputs import OutputFile

from .test_option_meanings import COMMANDS

#: the least command line of each command that writes files, before its output option
BASE = {
    "angle": ["angle"],  # --annotate: below
    "approximate": ["approximate", "--setup", "paper"],
    "array": ["array", "--setup", "array"],
    "bend": ["bend", "--setup", "force-sensor", "--tip-force", "0.02"],
    "design": ["design", "--setup", "force-sensor"],
    "export": ["export", "rec.csv"],
    "show": ["show", "--setup", "paper"],
    "field": ["field", "--setup", "paper", "--angles", "0:10:10"],
    "modes": ["modes", "--setup", "force-sensor"],
    "optimise": ["optimise", "--setup", "paper"],
    "readout": ["readout", "--setup", "paper", "rec.csv", "--quantity", "angle", "--span",
                "0:80"],
    "record": ["record"],
    "live": ["live"],
    "dashboard": ["dashboard"],
}

#: the file options that name inputs (everything else of type file is an output)
INPUT_FILES = {"--actuation", "--data", "--loads", "--prior-from", "--tare-file"}


def _outputs() -> list[tuple[str, str]]:
    found = []
    for name, command in COMMANDS.items():
        for param in command.params:
            if isinstance(param, click.Option) and isinstance(param.type, OutputFile):
                found.append((name, max(param.opts, key=len)))
    return sorted(found)


OUTPUTS = _outputs()


def test_every_output_file_option_is_an_output_file_and_checked_here() -> None:
    """A new file option is an input (listed) or an :class:`OutputFile` (and covered below);
    every command that writes one takes --force."""
    for name, command in COMMANDS.items():
        for param in command.params:
            if (isinstance(param, click.Option) and isinstance(param.type, click.Path)
                    and param.type.file_okay and not param.type.dir_okay):
                opt = max(param.opts, key=len)
                assert isinstance(param.type, OutputFile) or opt in INPUT_FILES, (name, opt)
    assert {name for name, _ in OUTPUTS} == set(BASE) - {"angle"}
    for name in BASE:
        opts = {o for p in COMMANDS[name].params if isinstance(p, click.Option)
                for o in [*p.opts, *getattr(p, "old_opts", ())]}
        assert "--force" in opts, name


def _suffix(option: str, name: str) -> str:
    if name in ("record", "live", "dashboard"):
        return ".tdms"
    if name == "show":
        return ".png"
    return {"--plot": ".png", "--crosstalk-plot": ".png", "--c-header": ".h",
            "--setup-out": ".toml", "--json-file": ".json"}.get(option, ".csv")


@pytest.mark.parametrize(("name", "option"), OUTPUTS, ids=[f"{n} {o}" for n, o in OUTPUTS])
def test_an_existing_output_file_is_left_byte_identical_without_force(
        name: str, option: str, tmp_path: Path, monkeypatch: pytest.MonkeyPatch,
        capsys: pytest.CaptureFixture[str]) -> None:
    monkeypatch.chdir(tmp_path)
    target = tmp_path / f"old{_suffix(option, name)}"
    before = b"precious \x00 bytes\n"
    target.write_bytes(before)
    assert main([*BASE[name], option, str(target)]) == 2
    err = capsys.readouterr().err
    assert err == (f"magcilia: error: {target} exists; pass --force to replace it, or choose "
                   f"another {option}\n")
    assert target.read_bytes() == before
    assert sorted(p.name for p in tmp_path.iterdir()) == [target.name]  # nothing else written


def test_the_annotated_figures_of_angle_too(tmp_path: Path,
                                            capsys: pytest.CaptureFixture[str]) -> None:
    photo = tmp_path / "holder.png"
    photo.write_bytes(b"not read: the check comes first")
    out = tmp_path / "fig"
    out.mkdir()
    (out / "holder_angle.png").write_bytes(b"old")
    assert main(["angle", str(photo), "--annotate", str(out)]) == 2
    assert "holder_angle.png exists; pass --force" in capsys.readouterr().err
    assert (out / "holder_angle.png").read_bytes() == b"old"


def test_the_setup_file_is_never_turned_into_a_csv(tmp_path: Path, monkeypatch: pytest.MonkeyPatch,
                                                   capsys: pytest.CaptureFixture[str]) -> None:
    """``magcilia field paper --csv examples/paper.toml`` of the issue: refused; the setup
    file as its own --csv is refused with --force too; another file is replaced with it."""
    monkeypatch.chdir(tmp_path)
    setup = tmp_path / "paper.toml"
    text = (Path(__file__).resolve().parents[2] / "examples" / "paper.toml").read_bytes()
    setup.write_bytes(text)
    assert main(["field", "paper", "--csv", str(setup)]) == 2
    assert f"{setup} exists; pass --force" in capsys.readouterr().err
    assert main(["field", "--setup", str(setup), "--csv", str(setup), "--force"]) == 2
    err = capsys.readouterr().err
    assert err == (f"magcilia: error: {setup} is the input of --setup; an input is never "
                   "replaced (--force neither): choose another --csv\n")
    assert setup.read_bytes() == text
    out = tmp_path / "table.csv"
    out.write_text("old\n")
    assert main(["field", "--setup", str(setup), "--angles", "0:10:10", "--csv", str(out),
                 "--force"]) == 0
    assert out.read_text().startswith("setup,angle_deg")
    assert not [p for p in tmp_path.iterdir() if p.name.startswith(".")]  # atomic: no partial


def test_a_recording_is_never_its_own_output(tmp_path: Path,
                                             capsys: pytest.CaptureFixture[str]) -> None:
    rec = tmp_path / "rec.csv"
    rec.write_text("voltage_V\n0.003\n")
    assert main(["readout", "--setup", "paper", str(rec), "--quantity", "angle", "--span",
                 "0:80", "--csv", str(rec), "--force"]) == 2
    assert "is the input of RECORDING" in capsys.readouterr().err
    assert rec.read_text() == "voltage_V\n0.003\n"


def test_two_outputs_naming_one_file_and_a_folder_as_a_file(
        tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    same = tmp_path / "x.csv"
    assert main(["field", "--setup", "paper", "--csv", str(same), "--json-file",
                 str(same)]) == 2
    assert "given to both --csv and --json-file" in capsys.readouterr().err
    assert not same.exists()
    folder = tmp_path / "d"
    folder.mkdir()
    assert main(["field", "--setup", "paper", "--plot", str(folder), "--force"]) == 2
    err = capsys.readouterr().err
    assert err.count("\n") == 1 and "--plot" in err and "is a directory" in err


def test_bend_force_alone_replaces_and_force_value_is_still_the_tip_force(
        tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    """bend's ``--force`` is the overwrite flag alone, and this release's deprecated
    ``--tip-force`` with a value."""
    out = tmp_path / "shape.json"
    out.write_text("old")
    assert main(["bend", "--setup", "force-sensor", "--tip-force", "0.02", "--json-file",
                 str(out), "--force"]) == 0
    assert out.read_text().startswith("{")
    assert main(["bend", "--setup", "force-sensor", "--force", "0.02", "--json-file",
                 str(out)]) == 2
    err = capsys.readouterr().err
    assert "--force is deprecated; use --tip-force" in err and "exists; pass --force" in err
