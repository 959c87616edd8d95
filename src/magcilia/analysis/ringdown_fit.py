"""Free oscillations in a time series: where they are, a first guess, and the fit (no physics).

A flick or a coil pulse makes the cilium ring; the output (or a field channel) is then a damped
sinusoid on an offset, ``y(t) = c + e^(−γt) (a cos ωt + b sin ωt)``, until it sinks into the
sensor's noise. The steps (:func:`free_segment`, :func:`first_guess`, :func:`fit_damped`):

1. **Segment.** The free oscillation starts at the last sample above half the largest
   deviation from the rest level (the record's median: rest and ring-down outweigh a held
   flick) before the signal first crosses that level: past the release of a deflection held
   at the peak (a flick held and let go, or a clipped top) whatever the noise, and 60° of
   phase before the crossing. It ends one period after its envelope (the largest deviation
   in blocks of one period) falls to the noise (:func:`floor`: at least :data:`FLOOR_SIGMAS`
   × the noise σ, the robust spread before the flick or of the tail's sample-to-sample
   differences), but not before :data:`FIT_PERIODS` periods where the record holds them.
2. **First guess.** The frequency from the spectral peak of the segment (zero padded,
   parabolic interpolation of the log magnitude); the decay rate from a straight line
   through the log of the envelope where it stands above the floor; ``a, b, c`` by linear least
   squares at that frequency and decay. Vectorised over many segments of one length.
3. **Fit.** One :func:`magcilia.fitting.fit_batch` over all segments at once (analytic Jacobian;
   optionally a second mode, four more parameters). σ of every parameter from the Jacobian and
   the residual noise: ``s² (JᵀJ)⁻¹`` with ``s² = χ²/(n − p)`` (white noise; with coloured
   noise the σ is too small by the noise's correlation length: the tests check the coverage
   with white sensor noise by Monte Carlo).

Times are seconds from the segment's first sample, rates in 1/s, angular frequencies rad/s.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np
from numpy.typing import ArrayLike, NDArray

from magcilia._errors import MagciliaError
from magcilia.fitting import fit_batch

F64 = NDArray[np.float64]

#: the envelope's end: at least this many noise σ (:func:`floor`)
FLOOR_SIGMAS = 3.0
#: fewest periods fitted where the record holds them (a heavily damped ring-down sinks into the
#: noise within a period or two; the samples after it still pin its decay)
FIT_PERIODS = 4.0
#: fewest periods a ring-down must hold
MIN_PERIODS = 2.0
#: a run of at least this many equal samples at the segment's extreme is a clipped one
CLIP_RUN = 3
#: the spectral peak above this fraction of the sample rate is too close to the Nyquist frequency
NYQUIST_FRACTION = 0.4
#: the flick's largest deviation must stand this many noise σ above the rest level (noise alone
#: reaches 6 σ once in ~5e8 samples)
MIN_SIGNAL_SIGMAS = 6.0
#: fewest samples before the flick for the noise σ from them (else from the tail)
MIN_REST_SAMPLES = 64
#: names of the fitted parameters (the second mode's four follow the first's with a ``2``)
NAMES = ("a", "b", "decay", "omega", "offset")
SECOND = ("a2", "b2", "decay2", "omega2")


def damped_sinusoid(t: ArrayLike, frequency: ArrayLike, decay: ArrayLike, amplitude: ArrayLike,
                    phase: ArrayLike = 0.0, offset: ArrayLike = 0.0) -> F64:
    """A free oscillation: ``offset + amplitude · e^(−decay·t) · cos(2π·frequency·t + phase)``.

    Parameters
    ----------
    t : array-like, shape (n,)
        Times, s (broadcast with the rest: (s, 1) parameters give (s, n) signals).
    frequency : array-like
        Damped frequency, Hz.
    decay : array-like
        Decay rate γ of the envelope, 1/s (``ζ ω_n``).
    amplitude, offset : array-like
        In the signal's unit (V, T).
    phase : array-like
        rad.

    Returns
    -------
    ndarray
        The signal, the broadcast shape of the arguments.

    Examples
    --------
    >>> round(float(damped_sinusoid(0.01, 100.0, 20.0, 1e-3)), 9)  # one period: e^(-0.2) mV
    0.000818731
    """
    t = np.asarray(t, dtype=np.float64)
    f, g, a = (np.asarray(x, dtype=np.float64) for x in (frequency, decay, amplitude))
    return np.asarray(offset + a * np.exp(-g * t) * np.cos(2.0 * np.pi * f * t + phase),
                      dtype=np.float64)


@dataclass(frozen=True)
class Segment:
    """Where the free oscillation is in a record: samples ``[start, stop)``, the rest level and
    the noise σ (the signal's unit), the first frequency guess (Hz)."""

    start: int
    stop: int
    rest: float
    noise: float
    frequency: float


def _runs_at(y: F64, value: float) -> F64:
    """Lengths of the runs of consecutive samples equal to ``value``."""
    hit = np.r_[False, y == value, False].astype(np.int8)
    edges = np.flatnonzero(np.diff(hit))
    return np.asarray(edges[1::2] - edges[::2], dtype=np.float64)


def clipped_samples(y: ArrayLike) -> int:
    """Samples of ``y`` in runs of ≥ :data:`CLIP_RUN` equal values at its maximum or minimum (a
    sensor or converter held at its limit), 0 where none."""
    y = np.asarray(y, dtype=np.float64)
    if y.size == 0:
        return 0
    runs = np.r_[_runs_at(y, float(y.max())), _runs_at(y, float(y.min()))]
    return int(runs[runs >= CLIP_RUN].sum())


def spectral_peak(y: ArrayLike, rate: float, above: float = 0.0) -> F64:
    """The frequency of the largest spectral peak of each row of ``y`` (s, n) or of ``y`` (n,),
    Hz (mean removed, zero padded to ≥ 4n, parabolic interpolation of the log magnitude;
    frequencies below one period in the record, and below ``above`` Hz, excluded). No window:
    a ring-down tapers itself, and a window would weight its decayed middle over its strong
    start."""
    y = np.atleast_2d(np.asarray(y, dtype=np.float64))
    n = y.shape[1]
    size = 1 << max(math.ceil(math.log2(max(n, 2))) + 2, 4)
    spec = np.abs(np.fft.rfft(y - y.mean(axis=1, keepdims=True), size, axis=1))
    spec[:, : max(2, math.ceil(size / n), math.ceil(above * size / rate))] = 0.0
    k = np.clip(np.argmax(spec, axis=1), 1, spec.shape[1] - 2)
    rows = np.arange(y.shape[0])
    lo, mid, hi = (np.log(spec[rows, k + d] + 1e-300) for d in (-1, 0, 1))
    den = lo - 2.0 * mid + hi
    shift = np.where(den < 0.0, 0.5 * (lo - hi) / np.where(den < 0.0, den, -1.0), 0.0)
    return np.asarray((k + np.clip(shift, -0.5, 0.5)) * rate / size, dtype=np.float64)


def envelope(y: ArrayLike, rate: float, frequency: ArrayLike) -> tuple[F64, F64]:
    """The envelope of each row of ``y`` (s, n) about zero: the largest ``|y|`` in blocks of one
    period of ``frequency`` (Hz, the batch's median; a partial last block left out), with the
    blocks' centre sample indices: (s, blocks) and (blocks,)."""
    y = np.atleast_2d(np.asarray(y, dtype=np.float64))
    width = max(2, round(rate / float(np.median(np.asarray(frequency, dtype=np.float64)))))
    blocks = max(1, y.shape[1] // width)
    width = min(width, y.shape[1])
    env = np.abs(y[:, : blocks * width]).reshape(y.shape[0], blocks, width).max(axis=2)
    return env, np.arange(blocks) * width + 0.5 * (width - 1)


def floor(noise: ArrayLike, rate: float, frequency: float) -> F64:
    """Where the envelope of :func:`envelope` meets the noise: :data:`FLOOR_SIGMAS` noise σ, or
    more where a period holds many samples (the largest of w samples of noise alone is
    ≈ σ √(2 ln w))."""
    w = max(rate / frequency, 2.0)
    return np.asarray(noise, dtype=np.float64) * max(FLOOR_SIGMAS,
                                                     math.sqrt(2.0 * math.log(w)) + 1.0)


def noise_sigma(y: F64, peak: int) -> float:
    """The noise σ of a record: the robust spread (1.4826 MAD) of the samples before the flick
    (where ≥ :data:`MIN_REST_SAMPLES` of them), or that of the last fifth's sample-to-sample
    differences / √2, whichever is smaller (the signal's unit)."""
    candidates = []
    rest = y[: int(0.8 * peak)]
    if rest.size >= MIN_REST_SAMPLES:
        candidates.append(1.4826 * float(np.median(np.abs(rest - np.median(rest)))))
    tail = np.diff(y[-max(y.size // 5, 8):])
    candidates.append(1.4826 * float(np.median(np.abs(tail - np.median(tail)))) / math.sqrt(2))
    return max(min(candidates), 1e-300)


def free_segment(y: ArrayLike, rate: float, start: int | None = None, *,
                 where: str = "the recording") -> Segment:
    """Where the free oscillation of one record ``y`` (n,) sampled at ``rate`` (Hz) is.

    ``start`` (a sample index) overrides the start found at the flick's peak. Errors (one line,
    :class:`~magcilia.MagciliaError`, naming ``where``): a record too short to hold a segment,
    a spectral peak at or near the Nyquist frequency (the sample rate below twice the
    oscillation's frequency).
    """
    y = np.asarray(y, dtype=np.float64)
    if y.size < 16:
        raise MagciliaError(f"{where}: {y.size} samples; a ring-down needs at least two periods "
                            "of free oscillation, many samples each")
    rest = float(np.median(y))
    dev = np.abs(y - rest)
    found = start is None
    if start is not None and not 0 <= start < y.size:
        raise MagciliaError(f"{where}: the start (sample {start}) lies outside its {y.size} "
                            "samples; give a start within the record")
    peak = int(np.argmax(dev)) if start is None else start
    noise = noise_sigma(y, peak)
    largest = float(dev[peak:].max())
    if largest < MIN_SIGNAL_SIGMAS * noise:
        raise MagciliaError(
            f"{where}: no free oscillation: the largest deviation from the rest level is "
            f"{largest / noise:.3g} noise σ; a ring-down needs a flick that stands well "
            f"above the noise (≥ {MIN_SIGNAL_SIGMAS:g} σ)")
    if start is None:  # a held deflection (or a flat top): start just after its release
        swing = (y[peak:] - rest) * np.sign(y[peak] - rest)
        crossed = np.flatnonzero(swing < 0.0)
        top = swing[: int(crossed[0]) if crossed.size else swing.size]
        start = peak + int(np.flatnonzero(top >= 0.5 * top[0])[-1])
    if y.size - start < 16 and found:
        raise MagciliaError(f"{where}: no free oscillation: the largest deviation comes at the "
                            "end of the record (the signal grows, or the record stops during "
                            "the flick); record the ring-down after the flick")
    if y.size - start < 16:
        raise MagciliaError(f"{where}: the free oscillation starts {y.size - start} samples "
                            "before the end; record longer after the flick (at least two "
                            "periods)")
    seg = y[start:] - rest
    f0 = float(spectral_peak(seg, rate)[0])
    if f0 >= NYQUIST_FRACTION * rate:
        raise MagciliaError(
            f"{where}: the oscillation's frequency is at or beyond what {rate:g} samples/s "
            f"resolve (spectral peak {f0:.4g} Hz, Nyquist {rate / 2:g} Hz); sample at least "
            "five times faster than the ring-down's frequency")
    env, centre = envelope(seg, rate, f0)
    below = np.flatnonzero(env[0] < floor(noise, rate, f0))
    period = rate / f0
    end = int(centre[below[0]] + period) if below.size else seg.size
    stop = start + min(seg.size, max(end, round(FIT_PERIODS * period)))
    return Segment(start, max(stop, start + 2), rest, noise, f0)


def first_guess(t: F64, y: F64, rate: float, frequency: F64 | None = None,
                noise: F64 | None = None) -> F64:
    """Starting points ``[a, b, decay, omega, offset]`` (s, 5) for segments ``y`` (s, n) at
    times ``t`` (n,): the spectral peak (or ``frequency``, Hz, per row), the decay from a line
    through the log of the envelope's blocks that stand twice above its floor (:func:`floor` of
    ``noise``, per row; the last tenth's spread by default), and ``a, b, offset`` by linear
    least squares."""
    s, n = y.shape
    c0 = np.median(y[:, -max(n // 10, 4):], axis=1)
    f = spectral_peak(y, rate) if frequency is None else np.asarray(frequency, dtype=np.float64)
    f = np.broadcast_to(f, (s,))
    env, centre = envelope(y - c0[:, None], rate, f)
    if noise is None:
        noise = 1.4826 * np.median(np.abs(y[:, -max(n // 10, 4):] - c0[:, None]), axis=1)
    level = floor(np.broadcast_to(np.asarray(noise, dtype=np.float64), (s,)), rate,
                  float(np.median(f)))
    use = env > 2.0 * level[:, None]
    use[use.sum(axis=1) < 2] = True  # too few blocks above the floor: all of them
    w = use.astype(np.float64)
    tb = centre / rate
    logenv = np.log(np.maximum(env, 1e-300))
    sw = w.sum(axis=1)
    tm = (w * tb).sum(axis=1) / sw
    lm = (w * logenv).sum(axis=1) / sw
    slope = (w * (tb - tm[:, None]) * (logenv - lm[:, None])).sum(axis=1) / np.maximum(
        (w * (tb - tm[:, None]) ** 2).sum(axis=1), 1e-300)
    decay = -slope
    omega = 2.0 * np.pi * f
    e = np.exp(-decay[:, None] * t)
    basis = np.stack([e * np.cos(omega[:, None] * t), e * np.sin(omega[:, None] * t),
                      np.ones((s, n))], axis=2)  # (s, n, 3)
    gram = np.einsum("snp,snq->spq", basis, basis)
    coef = np.linalg.solve(gram, np.einsum("snp,sn->sp", basis, y)[..., None])[..., 0]
    return np.column_stack([coef[:, 0], coef[:, 1], decay, omega, coef[:, 2]])


def damped_model(t: F64, x: F64) -> tuple[F64, F64]:
    """The damped sinusoid(s) of parameters ``x`` (m, 5 or 9) at ``t`` (n,) and the Jacobian
    (m, n, p)."""
    m = x.shape[0]
    jac = np.empty((m, t.size, x.shape[1]))
    y = np.broadcast_to(x[:, 4:5], (m, t.size)).copy()
    jac[:, :, 4] = 1.0
    for cols in ((0, 1, 2, 3), (5, 6, 7, 8)) if x.shape[1] == 9 else ((0, 1, 2, 3),):
        a, b, g, w = (x[:, c:c + 1] for c in cols)
        e = np.exp(-g * t)
        cos, sin = np.cos(w * t), np.sin(w * t)
        osc = e * (a * cos + b * sin)
        y += osc
        jac[:, :, cols[0]] = e * cos
        jac[:, :, cols[1]] = e * sin
        jac[:, :, cols[2]] = -t * osc
        jac[:, :, cols[3]] = t * e * (b * cos - a * sin)
    return y, jac


@dataclass(frozen=True)
class DampedFit:
    """Fitted free oscillations of ``s`` segments: parameters ``x`` (s, p) in the order of
    :data:`NAMES` (+ :data:`SECOND`), their covariance (s, p, p), the residual noise σ (s,) and
    the degrees of freedom."""

    x: F64
    covariance: F64
    noise: F64
    dof: int
    converged: NDArray[np.bool_]

    @property
    def sigma(self) -> F64:
        """1 σ of each parameter (s, p)."""
        return np.asarray(np.sqrt(np.abs(np.diagonal(self.covariance, axis1=1, axis2=2))))


def fit_damped(t: ArrayLike, y: ArrayLike, x0: ArrayLike) -> DampedFit:
    """Least squares of damped sinusoids (+ offset) to segments ``y`` (s, n) at times ``t`` (n,)
    from starts ``x0`` (s, 5), or (s, 9) with a second mode: one :func:`fit_batch` call.

    The frequency stays within a factor 2 of its start, the decay within ±(start's ω); σ from
    ``s² (JᵀJ)⁻¹``, ``s² = χ²/(n − p)``.
    """
    t = np.asarray(t, dtype=np.float64)
    data = np.atleast_2d(np.asarray(y, dtype=np.float64))
    start = np.atleast_2d(np.asarray(x0, dtype=np.float64))
    s, p = start.shape
    lower = np.full((s, p), -np.inf)
    upper = np.full((s, p), np.inf)
    for g, w in ((2, 3), (7, 8)) if p == 9 else ((2, 3),):
        lower[:, w], upper[:, w] = 0.5 * start[:, w], 2.0 * start[:, w]
        lower[:, g], upper[:, g] = -start[:, w], start[:, w]
    start = np.clip(start, lower, upper)

    def residuals(x: F64, which: NDArray[np.intp]) -> tuple[F64, F64]:
        model, jac = damped_model(t, x)
        return model - data[which], jac

    fit = fit_batch(residuals, start, lower, upper, jacobian=True, maxiter=100, ftol=1e-14,
                    xtol=1e-13)
    dof = max(t.size - p, 1)
    s2 = fit.cost / dof
    with np.errstate(invalid="ignore", over="ignore"):
        try:
            inverse = np.linalg.inv(fit.jtj)
        except np.linalg.LinAlgError:
            inverse = np.linalg.pinv(fit.jtj)
    return DampedFit(fit.x, inverse * s2[:, None, None], np.sqrt(s2), dof, fit.converged)
