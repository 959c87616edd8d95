"""What the live tests share: a simulated sensor whose cable can be pulled, and a headless
Chromium for the dashboard's browser tests (skipped without one)."""

from __future__ import annotations

import math
import os
import shutil
import subprocess
import time
from collections.abc import Iterator
from typing import Any

import pytest

from magcilia._errors import AcquisitionError
from magcilia.acquire import SimulatedSource
from magcilia.acquire.source import Block
from magcilia.live.chromium import CHROMIUM_ARGS, find_chromium


class Unplugged(SimulatedSource):
    """A simulated sensor whose cable is pulled by :meth:`unplug` or after ``good`` reads, and
    put back by :meth:`plug` or ``down`` s later: reads fail ("sim: device vanished") and so
    do reopenings ("sim: no such device") meanwhile."""

    def __init__(self, *args: Any, good: int | None = None, down: float = math.inf,
                 **kw: Any) -> None:
        super().__init__(*args, **kw)
        self.good, self.down, self.reads = good, down, 0
        self.unplugged_at: float | None = None

    def unplug(self) -> None:
        self.unplugged_at = time.monotonic()

    def plug(self) -> None:
        self.unplugged_at = None

    @property
    def unplugged(self) -> bool:
        return self.unplugged_at is not None and time.monotonic() - self.unplugged_at < self.down

    def _open(self) -> None:
        if self.unplugged:
            raise AcquisitionError("sim: no such device (unplugged)")
        super()._open()

    def _read(self, n: int) -> Block:
        self.reads += 1
        if self.reads == self.good:
            self.unplug()
        if self.unplugged:
            raise AcquisitionError("sim: device vanished")
        return super()._read(n)


@pytest.fixture
def unplugged() -> type[Unplugged]:
    """The class :class:`Unplugged` (a fixture: test modules are not importable here)."""
    return Unplugged


# -- the page in a real browser ---------------------------------------------------------------


@pytest.fixture(scope="session")
def chromium() -> str:
    """Debian's Chromium, installed with apt-get where it is missing and we may."""
    path = find_chromium()
    if path is not None:
        return path
    if not (hasattr(os, "geteuid") and os.geteuid() == 0 and shutil.which("apt-get")):
        pytest.skip("no Chromium: not installed, and installing it needs root and apt-get")
    env = {**os.environ, "DEBIAN_FRONTEND": "noninteractive"}
    why = "apt-get install -y chromium did not install it"
    try:
        for command in (["apt-get", "install", "-y", "chromium"], ["apt-get", "update"],
                        ["apt-get", "install", "-y", "chromium"]):
            subprocess.run(command, env=env, capture_output=True, timeout=600, check=False)
            if find_chromium():
                break
    except subprocess.TimeoutExpired:
        why = "apt-get took longer than 600 s"
    path = find_chromium()
    if path is None:
        pytest.skip(f"no Chromium: {why}")
    return path


@pytest.fixture(scope="module")
def browser(chromium: str) -> Iterator[Any]:
    sync_api = pytest.importorskip("playwright.sync_api")
    with sync_api.sync_playwright() as p:
        launched = p.chromium.launch(executable_path=chromium, headless=True,
                                     args=CHROMIUM_ARGS)
        yield launched
        launched.close()
