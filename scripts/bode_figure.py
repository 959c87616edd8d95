"""Draw the README's Bode plot, ``docs/images/bode.png``: the force-sensor cilium's response to a
tip force (examples/force-sensor.toml, E 0.669 MPa) in air, water and glycerol, about rest, 1 Hz
to 5 kHz (:func:`magcilia.frequency_response`), and print the figures of merit it shows.

    python scripts/bode_figure.py [--out docs/images/bode.png] [--style screen|paper]
"""

from __future__ import annotations

import argparse
from pathlib import Path

import numpy as np

import magcilia as mc
from magcilia._atomic import save_figure
from magcilia.report import style
from magcilia.report.dynamics import bode_figure

ROOT = Path(__file__).resolve().parents[1]


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--out", default=str(ROOT / "docs" / "images" / "bode.png"))
    parser.add_argument("--style", default="screen", choices=("screen", "paper"))
    args = parser.parse_args()
    setup = mc.load_setup(ROOT / "examples" / "force-sensor.toml")
    freq = np.geomspace(1.0, 5000.0, 400)
    responses = [mc.frequency_response(setup, freq, fluid=f) for f in ("air", "water", "glycerol")]
    for r in responses:
        print(r.report())
    with style.use(args.style):
        save_figure(bode_figure(responses), args.out, dpi=style.dpi())
    print(f"wrote {args.out}")


if __name__ == "__main__":
    main()
