"""Sensing while actuating (issue 15): force read-out errors with and without compensation.

The paper's cilium with a 0.05 mm tip radius (the ``force-sensor`` preset) over its HMC1021Z; an
external tip force sweep 0…0.04 mN along +x (tip deflections up to about L/2 with the presets'
0.669 MPa modulus) while an actuation field acts. Each reading goes through the full model: the
cilium bent by the force *and* the actuation (:func:`magcilia.bend` with ``actuation=``), its
field at the element plus the actuation's direct field, the sensor's volts (noise-free: the
errors are the read-outs', not the noise's). The readings are then read

* **raw**: with the plain ``Readout`` (no knowledge of the actuation);
* **tared**: with the plain ``Readout`` zeroed on unloaded readings taken under the actuation
  (the usual practice: it removes the constant offset, not the actuation's bending);
* **M·I only** (varying current): the direct coupling M subtracted per reading, no bending model;
* **compensated**: ``Readout(..., actuation=act)`` for a constant actuation,
  ``ActuatedReadout(..., levels=...)`` for a varying coil current (with the modelled coupling,
  and with M measured on the clamped cilium as the NOTES describe).

Cases: Helmholtz fields of 2 G along x and 5 G along z (a few tenths of a mT: the HMC1021Z's
range is ±6 G of total field, 20 G flips it), a magpylib cuboid magnet 15 mm beside the element,
and a coil current varying per reading (2 G along x per ampere, −1…1 A; the coupling M also
measured on the clamped cilium from 21 currents, each averaged over 2000 noisy samples). Prints
the RMS and largest force errors (mN) of each read-out and the ratio uncompensated /
compensated. Last, force vectors from a 3-axis MMC5983MA at the element under a field along z
and one with all three components (``BiaxialReadout(..., actuation=)``), against the biaxial
read-out tared under the field.

Run: python benchmarks/bench_actuation.py [--quick]
"""

from __future__ import annotations

import argparse
import math
import time

import magpylib
import numpy as np

import magcilia as mc
from magcilia.cli._common import PRESETS
from magcilia.readout.actuated import ActuatedReadout, measure_coupling
from magcilia.readout.inverse import model_output

SETUP = PRESETS["force-sensor"]()
SPAN = (0.0, 4e-5)


def errors(estimate: np.ndarray, truth: np.ndarray) -> tuple[float, float, int]:
    """RMS and largest |error| (N) over the readings with an estimate, and how many lack one."""
    good = np.isfinite(estimate)
    if not good.any():
        return math.nan, math.nan, int(estimate.size)
    err = estimate[good] - truth[good]
    return (float(np.sqrt(np.mean(err**2))), float(np.max(np.abs(err))),
            int(estimate.size - good.sum()))


def line(name: str, stats: tuple[float, float, int]) -> str:
    rms, peak, missing = stats
    if math.isnan(rms):
        return f"  {name:<28} no estimate for any of the readings (outside the span)"
    extra = f", {missing} without an estimate" if missing else ""
    return f"  {name:<28} RMS {rms * 1e3:.3e} mN, max {peak * 1e3:.3e} mN{extra}"


def constant(name: str, act: mc.Actuation, forces: np.ndarray, table_size: int,
             plain: mc.Readout) -> float:
    t0 = time.perf_counter()
    volts = model_output(SETUP, "force", forces, None, act)
    rest = model_output(SETUP, "force", np.zeros(2), None, act)
    comp = mc.Readout(SETUP, "force", SPAN, actuation=act, table_size=table_size)
    built = time.perf_counter() - t0
    raw = errors(plain.read(volts).value, forces)
    tared = errors(plain.tare(rest + np.array([0.0, 1e-12])).read(volts).value, forces)
    good = errors(comp.read(volts).value, forces)
    print(f"{name}: {act.describe()} (built in {built:.2f} s)")
    print(f"  {comp.report().split('; ')[-1]}")
    for label, stats in (("raw (uncompensated)", raw), ("tared (uncompensated)", tared),
                         ("compensated", good)):
        print(line(label, stats))
    ratio = tared[0] / good[0]
    print(f"  ratio tared / compensated: RMS {ratio:.3g}x, max {tared[1] / good[1]:.3g}x")
    return ratio


def varying(forces: np.ndarray, table_size: int, plain: mc.Readout,
            rng: np.random.Generator) -> float:
    coil = mc.Actuation.uniform((2e-4, 0.0, 0.0))  # 2 G along x per ampere
    current = rng.uniform(-1.0, 1.0, forces.size)
    volts = np.array([model_output(SETUP, "force", [f], None, coil.scaled(i))[0]
                      for f, i in zip(forces, current, strict=True)])
    t0 = time.perf_counter()
    comp = ActuatedReadout(SETUP, "force", SPAN, coil, levels=np.linspace(-1.0, 1.0, 9),
                           table_size=table_size)
    built = time.perf_counter() - t0
    # the practical coupling: readings against the current with the cilium clamped (its field
    # does not change): 21 currents, each the mean of 2000 samples at 1 kHz with the sensor's
    # white + 1/f noise (as the paper averages each angle)
    clamped_i = np.linspace(-1.0, 1.0, 21)
    rest = float(SETUP.output([0.0])[0])
    noise = SETUP.sensor.noise(2000 * clamped_i.size, 1000.0, rng=rng).reshape(
        clamped_i.size, 2000).mean(axis=1)  # windows of one record: their means vary
    clamped = rest + comp.model_coupling * clamped_i + noise
    coupling = measure_coupling(clamped_i, clamped)
    measured = ActuatedReadout(SETUP, "force", SPAN, coil, levels=np.linspace(-1.0, 1.0, 9),
                               coupling=coupling, table_size=table_size)
    raw = errors(plain.read(volts).value, forces)
    direct_only = errors(plain.read(volts - comp.model_coupling * current).value, forces)
    good = errors(comp.read(volts, level=current).value, forces)
    good_m = errors(measured.read(volts, level=current).value, forces)
    print(f"coil current per reading: {coil.describe()} per A, I uniform in -1…1 A "
          f"(built in {built:.2f} s)")
    print(f"  {comp.report()}")
    print(f"  {coupling.report()}")
    for label, stats in (("raw (uncompensated)", raw), ("M·I only (no bending)", direct_only),
                         ("compensated (model M)", good), ("compensated (measured M)", good_m)):
        print(line(label, stats))
    ratio = direct_only[0] / good[0]
    print(f"  ratio M·I-only / compensated: RMS {ratio:.3g}x, max "
          f"{direct_only[1] / good[1]:.3g}x; measured M: RMS "
          f"{direct_only[0] / good_m[0]:.3g}x")
    return ratio


def biaxial(field: tuple[float, float, float], grid: tuple[int, int],
            rng: np.random.Generator) -> float:
    """Force vectors from a 3-axis MMC5983MA at the element under a uniform field."""
    from magcilia.device.magnetometer import Magnetometer

    sensor = Magnetometer.preset("MMC5983MA")
    act = mc.Actuation.uniform(field)
    f, phi = rng.uniform(0.1, 0.9, 24) * SPAN[1], rng.uniform(-np.pi, np.pi, 24)
    truth = np.stack([f * np.cos(phi), f * np.sin(phi)], -1)

    def reading(force: float, azimuth: float) -> np.ndarray:
        shape = mc.bend(SETUP, force, azimuth=azimuth, actuation=act)
        return np.asarray(sensor.to_sensor(SETUP.field(shape)[0] + np.asarray(field)))

    b = np.array([reading(fi, p) for fi, p in zip(f, phi, strict=True)])
    t0 = time.perf_counter()
    comp = mc.BiaxialReadout(SETUP, sensor, SPAN[1], table_size=grid, actuation=act)
    built = time.perf_counter() - t0
    rest = reading(0.0, 0.0)
    plain = mc.BiaxialReadout(SETUP, sensor, SPAN[1], table_size=grid).tare(
        np.stack([rest + 1e-12, rest - 1e-12]))
    errs = []
    for res in (plain.read(b), comp.read(b)):
        e = np.hypot(res.fx - truth[:, 0], res.fy - truth[:, 1])
        errs.append((float(np.sqrt(np.mean(e**2))), float(np.max(e)), 0))
    print(f"biaxial ({sensor.name}): {act.describe()}, grid {grid[0]} x {grid[1]} (built in "
          f"{built:.2f} s), 24 force vectors")
    print(line("tared (uncompensated)", errs[0]))
    print(line("compensated", errs[1]))
    ratio = errs[0][0] / errs[1][0]
    print(f"  ratio tared / compensated: RMS {ratio:.3g}x (vector error |F - F_true|)")
    return ratio


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--quick", action="store_true", help="smaller tables, fewer readings")
    args = parser.parse_args()
    size, count = (65, 21) if args.quick else (257, 41)
    rng = np.random.default_rng(15)
    forces = np.linspace(SPAN[0], SPAN[1], count)
    plain = mc.Readout(SETUP, "force", SPAN, table_size=size)
    print(f"force read-out over 0…{SPAN[1] * 1e3:g} mN, {count} readings, noise-free; "
          f"{SETUP.sensor.name} (±{SETUP.sensor.field_range / 1e-4:g} G)")
    ratios = [
        constant("Helmholtz x", mc.Actuation.uniform((2e-4, 0.0, 0.0)), forces, size, plain),
        constant("Helmholtz z", mc.Actuation.uniform((0.0, 0.0, 5e-4)), forces, size, plain),
    ]
    magnet = magpylib.magnet.Cuboid(polarization=(0.0, 0.0, 1.0), dimension=(2e-3,) * 3,
                                    position=(15e-3, 0.0, 0.0))
    ratios.append(constant("magnet", mc.Actuation.magpylib(magnet), forces,
                           min(size, 65), plain))
    ratios.append(varying(forces, size, plain, rng))
    ratios.append(biaxial((0.0, 0.0, 5e-4), (33, 64) if args.quick else (65, 128), rng))
    ratios.append(biaxial((2e-4, 1e-4, 3e-4), (9, 16) if args.quick else (17, 32), rng))
    print(f"smallest ratio uncompensated / compensated (RMS): {min(ratios):.3g}x")


if __name__ == "__main__":
    main()
