"""In-use re-calibration against drifts (issue 29 item 2): a read-out with coil pulses against one
without.

The force-sensor cilium on a simulated HMC1021Z (set/reset strap every 10 samples, 20 µV read-out
noise) carries a tip load for 60 s — 1 s off, 4 s on (a different load each time) — while its
sensitivity drifts −3 %, its magnetization −5 % and its offset +0.5 mV, linearly. Every second a
5 G, 100 ms coil pulse (along x, then y) fires;
:class:`~magcilia.readout.recalibration_stream.PulseTracker` masks its samples and, with the
strap's levels and the unloaded seconds (rest windows: the rest field is proportional to M),
tracks offset, sensitivity, magnetization and stiffness. The read-out without it reads the
set/reset-demodulated output as calibrated (the strap removes the offset; the gain drifts stay);
the one with it reads ``Recalibration.read`` (the corrected output, σ with the drifts' σ). Both
are tared on the first unloaded second, as ``magcilia live`` does. Printed: the true load and
both read-outs with σ every 5 s, the share of readings within 2σ of the truth and the largest
error in σ, and the tracked drifts against the truth at the end. No timing: the figures are
accuracies.

Run: python benchmarks/bench_recalibration.py [--seed N] [--quick]
"""

from __future__ import annotations

import argparse
import time

import numpy as np

import magcilia as mc
from magcilia.acquire import Script
from magcilia.acquire.simulated_coil import (
    ACTUATION_COLUMNS,
    CoilPulses,
    Drifts,
    SimulatedCoilSource,
)
from magcilia.readout.recalibration import Recalibrator
from magcilia.readout.recalibration_stream import PulseTracker

SECONDS = 60.0
#: the tip load: 1 s off, then 4 s on (a different load each time), N
LOADS = [(0.0, 0.0)] + [(5.0 * i + 1.0, f) for i, f in enumerate(
    [2e-6, -1e-6, 3e-6, 1.5e-6, -2e-6, 2.5e-6, 1e-6, -0.5e-6, 3e-6, 2e-6, -1.5e-6, 2.5e-6])]
LOADS = sorted(LOADS + [(5.0 * i, 0.0) for i in range(1, 12)])
TRUTH = {"sensitivity": -0.03, "magnetization": -0.05, "offset": 0.5e-3,
         "stiffness": 0.0}  # over SECONDS
WINDOW = 100  # samples per reading
#: the tracking's random walk per √s: the drifts here reach 0.08 %/s, so a scale moves ~0.4 %
#: between rest windows 5 s apart (≈ 2e-3·√5)
WALK = {"offset": 2e-5, "sensitivity": 2e-3, "magnetization": 2e-3, "stiffness": 2e-3}


def run(seed: int, seconds: float = SECONDS) -> dict[str, float]:
    setup = mc.presets.load("force-sensor")
    source = SimulatedCoilSource(
        setup, Script.from_steps(LOADS, "force"), rng=seed, readout_noise=2e-5, set_reset=10,
        pulses=CoilPulses(every=1.0, duration=0.1, amplitude=5e-4, start=0.5),
        drifts=Drifts(TRUTH["sensitivity"] / SECONDS, TRUTH["magnetization"] / SECONDS),
        drift=TRUTH["offset"] / SECONDS)  # the same rates in a --quick run
    readout = mc.Readout(setup, "force", span=(-2e-5, 2e-5))
    tracker = PulseTracker(Recalibrator(setup, span=(-5e-6, 5e-6), hold=()), walk=WALK)
    o0 = setup.sensor.offset
    rows = []
    with source:
        for _ in range(int(seconds / 0.5)):
            block = source.read(500)
            applied = np.column_stack([block[c] for c in ACTUATION_COLUMNS])
            out, mask = tracker.push(block.time, block["output"], applied, block.setreset)
            assert block.setreset is not None
            off = (block.time % 5.0 >= 0.2) & (block.time % 5.0 < 1.0) & ~mask  # unloaded
            if off.sum() >= 100:
                tracker.rest(block.time[off], block["output"][off], block.setreset[off])
            p = block.setreset.astype(float)
            for i in range(0, 500, WINDOW):
                part = slice(i, i + WINDOW)
                if mask[part].any():
                    continue  # a pulse: no force reading
                t = float(block.time[part].mean())
                level = o0 + float(np.mean(p[part] * out[part]))  # set/reset demodulated
                rows.append((t, Script.from_steps(LOADS, "force").values(np.array([t]))[0],
                             level, tracker.state))
    t = np.array([r[0] for r in rows])
    truth = np.array([r[1] for r in rows])
    level = np.array([r[2] for r in rows])
    rest = (t >= 0.2) & (t < 1.0)  # the first unloaded second: both read-outs tared on it
    readout = readout.tare(level[rest])
    plain = readout.read(level)
    fixed = [r[3].read(readout, np.array([r[2]]), offset=o0) for r in rows]
    fixed_value = np.array([f[0][0] for f in fixed])
    fixed_sigma = np.array([f[1][0] for f in fixed])
    plain_z = (np.asarray(plain.value) - truth) / np.asarray(plain.sigma_noise)
    fixed_z = (fixed_value - truth) / fixed_sigma
    print(f"{'t s':>6} {'true µN':>8} {'without µN':>20} {'with re-calibration µN':>24}")
    for when in np.arange(5.0, seconds + 1e-9, 5.0):
        j = int(np.argmin(np.abs(t - (when - 1.25))))  # loaded
        print(f"{t[j]:6.2f} {truth[j] * 1e6:+8.3f} {plain.value[j] * 1e6:+10.3f} ± "
              f"{plain.sigma_noise[j] * 1e6:.3f}    {fixed_value[j] * 1e6:+10.3f} ± "
              f"{fixed_sigma[j] * 1e6:.3f}")
    late = t > 5.0  # after the first pulses of each kind
    state = tracker.state
    print(f"within 2σ of the true load (t > 5 s, {late.sum()} readings): without "
          f"{np.mean(np.abs(plain_z[late]) <= 2) * 100:.1f} % (largest error "
          f"{np.nanmax(np.abs(plain_z[late])):.3g} σ; NaN: beyond the span), with re-calibration "
          f"{np.mean(np.abs(fixed_z[late]) <= 2) * 100:.1f} % (largest "
          f"{np.max(np.abs(fixed_z[late])):.3g} σ)")
    end = state.time / SECONDS
    for name, total in TRUTH.items():
        truth_now = total * end
        got, sigma = state.change(name), state.sigma[name] / (
            1.0 if name == "offset" else state.reference[name])
        unit, f = ("mV", 1e3) if name == "offset" else ("%", 100.0)
        print(f"{name:<13} true {truth_now * f:+.3f} {unit}, tracked {got * f:+.3f} ± "
              f"{sigma * f:.3f} {unit} ({(got - truth_now) / sigma:+.2f} σ)")
    print(f"pulses used {tracker.updates}, left out (load moved) {tracker.rejected}")
    return {"within_plain": float(np.mean(np.abs(plain_z[late]) <= 2)),
            "within_fixed": float(np.mean(np.abs(fixed_z[late]) <= 2))}


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--seed", type=int, default=3)
    parser.add_argument("--quick", action="store_true",
                        help="20 s instead of 60 s (the same drift rates: a third of the drifts)")
    args = parser.parse_args()
    t0 = time.perf_counter()
    run(args.seed, 20.0 if args.quick else SECONDS)
    print(f"({time.perf_counter() - t0:.1f} s of wall time; the figures are accuracies)")


if __name__ == "__main__":
    main()
