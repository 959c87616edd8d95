"""Ring-down identification (issue 28, item 4): the damped frequency and decay of free
oscillations with σ, the Young's modulus they give through the modal model, bad recordings,
and the modulus handed to the calibration as a prior.

Synthetic ring-downs: the force-sensor cilium (examples/force-sensor.toml) at E = 0.5 MPa, its
first mode in air and in water from the modal model (``mc.modes``: undamped frequency with the
added mass, damping ratio), simulated as that mode's damped sinusoid (the output swing of a 2°
tilt, ~46 µV) on the output's rest level plus the sensor's noise (``Sensor.noise``: the
HMC1021Z's white + 1/f, 5–11 % of the swing per sample at 2–10 kHz), after a flick held and
released. The coverage tests fit 200 seeds at once
(``MAGCILIA_FUZZ=long``: 2000) and ask that the stated 2σ interval holds the truth at its
stated rate (95.4 %; a binomial 3.4 σ band around it).
"""

from __future__ import annotations

import json
import math
import os

import numpy as np
import pytest

import magcilia as mc
from magcilia._errors import MagciliaError
from magcilia.analysis import ringdown_fit as rf
from magcilia.analysis.ringdown import modulus_from_frequency, ringdown, ringdown_prior
from magcilia.calibration.experiments import Prior
from magcilia.io import presets

SEEDS = 2000 if os.environ.get("MAGCILIA_FUZZ") == "long" else 200
COVER = math.erf(2.0 / math.sqrt(2.0))  # 0.9545: the rate a 2σ interval states
E_TRUE = 0.5e6
SETUP = presets.setup("force-sensor").replace(youngs_modulus=E_TRUE)
RATE = 10_000.0  # Hz


def _band(n: int) -> tuple[float, float]:
    """The binomial 3.4 σ band of the coverage of ``n`` seeds."""
    half = 3.4 * math.sqrt(COVER * (1 - COVER) / n)
    return COVER - half, min(1.0, COVER + half)


def _mode(fluid: str | None) -> tuple[float, float]:
    """The first mode's undamped frequency (Hz) and damping ratio at the truth."""
    m = mc.modes(SETUP, fluid)
    return float(m.frequencies[0]), float(m.damping_ratios[0])


def _amplitude() -> float:
    """A flick's output swing, V: the output change of a 2 degree tilt (the tip ~0.1 mm)."""
    out = SETUP.output(np.radians([0.0, 2.0]))
    return float(abs(out[1] - out[0]))


def _record(fn: float, zeta: float, rng: np.random.Generator, seeds: int = 1, *,
            rest: float = 0.1, hold: float = 0.05, ring: float | None = None) -> np.ndarray:
    """Records (seeds, n): rest, a held deflection, then the mode rings down, plus the sensor's
    noise (the HMC1021Z's white + 1/f, :meth:`Sensor.noise`)."""
    gamma = zeta * 2 * math.pi * fn
    fd = fn * math.sqrt(1 - zeta**2)
    ring = ring if ring is not None else min(12.0 / gamma, 4.0)
    t = np.arange(int((rest + hold + ring) * RATE)) / RATE
    amp = _amplitude()
    phase = rng.uniform(-0.3, 0.3, (seeds, 1))  # released a little after the crest
    free = rf.damped_sinusoid(t - rest - hold, fd, gamma, amp, phase)
    y = np.where(t < rest, 0.0, np.where(t < rest + hold, amp * np.cos(phase), free))
    offset = float(SETUP.output(np.zeros(1))[0])
    return np.asarray(offset + y + SETUP.sensor.noise(t.size, RATE, rng, size=seeds))


# -- the fit alone: σ that covers ------------------------------------------------------------------

@pytest.mark.parametrize(("zeta", "snr"), [(0.01, 300.0), (0.15, 100.0)], ids=["light", "heavy"])
def test_fit_sigma_covers_at_its_stated_rate(zeta: float, snr: float) -> None:
    """Monte Carlo over seeds: the frequency's and decay's 2σ intervals hold the truth at 95 %."""
    rng = np.random.default_rng(7)
    fn, amp = 250.0, 1.0
    gamma, fd = zeta * 2 * math.pi * fn, fn * math.sqrt(1 - zeta**2)
    rate = 20.0 * fn
    t = np.arange(int(6.0 / gamma * rate)) / rate
    y = rf.damped_sinusoid(t, fd, gamma, amp, rng.uniform(0, 2 * math.pi, (SEEDS, 1)), 0.3)
    y = y + rng.normal(0.0, amp / snr, y.shape)
    fit = rf.fit_damped(t, y, rf.first_guess(t, y, rate))
    assert fit.converged.all()
    lo, hi = _band(SEEDS)
    for column, truth in ((3, 2 * math.pi * fd), (2, gamma)):
        z = (fit.x[:, column] - truth) / fit.sigma[:, column]
        assert lo <= np.mean(np.abs(z) < 2.0) <= hi, column
        assert abs(np.mean(z)) < 4.0 / math.sqrt(SEEDS)  # unbiased
    assert np.mean(fit.noise) == pytest.approx(amp / snr, rel=0.03)


def test_first_guess_and_spectral_peak_against_the_truth() -> None:
    t = np.arange(3000) / RATE
    y = rf.damped_sinusoid(t, [[123.4], [432.1]], [[5.0], [60.0]], 2.0, 0.4)
    assert rf.spectral_peak(y, RATE) == pytest.approx([123.4, 432.1], rel=2e-3)
    x0 = rf.first_guess(t, y, RATE, noise=np.full(2, 1e-6))
    assert x0[:, 2] == pytest.approx([5.0, 60.0], rel=0.1)
    assert np.hypot(x0[:, 0], x0[:, 1]) == pytest.approx(2.0, rel=0.1)


def test_second_mode_is_fitted_beside_the_first() -> None:
    rng = np.random.default_rng(3)
    t = np.arange(8000) / RATE
    y = (rf.damped_sinusoid(t, 200.0, 8.0, 1.0, 0.2) + rf.damped_sinusoid(t, 1250.0, 30.0, 0.3)
         + rng.normal(0.0, 1e-3, t.size))
    one = ringdown(y, RATE)
    two = ringdown(y, RATE, second_mode=True)
    assert two.frequency == pytest.approx(200.0, abs=3 * two.frequency_sigma + 1e-9)
    assert two.second_frequency == pytest.approx(1250.0, rel=1e-3)
    assert two.second_decay_rate == pytest.approx(30.0, rel=0.05)
    assert two.noise < 0.5 * one.noise  # the second mode is signal, not noise
    single = rf.damped_sinusoid(t, 200.0, 8.0, 1.0, 0.2) + rng.normal(0.0, 1e-3, t.size)
    with pytest.raises(MagciliaError, match="no second mode"):
        ringdown(single, RATE, second_mode=True)


# -- the modulus ----------------------------------------------------------------------------------

def test_vacuum_modulus_scales_with_the_square_of_the_frequency() -> None:
    f1 = _mode(None)[0]
    for ratio in (0.5, 1.0, 3.0):
        assert modulus_from_frequency(SETUP, ratio * f1) == pytest.approx(ratio**2 * E_TRUE,
                                                                          rel=1e-7)


@pytest.mark.parametrize("fluid", ["air", "water"])
def test_fluid_modulus_inverts_the_modal_model(fluid: str) -> None:
    f1 = _mode(fluid)[0]
    assert modulus_from_frequency(SETUP, f1, fluid, start=3e6) == pytest.approx(E_TRUE, rel=1e-7)


@pytest.mark.parametrize("fluid", ["air", "water"])
def test_modulus_recovered_and_covered_over_seeds(fluid: str) -> None:
    """E from seeded ring-downs: each within its 2σ at the stated rate; the fit batched over
    the seeds, E from the modal model (three exact inversions, interpolated in log-log)."""
    fn, zeta = _mode(fluid)
    rng = np.random.default_rng(11)
    gamma, fd = zeta * 2 * math.pi * fn, fn * math.sqrt(1 - zeta**2)
    rate = 2000.0  # 15–25 samples a period: enough, and the batch stays small
    t = np.arange(int(min(6.0 / gamma, 0.5) * rate)) / rate
    y = rf.damped_sinusoid(t, fd, gamma, _amplitude(), rng.uniform(0, 2 * math.pi, (SEEDS, 1)))
    y = y + SETUP.sensor.noise(t.size, rate, rng, size=SEEDS)  # white + 1/f, V
    fit = rf.fit_damped(t, y, rf.first_guess(t, y, rate))
    g, w = fit.x[:, 2], fit.x[:, 3]
    wn = np.hypot(g, w)
    c = fit.covariance
    var = (g / wn) ** 2 * c[:, 2, 2] + (w / wn) ** 2 * c[:, 3, 3] + 2 * g * w / wn**2 * c[:, 2, 3]
    f_n, s_n = wn / (2 * math.pi), np.sqrt(var) / (2 * math.pi)
    grid = np.quantile(f_n, [0.0, 0.5, 1.0]) * [0.999, 1.0, 1.001]
    e_grid = [modulus_from_frequency(SETUP, f, fluid) for f in grid]
    coef = np.polyfit(np.log(grid), np.log(e_grid), 2)
    e = np.exp(np.polyval(coef, np.log(f_n)))
    slope = np.polyval(np.polyder(coef), np.log(f_n))
    sigma = slope * e * s_n / f_n
    lo, hi = _band(SEEDS)
    assert lo <= np.mean(np.abs(e - E_TRUE) < 2 * sigma) <= hi
    assert abs(np.median(e) / E_TRUE - 1) < 2 * np.median(sigma) / E_TRUE


@pytest.mark.parametrize("fluid", ["air", "water"])
def test_ringdown_of_a_recording_gives_the_modulus(fluid: str) -> None:
    fn, zeta = _mode(fluid)
    rng = np.random.default_rng(5)
    y = _record(fn, zeta, rng)[0]
    r = ringdown(y, RATE, setup=SETUP, fluid=fluid)
    # one seed: within 3σ (the 2σ coverage over seeds is the test above)
    assert abs(r.youngs_modulus - E_TRUE) < 3 * r.youngs_modulus_sigma
    assert abs(r.damping_ratio - zeta) < 3 * r.damping_ratio_sigma
    assert abs(r.natural_frequency - fn) < 3 * r.natural_frequency_sigma
    assert r.model_damping_ratio == pytest.approx(zeta, rel=0.05)  # the fluid's, at the fit's E
    # after the release at the end of the hold (0.15 s), within a few periods (a noisy later
    # crest may stand highest in air)
    assert 0.15 < r.start < 0.15 + 3.0 / fn
    assert r.fluid == fluid and r.periods >= 2
    assert r.dominant == "frequency" and set(r.modulus_terms) == {"frequency"}


def test_size_sigma_propagates_and_dominates() -> None:
    fn, zeta = _mode("air")
    y = _record(fn, zeta, np.random.default_rng(2))[0]
    bare = ringdown(y, RATE, setup=SETUP, fluid="air")
    sized = ringdown(y, RATE, setup=SETUP, fluid="air",
                     size_sigma={"height": 0.05e-3, "base_radius": 5e-6})
    assert sized.youngs_modulus == pytest.approx(bare.youngs_modulus, rel=1e-9)
    assert sized.dominant in ("height", "base_radius")
    # a frustum's f ∝ r/L² √(E/ρ) (taper fixed): E ∝ L⁴/r², so σ_E/E ≈ √((4σ_L/L)² + (2σ_r/r)²)
    c = SETUP.cilium
    expect = math.hypot(4 * 0.05e-3 / c.height, 2 * 5e-6 / c.base_radius)
    assert sized.youngs_modulus_sigma / sized.youngs_modulus == pytest.approx(expect, rel=0.3)
    total = math.sqrt(sum(s**2 for s in sized.modulus_terms.values()))
    assert sized.youngs_modulus_sigma == pytest.approx(total)


# -- bad recordings: one line each ----------------------------------------------------------------

def _steady(t: np.ndarray) -> np.ndarray:
    return np.sin(2 * np.pi * 200.0 * t)


BAD = {
    "noise only": (lambda t, rng: rng.normal(0.0, 1e-3, t.size), "no free oscillation"),
    "no decay": (lambda t, rng: _steady(t) + rng.normal(0.0, 1e-3, t.size),
                 "no free oscillation"),
    "growing": (lambda t, rng: np.exp(3.0 * t) * _steady(t) + rng.normal(0.0, 1e-3, t.size),
                "no free oscillation"),
    "clipped": (lambda t, rng: np.clip(rf.damped_sinusoid(t, 200.0, 10.0, 1.0), -0.6, 0.6),
                "clipped"),
    "too short": (lambda t, rng: np.r_[np.zeros(t.size - 75), rf.damped_sinusoid(
        t[:75], 200.0, 10.0, 1.0)] + rng.normal(0.0, 1e-3, t.size), "periods"),  # 1.5 periods
    "near Nyquist": (lambda t, rng: rf.damped_sinusoid(t, 4700.0, 50.0, 1.0)
                     + rng.normal(0.0, 1e-3, t.size), "Nyquist"),
}


@pytest.mark.parametrize("case", sorted(BAD))
def test_bad_recordings_say_what_is_missing(case: str) -> None:
    make, words = BAD[case]
    t = np.arange(4000) / RATE
    with pytest.raises(MagciliaError, match=words) as info:
        ringdown(make(t, np.random.default_rng(0)), RATE)
    assert "\n" not in str(info.value)


def test_sample_rate_below_twice_the_mode_is_refused() -> None:
    fn, _ = _mode(None)
    slow = 1.5 * fn
    t = np.arange(4000) / slow
    y = rf.damped_sinusoid(t, fn, 10.0, 1.0)  # aliased: would look like a slower ring-down
    with pytest.raises(MagciliaError, match="below twice"):
        ringdown(y, slow, setup=SETUP)


def test_overdamped_fluid_is_said() -> None:
    assert mc.modes(SETUP, "glycerol").overdamped[0]
    y = rf.damped_sinusoid(np.arange(4000) / RATE, 200.0, 10.0, 1.0)
    with pytest.raises(MagciliaError, match="overdamped in glycerol"):
        ringdown(y, RATE, setup=SETUP, fluid="glycerol")


def test_bad_arguments_are_one_line_errors() -> None:
    y = rf.damped_sinusoid(np.arange(4000) / RATE, 200.0, 10.0, 1.0)
    for kwargs, words in (({}, "rate"), ({"rate": -1.0}, "rate"),
                          ({"rate": RATE, "fluid": "honey"}, "fluid"),
                          ({"rate": RATE, "size_sigma": {"width": 1e-5}}, "size_sigma"),
                          ({"rate": RATE, "start": 10.0}, "start must be a time within")):
        with pytest.raises(MagciliaError, match=words):
            ringdown(y, **kwargs)  # type: ignore[arg-type]
    with pytest.raises(MagciliaError, match="not finite"):
        ringdown(np.r_[y, np.nan], RATE)


# -- the prior ------------------------------------------------------------------------------------

def test_prior_round_trips_through_json_and_the_option(tmp_path) -> None:
    from magcilia._atomic import json_text
    from magcilia.cli._common import parse_priors

    fn, zeta = _mode("air")
    r = ringdown(_record(fn, zeta, np.random.default_rng(4))[0], RATE,
                 setup=SETUP, fluid="air")
    p = r.prior()
    assert isinstance(p, Prior) and p.name == "youngs_modulus"
    assert (p.value, p.sigma) == (r.youngs_modulus, r.youngs_modulus_sigma)
    path = tmp_path / "ringdown.json"
    path.write_text(json_text(r.to_dict()))
    assert ringdown_prior(path) == {"youngs_modulus": (p.value, p.sigma)}
    name, _, text = r.prior_option().removeprefix("--prior ").partition("=")
    back = parse_priors((f"{name}={text}",), ("youngs_modulus",))["youngs_modulus"]
    assert back == pytest.approx((p.value, p.sigma), rel=1e-5)
    bare = ringdown(_record(fn, zeta, np.random.default_rng(4))[0], RATE)
    with pytest.raises(MagciliaError, match="no modulus"):
        bare.prior()
    path.write_text(json_text(bare.to_dict()))
    with pytest.raises(MagciliaError, match="no modulus"):
        ringdown_prior(path)
    path.write_text(json.dumps({"kind": "calibration"}))
    with pytest.raises(MagciliaError, match="not a ring-down"):
        ringdown_prior(path)


def test_joint_fit_with_the_ringdown_prior_pulls_the_modulus_to_the_truth() -> None:
    """Tilts at two azimuths and a tip-force sweep (3-axis field, the joint fit of
    tests/calibration/test_joint_loads.py, smaller) leave E loose (≈ 40 %: E and the size trade
    off); the ring-down's prior (size known to 0.05 mm and 5 µm) pins it to the truth."""
    from magcilia.calibration.joint import PhysicalLayout, calibrate_joint
    from magcilia.io.recordings import Measurement

    truth = mc.Setup.paper(ring="rms", tip_radius=5e-5, youngs_modulus=E_TRUE).replace(
        n_loops=16, dipoles_per_loop=5)
    initial = truth.replace(height=3.0e-3, base_radius=0.2e-3, x=1.0e-3, y=1.5e-3, z=0.5e-3,
                            youngs_modulus=2.5e6)
    rng = np.random.default_rng(1)
    noise = 0.2e-6  # T

    def measurement(b: np.ndarray, name: str, phi: float = 0.0,
                    angles: np.ndarray | None = None, **loads: np.ndarray) -> Measurement:
        a = b.shape[0]
        return Measurement(
            angles=np.zeros(a) if angles is None else angles, volts=np.full(a, np.nan),
            sem=np.full(a, np.nan), counts=np.full(a, 100), saturated=np.zeros(a, np.int64),
            nonfinite=np.zeros(a, np.int64), source=name, azimuths=np.full(a, phi),
            fields=b + rng.normal(0.0, 10e-6, 3) + rng.normal(0.0, noise, b.shape),
            field_sem=np.full((a, 3), noise), **loads)

    angles, forces = np.radians(np.linspace(0.0, 80.0, 9)), np.linspace(0.0, 2e-5, 5)
    data = [measurement(truth.field(angles, azimuth=phi), f"tilt{i}", phi, angles)
            for i, phi in enumerate((0.0, math.pi / 2))]
    data.append(measurement(truth.field(mc.bend_sweep(truth, forces=forces)), "force",
                            forces=forces))
    m = mc.modes(truth, "air")
    fn, zeta = float(m.frequencies[0]), float(m.damping_ratios[0])
    t = np.arange(7500) / 5000.0
    y = rf.damped_sinusoid(t, fn * math.sqrt(1 - zeta**2), zeta * 2 * math.pi * fn, 1e-3)
    ring = ringdown(y + np.random.default_rng(2).normal(0.0, 2e-5, t.size), 5000.0,
                    setup=truth, fluid="air", size_sigma={"height": 0.05e-3, "base_radius": 5e-6})
    p = ring.prior()
    loose = calibrate_joint(data, initial, rng=0, layout=PhysicalLayout(16, 5))
    pinned = calibrate_joint(data, initial, rng=0, layout=PhysicalLayout(16, 5),
                             priors={p.name: (p.value, p.sigma)})
    e0, s0 = loose.values["youngs_modulus"], loose.stderr["youngs_modulus"]
    e1, s1 = pinned.values["youngs_modulus"], pinned.stderr["youngs_modulus"]
    assert s0 > 0.25 * E_TRUE  # the loads alone leave the modulus loose
    assert s1 < min(0.3 * s0, 1.05 * p.sigma)
    assert abs(e1 - E_TRUE) < 2 * s1
    assert abs(e1 - E_TRUE) < abs(e0 - E_TRUE)


def test_ring_down_of_an_independent_full_solve() -> None:
    """A released hair solved independently of the modal model: a Rayleigh–Ritz beam on a
    power basis (w = Σ a_k (s/L)^k, k = 2…11: clamped at the base; 40-point Gauss quadrature of
    the frustum's ρA and EI), released from the static shape of a tip force (its tip 0.1 mm
    aside: the first mode holds 82 % of it, the second 13 %), every mode rung with ζ = 0.004
    (a material loss), in vacuum. The ring-down of its tip (the output 0.46 V/m of it, plus the
    sensor's noise) gives E within 3σ, and the second mode where asked."""
    import scipy.linalg

    c = SETUP.cilium
    x, weights = np.polynomial.legendre.leggauss(40)
    s, weights = (x + 1) / 2 * c.height, weights * c.height / 2
    r = c.base_radius + (c.tip_radius - c.base_radius) * s / c.height
    k = np.arange(2, 12)[:, None]
    xi = (s / c.height)[None, :]
    phi, curve = xi**k, k * (k - 1) * xi ** (k - 2) / c.height**2
    mass = (phi * SETUP.material.density * math.pi * r**2 * weights) @ phi.T
    stiff = (curve * E_TRUE * math.pi * r**4 / 4 * weights) @ curve.T
    lam, vec = scipy.linalg.eigh(stiff, mass)
    omega = np.sqrt(lam)
    assert omega[:3] / (2 * math.pi) == pytest.approx(mc.modes(SETUP).frequencies, rel=1e-6)
    shape = np.linalg.solve(stiff, np.ones(k.size))  # a tip force (every φ_k is 1 at the tip)
    shape *= 1e-4 / shape.sum()
    tip = vec.sum(axis=0) * (vec.T @ mass @ shape)  # each mode's share of the tip, m
    zeta = 0.004
    t = np.arange(10_000) / RATE
    wd = omega[:, None] * math.sqrt(1 - zeta**2)
    free = (tip[:, None] * np.exp(-zeta * omega[:, None] * t)
            * (np.cos(wd * t) + zeta * omega[:, None] / wd * np.sin(wd * t))).sum(axis=0)
    y = 0.46 * np.r_[np.full(1000, 1e-4), free] + float(SETUP.output(np.zeros(1))[0])
    y = y + SETUP.sensor.noise(y.size, RATE, rng=0)
    one = ringdown(y, RATE, setup=SETUP)
    two = ringdown(y, RATE, setup=SETUP, second_mode=True)
    for r_ in (one, two):
        assert abs(r_.youngs_modulus - E_TRUE) < 3 * r_.youngs_modulus_sigma
        assert abs(r_.damping_ratio - zeta) < 3 * r_.damping_ratio_sigma
    assert two.second_frequency == pytest.approx(omega[1] / (2 * math.pi), rel=0.01)


def test_a_given_start_and_a_field_channel() -> None:
    """``start=`` picks the segment (here a crest after the release: the same modulus within
    σ), and a field channel (T) rings as the output does."""
    fn, zeta = _mode("air")
    y = _record(fn, zeta, np.random.default_rng(6))[0]
    found = ringdown(y, RATE, setup=SETUP, fluid="air")
    later = ringdown(y, RATE, setup=SETUP, fluid="air", start=0.15 + 5.0 / fn)
    assert later.start == pytest.approx(0.15 + 5.0 / fn, abs=1.0 / RATE)
    assert abs(later.youngs_modulus - found.youngs_modulus) < 3 * later.youngs_modulus_sigma
    field = ringdown(y / SETUP.sensor.scale, RATE, channel="field_x")
    assert field.unit == "T" and field.frequency == pytest.approx(found.frequency, rel=1e-7)
