"""Draw the terminal view of ``magcilia live`` on the simulated sensor into
docs/images/terminal.svg (the README's picture), as a terminal 100 columns wide shows it.

Run: python scripts/terminal_screenshot.py  (needs the ``live`` extra: rich)
"""

from __future__ import annotations

import time
from pathlib import Path

from rich.console import Console

from magcilia.cli._live import build_live
from magcilia.live.terminal import render

OUT = Path(__file__).resolve().parents[1] / "docs" / "images" / "terminal.svg"


def main() -> None:
    live = build_live(source_spec="sim", setup_arg="force-sensor", quantity="force",
                      span_text=None, calibration_path=None, fluid="water", rate=1000.0,
                      source_rate=10000.0, channel="output", set_reset=None, no_tare=False,
                      tracking=30.0, seed=0, tip_radius=None, modulus=None)
    with live:
        time.sleep(8.5)  # rest, a push of 50 %, rest, a pull of 30 %, rest, 80 %
        samples = live.history.last(10.0, live.rate)
        view = render(live.status, samples, live.limits(), live.events,
                      source=live.source.name, width=80)
    console = Console(record=True, width=100, force_terminal=True, color_system="truecolor")
    console.print(view)
    OUT.parent.mkdir(parents=True, exist_ok=True)
    console.save_svg(str(OUT), title="magcilia live")
    print(f"wrote {OUT}")


if __name__ == "__main__":
    main()
