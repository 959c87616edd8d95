"""docs/gallery.md (scripts/gallery.py) lists every figure the command line can write, each under
a command line the CLI parses, and is the script's current page; its images are committed, small."""

from __future__ import annotations

import ast
import importlib
import importlib.util
import re
import shlex
import sys
from pathlib import Path
from types import ModuleType

import click
import pytest

ROOT = Path(__file__).resolve().parents[2]
SRC = ROOT / "src" / "magcilia"
PAGE = ROOT / "docs" / "gallery.md"
IMAGES = ROOT / "docs" / "images" / "gallery"
#: the gallery's images together, bytes (the repository's size matters)
MAX_BYTES = 1_000_000


def _script() -> ModuleType:
    spec = importlib.util.spec_from_file_location("gallery", ROOT / "scripts" / "gallery.py")
    assert spec is not None and spec.loader is not None
    module = importlib.util.module_from_spec(spec)
    sys.modules.setdefault("gallery", module)  # its dataclass looks its module up
    spec.loader.exec_module(module)
    return module


def png_names() -> set[str]:
    """Every PNG file name (stem; ``_angle`` for ``{stem}_angle.png``) written in cli/ and
    report/."""
    found: set[str] = set()
    for folder in ("cli", "report"):
        for path in (SRC / folder).glob("*.py"):
            text = path.read_text(encoding="utf-8")  # a name in code: after a quote, / or }
            found |= set(re.findall(r"(?<=[\"'/}])([A-Za-z0-9_]+)\.png\b", text))
    return found


def figure_options() -> set[tuple[str, str]]:
    """(command, option) of every CLI option that writes figures: a path option named ``*plot``
    or whose help says it writes a figure or a ``.png``, and any option whose help names a
    ``.png`` (``batch --figures``)."""
    found: set[tuple[str, str]] = set()
    for path in (SRC / "cli").glob("*.py"):
        for node in ast.walk(ast.parse(path.read_text(encoding="utf-8"))):
            if not (isinstance(node, ast.Call) and isinstance(node.func, ast.Attribute)
                    and node.func.attr == "option"):
                continue
            names = [a.value.split("/")[0] for a in node.args
                     if isinstance(a, ast.Constant) and isinstance(a.value, str)
                     and a.value.startswith("--")]
            kw = {k.arg: k.value for k in node.keywords}
            help_text = "".join(c.value for c in ast.walk(kw["help"])
                                if isinstance(c, ast.Constant) and isinstance(c.value, str)) \
                if "help" in kw else ""
            is_path = "type" in kw and any(t in ast.unparse(kw["type"])
                                           for t in ("Path", "OUTPUT_FILE"))
            writes = ".png" in help_text or (is_path and (
                "figure" in help_text.lower() or any(n.endswith("plot") for n in names)))
            if names and writes:
                found.add((path.stem, names[0]))
    return found


def test_the_discovery_finds_the_known_figures() -> None:
    """The search itself works (else the coverage test below would pass on nothing)."""
    assert {"fit", "residuals", "pairs", "fig09_xy", "sobol", "xy_map", "_angle"} <= png_names()
    assert {("field", "--plot"), ("array", "--crosstalk-plot"), ("angle", "--annotate"),
            ("show", "--out"), ("calibrate", "--out"), ("batch", "--figures")} <= figure_options()


def test_the_gallery_lists_every_figure_the_cli_writes() -> None:
    page = PAGE.read_text(encoding="utf-8")
    missing = [f"{n}.png" for n in sorted(png_names()) if f"{n}.png`*" not in page]
    assert not missing, f"add a command writing {missing} to scripts/gallery.py ENTRIES"
    for command, option in sorted(figure_options()):
        pattern = rf"magcilia {command}\b[^\n`]*\s{re.escape(option)}\b"
        assert re.search(pattern, page), f"scripts/gallery.py: no `magcilia {command} {option}`"


def test_the_page_is_current_and_its_images_are_committed() -> None:
    script = _script()
    page = PAGE.read_text(encoding="utf-8")
    assert page == script.page(), "run PYTHONPATH=src python scripts/gallery.py --write"
    listed = {e.image(f) for e in script.ENTRIES for f in e.figures}
    assert listed == {p.name for p in IMAGES.iterdir()}, "run scripts/gallery.py --write"
    for name in listed:
        assert (IMAGES / name).read_bytes()[:8] == b"\x89PNG\r\n\x1a\n", name
    assert sum(p.stat().st_size for p in IMAGES.iterdir()) < MAX_BYTES
    assert "gallery.md" in (ROOT / "mkdocs.yml").read_text(encoding="utf-8")


def test_every_command_line_parses(tmp_path: Path, monkeypatch: pytest.MonkeyPatch) -> None:
    """Each listed line is a real command line: the command's parser takes it (inputs present
    in the run folder, as the script makes them); nothing is run."""
    script = _script()
    monkeypatch.chdir(tmp_path)
    (tmp_path / script.RECORDING).write_text("angle_deg,voltage_V\n", encoding="utf-8")
    (tmp_path / script.PHOTO).write_bytes(b"")
    lines = re.findall(r"```console\nmagcilia (.+)\n```", PAGE.read_text(encoding="utf-8"))
    assert len(lines) == len(script.ENTRIES)
    for line in lines:
        name, *args = shlex.split(line)
        command = importlib.import_module(f"magcilia.cli.{name}").command
        with command.make_context(name, list(args)):
            pass
        with pytest.raises(click.UsageError):  # the check can fail
            command.make_context(name, [*args, "--no-such-option"])
