"""Draw the browser dashboard on the simulated sensor into docs/images/dashboard.png (the README's
picture), as a headless Chromium 1280 × 800 shows it.

The simulated force goes through what the picture should show: the tare at the start, a push of
0.15 mN, rest, a pull of 0.1 mN, a push beyond the span (flagged: no value), rest, a tare pressed
on the page, then a recording started from the page during a push of 0.2 mN and stopped.

Run: python scripts/dashboard_screenshot.py [--out PATH]  (needs the ``dashboard`` extra,
Playwright and Chromium: Debian's ``apt-get install chromium``)
"""

from __future__ import annotations

import argparse
import shutil
import sys
import tempfile
import time
from pathlib import Path

import magcilia as mc
from magcilia.acquire import Script, SimulatedSource
from magcilia.live import LiveReadout
from magcilia.live.dashboard import DashboardServer

OUT = Path(__file__).resolve().parents[1] / "docs" / "images" / "dashboard.png"
CHROMIUM_ARGS = ["--no-sandbox", "--disable-gpu", "--disable-quic", "--no-first-run",
                 "--disable-background-networking", "--disable-component-update",
                 "--disable-sync"]
#: what the simulated cilium does: (force in N, seconds held after the page shows it)
STEPS = ((1.5e-4, 1.0), (0.0, 0.8), (-1e-4, 0.8), (3.6e-4, 0.6), (0.0, 0.5))


def chromium() -> str | None:
    for candidate in ("/usr/bin/chromium", shutil.which("chromium"),
                      shutil.which("chromium-browser")):
        if candidate and Path(candidate).exists():
            return candidate
    return None


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--out", type=Path, default=OUT, help="the PNG to write")
    args = parser.parse_args()
    browser_path = chromium()
    if browser_path is None:
        sys.exit("dashboard_screenshot: no Chromium found (Debian: apt-get install chromium)")
    from playwright.sync_api import sync_playwright

    setup = mc.Setup.paper(tip_radius=5e-5)
    source = SimulatedSource(setup, Script.constant(0.0, "force"), rate=10000.0, realtime=True,
                             rng=0, readout_noise=2e-5)
    live = LiveReadout(source, mc.Readout(setup, "force", span=(-3e-4, 3e-4)), rate=1000,
                       tare_at_start=True)
    with tempfile.TemporaryDirectory() as records, sync_playwright() as p, live, \
            DashboardServer(live, port=0, record_dir=records) as server:
        browser = p.chromium.launch(executable_path=browser_path, headless=True,
                                    args=CHROMIUM_ARGS)
        page = browser.new_page(viewport={"width": 1280, "height": 800})
        page.goto(server.url)
        page.wait_for_function("() => window.magcilia.lastValue !== null && "
                               "window.magcilia.status && window.magcilia.status.tared",
                               timeout=20000)
        time.sleep(0.5)
        for force, hold in STEPS:
            source.set_value(force)
            time.sleep(hold)
        page.click("#tare")
        time.sleep(0.8)
        page.click("#record")
        page.wait_for_function("() => window.magcilia.status.recording", timeout=10000)
        source.set_value(2e-4)
        time.sleep(1.0)
        page.click("#record")
        page.wait_for_function("() => !window.magcilia.status.recording", timeout=10000)
        time.sleep(0.8)
        args.out.parent.mkdir(parents=True, exist_ok=True)
        page.screenshot(path=str(args.out))
        browser.close()
    print(f"wrote {args.out}")


if __name__ == "__main__":
    main()
