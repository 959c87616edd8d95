"""The README's robust-design table: the paper's placement, today's optimum (``force-range``) and
the robust optimum (``robust``) on calibration-free error, range and minimum detectable force,
each error confirmed by an independent Monte Carlo, and each tolerance's error alone at the
robust optimum (which tolerances make calibration unavoidable).

The optimiser's metric (:mod:`magcilia.design.robust`) draws its devices once and bends them all
in one batched solve. The independent check shares none of that: fresh draws (another seed and
sample count, drawn here with NumPy), each device built as a perturbed ``Setup`` with
``Setup.replace``, bent by ``mc.bend_sweep`` and its output ``Setup.output``, read by the nominal
design's public ``mc.Readout`` (span the design's range, ``edge="clip"``, tared at rest with
``Readout.tare``; a reading beyond the span counted at the span's end).

Run: python scripts/robust_table.py [--quick]
"""

from __future__ import annotations

import argparse
import math
import os
import platform
import time

import numpy as np

import magcilia as mc
from magcilia.design.robust import (
    TOLERANCES,
    RobustSpec,
    Tolerances,
    calibration_free_error,
    tolerance_shares,
)

#: the independent check's devices and seed (the optimiser's are 64 from the search's rng)
CHECK_DEVICES = 200
CHECK_SEED = 20261127
#: the tolerances a design can act on: the material's modulus and magnetization, shared by a
#: batch of composite, set to 0
GEOMETRY = Tolerances(magnetization=0.0, modulus=0.0)
#: bounds beyond the registry's calibration bounds (the defaults): a taller hair, a deeper element
WIDER = {"height": (2e-3, 6e-3), "z": (0.0, 2e-3)}


def independent_error(setup: mc.Setup, span: float, tol: Tolerances, devices: int,
                      seed: int, points: int = 17) -> float:
    """RMS of ``(F_read − F) / span`` over fresh devices built as perturbed setups and read by
    the nominal setup's public Readout (module docstring)."""
    gen = np.random.default_rng(seed)
    z = np.clip(gen.standard_normal((devices, 7)), -3.0, 3.0)
    forces = np.linspace(0.0, span, points)
    readout = mc.Readout(setup, "force", span=(0.0, span), edge="clip")
    errors = []
    for row in z:
        device = setup.replace(
            height=setup.cilium.height * math.exp(tol.height * row[0]),
            base_radius=setup.cilium.base_radius * math.exp(tol.base_radius * row[1]),
            x=setup.value("x") + tol.placement * row[2],
            y=setup.value("y") + tol.placement * row[3],
            z=setup.value("z") + tol.placement * row[4],
            youngs_modulus=setup.youngs_modulus * math.exp(tol.modulus * row[5]),
            magnetization_scale=setup.value("magnetization_scale")
            * math.exp(tol.magnetization * row[6]))
        volts = device.output(mc.bend_sweep(device, forces=forces))
        result = readout.tare(volts[0] + np.array([-1e-12, 1e-12])).read(volts)
        value = np.array(result.value, dtype=np.float64)
        blank = np.isnan(value)
        value[blank & ((result.flags & mc.Flag.ABOVE_SPAN) != 0)] = span
        value[blank & ((result.flags & mc.Flag.BELOW_SPAN) != 0)] = 0.0
        errors.append((value - forces) / span)
    return float(np.sqrt(np.nanmean(np.square(errors))))


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__)
    parser.add_argument("--quick", action="store_true", help="small searches (a smoke run)")
    args = parser.parse_args()
    n, refine, polish, samples, check = (256, 16, 1, 16, 24) if args.quick else \
        (1024, 64, 3, 64, CHECK_DEVICES)
    start = time.perf_counter()
    paper = mc.Setup.paper(tip_radius=5e-5, layout="converged").resolve_layout()
    paper_force = mc.design_metrics(paper).force
    today = mc.optimise_design(paper, "force-range", min_force=1e-7, n=4096, refine=64, rng=0)
    rows = [("paper's placement", paper, paper_force.range, paper_force.minimum,
             paper_force.reached),
            ("today's optimum (force-range)", today.best_setup, today.best.range,
             today.best.minimum, today.best.reached)]
    robust = {}
    # the robust optima resolve at least half as finely as the paper's cilium (min_force twice
    # its own) and reach at least its force range (a range constraint; the last row without)
    same_range = {"range": paper_force.range}
    for label, tol, bounds, constraints in (
            ("robust optimum (all tolerances)", Tolerances(), None, same_range),
            ("robust optimum (placement, size)", GEOMETRY, None, same_range),
            ("robust optimum (placement, size; height ≤ 6 mm, z ≤ 2 mm)", GEOMETRY, WIDER,
             same_range),
            ("robust optimum (all tolerances; no range constraint)", Tolerances(), None, None)):
        found = mc.optimise_design(paper, "robust", min_force=2.0 * paper_force.minimum, n=n,
                                   refine=refine, polish=polish, rng=0, samples=samples,
                                   tolerances=tol, bounds=bounds, constraints=constraints)
        robust[label] = found
        rows.append((label, found.best_setup, found.best.range, found.best.minimum,
                     found.best.reached))
    spec = RobustSpec(samples=256, seed=1)
    print(f"machine: {platform.machine()} {platform.processor() or ''} "
          f"{os.cpu_count()} cores; load {os.getloadavg()[0]:.1f}; "
          f"searches: {n} screened, {refine} refined, {polish} polish rounds, "
          f"{samples} devices each; the table's errors: 256 devices (seed 1), tared at rest; "
          f"independent check: {check} fresh devices (seed {CHECK_SEED}) through Readout")
    print("| design | range (mN) | min. force (µN) | error, all tolerances | untared | "
          "independent | error, placement and size only | independent |")
    print("|---|---|---|---|---|---|---|---|")
    results = {}
    for label, setup, span, minimum, reached in rows:
        full = calibration_free_error(setup, span, spec)
        raw = calibration_free_error(setup, span, RobustSpec(samples=256, seed=1, tare=False))
        geo = calibration_free_error(setup, span, spec.with_tolerances(GEOMETRY))
        ind_full = independent_error(setup, span, Tolerances(), check, CHECK_SEED)
        ind_geo = independent_error(setup, span, GEOMETRY, check, CHECK_SEED)
        results[label] = (full.rms, geo.rms, minimum)
        print(f"| {label} | {'' if reached else '≥ '}{span * 1e3:.3g} | {minimum * 1e6:.3g} | "
              f"{full.rms * 100:.3g} % (p95 {full.p95 * 100:.3g} %) | {raw.rms * 100:.3g} % | "
              f"{ind_full * 100:.3g} % | {geo.rms * 100:.3g} % (p95 {geo.p95 * 100:.3g} %) | "
              f"{ind_geo * 100:.3g} % |")
    for label, found in robust.items():
        p = found.best.params
        print(f"{label}: " + ", ".join(
            f"{k} {p[k] * 1e3:.4g} mm" for k in ("height", "base_radius", "tip_radius", "x",
                                                 "y", "z")))
    ref_full, ref_geo, ref_min = results["paper's placement"]
    for label in robust:
        full, geo, minimum = results[label]
        print(f"{label} against the paper's placement: all tolerances {ref_full / full:.2f}× "
              f"lower, placement and size only {ref_geo / geo:.2f}× lower, at "
              f"{minimum / ref_min:.2f}× its minimum detectable force")
    best = robust["robust optimum (all tolerances)"]
    for label, setup, span in (("paper's placement", paper, paper_force.range),
                               ("robust optimum (all tolerances)", best.best_setup,
                                best.best.range)):
        shares = tolerance_shares(setup, span, spec)
        print(f"each tolerance alone at the {label}: " + ", ".join(
            f"{name} {shares[name].rms * 100:.3g} %" for name in (*TOLERANCES, "all")))
    print(f"({time.perf_counter() - start:.0f} s)")


if __name__ == "__main__":
    main()
