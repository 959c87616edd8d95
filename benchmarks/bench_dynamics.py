"""The hair in time: the dynamic read-out against the static one on simulated force steps, and
the speed of the time-domain simulator (issue #28, items 3 and 5).

1. Settling. The force-sensor cilium (its modulus taken as known, so that σ is the read-out's
   noise part) steps from rest to a force, simulated by the moving hair
   (``SimulatedSource(..., dynamics=True)``, 10 kHz samples, the sensor's and the amplifier's
   noise) in air and in water; read as samples, or as means of 10 (1 kHz, as ``magcilia live``
   reads) for a smaller step. ``stiffen``: the response's stiffening (the forward model's
   validity: its ringing is quantitative below a few per cent, qualitative beyond). The static
   read-out (:class:`magcilia.Readout`) and the dynamic one
   (:class:`magcilia.readout.dynamic.DynamicReadout`, the Kalman filter on the modal model) read
   the same samples; both are tared on the rest before the step (their noise: the tare's
   spread). *Settled* is the first time after which the estimate of the noise-free output stays
   within 2σ of the applied force (σ: what each read-out states for the noisy samples), in
   periods of the first mode; the empirical share of the noisy estimates within 2σ after it is
   printed beside it. Done when the dynamic read-out settles within 1.5 periods where the static
   one rings for ≥ 5 (air; water where the mode is underdamped).
2. Speed. :func:`magcilia.mechanics.transient.simulate_response` of 10 s of a random force at
   10 kHz (10⁵ samples), one thread: the first call (modes and the static map built) and the
   next calls (the same hair: a :class:`ResponseStream` pushed on), against real time (target:
   ≥ 10×) and against SciPy's ``scipy.signal.lsim`` of the same three modes (the ordinary route,
   interleaved).

Run: ``python benchmarks/bench_dynamics.py`` (``--quick``: fewer repeats, a shorter series).
"""

from __future__ import annotations

import os

os.environ.setdefault("OMP_NUM_THREADS", "1")
os.environ.setdefault("OPENBLAS_NUM_THREADS", "1")
os.environ.setdefault("MKL_NUM_THREADS", "1")

import argparse
import statistics
import sys
import time
from pathlib import Path

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parent))
from _timing import interleaved

import magcilia as mc
from magcilia.acquire import Script, SimulatedSource
from magcilia.mechanics.transient import ResponseStream, simulate_response
from magcilia.readout.dynamic import DynamicReadout

RATE = 10_000.0
SPAN = (-4e-5, 4e-5)  # N: the steps' overshoot stays inside
STEP = 1.6e-5  # N
REST = 0.2  # s of rest before the step (the tare)
#: white read-out noise of amplifier and ADC, V rms per sample (`magcilia live`'s simulation)
NOISE = 2e-5


def known_modulus(setup: mc.Setup) -> mc.Setup:
    """The setup with its Young's modulus taken as known (σ_E = 0)."""
    return setup.replace(youngs_modulus=setup.youngs_modulus, youngs_modulus_sigma=0.0)


def settled(value: np.ndarray, sigma: np.ndarray, truth: float) -> int:
    """Samples after which |value − truth| ≤ 2σ holds to the end (NaN: not within)."""
    outside = ~(np.abs(value - truth) <= 2.0 * sigma)
    bad = np.flatnonzero(outside)
    return int(bad[-1] + 1) if bad.size else 0


def settling(fluid: mc.Fluid, step: float, seconds: float, window: int,
             seed: int) -> dict[str, object]:
    """Static and dynamic read-outs of a force ``step`` (N) in ``fluid`` over ``seconds`` s:
    readings that are 10 kHz samples (``window`` 1) or means of ``window`` of them (as
    ``magcilia live`` reads)."""
    setup = known_modulus(mc.presets.load("force-sensor"))
    modes = mc.modes(setup, fluid)
    period = 1.0 / float(modes.frequencies[0])
    n_rest, n = round(REST * RATE), round((REST + seconds) * RATE)
    script = Script.from_steps([(0.0, 0.0), (REST, step)], "force")
    with SimulatedSource(setup, script, rate=RATE, dynamics=True, fluid=fluid, rng=seed,
                         readout_noise=NOISE) as src:
        noisy = src.read(n).data[0]
    # the same hair without noise
    response = simulate_response(src.setup, script.values(np.arange(n) / RATE), RATE,
                                 fluid=fluid, modes=modes)
    clean = response.output
    rate = RATE / window
    noisy, clean = (x.reshape(-1, window).mean(axis=1) for x in (noisy, clean))
    n_rest, n = n_rest // window, n // window
    static = mc.Readout(setup, quantity="force", span=SPAN).tare(noisy[:n_rest])
    dynamic = DynamicReadout(static, rate, fluid=fluid, modes=modes, averaged=window > 1)
    out: dict[str, object] = {"fluid": fluid.name, "f1_Hz": float(modes.frequencies[0]),
                              "zeta1": float(modes.damping_ratios[0]), "rate_Hz": rate,
                              "step_N": step, "stiffening": response.stiffening,
                              "noise_gain": dynamic.filter.noise_gain}
    for name, r in (("static", static), ("dynamic", dynamic)):
        if isinstance(r, DynamicReadout):
            r.reset()
        got = r.read(noisy)
        if isinstance(r, DynamicReadout):
            r.reset()
        ideal = r.read(clean, noise=_noise(r))
        after = slice(n_rest, n)
        k = settled(np.asarray(ideal.value)[after], np.asarray(got.sigma)[after], step)
        tail = slice(n_rest + k, n)
        within = np.abs(np.asarray(got.value)[tail] - step) <= 2 * np.asarray(got.sigma)[tail]
        out[name] = {"settled_periods": k / rate / period,
                     "sigma_N": float(np.nanmedian(np.asarray(got.sigma)[after])),
                     "within_2sigma_after": float(np.mean(within)) if within.size else float("nan")}
    return out


def _noise(readout: mc.Readout | DynamicReadout) -> float:
    """The noise RMS (V) a tared read-out uses: its tare's spread."""
    base = readout.static.baseline if isinstance(readout, DynamicReadout) else readout.baseline
    assert base is not None  # tared above
    return float(base.noise)


def speed(seconds: float, repeat: int) -> dict[str, float]:
    from scipy import signal

    setup = mc.presets.load("force-sensor")
    n = round(seconds * RATE)
    rng = np.random.default_rng(0)
    load = np.clip(np.cumsum(rng.normal(0.0, 2e-8, n)), -1e-5, 1e-5)
    t0 = time.perf_counter()
    simulate_response(setup, load, RATE, fluid=mc.AIR)
    first = time.perf_counter() - t0
    stream = ResponseStream(setup, "force", RATE, fluid=mc.AIR)
    stream.prepare(load)
    modes = mc.modes(setup, mc.AIR)
    dyn = stream.dynamics
    a, b, c, d = dyn.state_space()
    system = signal.StateSpace(a, b[:, None], c[None, :], np.array([[d]]))
    t = np.arange(n) / RATE

    def anchor() -> object:
        return signal.lsim(system, load, t, interp=False)

    times = interleaved({"magcilia": lambda: stream.push(load), "lsim": anchor}, repeat)
    ours, theirs = (statistics.median(times[k]) for k in ("magcilia", "lsim"))
    return {"seconds": seconds, "first_s": first, "warm_s": ours, "lsim_s": theirs,
            "f1_Hz": float(modes.frequencies[0])}


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--quick", action="store_true", help="fewer repeats, shorter series")
    args = parser.parse_args()
    seconds, repeat = (2.0, 3) if args.quick else (10.0, 7)
    print(f"load: {os.getloadavg()[0]:.2f} (1-min average), one thread")
    print("\n1. settling after a force step (force-sensor, modulus known; the hair and the "
          "readings simulated at 10 kHz)")
    print(f"{'fluid':6} {'f1 Hz':>7} {'zeta1':>6} {'step mN':>8} {'stiffen':>8} {'read Hz':>8} "
          f"{'read-out':9} {'settled (periods)':>18} {'sigma mN':>9} {'within 2σ after':>16}")
    air_s = 0.3 if args.quick else 1.0
    cases = ((mc.AIR, STEP, air_s, 1), (mc.AIR, STEP / 4, air_s, 10), (mc.WATER, STEP, 0.2, 1))
    for fluid, step, length, window in cases:
        res = settling(fluid, step, length, window, seed=1)
        for name in ("static", "dynamic"):
            part = res[name]
            assert isinstance(part, dict)
            print(f"{res['fluid']:6} {res['f1_Hz']:7.1f} {res['zeta1']:6.3f} "
                  f"{res['step_N'] * 1e3:8.4f} {res['stiffening']:8.1%} {res['rate_Hz']:8g} "
                  f"{name:9} {part['settled_periods']:18.2f} {part['sigma_N'] * 1e3:9.2e} "
                  f"{part['within_2sigma_after']:16.3f}")
        print(f"{'':6} dynamic noise gain {res['noise_gain']:.3g} (σ of the load per σ of a "
              "reading's static estimate)")
    print("\n2. simulator speed (simulate_response, force, air, 3 modes), one thread")
    sp = speed(seconds, repeat)
    real = sp["seconds"]
    print(f"{sp['seconds']:g} s of signal at {RATE / 1e3:g} kHz: first call {sp['first_s']:.3f} s "
          f"({real / sp['first_s']:.0f}× real time, modes and static map built); warm "
          f"{sp['warm_s'] * 1e3:.1f} ms ({real / sp['warm_s']:.0f}× real time; target ≥ 10×)")
    print(f"anchor scipy.signal.lsim of the same modes: {sp['lsim_s'] * 1e3:.1f} ms "
          f"(magcilia {sp['lsim_s'] / sp['warm_s']:.1f}× faster, and on the static map too)")


if __name__ == "__main__":
    main()
