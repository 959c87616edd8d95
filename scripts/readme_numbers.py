"""Print the numbers the README quotes that no other script prints, each from the command or call
the README names, so that they can be rerun and pasted after any change to the model, the
modulus, the layout rule or the example recording.

Sections (the README paragraph each one feeds):

* ``calibration`` — "Calibration": ``magcilia demo`` (the Fig. 8 paragraph: RMS, the paper
  model's effective height and x, n × k), ``calibrate --model physical --prior height=3.2:0.15``
  and ``--model both`` on the bundled example, ``--fix height=3.1``;
* ``posterior`` — the same physical fit with ``--posterior`` (60 s of sampling; not in ``all``);
* ``joint`` — "Several experiments": the 1σ coverage of ``tests/calibration/test_joint.py``'s
  100 exact-field datasets, and the σ of height and E of ``test_joint_loads.py``'s force and
  force + flow fits (the tests' own data);
* ``plan`` — the two ``magcilia plan`` commands;
* ``bend`` — ``magcilia bend force-sensor`` at 0.02 mN (the force-scale line), the output change
  of a full 0.04 mN load ("Sensing while actuating"), the small-load tip compliance against the
  closed form L³/(3 E I_b λ) of a linearly tapered rod (an independent reference);
* ``api`` — "Python API": ``layout_check().text()`` of a converged paper setup, the material's
  φ, M_Co and modulus, the ``repr`` of the example's fit;
* ``array`` — "Arrays of cilia": the two ``magcilia array`` commands (the exact body's fields
  are ``scripts/array_example.py``'s);
* ``optimise`` — "Design optimisation": the README's ``magcilia optimise`` command, ``design`` of
  its chosen setup, the count of feasible refined designs and the paper layout's minimum.

Figures are ``scripts/readme_figures.py``'s, the actuation table
``benchmarks/bench_actuation.py``'s, the live views' pictures ``scripts/dashboard_screenshot.py``
and ``scripts/terminal_screenshot.py``'s.

Run: python scripts/readme_numbers.py [--section NAME ...]   (every section but posterior: ~1 min)
"""

from __future__ import annotations

import argparse
import importlib
import math
import sys
import tempfile
from collections.abc import Callable
from pathlib import Path
from types import ModuleType

import numpy as np

import magcilia as mc
from magcilia.cli import main as cli
from magcilia.io import example_path

ROOT = Path(__file__).resolve().parents[1]
EXAMPLES = ROOT / "examples"
PRIOR = ["--prior", "height=3.2:0.15"]


def run(*argv: str) -> None:
    """Run a magcilia command in this process, echoing it first."""
    print(f"$ magcilia {' '.join(argv)}", flush=True)
    status = cli(list(argv))
    if status:
        raise SystemExit(f"readme_numbers: magcilia {argv[0]} exited with {status}")
    print(flush=True)


def calibration(work: Path) -> None:
    example = str(example_path())
    run("demo", "--out", str(work / "demo"))
    run("calibrate", example, "--model", "physical", *PRIOR, "--out", str(work / "physical"))
    run("calibrate", example, "--model", "both", *PRIOR, "--out", str(work / "both"))
    run("calibrate", example, "--fix", "height=3.1", "--out", str(work / "fixed"))


def posterior(work: Path) -> None:
    run("calibrate", str(example_path()), "--model", "physical", *PRIOR, "--posterior",
        "--out", str(work / "posterior"))


def _test_module(name: str) -> ModuleType:
    """A test module of tests/calibration, for its synthetic data (one definition of them)."""
    if str(ROOT / "tests" / "calibration") not in sys.path:
        sys.path.insert(0, str(ROOT / "tests" / "calibration"))
    return importlib.import_module(name)


def joint(_work: Path) -> None:
    t = _test_module("test_joint")
    names = ("height", "base_radius", "x", "y", "z")
    exact = [t._exact(phi) for phi in t.AZIMUTHS]
    truth = t.TRUTH.params()
    sigma = t.HEIGHT_PRIOR["height"][1]
    hits = dict.fromkeys(names, 0)
    runs = 100  # as test_coverage_of_one_sigma_intervals
    for seed in range(runs):
        mu = truth["height"] + np.random.default_rng(seed).normal(0.0, sigma)
        fit = mc.calibrate(t._datasets(exact, 1000 + seed), model="physical",
                           rng=seed, initial=t.INITIAL, priors={"height": (mu, sigma)},
                           layout=t.LAYOUT, starts=16)
        for n in names:
            hits[n] += abs(fit.values[n] - truth[n]) <= fit.stderr[n]
    print(f"1-sigma coverage over {runs} exact-field datasets (2 azimuths x 17 angles, 3-axis, "
          f"height prior): {sum(hits.values())} of {runs * len(names)} intervals "
          f"({sum(hits.values()) / (runs * len(names)):.1%}); per parameter {hits}")

    t = _test_module("test_joint_loads")
    from magcilia.calibration.joint import calibrate_joint

    rng = np.random.default_rng(1)  # as the test's data fixture
    tilts = [t._measurement(t.TRUTH.field(t.ANGLES, azimuth=phi), rng, f"tilt{i}", phi,
                            t.ANGLES)
             for i, phi in enumerate((0.0, math.pi / 2))]
    force = t._measurement(t.TRUTH.field(mc.bend_sweep(t.TRUTH, forces=t.FORCES)), rng,
                           "force", forces=t.FORCES)
    flow = t._measurement(t.TRUTH.field(mc.bend_sweep(
        t.TRUTH, speeds=t.SPEEDS, flow=mc.Flow.uniform(0.3, mc.WATER))), rng, "flow",
        speeds=t.SPEEDS, metadata={"fluid": "water"})
    for label, data in (("tilts + force", [*tilts, force]),
                        ("tilts + force + flow", [*tilts, force, flow])):
        r = calibrate_joint(data, t.INITIAL, rng=0, layout=t.LAYOUT)
        print(f"{label}, no prior (E true {t.E_TRUE / 1e6:g} MPa): height "
              f"{r.values['height'] * 1e3:.3f} mm ± {r.stderr['height'] / r.values['height']:.0%}"
              f", E {r.values['youngs_modulus'] / 1e6:.3f} MPa ± "
              f"{r.stderr['youngs_modulus'] / r.values['youngs_modulus']:.0%}")
    print()


def plan(_work: Path) -> None:
    run("plan", "--setup", "paper", "--budget", "33", "--prior", "height=3.26:0.1", "--noise",
        "0.05")
    run("plan", "--setup", "force-sensor", "--budget", "24", "--measure", "field", "--noise",
        "10nT", "--azimuths", "0,45,90")


def bend(_work: Path) -> None:
    run("bend", "--setup", "force-sensor", "--tip-force", "0.02mN")
    setup = mc.load_setup(EXAMPLES / "force-sensor.toml").resolve_layout()
    rest, full = setup.output(mc.bend_sweep(setup, forces=[0.0, 4e-5]))
    print(f"a full 0.04 mN load moves the force-sensor output by {(rest - full) * 1e3:.3f} mV "
          f"(2 G along x are {2e-4 * setup.sensor.scale * 1e3:.3g} mV)")
    # independent reference: a linearly tapered rod's small-load tip compliance is L³/(3 E I_b λ)
    c = setup.cilium
    lam = c.tip_radius / c.base_radius
    closed = c.height**3 / (3.0 * setup.youngs_modulus * math.pi * c.base_radius**4 / 4.0 * lam)
    load = 1e-9  # N: a deflection of a few µm, linear
    got = mc.bend(setup, force=load).tip[0] / load
    print(f"small-load tip compliance {got:.6g} m/N; closed form L^3/(3 E I_b lambda) "
          f"{closed:.6g} m/N (relative difference {got / closed - 1:.1e})")
    print()


def api(_work: Path) -> None:
    print("Setup.paper(layout='converged').layout_check().text():",
          repr(mc.Setup.paper(layout="converged").layout_check().text()))
    m = mc.Setup.paper().material
    print(f"material: phi {m.volume_fraction:.4f}, M_Co {m.cobalt_magnetization:.4g} A/m, "
          f"composite modulus {m.composite_modulus / 1e6:.3f} MPa ± "
          f"{m.composite_modulus_uncertainty:.0%}")
    fit = mc.calibrate(mc.read_measurements(example_path()), initial=mc.Setup.paper_initial(),
                       rng=0)
    print("calibrate(example, initial=paper_initial(), rng=0):", repr(fit))
    print()


def array(work: Path) -> None:
    example = str(EXAMPLES / "array.toml")
    run("array", "--setup", example, "--random", "50", "--seed", "1", "--csv",
        str(work / "forward.csv"))
    run("array", "--setup", example, "--random", "1", "--metrics", "--pitches", "2.5:6:0.5mm")


def optimise(work: Path) -> None:
    best = work / "best.toml"
    run("optimise", "--setup", "force-sensor", "--min-force", "0.1uN", "--designs", "4096",
        "--refine", "64", "--seed", "0", "--setup-out", str(best))
    run("design", "--setup", str(best))
    result = mc.optimise_design(mc.load_setup(EXAMPLES / "force-sensor.toml"), "force-range",
                                min_force=1e-7, n=4096, refine=64, rng=0)
    feasible = [d for d in result.designs if d.rank >= 0]
    print(f"refined {len(result.designs)}, feasible {len(feasible)}, of which the range was "
          f"reached {sum(d.reached for d in feasible)}; the chosen design's layout: "
          f"{result.best_setup.layout_check().text()}")
    paper = mc.design_metrics(mc.Setup.paper(tip_radius=5e-5))
    print(f"the paper's n = 2, k = 5 (tip radius 0.05 mm): minimum detectable force "
          f"{paper.force.minimum * 1e6:.3g} uN")
    print()


SECTIONS: dict[str, Callable[[Path], None]] = {
    "calibration": calibration, "posterior": posterior, "joint": joint, "plan": plan,
    "bend": bend, "api": api, "array": array, "optimise": optimise}
#: sections run by default (the posterior samples for a minute)
DEFAULT = tuple(name for name in SECTIONS if name != "posterior")


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--section", action="append", choices=tuple(SECTIONS),
                        help=f"repeatable; default: {', '.join(DEFAULT)}")
    args = parser.parse_args()
    with tempfile.TemporaryDirectory(prefix="readme-numbers-") as tmp:
        for name in args.section or DEFAULT:
            print(f"=== {name}", flush=True)
            SECTIONS[name](Path(tmp))


if __name__ == "__main__":
    main()
