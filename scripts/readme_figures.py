"""Draw the README's figures from what the code renders today: Fig. 8 (``docs/images/fig8.png``)
is ``fit.png`` of ``magcilia demo``, the calibration of the bundled synthetic recording from the
paper's initial values (seed 0, as the demo); ``--figure array`` draws ``docs/images/array.png``,
the map and crosstalk of ``examples/array.toml`` under the random loads of
``magcilia array examples/array.toml --random 1 --seed 0``; ``--figure biaxial`` draws
``docs/images/biaxial.png``, the force-vector read-out of the ``force-sensor`` example with a
3-axis sensor at the element, against the truth; ``--figure bend-actuated`` draws
``docs/images/bend-actuated.png`` with the README's ``magcilia bend ... --actuation-field ...
--plot`` command (:data:`BEND_ACTUATED`); ``--figure pareto`` draws ``docs/images/pareto.png``,
the Pareto front of the README's ``magcilia optimise`` example (:func:`pareto`)."""

from __future__ import annotations

import argparse

import magcilia as mc
from magcilia._atomic import save_figure
from magcilia.io.recordings import example_path
from magcilia.report import style
from magcilia.report.calibration import fit_figure

#: the README's optimise example: the force-sensor preset (the paper's Table I cilium and
#: placement with a 0.05 mm tip radius), a minimum detectable force of at most 0.1 uN (finer
#: than the preset's own 0.12 uN at the presets' 0.669 MPa modulus)
PARETO_EXAMPLE = {"min_force": 1e-7, "n": 4096, "refine": 64, "rng": 0}
#: the README's figure of a bend under a force and an actuation field: the command, as typed
BEND_ACTUATED = ("bend", "--setup", "force-sensor", "--force-vector", "0.02,-0.016,0",
                 "--actuation-field", "0.4,-0.2,0")


def pareto(out: str = "docs/images/pareto.png", style_name: str = "screen", dpi: int = 110,
           workers: int | None = None) -> mc.DesignOptimum:
    """The Pareto figure of ``magcilia optimise force-sensor --min-force 0.1uN --designs 4096
    --refine 64 --seed 0`` written to ``out``; returns the result."""
    from magcilia.report.optimise import pareto_figure

    setup = mc.Setup.paper(tip_radius=5e-5, layout="converged")  # the force-sensor preset
    result = mc.optimise_design(setup, workers=workers, **PARETO_EXAMPLE)  # type: ignore[arg-type]
    with style.use(style_name):
        save_figure(pareto_figure(result), out, dpi=dpi)
    print(f"wrote {out}")
    print(result.report())
    return result


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


def biaxial_png(out: str, kind: str = "screen", dpi: int = 110) -> str:
    """``docs/images/biaxial.png``: the force-vector read-out of the ``force-sensor`` example with
    an MMC5983MA at the element, 72 seeded noisy readings (24 directions at 0.3, 0.6 and 0.9 of
    a 0.04 mN span: tip deflections up to about L/2 with the presets' 0.669 MPa modulus)
    against the truth, the noise's 2σ ellipses drawn 10× larger
    (:func:`magcilia.report.biaxial.force_vector_figure`); the pulls use the noise's σ (the
    force scale's is systematic: readings made with the same modulus cannot show it)."""
    from pathlib import Path

    import numpy as np

    from magcilia.report.biaxial import force_vector_figure, noise_sigmas

    setup = mc.load_setup(Path(__file__).resolve().parents[1] / "examples" / "force-sensor.toml")
    sensor = mc.Magnetometer.preset("MMC5983MA")
    span = 4e-5
    readout = mc.BiaxialReadout(setup, sensor, span)
    phi = np.radians(np.arange(24) * 15.0)
    truth = np.concatenate([f * span * np.stack([np.cos(phi), np.sin(phi)], axis=1)
                            for f in (0.3, 0.6, 0.9)])
    fields = np.stack([setup.field(mc.bend(setup, force=(fx, fy, 0.0)))[0]
                       for fx, fy in truth])
    result = readout.read(sensor.measure(fields, rng=0))
    with style.use(kind):
        save_figure(force_vector_figure(truth, result, ellipse_scale=10.0), out, dpi=dpi)
    noise = noise_sigmas(result)[0]
    pull = (result.magnitude - np.hypot(*truth.T)) / noise
    return (f"wrote {out} (median noise sigma |F| {np.median(noise) * 1e3:.3g} mN, pulls sd "
            f"{np.std(pull):.3g}, {int(np.sum(result.flags != 0))} flagged; median sigma |F| "
            f"with the force scale {np.median(result.sigma_magnitude) * 1e3:.3g} mN: "
            f"{result.scale_note})")


def bend_actuated_png(out: str) -> int:
    """``docs/images/bend-actuated.png``: what ``magcilia bend force-sensor --force-vector
    0.02,-0.016,0 --actuation-field 0.4,-0.2,0 --plot OUT`` prints and draws (the command's own
    figure and style); returns its exit status."""
    from magcilia.cli import main as cli

    return cli([*BEND_ACTUATED, "--plot", out])


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__)
    parser.add_argument("--figure", choices=("fig8", "array", "biaxial", "bend-actuated",
                                             "pareto"),
                        default="fig8")
    parser.add_argument("--out", default=None, help="default docs/images/FIGURE.png")
    parser.add_argument("--style", choices=style.STYLES, default="screen")
    parser.add_argument("--dpi", type=int, default=110, help="resolution of a PNG (keeps the "
                        "committed image small)")
    args = parser.parse_args()
    if args.figure == "pareto":
        pareto(args.out or "docs/images/pareto.png", args.style, args.dpi)
        return
    if args.figure == "bend-actuated":
        raise SystemExit(bend_actuated_png(args.out or "docs/images/bend-actuated.png"))
    if args.figure in ("array", "biaxial"):
        draw = array_png if args.figure == "array" else biaxial_png
        print(draw(args.out or f"docs/images/{args.figure}.png", args.style, args.dpi))
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
