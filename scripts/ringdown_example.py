"""The README's ring-down example ("In the lab": the modulus from a flick): a simulated flick of
the force-sensor cilium written as a recording, and what ``magcilia ringdown`` prints for it.

The recording: the force-sensor cilium (examples/force-sensor.toml) with E = 0.5 MPa, flicked in
air: 0.1 s at rest, a deflection held 0.05 s (the output swing of a 10° tilt), released; its
first mode from ``mc.modes`` (undamped frequency with the air's added mass, damping ratio) rings
down as a damped sinusoid, sampled at 10 kHz for 2 s with the HMC1021Z's own noise (white +
1/f, ``Sensor.noise``). Then

    magcilia ringdown flick.csv --setup force-sensor --fluid air --size-sigma height=0.05 \\
        --size-sigma base_radius=0.005
    magcilia ringdown flick.csv --setup force-sensor --fluid air --json > ringdown.json
    magcilia calibrate ... --model physical --prior-from ringdown.json

and the joint fit of tests/analysis/test_ringdown.py (tilts and a force sweep) without and with
the ring-down's prior on the modulus.

Run: python scripts/ringdown_example.py [FOLDER]   (writes FOLDER/flick.csv, default: a
temporary folder)
"""

from __future__ import annotations

import math
import sys
import tempfile
from pathlib import Path

import numpy as np

import magcilia as mc
from magcilia.analysis.ringdown_fit import damped_sinusoid
from magcilia.cli import main as cli
from magcilia.io import presets
from magcilia.io.csvfile import write_samples_csv

E_TRUE = 0.5e6  # Pa
RATE = 10_000.0  # Hz


def flick(path: Path) -> Path:
    """Write the simulated flick (time_s, voltage_V) to ``path``."""
    setup = presets.setup("force-sensor").replace(youngs_modulus=E_TRUE)
    m = mc.modes(setup, "air")
    fn, zeta = float(m.frequencies[0]), float(m.damping_ratios[0])
    rest, held = setup.output(np.radians([0.0, 10.0]))
    t = np.arange(int(2.15 * RATE)) / RATE
    ring = damped_sinusoid(t - 0.15, fn * math.sqrt(1 - zeta**2), zeta * 2 * math.pi * fn,
                           held - rest)
    y = rest + np.where(t < 0.1, 0.0, np.where(t < 0.15, held - rest, ring))
    y = y + setup.sensor.noise(t.size, RATE, rng=0)
    print(f"simulated: E = {E_TRUE / 1e6:g} MPa, f1 = {fn:.4f} Hz, zeta = {zeta:.5f} (air)")
    return write_samples_csv(path, {"time_s": t, "voltage_V": y},
                             comment="SYNTHETIC: scripts/ringdown_example.py")


def joint() -> None:
    """The modulus of a joint fit (tilts at two azimuths, a tip-force sweep; 3-axis field with
    0.2 µT noise) without and with a ring-down's prior: the data of
    tests/analysis/test_ringdown.py::test_joint_fit_with_the_ringdown_prior_pulls_the_modulus_to_the_truth."""
    from magcilia.calibration.joint import PhysicalLayout, calibrate_joint
    from magcilia.io.recordings import Measurement

    truth = mc.Setup.paper(ring="rms", tip_radius=5e-5, youngs_modulus=E_TRUE).replace(
        n_loops=16, dipoles_per_loop=5)
    initial = truth.replace(height=3.0e-3, base_radius=0.2e-3, x=1.0e-3, y=1.5e-3, z=0.5e-3,
                            youngs_modulus=2.5e6)
    rng = np.random.default_rng(1)

    def measurement(b: np.ndarray, name: str, phi: float = 0.0,
                    angles: np.ndarray | None = None, **loads: np.ndarray) -> Measurement:
        a = b.shape[0]
        return Measurement(
            angles=np.zeros(a) if angles is None else angles, volts=np.full(a, np.nan),
            sem=np.full(a, np.nan), counts=np.full(a, 100), saturated=np.zeros(a, np.int64),
            nonfinite=np.zeros(a, np.int64), source=name, azimuths=np.full(a, phi),
            fields=b + rng.normal(0.0, 10e-6, 3) + rng.normal(0.0, 0.2e-6, b.shape),
            field_sem=np.full((a, 3), 0.2e-6), **loads)

    angles, forces = np.radians(np.linspace(0.0, 80.0, 9)), np.linspace(0.0, 2e-5, 5)
    data = [measurement(truth.field(angles, azimuth=phi), f"tilt{i}", phi, angles)
            for i, phi in enumerate((0.0, math.pi / 2))]
    data.append(measurement(truth.field(mc.bend_sweep(truth, forces=forces)), "force",
                            forces=forces))
    m = mc.modes(truth, "air")
    fn, zeta = float(m.frequencies[0]), float(m.damping_ratios[0])
    t = np.arange(7500) / 5000.0
    y = damped_sinusoid(t, fn * math.sqrt(1 - zeta**2), zeta * 2 * math.pi * fn, 1e-3)
    ring = mc.ringdown(y + np.random.default_rng(2).normal(0.0, 2e-5, t.size), 5000.0,
                       setup=truth, fluid="air",
                       size_sigma={"height": 0.05e-3, "base_radius": 5e-6})
    p = ring.prior()
    print(f"ring-down prior: E = {p.value / 1e6:.3f} ± {p.sigma / 1e6:.3f} MPa")
    for label, priors in (("without", None), ("with", {p.name: (p.value, p.sigma)})):
        r = calibrate_joint(data, initial, rng=0, layout=PhysicalLayout(16, 5), priors=priors)
        print(f"joint fit {label} it: E = {r.values['youngs_modulus'] / 1e6:.3f} ± "
              f"{r.stderr['youngs_modulus'] / 1e6:.3f} MPa (truth {E_TRUE / 1e6:g})")


def main(argv: list[str]) -> int:
    folder = Path(argv[0]) if argv else Path(tempfile.mkdtemp())
    path = flick(folder / "flick.csv")
    print(f"$ magcilia ringdown {path.name} --setup force-sensor --fluid air --size-sigma "
          "height=0.05 --size-sigma base_radius=0.005")
    code = cli(["ringdown", str(path), "--setup", "force-sensor", "--fluid", "air",
                "--size-sigma", "height=0.05", "--size-sigma", "base_radius=0.005"])
    joint()
    return code


if __name__ == "__main__":
    sys.exit(main(sys.argv[1:]))
