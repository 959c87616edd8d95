"""Converged layouts remembered across processes (``model/layout_cache.py``): the same answer
as computing it, a new question (geometry, tolerance, probe) computed anew, a damaged or
unwritable cache ignored, the cache off when ``MAGCILIA_CACHE_DIR`` is empty."""

from __future__ import annotations

import json
import os
import subprocess
import sys
from pathlib import Path

import pytest

import magcilia as mc
from magcilia.model import convergence as cv
from magcilia.model import layout_cache


@pytest.fixture
def cache(tmp_path: Path, monkeypatch: pytest.MonkeyPatch) -> Path:
    monkeypatch.setenv("MAGCILIA_CACHE_DIR", str(tmp_path / "cache"))
    return tmp_path / "cache" / "layouts"


def _files(folder: Path) -> list[Path]:
    return sorted(folder.glob("*.json")) if folder.exists() else []


def test_a_remembered_layout_is_the_computed_one_and_skips_the_reference(
        cache: Path, monkeypatch: pytest.MonkeyPatch) -> None:
    spec = mc.Setup.paper().spec
    first = cv.converged_layout(spec)
    assert len(_files(cache)) == 1
    # the second answer comes from the file: the exact reference is not computed again
    cv._REFERENCES.clear()

    def no_reference(*args: object, **kwargs: object) -> None:
        raise AssertionError("the reference was computed")

    monkeypatch.setattr(cv, "reference", no_reference)
    again = cv.converged_layout(spec)
    assert again == first and again.converged
    # another question: a tolerance, a geometry, a probe of its own
    monkeypatch.undo()
    monkeypatch.setenv("MAGCILIA_CACHE_DIR", str(cache.parent))
    looser = cv.converged_layout(spec, 2e-2)
    assert looser.tolerance == 2e-2 and looser.n_loops <= first.n_loops
    other = mc.Setup.paper(height=2.5e-3).spec
    computed = cv.converged_layout(other)
    assert cv.converged_layout(other) == computed
    cv.converged_layout(spec, tilts=[0.0, 0.5])
    assert len(_files(cache)) == 4


def test_a_damaged_file_is_recomputed_and_an_unusable_folder_ignored(
        cache: Path, tmp_path: Path, monkeypatch: pytest.MonkeyPatch) -> None:
    spec = mc.Setup.paper().spec
    expected = cv.converged_layout(spec)
    (path,) = _files(cache)
    for damage in ("{not json", json.dumps({"n_loops": "many"}), json.dumps([1, 2])):
        path.write_text(damage)
        assert cv.converged_layout(spec) == expected
    assert json.loads(path.read_text())["n_loops"] == expected.n_loops  # (rewritten)
    # a file where the folder should be: nothing written, the layout computed all the same
    blocked = tmp_path / "blocked"
    blocked.write_text("")
    monkeypatch.setenv("MAGCILIA_CACHE_DIR", str(blocked))
    assert cv.converged_layout(spec) == expected
    # off
    monkeypatch.setenv("MAGCILIA_CACHE_DIR", "")
    assert layout_cache.folder() is None
    assert cv.converged_layout(spec) == expected


def test_the_default_folder_follows_xdg(monkeypatch: pytest.MonkeyPatch, tmp_path: Path) -> None:
    monkeypatch.delenv("MAGCILIA_CACHE_DIR")
    monkeypatch.setenv("XDG_CACHE_HOME", str(tmp_path))
    assert layout_cache.folder() == tmp_path / "magcilia"
    monkeypatch.delenv("XDG_CACHE_HOME")
    assert layout_cache.folder() == Path("~/.cache/magcilia").expanduser()


def test_loading_a_converged_setup_file_twice_imports_no_magpylib_the_second_time(
        tmp_path: Path) -> None:
    """The point of the cache: a second process loading the same setup file (the example
    force sensor, ``layout = "converged"``) does not import magpylib."""
    setup_file = Path(__file__).resolve().parents[2] / "examples" / "force-sensor.toml"
    code = (f"import sys\nimport magcilia as mc\nmc.load_setup({str(setup_file)!r})\n"
            "print('magpylib' in sys.modules)")
    src = Path(mc.__file__).resolve().parents[1]
    env = {**os.environ, "MAGCILIA_CACHE_DIR": str(tmp_path),
           "PYTHONPATH": os.pathsep.join([str(src), *filter(None, [os.environ.get("PYTHONPATH")])])}
    runs = [subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, env=env,
                           timeout=300, check=True).stdout.split() for _ in range(2)]
    assert runs == [["True"], ["False"]]
    assert len(list((tmp_path / "layouts").glob("*.json"))) == 1
