"""Lazy public names and a light start-up (issue 27 item 3).

Every package face hands out its names on first access (:mod:`magcilia._lazy`): each name of each
``__all__`` resolves, ``dir()`` lists them, ``from … import`` works, a name that is also a
submodule's keeps meaning the name. ``import magcilia`` and ``magcilia --help`` import none of the
heavy libraries (checked in fresh processes from ``sys.modules``, no timing).
"""

from __future__ import annotations

import importlib
import json
import os
import subprocess
import sys
import types
from pathlib import Path

import pytest

import magcilia
from magcilia import _lazy

SRC = Path(magcilia.__file__).resolve().parent
#: the package faces with lazy names: magcilia itself and every room but cli and report
FACES = sorted(["magcilia", *(f"magcilia.{p.parent.name}" for p in SRC.glob("*/__init__.py")
                              if p.parent.name not in ("cli", "report"))])
#: libraries that ``import magcilia`` and ``magcilia --help`` must not load (top-level names,
#: and SciPy's heavy subpackages by their full names)
HEAVY = ("scipy", "pandas", "pyarrow", "matplotlib", "numba", "llvmlite", "magpylib", "tqdm",
         "emcee", "SALib", "h5py", "nptdms", "dask", "rich", "starlette", "uvicorn", "PIL")


def _modules_after(code: str) -> set[str]:
    """``sys.modules`` of a fresh interpreter (this tree first on the path) after ``code``."""
    env = {**os.environ, "PYTHONPATH": os.pathsep.join(
        [str(SRC.parent), *filter(None, [os.environ.get("PYTHONPATH")])])}
    done = subprocess.run(
        [sys.executable, "-c", f"{code}\nimport json, sys\nprint(json.dumps(sorted(sys.modules)))"],
        capture_output=True, text=True, env=env, timeout=120, check=True)
    return set(json.loads(done.stdout.splitlines()[-1]))


def _heavy(modules: set[str]) -> list[str]:
    return sorted(m for m in modules if m.split(".")[0] in HEAVY)


def test_import_magcilia_loads_no_heavy_library() -> None:
    modules = _modules_after("import magcilia")
    assert "magcilia" in modules  # (the tree under test was imported)
    assert _heavy(modules) == []
    # not even the rooms: the faces load when a name is first used
    assert sorted(m for m in modules if m.startswith("magcilia.")) == [
        "magcilia._errors", "magcilia._lazy", "magcilia._version"]


def test_magcilia_help_loads_no_heavy_library_and_no_command() -> None:
    modules = _modules_after(
        "from magcilia.cli import main\nimport contextlib, io\n"
        "with contextlib.redirect_stdout(io.StringIO()):\n    assert main(['--help']) == 0")
    assert _heavy(modules) == []
    assert "numpy" not in modules
    from magcilia.cli import COMMANDS

    assert sorted(m for m in modules if m.removeprefix("magcilia.cli.") in COMMANDS) == []


def test_no_command_help_loads_a_heavy_library() -> None:
    """``magcilia COMMAND --help`` for every command, one after another in one process: the
    command modules import only what their options need; SciPy, pandas, numba, matplotlib,
    tqdm, ... load inside the functions that use them (checked after each command, so the first
    command to load one is named)."""
    code = """
import contextlib, io, json, sys
from magcilia.cli import COMMANDS, main
HEAVY = HEAVY_MODULES
found = {}
for name in COMMANDS:
    with contextlib.redirect_stdout(io.StringIO()) as out:
        assert main([name, "--help"]) == 0, name
    assert "Usage: magcilia " + name in out.getvalue(), name
    assert "magcilia.cli." + name in sys.modules, name  # (the command module was imported)
    heavy = sorted(m for m in sys.modules if m.split(".")[0] in HEAVY)
    if heavy:
        found[name] = heavy
        break
print(json.dumps(found))
""".replace("HEAVY_MODULES", repr(HEAVY))
    env = {**os.environ, "PYTHONPATH": os.pathsep.join(
        [str(SRC.parent), *filter(None, [os.environ.get("PYTHONPATH")])])}
    done = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, env=env,
                          timeout=120, check=True)
    assert json.loads(done.stdout.splitlines()[-1]) == {}


def test_every_face_imports_nothing_of_its_room() -> None:
    """Importing every package face loads none of their modules: a name added to a face goes
    into its ``if TYPE_CHECKING:`` block (an eager import there would load its module, and what
    that imports, at ``import magcilia``)."""
    modules = _modules_after("\n".join(f"import {face}" for face in FACES))
    assert set(FACES) <= modules
    loaded = sorted(m for m in modules if m.startswith("magcilia.") and m not in FACES
                    and m.count(".") >= 2)
    assert loaded == []
    assert _heavy(modules) == []


def test_reading_a_small_csv_recording_loads_no_pandas() -> None:
    """A plain CSV of up to 64 MB is parsed by NumPy (``io.csvparsers.NUMPY_BYTES``): pandas
    loads only for larger files and for those NumPy cannot parse (the decimal comma, ...)."""
    modules = _modules_after("import magcilia as mc\n"
                             "mc.read_measurements(mc.io.example_path())")
    assert "magcilia.io.csvfile" in modules
    assert not {"pandas", "pyarrow", "matplotlib", "numba"} & modules


def test_a_room_face_loads_only_what_its_used_name_needs() -> None:
    """Touching one light name of a room imports its module, not the room's heavy ones."""
    modules = _modules_after("from magcilia.device import Cilium")
    assert "magcilia.device.cilium" in modules
    assert _heavy(modules) == []
    assert "magcilia.calibration" not in modules


@pytest.mark.parametrize("face", FACES)
def test_every_public_name_resolves_and_is_listed(face: str) -> None:
    module = importlib.import_module(face)
    listed = dir(module)
    for name in module.__all__:
        assert name in listed, f"{face}.{name} missing from dir()"
        value = getattr(module, name)
        assert value is not None or name.isupper()
        namespace: dict[str, object] = {}
        exec(f"from {face} import {name}", namespace)  # noqa: S102 (the statement users write)
        assert namespace[name] is value
    # every public name is lazy, but for magcilia's few light ones bound at import
    eager = {"__version__", "LayoutWarning", "MagciliaError", "MagciliaWarning",
             "MissingDependencyError"} if face == "magcilia" else set()
    assert set(module.__all__) - eager <= set(_lazy.lazy_table(face)), "a public name is eager"


@pytest.mark.parametrize("face", FACES)
def test_unknown_names_raise_attribute_error(face: str) -> None:
    module = importlib.import_module(face)
    with pytest.raises(AttributeError, match=f"module '{face}' has no attribute 'nothing_here'"):
        module.nothing_here  # noqa: B018
    assert not hasattr(module, "nothing_here")


def test_star_import_gives_every_public_name() -> None:
    namespace: dict[str, object] = {}
    exec("from magcilia import *", namespace)  # noqa: S102
    assert set(magcilia.__all__) <= set(namespace)
    assert namespace["calibrate"] is magcilia.calibration.search.calibrate


def test_a_public_name_that_is_also_a_submodule_keeps_its_meaning() -> None:
    """``mechanics.bend`` is the function, ``fitting.multistart``/``polish`` the functions, as
    with an eager ``__init__``, even when the submodule of the same name is imported first (which
    binds the module on its package)."""
    code = """
import magcilia.mechanics.bend, magcilia.fitting.multistart, magcilia.fitting.polish
import magcilia.io.presets
import magcilia.mechanics as m, magcilia.fitting as f, magcilia.io as io
from magcilia.mechanics import bend
import types
assert callable(m.bend) and not isinstance(m.bend, types.ModuleType) and bend is m.bend
assert not isinstance(f.multistart, types.ModuleType) and not isinstance(f.polish, types.ModuleType)
assert isinstance(io.presets, types.ModuleType)  # a public name that is the submodule itself
import magcilia
assert magcilia.bend is m.bend and magcilia.presets is io.presets
"""
    _modules_after(code)  # (check=True: an assertion there fails here)
    import magcilia.mechanics

    assert not isinstance(magcilia.mechanics.bend, types.ModuleType)


def test_the_table_is_read_from_the_type_checking_block() -> None:
    table = _lazy.lazy_table("magcilia.calibration")
    assert table["calibrate"] == ("magcilia.calibration.search", "calibrate")
    assert table["JointProblem"] == ("magcilia.calibration.joint", "JointProblem")
    assert _lazy.lazy_table("magcilia")["presets"] == ("magcilia.io", "presets")


@pytest.mark.slow
def test_numba_caches_load_in_a_new_process_without_compiling(tmp_path: Path) -> None:
    """The compiled kernels (``cache=True``) compile once into the cache folder; a second fresh
    process loads every one of them from it and compiles nothing (NUMBA_DEBUG_CACHE's lines)."""
    code = """
import numpy as np
import magcilia as mc
from magcilia.model import compiled
setup = mc.presets.setup("paper")
setup.output(np.radians([0.0, 10.0, 20.0]))  # the tilt kernel
readout = mc.Readout(setup, span=(0.0, 0.5))
readout.read(np.array([readout.rest, readout.rest]))  # the read-out's compiled pass
assert compiled.kernels() is not None
"""
    env = {**os.environ, "NUMBA_CACHE_DIR": str(tmp_path), "NUMBA_DEBUG_CACHE": "1",
           "PYTHONPATH": os.pathsep.join([str(SRC.parent),
                                         *filter(None, [os.environ.get("PYTHONPATH")])])}
    runs = [subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, env=env,
                           timeout=600, check=True).stdout for _ in range(2)]
    assert "data saved" in runs[0]  # (the first process compiled and saved)
    assert "data saved" not in runs[1] and "index saved" not in runs[1], runs[1]
    # (a helper compiled into its caller, saved once, is not loaded again: count the loads loosely)
    assert 1 <= runs[1].count("data loaded") <= runs[0].count("data saved")
