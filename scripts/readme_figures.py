"""Draw the README's figures from what the code renders today: Fig. 8 (``docs/images/fig8.png``)
is ``fit.png`` of ``magcilia demo``, the calibration of the bundled synthetic recording from the
paper's initial values (seed 0, as the demo); ``--pareto`` draws ``docs/images/pareto.png``, the
Pareto front of the README's ``magcilia optimise`` example (:func:`pareto`)."""

from __future__ import annotations

import argparse

import magcilia as mc
from magcilia._atomic import save_figure
from magcilia.io.recordings import example_path
from magcilia.report import style
from magcilia.report.calibration import fit_figure

#: the README's optimise example: the force-sensor preset (the paper's Table I cilium and
#: placement with a 0.05 mm tip radius), a minimum detectable force of at most 0.5 uN
PARETO_EXAMPLE = {"min_force": 0.5e-6, "n": 4096, "refine": 64, "rng": 0}


def pareto(out: str = "docs/images/pareto.png", style_name: str = "screen", dpi: int = 110,
           workers: int | None = None) -> mc.DesignOptimum:
    """The Pareto figure of ``magcilia optimise force-sensor --min-force 0.5uN --designs 4096
    --refine 64 --seed 0`` written to ``out``; returns the result."""
    from magcilia.report.optimise import pareto_figure

    setup = mc.Setup.paper(tip_radius=5e-5, n_loops=24, dipoles_per_loop=4, ring="rms")
    result = mc.optimise_design(setup, workers=workers, **PARETO_EXAMPLE)  # type: ignore[arg-type]
    with style.use(style_name):
        save_figure(pareto_figure(result), out, dpi=dpi)
    print(f"wrote {out}")
    print(result.report())
    return result


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__)
    parser.add_argument("--out", default="docs/images/fig8.png")
    parser.add_argument("--style", choices=style.STYLES, default="screen")
    parser.add_argument("--dpi", type=int, default=110, help="resolution of a PNG (keeps the "
                        "committed image small)")
    parser.add_argument("--pareto", action="store_true", help="draw docs/images/pareto.png "
                        "(the optimise example) instead of Fig. 8 (--out defaults to it)")
    args = parser.parse_args()
    if args.pareto:
        out = "docs/images/pareto.png" if args.out == "docs/images/fig8.png" else args.out
        pareto(out, args.style, args.dpi)
        return
    initial = mc.Setup.paper_initial()
    data = mc.read_measurements(example_path(), sensor=initial.sensor)
    result = mc.calibrate(data, initial=initial, rng=0)
    with style.use(args.style):
        save_figure(fit_figure(result), args.out, dpi=args.dpi)
    print(f"wrote {args.out} (RMS residual {result.rms * 1e6:.3g} uV)")


if __name__ == "__main__":
    main()
