"""Free oscillations in a time series: where they are, a first guess, and the fit (no physics).

A flick or a coil pulse makes the cilium ring; the output (or a field channel) is then a damped
sinusoid on an offset, ``y(t) = c + e^(−γt) (a cos ωt + b sin ωt)``, until it sinks into the
sensor's noise. The steps (:func:`free_segment`, :func:`first_guess`, :func:`fit_damped`):

1. **Segment.** The free oscillation starts at the largest deviation from the rest level (the
   median of the record's last fifth), or just after it where the deviation is held (a
   deflection held and released, or a clipped flick), and ends where its envelope (the
   Hilbert transform's magnitude, averaged over one period) falls below
   :data:`FLOOR_SIGMAS` × the noise σ (the robust spread before the flick, or of the
   tail's sample-to-sample differences).
2. **First guess.** The frequency from the spectral peak of the segment (Hann window, zero
   padded, parabolic interpolation of the log magnitude); the decay rate from a straight line
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

#: the envelope's end: this many noise σ (the Hilbert envelope of noise alone averages ≈ 1.25 σ)
FLOOR_SIGMAS = 3.0
#: fewest periods a ring-down must hold
MIN_PERIODS = 2.0
#: a run of at least this many equal samples at the segment's extreme is a clipped one
CLIP_RUN = 3
#: the spectral peak above this fraction of the sample rate is too close to the Nyquist frequency
NYQUIST_FRACTION = 0.4
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


def spectral_peak(y: ArrayLike, rate: float) -> F64:
    """The frequency of the largest spectral peak of each row of ``y`` (s, n) or of ``y`` (n,),
    Hz (mean removed, Hann window, zero padded to ≥ 4n, parabolic interpolation of the log
    magnitude; the zero-frequency bin excluded)."""
    y = np.atleast_2d(np.asarray(y, dtype=np.float64))
    n = y.shape[1]
    size = 1 << max(math.ceil(math.log2(max(n, 2))) + 2, 4)
    w = np.hanning(n)
    spec = np.abs(np.fft.rfft((y - y.mean(axis=1, keepdims=True)) * w, size, axis=1))
    spec[:, :2] = 0.0
    k = np.clip(np.argmax(spec, axis=1), 1, spec.shape[1] - 2)
    rows = np.arange(y.shape[0])
    lo, mid, hi = (np.log(spec[rows, k + d] + 1e-300) for d in (-1, 0, 1))
    den = lo - 2.0 * mid + hi
    shift = np.where(den < 0.0, 0.5 * (lo - hi) / np.where(den < 0.0, den, -1.0), 0.0)
    return np.asarray((k + np.clip(shift, -0.5, 0.5)) * rate / size, dtype=np.float64)


def envelope(y: ArrayLike, rate: float, frequency: ArrayLike) -> F64:
    """The envelope of each row of ``y`` (s, n) about zero: the magnitude of its analytic signal
    averaged over one period of ``frequency`` (Hz, per row), same shape."""
    from scipy.signal import hilbert

    y = np.atleast_2d(np.asarray(y, dtype=np.float64))
    env = np.abs(hilbert(y, axis=1))
    width = np.maximum(1, np.round(rate / np.asarray(frequency, dtype=np.float64)).astype(int))
    width = np.broadcast_to(width, (y.shape[0],))
    out = np.empty_like(env)
    csum = np.concatenate([np.zeros((y.shape[0], 1)), np.cumsum(env, axis=1)], axis=1)
    n = y.shape[1]
    idx = np.arange(n)
    for i, w in enumerate(width):  # one moving mean per row (rows of one batch share w)
        lo = np.clip(idx - w // 2, 0, n)
        hi = np.clip(idx - w // 2 + w, 0, n)
        out[i] = (csum[i, hi] - csum[i, lo]) / np.maximum(hi - lo, 1)
    return out


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
    rest = float(np.median(y[-max(y.size // 5, 8):]))
    dev = np.abs(y - rest)
    if start is None:
        peak = int(np.argmax(dev))
        runs = np.flatnonzero(y[peak:] != y[peak])  # a held (or clipped) peak: start at release
        start = peak + (int(runs[0]) - 1 if runs.size else 0)
    else:
        peak = start
    if y.size - start < 16:
        raise MagciliaError(f"{where}: the free oscillation starts {y.size - start} samples "
                            "before the end; record longer after the flick (at least two "
                            "periods)")
    noise = noise_sigma(y, peak)
    seg = y[start:] - rest
    f0 = float(spectral_peak(seg, rate)[0])
    if f0 >= NYQUIST_FRACTION * rate:
        raise MagciliaError(
            f"{where}: the oscillation's frequency is at or beyond what {rate:g} samples/s "
            f"resolve (spectral peak {f0:.4g} Hz, Nyquist {rate / 2:g} Hz); sample at least "
            "five times faster than the ring-down's frequency")
    env = envelope(seg, rate, f0)[0]
    below = np.flatnonzero(env < FLOOR_SIGMAS * noise)
    stop = start + (int(below[0]) if below.size else seg.size)
    return Segment(start, max(stop, start + 2), rest, noise, f0)


def first_guess(t: F64, y: F64, rate: float, frequency: F64 | None = None,
                noise: F64 | None = None) -> F64:
    """Starting points ``[a, b, decay, omega, offset]`` (s, 5) for segments ``y`` (s, n) at
    times ``t`` (n,): the spectral peak (or ``frequency``, Hz, per row), the decay from a line
    through the log envelope above :data:`FLOOR_SIGMAS` × ``noise`` (per row; the last tenth's
    spread by default), and ``a, b, offset`` by linear least squares."""
    s, n = y.shape
    c0 = np.median(y[:, -max(n // 10, 4):], axis=1)
    f = spectral_peak(y, rate) if frequency is None else np.asarray(frequency, dtype=np.float64)
    f = np.broadcast_to(f, (s,))
    env = envelope(y - c0[:, None], rate, f)
    if noise is None:
        noise = 1.4826 * np.median(np.abs(y[:, -max(n // 10, 4):] - c0[:, None]), axis=1)
    floor = FLOOR_SIGMAS * np.broadcast_to(np.asarray(noise, dtype=np.float64), (s,))
    period = np.maximum(1, (rate / f).astype(int))
    use = (env > floor[:, None]) & (np.arange(n) >= (period // 2)[:, None]) \
        & (np.arange(n) < n - (period // 2)[:, None])
    use[use.sum(axis=1) < 4] = True  # too few above the floor: the whole segment
    w = use.astype(np.float64)
    logenv = np.log(np.maximum(env, 1e-300))
    sw = w.sum(axis=1)
    tm = (w * t).sum(axis=1) / sw
    lm = (w * logenv).sum(axis=1) / sw
    slope = (w * (t - tm[:, None]) * (logenv - lm[:, None])).sum(axis=1) / np.maximum(
        (w * (t - tm[:, None]) ** 2).sum(axis=1), 1e-300)
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
