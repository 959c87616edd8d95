"""Shared test configuration: a headless matplotlib backend, a quick Hypothesis profile, the
command that runs the magcilia under test in a subprocess, and a guard that fails the run if the
suite changed the checkout (``git status``)."""

from __future__ import annotations

import os
import shutil
import subprocess
import sys
from collections.abc import Iterator, Mapping
from dataclasses import dataclass
from pathlib import Path

import matplotlib
import pytest
from hypothesis import settings

matplotlib.use("Agg")

# the converged-layout cache across processes (model/layout_cache.py) off: every test computes
# its layouts (a monkeypatched model must not meet a remembered answer), and nothing is written
# into the user's cache folder; tests of the cache turn it on in tmp_path
os.environ["MAGCILIA_CACHE_DIR"] = ""

settings.register_profile("magcilia", max_examples=40, deadline=None)
settings.load_profile("magcilia")

ROOT = Path(__file__).resolve().parents[1]


@dataclass(frozen=True)
class TreeCommand:
    """How a subprocess runs the magcilia this test run imported (the tree under test), never
    a ``magcilia`` found on PATH or installed elsewhere.

    ``argv`` is ``[sys.executable, "-m", "magcilia"]``; :meth:`env` puts the folder holding the
    imported package first on ``PYTHONPATH``, so it holds in a bare environment too (tmux,
    pexpect)."""

    argv: tuple[str, ...]
    path: str

    def env(self, base: Mapping[str, str] | None = None, **extra: str) -> dict[str, str]:
        """``base`` (default: this process's environment) plus ``extra``, with the tree under
        test first on ``PYTHONPATH``."""
        env = dict(os.environ if base is None else base, **extra)
        env["PYTHONPATH"] = os.pathsep.join([self.path, *filter(None, [env.get("PYTHONPATH")])])
        return env

    def shell(self) -> str:
        """The command as one shell word list (for tmux), with ``PYTHONPATH`` set inline."""
        import shlex

        return (f"PYTHONPATH={shlex.quote(self.path)} "
                + " ".join(shlex.quote(a) for a in self.argv))


@pytest.fixture(scope="session")
def magcilia_command() -> TreeCommand:
    """The command line that runs the magcilia under test (:class:`TreeCommand`)."""
    import magcilia

    return TreeCommand((sys.executable, "-m", "magcilia"),
                       str(Path(magcilia.__file__).resolve().parents[1]))


def _git_status() -> str | None:
    """``git status --porcelain`` of the checkout holding these tests, or None outside one."""
    git = shutil.which("git")
    if git is None:
        return None
    try:
        inside = subprocess.run([git, "-C", str(ROOT), "rev-parse", "--show-toplevel"],
                                capture_output=True, text=True, timeout=60, check=False)
        if inside.returncode != 0 or Path(inside.stdout.strip()).resolve() != ROOT:
            return None
        done = subprocess.run([git, "-C", str(ROOT), "status", "--porcelain",
                               "--untracked-files=all"],
                              capture_output=True, text=True, timeout=60, check=False)
    except (OSError, subprocess.TimeoutExpired):
        return None
    return done.stdout if done.returncode == 0 else None


@pytest.fixture(scope="session", autouse=True)
def _checkout_left_as_found() -> Iterator[None]:
    """Tests never write into the repository: the run fails (an error at the last teardown)
    if ``git status --porcelain`` shows an entry after the run that it did not show before (a
    file changed, added or deleted). Entries that went away meanwhile (a commit made while the
    suite ran) are no test's doing and pass. Skipped outside a git checkout (an sdist, an
    installed copy)."""
    before = _git_status()
    yield
    if before is None:
        return
    after = _git_status()
    new = sorted(set((after or "").splitlines()) - set(before.splitlines()))
    if after is not None and new:
        pytest.fail(f"the test run changed the checkout (git status --porcelain): {new}; "
                    "tests must write into tmp_path only", pytrace=False)
