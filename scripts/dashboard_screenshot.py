"""Draw the browser dashboard on the simulated sensor into docs/images/dashboard.png (the README's
picture), as a headless Chromium 1280 × 800 shows it.

The sensor is the ``force-sensor`` preset (what ``magcilia dashboard`` reads by default: the
paper's cilium with a 0.05 mm tip radius, the presets' 0.669 MPa ± 27 % modulus, a converged
layout), read out over ±0.06 mN. The simulated force goes through what the picture should show:
the tare at the start, a push of 0.03 mN, rest, a pull of 0.02 mN, a push beyond the span
(flagged: no value), rest, a tare pressed on the page, then a recording started from the page
during a push of 0.04 mN and stopped. The σ band holds the noise and the force scale (±27 % of
the value: the modulus is assumed).

With ``--kind vector`` it draws a 3-axis sensor (an MMC5983MA at the element of the
``force-sensor`` preset, what ``magcilia dashboard --sensor MMC5983MA`` reads) into
docs/images/dashboard-vector.png: the simulation pushes the tip in changing directions (the
demo of ``magcilia live``), the picture shows the polar view during the third push (80 % of the
span; the trail of the last 3 s), Fx and Fy with their σ bands, and |F|. With ``--kind array`` it
draws examples/array.toml (16 cilia over 16 magnetometers, what ``magcilia dashboard --setup
examples/array.toml`` reads) into docs/images/dashboard-array.png: every cilium pushed in its own
direction, the map of the cilia, cilium r2c3 clicked and followed.

Run: python scripts/dashboard_screenshot.py [--kind scalar|vector|array] [--out PATH]  (needs
the ``dashboard`` extra, Playwright and Chromium: Debian's ``apt-get install chromium``)
"""

from __future__ import annotations

import argparse
import sys
import tempfile
import time
from pathlib import Path

import magcilia as mc
from magcilia.acquire import Script, SimulatedSource
from magcilia.cli._common import load_setup_arg
from magcilia.live import LiveReadout
from magcilia.live.chromium import CHROMIUM_ARGS, find_chromium
from magcilia.live.dashboard import DashboardServer

ROOT = Path(__file__).resolve().parents[1]
OUT = ROOT / "docs" / "images" / "dashboard.png"
#: the pictures of force vectors
OUTS = {"scalar": OUT, "vector": ROOT / "docs" / "images" / "dashboard-vector.png",
        "array": ROOT / "docs" / "images" / "dashboard-array.png"}
#: seconds of the simulated demo before the picture: during the third push (80 % of the span)
VECTOR_SECONDS = 11.0
#: the array's cilium clicked on the map (r2c3)
CHOSEN = 6
#: the read-out's span, N (tip deflections up to about L/2 at the presets' modulus)
SPAN = 6e-5
#: what the simulated cilium does: (force in N, seconds held after the page shows it)
STEPS = ((3e-5, 1.0), (0.0, 0.8), (-2e-5, 0.8), (7.2e-5, 0.6), (0.0, 0.5))
#: the force held while a recording is started and stopped from the page, N
RECORDED = 4e-5


def vectors(kind: str, out: Path, browser_path: str) -> None:
    """The picture of a 3-axis sensor or of the array (see the module docstring)."""
    from playwright.sync_api import sync_playwright

    from magcilia.cli._live import build_live

    setup, sensor = (("force-sensor", "MMC5983MA") if kind == "vector"
                     else (str(ROOT / "examples" / "array.toml"), None))
    live = build_live(source_spec="sim", setup_arg=setup, sensor_name=sensor, sensor_noise=None,
                      quantity="force", span_text=None, calibration_path=None, fluid="water",
                      rate=None, source_rate=None, channel="output", set_reset=None,
                      no_tare=False, tracking=30.0, seed=0, tip_radius=None, modulus=None)
    with tempfile.TemporaryDirectory() as records, sync_playwright() as p, live, \
            DashboardServer(live, port=0, record_dir=records) as server:
        browser = p.chromium.launch(executable_path=browser_path, headless=True,
                                    args=CHROMIUM_ARGS)
        page = browser.new_page(viewport={"width": 1280, "height": 1000})
        page.goto(server.url)
        page.wait_for_function("() => window.magcilia.lastValue !== null && "
                               "window.magcilia.status && window.magcilia.status.tared",
                               timeout=20000)
        if kind == "array":
            x, y = page.evaluate(f"window.magciliaVectors.cellOf({CHOSEN})")
            page.mouse.click(x, y)
        started = live.status.samples / live.rate
        time.sleep(max(0.0, VECTOR_SECONDS - started))
        out.parent.mkdir(parents=True, exist_ok=True)
        page.screenshot(path=str(out))
        browser.close()
    print(f"wrote {out}")


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--kind", choices=sorted(OUTS), default="scalar",
                        help="a single output (default), a 3-axis sensor or the array")
    parser.add_argument("--out", type=Path, default=None, help="the PNG to write")
    args = parser.parse_args()
    browser_path = find_chromium()
    if browser_path is None:
        sys.exit("dashboard_screenshot: no Chromium found (Debian: apt-get install chromium)")
    args.out = args.out or OUTS[args.kind]
    if args.kind != "scalar":
        vectors(args.kind, args.out, browser_path)
        return
    from playwright.sync_api import sync_playwright

    setup = load_setup_arg("force-sensor")
    source = SimulatedSource(setup, Script.constant(0.0, "force"), rate=10000.0, realtime=True,
                             rng=0, readout_noise=2e-5)
    live = LiveReadout(source, mc.Readout(setup, "force", span=(-SPAN, SPAN)), rate=1000,
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
        source.set_value(RECORDED)
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
