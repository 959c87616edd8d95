"""The dashboard of force vectors in a headless Chromium: a 3-axis sensor (the value is |F|, the
direction and components are shown, the polar view is drawn) and an array (the map of the cilia,
a click chooses the cilium traced). The waits are guards against a hang, not timings; the
README's pictures come from ``scripts/dashboard_screenshot.py``.
"""

from __future__ import annotations

import functools
import math
import time
from collections.abc import Iterator
from pathlib import Path
from typing import Any

import numpy as np
import pytest

import magcilia as mc
from magcilia.acquire import LoadScript, SimulatedFieldSource, single_cilium
from magcilia.device.magnetometer import Magnetometer
from magcilia.io.array_file import load_array
from magcilia.live import LiveReadout
from magcilia.live.dashboard import DashboardServer

ROOT = Path(__file__).resolve().parents[2]
HANG = 20_000  # ms any single wait may take before a test calls it a hang
PART = Magnetometer.preset("MMC5983MA")
SETUP = mc.Setup.paper(tip_radius=5e-5, youngs_modulus=2e6)
LOAD = (2e-5, -1.5e-5)  # N


@pytest.fixture
def page(browser: Any) -> Iterator[Any]:
    page = browser.new_page(viewport={"width": 1280, "height": 1000})
    errors: list[str] = []
    page.on("console", lambda m: errors.append(m.text) if m.type == "error" else None)
    page.on("pageerror", lambda e: errors.append(str(e)))
    page.errors = errors
    try:
        yield page
    finally:
        page.close()


def _painted(page: Any, canvas: str) -> int:
    """Pixels of ``canvas`` that are not blank."""
    return int(page.evaluate(f"""() => {{
        const c = document.getElementById("{canvas}");
        const d = c.getContext("2d").getImageData(0, 0, c.width, c.height).data;
        let n = 0;
        for (let i = 3; i < d.length; i += 4) if (d[i] > 0) n++;
        return n; }}"""))


def test_the_page_of_a_3_axis_sensor_shows_magnitude_direction_and_a_polar_view(
        page: Any, tmp_path: Path) -> None:
    readout = mc.BiaxialReadout(SETUP, PART, span=4e-5, table_size=(33, 64))
    script = LoadScript.from_steps([(0.0, [0.0, 0.0]), (2.0, LOAD)])
    source = SimulatedFieldSource(PART, single_cilium(SETUP, PART), script, realtime=True,
                                  rng=0)
    live = LiveReadout(source, readout, rate=50, tare_at_start=True)
    with live, DashboardServer(live, port=0, record_dir=tmp_path) as server:
        page.goto(server.url)
        page.wait_for_function("() => window.magcilia.status && window.magcilia.status.tared "
                               "&& window.magcilia.lastValue !== null", timeout=HANG)
        assert page.evaluate("window.magcilia.info.kind") == "vector"
        target = math.hypot(*LOAD) * 1e3  # mN
        page.wait_for_function(f"() => Math.abs(window.magcilia.lastValue - {target}) < "
                               f"{0.05 * target}", timeout=HANG)
        direction = page.evaluate("window.magcilia.lastDirection")
        assert math.degrees(direction) == pytest.approx(math.degrees(math.atan2(LOAD[1], LOAD[0])),
                                                        abs=3.0)
        assert "toward" in page.inner_text("#direction") and "Fx" in page.inner_text("#direction")
        assert page.inner_text("#badges") == "OK"
        assert "3 channels" in page.inner_text("#tared")
        assert _painted(page, "polar") > 1000
        assert page.is_hidden("#map-card")
        tares = sum(e.kind == "tare" for e in live.events)
        page.click("#tare")
        deadline = time.monotonic() + HANG / 1e3
        while sum(e.kind == "tare" for e in live.events) == tares and \
                time.monotonic() < deadline:
            time.sleep(0.02)
        assert sum(e.kind == "tare" for e in live.events) == tares + 1
        page.screenshot(path=str(tmp_path / "vector.png"))
    assert not page.errors, page.errors


def test_the_page_of_an_array_maps_the_cilia_and_follows_the_one_clicked(
        page: Any, tmp_path: Path) -> None:
    array = load_array(ROOT / "examples" / "array.toml")
    readout = mc.ArrayReadout(array, 2e-5)
    loads = np.zeros((len(array), 2))
    loads[6] = [1.2e-5, 0.0]  # r2c3 pushed toward +x
    script = LoadScript.from_steps([(0.0, np.zeros_like(loads)), (1.5, loads)])
    source = SimulatedFieldSource(array.sensors, functools.partial(mc.field_for_loads, array),
                                  script, realtime=True, rng=0)
    live = LiveReadout(source, readout, rate=50, tare_at_start=True)
    with live, DashboardServer(live, port=0, record_dir=tmp_path) as server:
        page.goto(server.url)
        page.wait_for_function("() => window.magcilia.status && window.magcilia.status.tared "
                               "&& window.magcilia.vectors && "
                               "window.magcilia.vectors.every(v => v !== null)", timeout=HANG)
        assert page.evaluate("window.magcilia.info.cilia") == list(array.names)
        assert page.is_visible("#map-card") and _painted(page, "map") > 1000
        x, y = page.evaluate("window.magciliaVectors.cellOf(6)")
        page.mouse.click(x, y)
        page.wait_for_function("() => window.magcilia.chosen === 6", timeout=HANG)
        assert page.inner_text("#chosen") == f"cilium {array.names[6]}"
        assert array.names[6] in page.inner_text("#value-title")
        page.wait_for_function("() => Math.abs(window.magcilia.lastValue - 0.012) < 0.002",
                               timeout=HANG)
        vectors = np.array(page.evaluate("window.magcilia.vectors"))
        assert vectors.shape == (16, 2)
        assert vectors[6, 0] == pytest.approx(0.012, abs=0.002)
        others = np.delete(np.hypot(vectors[:, 0], vectors[:, 1]), 6)
        assert np.all(others < 0.002)  # the others at rest (crosstalk is in the inverse)
        page.screenshot(path=str(tmp_path / "array.png"))
    assert not page.errors, page.errors
