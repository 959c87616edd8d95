"""Synthetic recordings for tests, demos and benchmarks (always labelled synthetic).

A recording is made from a :class:`~magcilia.Setup` (the truth) by sampling its output at each
tilt angle and adding what a real bench adds: the sensor's white + 1/f noise (``Sensor.noise``),
white read-out noise of the amplifier and DAQ, a slow drift over the whole run and a DC bias
(earth's and lab fields, bridge offset).
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np
from numpy.typing import ArrayLike, NDArray

from magcilia import _validate as v
from magcilia.device.setup import Setup

F64 = NDArray[np.float64]


@dataclass(frozen=True)
class Recording:
    """Raw samples of a synthetic recording.

    Attributes
    ----------
    angle_deg : ndarray, shape (s,)
        Tilt angle of each sample, degrees (the file convention).
    voltage : ndarray, shape (s,)
        Output, V.
    time : ndarray, shape (s,)
        Sample time from the start of the run, s.
    """

    angle_deg: F64
    voltage: F64
    time: F64


def synthetic_recording(
    setup: Setup,
    angles: ArrayLike,
    *,
    samples_per_angle: int = 2000,
    rate: float = 1000.0,
    settle: float = 1.0,
    readout_noise: float = 2e-4,
    drift: float = 2e-5,
    bias: float = 2.0e-3,
    rng: int | np.random.Generator | None = None,
) -> Recording:
    """Simulate the paper's measurement of ``setup`` at the given tilt angles.

    Parameters
    ----------
    setup : Setup
        The true sensor (its ``sensor.offset`` adds to ``bias``).
    angles : array-like, shape (a,)
        Tilt angles, rad, in the order they are visited.
    samples_per_angle : int
        Samples recorded at each angle (paper: 2000).
    rate : float
        Sampling rate, Hz (paper: 1 kHz).
    settle : float
        Pause between angles (moving the thread), s; drift continues during it.
    readout_noise : float
        White noise of amplifier + DAQ per sample, V rms (a 16-bit ±10 V DAQ has a 0.3 mV step).
    drift : float
        Linear output drift over the whole run, V.
    bias : float
        DC bias added to every sample, V.
    rng : int, Generator or None
        Randomness; None (default) draws fresh entropy, an int repeats the recording.
    """
    ang = v.finite_array("angles", angles, ndim=1, unit="rad")
    n = v.integer("samples_per_angle", samples_per_angle, 2)
    rate = v.positive("rate", rate, "Hz", "frequency")
    gen = np.random.default_rng(rng)
    clean = setup.output(ang)
    block = n / rate + settle
    t = (np.arange(ang.size)[:, None] * block + np.arange(n)[None, :] / rate).ravel()
    total = max(float(t[-1]), 1.0 / rate)
    # the sensor's 1/f noise is one continuous record over the run (it does not restart)
    n_total = math.ceil(total * rate) + 1
    sensor_noise = setup.sensor.noise(n_total, rate, rng=gen)
    idx = np.minimum(np.rint(t * rate).astype(np.int64), n_total - 1)
    volts = (np.repeat(clean, n) + sensor_noise[idx] + readout_noise * gen.standard_normal(t.size)
             + bias + drift * t / total)
    return Recording(np.repeat(np.degrees(ang), n), volts, t)
