"""The documentation site builds with warnings as errors and renders the docstrings.

`mkdocs build --strict` (mkdocs.yml at the repository root) into tmp_path: the API reference
pages (mkdocstrings, numpy docstrings), the tutorial notebook (mkdocs-jupyter, not executed here:
its outputs are committed, and tests/docs/test_notebook.py runs it and checks them), the gallery
(scripts/gallery.py) and the notes in docs/.
"""

from __future__ import annotations

import html
import inspect
import os
import re
import subprocess
import sys
from pathlib import Path

import pytest

import magcilia

pytest.importorskip("mkdocs", reason="the docs extra: pip install -e '.[docs]'")
pytest.importorskip("mkdocstrings", reason="the docs extra: pip install -e '.[docs]'")
pytest.importorskip("mkdocs_jupyter", reason="the docs extra: pip install -e '.[docs]'")

ROOT = Path(__file__).resolve().parents[2]
CONFIG = ROOT / "mkdocs.yml"
#: subpackages that are not Python API (the command line; the report writers behind it)
NOT_API = {"cli", "report"}


def text_of(page: Path) -> str:
    """The visible text of a built page's article, whitespace collapsed."""
    source = page.read_text(encoding="utf-8")
    article = source[source.index("<article"):source.index("</article>")]
    return re.sub(r"\s+", " ", html.unescape(re.sub(r"<[^>]+>", " ", article)))


def repository_state() -> tuple[str, bool, bool]:
    """Untracked and changed files (git), and whether site/ and .cache/ exist."""
    status = subprocess.run(["git", "status", "--porcelain"], cwd=ROOT, capture_output=True,
                            text=True, check=False).stdout
    return status, (ROOT / "site").exists(), (ROOT / ".cache").exists()


@pytest.fixture(scope="module")
def site(tmp_path_factory: pytest.TempPathFactory) -> Path:
    out = tmp_path_factory.mktemp("site")
    env = dict(os.environ, NO_MKDOCS_2_WARNING="1", JUPYTER_PLATFORM_DIRS="1")
    # the hook imports the magcilia under test (an editable install, or PYTHONPATH=src)
    env["PYTHONPATH"] = os.pathsep.join(
        [str(Path(magcilia.__file__).resolve().parents[1]),
         *filter(None, [os.environ.get("PYTHONPATH")])])
    before = repository_state()
    proc = subprocess.run(
        [sys.executable, "-m", "mkdocs", "build", "--strict", "--config-file", str(CONFIG),
         "--site-dir", str(out / "site")],
        cwd=out, env=env, capture_output=True, text=True, timeout=300, check=False)
    assert proc.returncode == 0, proc.stdout + proc.stderr
    assert "WARNING" not in proc.stderr, proc.stderr
    assert repository_state() == before, "the build wrote into the repository"
    return out / "site"


def test_pages_exist(site: Path) -> None:
    for page in ("index.html", "tutorial/index.html", "api/magcilia/index.html",
                 "ARCHITECTURE/index.html", "convergence/index.html", "mechanics/index.html",
                 "serial-protocol/index.html", "stiffness/index.html", "gallery/index.html",
                 "show/index.html"):
        assert (site / page).is_file(), page
    assert (site / "tutorial" / "tutorial.ipynb").is_file()  # the notebook, to download


def test_calibrate_is_rendered_with_its_signature_and_parameters(site: Path) -> None:
    text = text_of(site / "api" / "magcilia.calibration" / "index.html")
    assert ("calibrate ( data : Measurement | Sequence [ Measurement ], initial : Setup | None = "
            "None") in text
    assert "Parameters:" in text and "Returns:" in text
    # a numpy-style parameter entry: name, type, its description with units
    assert re.search(r"bounds mapping of str to \(low, high\) Search bounds in SI", text), text
    assert "CalibrationResult" in text and "ParameterCovariance" in text
    assert ":func:" not in text  # Sphinx roles are shown as code, not as text


def test_every_public_area_has_a_rendered_page(site: Path) -> None:
    src = ROOT / "src" / "magcilia"
    packages = {p.parent.name for p in src.glob("*/__init__.py")}
    modules = {p.stem for p in src.glob("*.py") if "\n__all__" in p.read_text(encoding="utf-8")}
    areas = sorted(a for a in packages | modules
                   if not a.startswith("_") and a not in NOT_API)
    for area in areas:
        page = site / "api" / f"magcilia.{area}" / "index.html"
        assert page.is_file(), f"add `- magcilia.{area}: api/magcilia.{area}.md` to mkdocs.yml"
        module = __import__(f"magcilia.{area}", fromlist=["__all__"])
        first = " ".join((module.__doc__ or "").strip().split("\n\n")[0].split())
        text = text_of(page)
        assert first[:40] in text, (area, first)
        # every class and function it exports has an entry of its own
        source = page.read_text(encoding="utf-8")
        for name in module.__all__:
            obj = getattr(module, name)
            if ((inspect.isclass(obj) or inspect.isfunction(obj))
                    and obj.__module__.startswith("magcilia.")):
                anchors = (f'id="magcilia.{area}.{name}"',
                           f'id="{obj.__module__}.{obj.__qualname__}"')
                assert any(a in source for a in anchors), f"magcilia.{area}.{name}"


def test_top_level_index_links_every_name(site: Path) -> None:
    page = (site / "api" / "magcilia" / "index.html").read_text(encoding="utf-8")
    for name in magcilia.__all__:
        if not name.startswith("_"):
            assert f"<code>{name}</code>" in page or f'id="magcilia.{name}"' in page, name
    assert 'href="../magcilia.calibration/#magcilia.calibration.calibrate"' in page
    assert 'id="magcilia.MagciliaError"' in page  # documented here: no subpackage exports it


def test_the_tutorial_page_shows_its_figures_and_printed_results(site: Path) -> None:
    page = (site / "tutorial" / "index.html").read_text(encoding="utf-8")
    figures = re.findall(r'<img [^>]*src="data:image/png;base64,', page)
    assert len(figures) == 4  # the four figures, inline (the theme's own PNGs are CSS)
    text = text_of(site / "tutorial" / "index.html")
    for printed in ("height 3.2613 mm, base radius 0.1801 mm", "33 angles 0..85 deg",
                    "cost ", "tip force read-out over", "tared", "applied (mN)"):
        assert printed in text, printed


def test_the_gallery_and_show_pages_show_their_images(site: Path) -> None:
    page = (site / "gallery" / "index.html").read_text(encoding="utf-8")
    images = re.findall(r'<img[^>]+src="\.\./images/gallery/([^"]+\.png)"', page)
    committed = {p.name for p in (ROOT / "docs" / "images" / "gallery").iterdir()}
    assert set(images) == committed and len(images) == len(committed)
    for name in committed:
        assert (site / "images" / "gallery" / name).is_file(), name
    assert "magcilia sensitivity --setup paper" in text_of(site / "gallery" / "index.html")
    show = (site / "show" / "index.html").read_text(encoding="utf-8")
    assert 'src="../images/gallery/show-show.png"' in show
