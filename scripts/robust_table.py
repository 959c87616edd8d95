"""The README's robust-design table: the paper's placement, today's optimum (``force-range``) and
the robust optimum (``robust``) on calibration-free error, range and minimum detectable force,
each error confirmed by an independent Monte Carlo, and each tolerance's error alone at the
robust optimum (which tolerances make calibration unavoidable); then the same designs (and the
robust optimum searched with it) read after a start-up coil self-test
(:mod:`magcilia.design.self_test`), its independent check through the public ``Recalibrator``
and ``Readout``, and each tolerance's share with it.

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
from dataclasses import replace

import numpy as np

import magcilia as mc
from magcilia.design.robust import (
    TOLERANCES,
    RobustSpec,
    Tolerances,
    calibration_free_error,
    tolerance_shares,
)
from magcilia.design.self_test import REACH, CoilSelfTest

#: the independent check's devices and seed (the optimiser's are 64 from the search's rng)
CHECK_DEVICES = 200
CHECK_SEED = 20261127
#: the tolerances a design can act on: the material's modulus and magnetization, shared by a
#: batch of composite, set to 0
GEOMETRY = Tolerances(magnetization=0.0, modulus=0.0)
#: bounds beyond the registry's calibration bounds (the defaults): a taller hair, a deeper element
WIDER = {"height": (2e-3, 6e-3), "z": (0.0, 2e-3)}
#: the start-up self-test of the second table (the defaults: ±3 G on the HMC1021Z, 0.25 s per
#: window, 1.75 s in all) and the row of the design searched with it
SELF_TEST = CoilSelfTest()
SELF_TESTED = "robust optimum read after the self-test (all tolerances)"
SELF_TESTED_WIDER = ("robust optimum read after the self-test (all tolerances; height ≤ 6 mm, "
                     "z ≤ 2 mm)")


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
        device = _device(setup, tol, row)
        volts = device.output(mc.bend_sweep(device, forces=forces))
        result = readout.tare(volts[0] + np.array([-1e-12, 1e-12])).read(volts)
        value = np.array(result.value, dtype=np.float64)
        blank = np.isnan(value)
        value[blank & ((result.flags & mc.Flag.ABOVE_SPAN) != 0)] = span
        value[blank & ((result.flags & mc.Flag.BELOW_SPAN) != 0)] = 0.0
        errors.append((value - forces) / span)
    return float(np.sqrt(np.nanmean(np.square(errors))))


def _device(setup: mc.Setup, tol: Tolerances, row: np.ndarray) -> mc.Setup:
    """A device drawn from ``tol`` by the standard-normal ``row`` (7,): a perturbed Setup."""
    return setup.replace(
        height=setup.cilium.height * math.exp(tol.height * row[0]),
        base_radius=setup.cilium.base_radius * math.exp(tol.base_radius * row[1]),
        x=setup.value("x") + tol.placement * row[2],
        y=setup.value("y") + tol.placement * row[3],
        z=setup.value("z") + tol.placement * row[4],
        youngs_modulus=setup.youngs_modulus * math.exp(tol.modulus * row[5]),
        magnetization_scale=setup.value("magnetization_scale")
        * math.exp(tol.magnetization * row[6]))


def independent_self_test_error(setup: mc.Setup, span: float, tol: Tolerances,
                                test: CoilSelfTest, devices: int, seed: int,
                                points: int = 17) -> float:
    """RMS of ``(F_read − F) / span`` over fresh devices (perturbed setups), each read after its
    own coil self-test by the public path: its windows from ``mc.bend(..., actuation=
    mc.Actuation.uniform(B))`` and ``Setup.field`` plus the sensor's noise (fresh draws),
    fitted by the public ``mc.Recalibrator`` (nothing held; Gauss–Newton over the six windows),
    then read by the nominal design's ``Readout`` through ``Recalibration.read`` (tared at the
    corrected rest level; the read-out's span reaching the device's estimated range, a reading
    beyond it at its end; a fit whose s, m or k is beyond 1/REACH .. REACH has failed: the
    device is read with the nominal model, the metric's rule)."""
    from magcilia.readout.recalibration_windows import PulseWindow, RestWindow, StrapWindow

    gen = np.random.default_rng(seed)
    z = np.clip(gen.standard_normal((devices, 7)), -3.0, 3.0)
    forces = np.linspace(0.0, span, points)
    recalibrator = mc.Recalibrator(setup, hold=())
    sigma, b = test.window_noise(setup), test.pulse(setup)
    pulses = b * np.array([[1.0, 0, 0], [-1.0, 0, 0], [0, 1.0, 0], [0, -1.0, 0]])
    readouts: dict[float, mc.Readout] = {}
    errors = []
    for row in z:
        device = _device(setup, tol, row)

        def output(field: np.ndarray, device: mc.Setup = device) -> float:
            shape = mc.bend(device, 0.0, actuation=mc.Actuation.uniform(field)
                            if np.any(field) else None)
            return float(device.sensor.voltage(np.ravel(device.field(shape))[0] + field[0]))

        noise = sigma * gen.standard_normal(7)
        offset = float(device.sensor.offset)
        rest = output(np.zeros(3)) + noise[2]
        windows: list[PulseWindow | RestWindow | StrapWindow] = [
            StrapWindow(offset + noise[0], sigma, offset + noise[1], sigma),
            RestWindow(rest, sigma)]
        for j, field in enumerate(pulses):
            windows.append(PulseWindow((field[0], field[1], field[2]), rest, sigma,
                                       output(field) + noise[3 + j], sigma))
        fit = recalibrator.update(windows)
        scales = [fit.values[name] for name in ("sensitivity", "magnetization", "stiffness")]
        if not all(1.0 / REACH <= x <= REACH for x in scales):  # a failed self-test: nominal
            fit = recalibrator.start()
        k = fit.values["stiffness"]
        reach = round(min(max(1.0, 1.02 / k), 4.0), 1) if k > 0 else 1.0
        if reach not in readouts:
            readouts[reach] = mc.Readout(setup, "force", span=(0.0, span * reach), edge="clip")
        volts = device.output(mc.bend_sweep(device, forces=forces))
        tared = readouts[reach].tare(fit.correct(volts[0] + np.array([-1e-12, 1e-12])))
        value, _ = fit.read(tared, volts)
        result = tared.read(fit.correct(volts))
        value = np.array(value, dtype=np.float64)
        blank = np.isnan(value)
        value[blank & ((result.flags & mc.Flag.ABOVE_SPAN) != 0)] = k * span * reach
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
    # the design best read after the self-test: the same search, each device self-tested
    for label, bounds in ((SELF_TESTED, None), (SELF_TESTED_WIDER, WIDER)):
        found = mc.optimise_design(paper, "robust", min_force=2.0 * paper_force.minimum, n=n,
                                   refine=refine, polish=polish, rng=0, samples=samples,
                                   constraints=same_range, bounds=bounds, self_test=SELF_TEST)
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
    for label, setup, span, minimum, reached in rows[:-2]:
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
    for label in (r for r in robust if r in results):
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
    self_test_table(rows, spec, check)
    print(f"({time.perf_counter() - start:.0f} s)")


def self_test_table(rows: list[tuple[str, mc.Setup, float, float, bool]], spec: RobustSpec,
                    check: int) -> None:
    """The second table: each design read after the start-up coil self-test, its independent
    check, against the paper's placement read without; then each tolerance's share with it."""
    tested = replace(spec, self_test=SELF_TEST)
    b = SELF_TEST.pulse(rows[0][1])
    print(f"\nwith the {SELF_TEST.report()} (±{b * 1e4:.3g} G; "
          f"{SELF_TEST.window_noise(rows[0][1]) * 1e9:.3g} nV window noise); independent: "
          f"{check} fresh devices (seed {CHECK_SEED + 1}), perturbed Setups, windows from "
          "mc.bend with Actuation.uniform, fitted by mc.Recalibrator, read by Readout via "
          "Recalibration.read")
    print("| design | range (mN) | min. force (µN) | calibration-free error | with the coil "
          "self-test | independent | with it, placement and size only | error vs the paper's "
          "calibration-free | min. force vs the paper's | failed self-tests |")
    print("|---|---|---|---|---|---|---|---|---|---|")
    ref = calibration_free_error(rows[0][1], rows[0][2], spec).rms
    ref_min = rows[0][3]
    for label, setup, span, minimum, reached in rows:
        free = calibration_free_error(setup, span, spec)
        full = calibration_free_error(setup, span, tested)
        geo = calibration_free_error(setup, span, tested.with_tolerances(GEOMETRY))
        ind = independent_self_test_error(setup, span, Tolerances(), SELF_TEST, check,
                                          CHECK_SEED + 1)
        print(f"| {label} | {'' if reached else '≥ '}{span * 1e3:.3g} | {minimum * 1e6:.3g} | "
              f"{free.rms * 100:.3g} % | {full.rms * 100:.3g} % (p95 {full.p95 * 100:.3g} %) | "
              f"{ind * 100:.3g} % | {geo.rms * 100:.3g} % | {ref / full.rms:.2f}× lower | "
              f"{minimum / ref_min:.2f}× | {full.self_test_failed} of {full.samples} |")
    for label, setup, span, _, _ in (rows[0], rows[2], rows[-2], rows[-1]):
        shares = tolerance_shares(setup, span, tested)
        print(f"each tolerance alone with the self-test at the {label}: " + ", ".join(
            f"{name} {shares[name].rms * 100:.3g} %" for name in (*TOLERANCES, "all")))

if __name__ == "__main__":
    main()
