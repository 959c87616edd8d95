"""Draw the README's figures from what the code renders today: Fig. 8 (``docs/images/fig8.png``)
is ``fit.png`` of ``magcilia demo``, the calibration of the bundled synthetic recording from the
paper's initial values (seed 0, as the demo); ``--figure array`` draws ``docs/images/array.png``,
the map and crosstalk of ``examples/array.toml`` under the random loads of
``magcilia array examples/array.toml --random 1 --seed 0``."""

from __future__ import annotations

import argparse

import magcilia as mc
from magcilia._atomic import save_figure
from magcilia.io.recordings import example_path
from magcilia.report import style
from magcilia.report.calibration import fit_figure


def array_png(out: str, kind: str = "screen", dpi: int = 110) -> str:
    """``docs/images/array.png``: the 4 × 4 array of ``examples/array.toml`` under random loads
    (seed 0, as ``magcilia array examples/array.toml --random 1 --seed 0``), the field change at
    its sensors, and its crosstalk (:func:`magcilia.report.array.array_figure`)."""
    from pathlib import Path

    import numpy as np

    from magcilia.cli.array import DEFAULT_SPAN, random_loads
    from magcilia.report.array import array_figure

    array = mc.load_array(Path(__file__).resolve().parents[1] / "examples" / "array.toml")
    forces = random_loads(1, len(array), DEFAULT_SPAN, np.random.default_rng(0))[0]
    readout = mc.ArrayReadout(array, DEFAULT_SPAN)
    change = mc.field_for_loads(array, forces) - array.field()
    crosstalk = readout.crosstalk()
    with style.use(kind):
        save_figure(array_figure(array, crosstalk, change, forces), out, dpi=dpi)
    return (f"wrote {out} (crosstalk ratio median {float(np.median(crosstalk.ratio)):.3g}, "
            f"largest {float(crosstalk.ratio.max()):.3g})")


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__)
    parser.add_argument("--figure", choices=("fig8", "array"), default="fig8")
    parser.add_argument("--out", default=None, help="default docs/images/FIGURE.png")
    parser.add_argument("--style", choices=style.STYLES, default="screen")
    parser.add_argument("--dpi", type=int, default=110, help="resolution of a PNG (keeps the "
                        "committed image small)")
    args = parser.parse_args()
    if args.figure == "array":
        print(array_png(args.out or "docs/images/array.png", args.style, args.dpi))
        return
    args.out = args.out or "docs/images/fig8.png"
    initial = mc.Setup.paper_initial()
    data = mc.read_measurements(example_path(), sensor=initial.sensor)
    result = mc.calibrate(data, initial=initial, rng=0)
    with style.use(args.style):
        save_figure(fit_figure(result), args.out, dpi=args.dpi)
    print(f"wrote {args.out} (RMS residual {result.rms * 1e6:.3g} uV)")


if __name__ == "__main__":
    main()
