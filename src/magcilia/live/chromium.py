"""The headless Chromium that drives the dashboard's page outside a person's browser: in the
browser tests, ``benchmarks/bench_live.py`` and ``scripts/dashboard_screenshot.py`` (Playwright
launches it with ``executable_path=find_chromium(), args=CHROMIUM_ARGS``)."""

from __future__ import annotations

import shutil
from pathlib import Path

#: the flags it runs with: no sandbox (a container's root), no GPU, nothing fetched on its own
CHROMIUM_ARGS = ["--no-sandbox", "--disable-gpu", "--disable-quic", "--no-first-run",
                 "--disable-background-networking", "--disable-component-update",
                 "--disable-sync"]


def find_chromium() -> str | None:
    """The path of Chromium's executable (Debian's ``/usr/bin/chromium``, else ``chromium`` or
    ``chromium-browser`` on PATH), or None where there is none."""
    for candidate in ("/usr/bin/chromium", shutil.which("chromium"),
                      shutil.which("chromium-browser")):
        if candidate and Path(candidate).exists():
            return candidate
    return None
