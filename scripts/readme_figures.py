"""Draw the README's figures from what the code renders today: Fig. 8 (``docs/images/fig8.png``)
is ``fit.png`` of ``magcilia demo``, the calibration of the bundled synthetic recording from the
paper's initial values (seed 0, as the demo)."""

from __future__ import annotations

import argparse

import magcilia as mc
from magcilia._atomic import save_figure
from magcilia.io.recordings import example_path
from magcilia.report import style
from magcilia.report.calibration import fit_figure


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__)
    parser.add_argument("--out", default="docs/images/fig8.png")
    parser.add_argument("--style", choices=style.STYLES, default="screen")
    parser.add_argument("--dpi", type=int, default=110, help="resolution of a PNG (keeps the "
                        "committed image small)")
    args = parser.parse_args()
    initial = mc.Setup.paper_initial()
    data = mc.read_measurements(example_path(), sensor=initial.sensor)
    result = mc.calibrate(data, initial=initial, rng=0)
    with style.use(args.style):
        save_figure(fit_figure(result), args.out, dpi=args.dpi)
    print(f"wrote {args.out} (RMS residual {result.rms * 1e6:.3g} uV)")


if __name__ == "__main__":
    main()
