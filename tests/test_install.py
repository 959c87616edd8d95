"""The install: Quickstart line 1 (the core dependencies alone) is the lab, every one-line
"missing package" error names an extra that installs the package, and the lock
(constraints.txt) pins every dependency within pyproject's ranges.

The lab check runs ``record`` (TDMS), ``live`` (plain lines), ``angle`` (a generated photo),
``record`` from a serial device (the emulator on a pseudo-terminal) and ``dashboard`` (GET /) in
a subprocess that cannot import any installed package outside the core install's dependency
closure (the extras' packages, the test tools, setuptools): what a fresh ``pip install .`` has.
"""

from __future__ import annotations

import ast
import json
import math
import os
import re
import signal
import subprocess
import sys
import textwrap
import tomllib
import urllib.request
from importlib import metadata
from pathlib import Path
from typing import Any

import numpy as np
import pytest

ROOT = Path(__file__).resolve().parents[1]
PYPROJECT = tomllib.loads((ROOT / "pyproject.toml").read_text(encoding="utf-8"))
CONSTRAINTS = ROOT / "constraints.txt"
#: what each lab command needs beyond numpy/scipy/matplotlib (distribution names)
LAB = {
    "record (TDMS)": ["npTDMS"],
    "serial source": ["pyserial", "cobs"],
    "live (terminal)": ["rich"],
    "dashboard": ["starlette", "uvicorn", "websockets"],
    "angle (photos)": ["scikit-image", "pillow"],
    "live --lsl (Lab Streaming Layer)": ["pylsl"],
}

requirements = pytest.importorskip("packaging.requirements")
utils = pytest.importorskip("packaging.utils")


def _name(requirement: str) -> str:
    return str(utils.canonicalize_name(requirements.Requirement(requirement).name))


def _extras() -> dict[str, list[str]]:
    return PYPROJECT["project"]["optional-dependencies"]


def _core() -> list[str]:
    return PYPROJECT["project"]["dependencies"]


def test_the_lab_is_in_the_core_install() -> None:
    core = {_name(r) for r in _core()}
    for what, packages in LAB.items():
        missing = [p for p in packages if utils.canonicalize_name(p) not in core]
        assert not missing, f"{what} needs {missing}, not in pyproject's core dependencies"
    for extra in ("nidaq", "cluster", "docs", "posterior", "hdf5", "sensitivity"):
        assert not {_name(r) for r in _extras()[extra]} & core, f"{extra} is meant to be extra"


def _require_calls() -> list[tuple[str, int, str | None, str]]:
    """(file, line, package or None when not a literal, extra) of every literal
    ``require(..., extra="...")`` in the package."""
    found = []
    for path in sorted((ROOT / "src" / "magcilia").rglob("*.py")):
        source = path.read_text(encoding="utf-8")
        if "require(" not in source:
            continue
        for node in ast.walk(ast.parse(source)):
            if not (isinstance(node, ast.Call) and getattr(node.func, "id", None) == "require"):
                continue
            kw = {k.arg: k.value for k in node.keywords}
            if isinstance(kw.get("extra"), ast.Constant):
                package = kw.get("package")
                found.append((path.name, node.lineno,
                              package.value if isinstance(package, ast.Constant) else None,
                              kw["extra"].value))  # type: ignore[union-attr]
    return found


def test_every_missing_package_message_names_an_extra_that_installs_it() -> None:
    calls = _require_calls()
    assert len(calls) >= 10  # the scan sees them
    extras = _extras()
    for file, line, package, extra in calls:
        assert extra in extras, f"{file}:{line}: extra {extra!r} is not in pyproject"
        if package is not None:
            names = {_name(r) for r in extras[extra]}
            assert _name(package) in names, f"{file}:{line}: [{extra}] does not install {package}"


def test_every_install_line_names_extras_that_exist() -> None:
    """``magcilia[...]`` and ``.[...]`` in the README, the docs and the package's messages."""
    extras = set(_extras())
    texts = [ROOT / "README.md", *(ROOT / "docs").rglob("*.md"),
             *(ROOT / "src" / "magcilia").rglob("*.py")]
    seen = 0
    for path in texts:
        text = path.read_text(encoding="utf-8")
        for match in re.finditer(r"(?:magcilia|[\"'\s]\.)\[([a-z0-9_,-]+)\]", text):
            seen += 1
            unknown = set(match[1].split(",")) - extras
            assert not unknown, f"{path.relative_to(ROOT)}: {match[0]} names no extra {unknown}"
    assert seen >= 5


def test_the_lock_pins_every_dependency_within_its_range() -> None:
    """constraints.txt (scripts/update_constraints.sh) pins each requirement of the dev install
    (core, the extras dev pulls, the dev tools) at a version pyproject allows."""
    pins: dict[str, str] = {}
    for line in CONSTRAINTS.read_text(encoding="utf-8").splitlines():
        if line.strip() and not line.startswith("#"):
            name, sep, version = line.partition("==")
            assert sep and version.strip(), f"constraints.txt: {line!r} is not NAME==VERSION"
            pins[str(utils.canonicalize_name(name))] = version.strip()
    extras = _extras()
    wanted = list(_core())
    for requirement in extras["dev"]:
        req = requirements.Requirement(requirement)
        if utils.canonicalize_name(req.name) == "magcilia":
            for extra in req.extras:
                wanted += extras[extra]
        else:
            wanted.append(requirement)
    for requirement in wanted:
        req = requirements.Requirement(requirement)
        name = str(utils.canonicalize_name(req.name))
        assert name in pins, f"constraints.txt lacks {req.name} (run scripts/update_constraints.sh)"
        assert req.specifier.contains(pins[name], prereleases=True), (
            f"constraints.txt pins {req.name}=={pins[name]}, outside pyproject's {req.specifier}")


def test_pyproject_keeps_ranges() -> None:
    """The package states lower bounds, never upper caps or pins (the lock pins)."""
    for requirement in [*_core(), *(r for rs in _extras().values() for r in rs)]:
        spec = requirements.Requirement(requirement).specifier
        assert all(s.operator in (">=", "!=") for s in spec), requirement


# -- the lab with the core install alone -------------------------------------------------------
def _core_closure() -> set[str]:
    """Canonical names of the installed distributions the core dependencies pull, with the
    extras they ask for (markers evaluated here)."""
    todo = [requirements.Requirement(r) for r in _core()]
    seen: dict[str, set[str]] = {}
    while todo:
        req = todo.pop()
        if req.marker is not None and not req.marker.evaluate({"extra": ""}):
            continue
        name = str(utils.canonicalize_name(req.name))
        known = seen.get(name)
        if known is not None and set(req.extras) <= known:
            continue
        seen.setdefault(name, set()).update(req.extras)
        try:
            dist = metadata.distribution(name)
        except metadata.PackageNotFoundError:
            continue
        for text in dist.requires or []:
            dep = requirements.Requirement(text)
            if dep.marker is None or any(dep.marker.evaluate({"extra": e})
                                         for e in ["", *seen[name]]):
                dep.marker = None
                todo.append(dep)
    return set(seen)


def _blocked_modules() -> list[str]:
    """Top-level modules of installed distributions outside the core closure."""
    allowed = _core_closure() | {"magcilia"}
    blocked = set()
    for module, dists in metadata.packages_distributions().items():
        if module in sys.stdlib_module_names or module.startswith("__"):
            continue
        if not any(str(utils.canonicalize_name(d)) in allowed for d in dists):
            blocked.add(module)
    return sorted(blocked)


BLOCKER = """
import importlib.abc, sys
BLOCKED = frozenset({blocked!r})

class CoreInstallOnly(importlib.abc.MetaPathFinder):
    def find_spec(self, name, path=None, target=None):
        if name.partition(".")[0] in BLOCKED:
            raise ModuleNotFoundError(f"No module named {{name!r}} (not in the core install)",
                                      name=name)
        return None

sys.meta_path.insert(0, CoreInstallOnly())
"""


def _write_photo(path: Path, angle_deg: float) -> None:
    """A grey photo (480 x 640) of a dark holder with a bright tape, tilted ``angle_deg`` from
    the vertical (top to the right > 0), lightly blurred and noisy."""
    from PIL import Image
    from scipy import ndimage

    rng = np.random.default_rng(0)
    h, w = 480, 640
    y, x = np.mgrid[0:h, 0:w].astype(np.float64)
    img = 0.55 + 0.4 * ndimage.gaussian_filter(rng.normal(0.0, 1.0, (h, w)), 6.0)
    th = math.radians(angle_deg)
    u = (x - w / 2) * math.sin(th) - (y - 0.86 * h) * math.cos(th)  # along the holder
    v = (x - w / 2) * math.cos(th) + (y - 0.86 * h) * math.sin(th)  # across it
    for half, u0, u1, grey in ((18.0, -10.0, 330.0, 0.12), (6.0, 10.0, 315.0, 0.88)):
        cover = np.clip(0.5 - np.maximum(np.abs(v) - half, np.maximum(u0 - u, u - u1)), 0, 1)
        img = img * (1 - cover) + grey * cover
    img = ndimage.gaussian_filter(img, 1.2) + rng.normal(0.0, 0.01, (h, w))
    Image.fromarray(np.asarray(np.clip(img, 0, 1) * 255 + 0.5, np.uint8)).save(path)


LAB_RUN = """
import contextlib, io, json, sys
for module in {extras_present!r}:
    try:
        __import__(module)
    except ImportError:
        pass
    else:
        raise SystemExit(f"the blocker let {{module}} through")
from magcilia.acquire import SimulatedSource
from magcilia.acquire.emulator import DeviceEmulator
from magcilia.cli import main
import magcilia as mc

def run(*args):
    out = io.StringIO()
    with contextlib.redirect_stdout(out):
        code = main(list(args))
    return code, out.getvalue()

results = {{}}
results["record"] = run("record", "--source", "sim", "--duration", "0.3", "--rate", "1000",
                        "--out", "sim.tdms", "--quiet")
results["live"] = run("live", "--duration", "0.5", "--tip-radius", "0.05mm")
results["angle"] = run("angle", "photo.png", "--json")
sim = SimulatedSource(mc.Setup.paper(), rate=1000.0, rng=0)
with DeviceEmulator(sim, samples_per_frame=20, realtime=False) as device:
    results["serial"] = run("record", "--source", f"serial:{{device.port}}", "--duration", "0.2",
                            "--out", "serial.tdms", "--quiet")
print("RESULTS" + json.dumps(results))
"""


def test_record_live_angle_and_serial_run_with_the_core_install_only(
        tmp_path: Path, magcilia_command: Any) -> None:
    blocked = _blocked_modules()
    assert "pytest" in blocked and "magcilia" not in blocked and "numpy" not in blocked
    present = [m for m in ("h5py", "emcee", "SALib", "pytest") if m in blocked]
    _write_photo(tmp_path / "photo.png", 17.0)
    code = BLOCKER.format(blocked=blocked) + LAB_RUN.format(extras_present=present)
    done = subprocess.run([sys.executable, "-c", code], cwd=tmp_path, capture_output=True,
                          text=True, timeout=300, check=False,
                          env=magcilia_command.env(MPLBACKEND="Agg"))
    assert done.returncode == 0, done.stdout + done.stderr
    results = json.loads(done.stdout.split("RESULTS", 1)[1])
    for what, (status, _) in results.items():
        assert status == 0, (what, done.stderr)
    assert (tmp_path / "sim.tdms").stat().st_size > 0
    assert (tmp_path / "serial.tdms").stat().st_size > 0
    # its plain lines (whatever the state: a first run may still be compiling kernels at 0.5 s)
    assert "start: sim" in results["live"][1] and re.search(r"\| \w+: ", results["live"][1])
    (photo,) = json.loads(results["angle"][1])
    assert photo["angle_deg"] == pytest.approx(17.0, abs=0.5)
    from magcilia.io.recordings import read_samples

    assert read_samples(tmp_path / "sim.tdms", required=("voltage_V",))["voltage_V"].size > 0


def test_the_dashboard_serves_its_page_with_the_core_install_only(
        tmp_path: Path, magcilia_command: Any) -> None:
    code = BLOCKER.format(blocked=_blocked_modules()) + textwrap.dedent("""
        import runpy
        sys.argv = ["magcilia", "dashboard", "--source", "sim", "--port", "0",
                    "--record-dir", "rec"]
        runpy.run_module("magcilia", run_name="__main__", alter_sys=True)
    """)
    server = subprocess.Popen([sys.executable, "-c", code], cwd=tmp_path, text=True,
                              stdout=subprocess.PIPE, stderr=subprocess.PIPE,
                              env=magcilia_command.env(MPLBACKEND="Agg"))
    try:
        assert server.stdout is not None
        line = server.stdout.readline()  # "magcilia dashboard: URL  (Ctrl-C to stop)"
        found = re.search(r"(http://127\.0\.0\.1:\d+/\S*)", line)
        assert found, line + (server.stderr.read() if server.poll() is not None else "")
        with urllib.request.urlopen(found[1], timeout=60) as page:
            assert page.status == 200
            assert b"<html" in page.read().lower()
    finally:
        server.send_signal(signal.SIGINT)
        try:
            _, err = server.communicate(timeout=60)
        except subprocess.TimeoutExpired:
            server.kill()
            _, err = server.communicate()
    assert server.returncode == 0, err
    assert "No module named" not in err and "Traceback" not in err, err


# -- the suite leaves the checkout as it found it ------------------------------------------------
def test_a_test_that_writes_into_the_checkout_fails_the_run(tmp_path: Path,
                                                            magcilia_command: Any) -> None:
    """The session guard in tests/conftest.py, run on a scratch checkout holding it and a test
    that leaves a file behind."""
    import shutil

    git = shutil.which("git")
    if git is None:
        pytest.skip("git is not installed")
    (tmp_path / "tests").mkdir()
    shutil.copy(ROOT / "tests" / "conftest.py", tmp_path / "tests" / "conftest.py")
    (tmp_path / "tests" / "test_stray.py").write_text(
        "from pathlib import Path\n\n\ndef test_stray() -> None:\n"
        "    (Path(__file__).parents[1] / 'stray.txt').write_text('left behind')\n")
    env = {"GIT_AUTHOR_NAME": "t", "GIT_AUTHOR_EMAIL": "t@t", "GIT_COMMITTER_NAME": "t",
           "GIT_COMMITTER_EMAIL": "t@t", "HOME": str(tmp_path), "PATH": os.environ["PATH"]}
    for args in (["init", "-q"], ["add", "."], ["commit", "-qm", "scratch"]):
        subprocess.run([git, *args], cwd=tmp_path, env=env, check=True, timeout=60)
    done = subprocess.run([sys.executable, "-m", "pytest", "-q", "-p", "no:cacheprovider",
                           "tests"], cwd=tmp_path, capture_output=True, text=True, timeout=300,
                          check=False, env=magcilia_command.env(env))
    assert done.returncode != 0, done.stdout
    assert "1 passed, 1 error" in done.stdout, done.stdout
    assert "the test run changed the checkout" in done.stdout and "stray.txt" in done.stdout
