"""Synthetic recordings for tests, demos and benchmarks (always labelled synthetic).

A recording is made from a :class:`~magcilia.Setup` (the truth) by sampling its output at each
tilt angle and adding what a real bench adds: the sensor's white + 1/f noise (``Sensor.noise``),
white read-out noise of the amplifier and DAQ, a slow drift over the whole run and a DC bias
(earth's and lab fields, bridge offset).

The clean signal comes from the setup's dipole layout, or, with ``exact_slices=n``, from the
exact body (:func:`magcilia.model.exact_field`, a stack of ``n`` magpylib cylinders: what a real
hair of that shape gives), so that a fit with any dipole layout meets its own model error.

:func:`synthetic_field_recording` makes the 3-axis kind: a magnetometer at the sensing point read
while the cilium is tilted toward several azimuths (``Setup.field(angles, azimuth=φ)``), with
white noise per component and an optional constant background field;
:meth:`FieldRecording.write_csv` writes it as a raw-sample CSV recording
(``angle_deg,azimuth_deg,field_x_T,field_y_T,field_z_T``) that
:func:`magcilia.read_measurements` reads.

Examples
--------
>>> import magcilia as mc
>>> rec = synthetic_field_recording(mc.Setup.paper(), np.radians([0.0, 40.0]),
...                                 np.radians([0.0, 90.0]), samples_per_angle=3, rng=0)
>>> rec.field.shape, sorted(set(rec.azimuth_deg.tolist()))
((12, 3), [0.0, 90.0])
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from pathlib import Path

import numpy as np
from numpy.typing import ArrayLike, NDArray

from magcilia import _validate as v
from magcilia.device.setup import Setup
from magcilia.io.csvfile import write_samples_csv
from magcilia.model.azimuth import field_from_tilt_frame, placement_in_tilt_frame
from magcilia.model.exact import exact_field

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


def clean_field(setup: Setup, angles: F64, azimuth: float = 0.0,
                exact_slices: int | None = None) -> F64:
    """The noise-free field at the sensing element, T, shape (a, 3), for tilts by ``angles``
    (rad) toward ``azimuth`` (rad): the setup's dipole layout (``exact_slices=None``,
    :meth:`Setup.field`), or the exact body as a stack of ``exact_slices`` magpylib cylinders
    (:func:`magcilia.model.exact_field`; error O(1/n²), ~1e-6 relative at 2000)."""
    if exact_slices is None:
        return setup.field(angles, azimuth=azimuth)
    n = v.integer("exact_slices", exact_slices, 1)
    if azimuth == 0.0:
        return exact_field(setup, angles, n_slices=n)
    x, y = placement_in_tilt_frame(setup.position[0], setup.position[1], azimuth)
    turned = setup.replace(position=(float(x), float(y), setup.position[2]))
    return field_from_tilt_frame(exact_field(turned, angles, n_slices=n), azimuth)


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
    exact_slices: int | None = None,
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
    exact_slices : int, optional
        None (default): the clean output from the setup's dipole layout; an int: from the exact
        body, a stack of that many magpylib cylinders (see :func:`clean_field`).
    rng : int, Generator or None
        Randomness; None (default) draws fresh entropy, an int repeats the recording.
    """
    ang = v.finite_array("angles", angles, ndim=1, unit="rad")
    n = v.integer("samples_per_angle", samples_per_angle, 2)
    rate = v.positive("rate", rate, "Hz", "frequency")
    gen = np.random.default_rng(rng)
    clean = (setup.output(ang) if exact_slices is None
             else setup.sensor.voltage(clean_field(setup, ang, 0.0, exact_slices)[:, 0]))
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


@dataclass(frozen=True)
class FieldRecording:
    """Raw samples of a synthetic 3-axis recording at several tilt azimuths.

    Attributes
    ----------
    angle_deg : ndarray, shape (s,)
        Tilt angle of each sample, degrees (the file convention).
    azimuth_deg : ndarray, shape (s,)
        Tilt direction of each sample, degrees (0: toward +x).
    field : ndarray, shape (s, 3)
        Field (B_x, B_y, B_z) at the sensing point, T.
    """

    angle_deg: F64
    azimuth_deg: F64
    field: F64

    def columns(self) -> dict[str, F64]:
        """The samples by the recording's column names (``angle_deg``, ``azimuth_deg``,
        ``field_x_T``, ``field_y_T``, ``field_z_T``), each shape (s,)."""
        return {"angle_deg": self.angle_deg, "azimuth_deg": self.azimuth_deg,
                "field_x_T": self.field[:, 0], "field_y_T": self.field[:, 1],
                "field_z_T": self.field[:, 2]}

    def write_csv(self, path: str | Path) -> Path:
        """Write the samples as a CSV recording (atomically; labelled synthetic in a comment
        line; values with 17 digits, read back exactly); returns ``path``."""
        return write_samples_csv(path, self.columns(),
                                 comment="SYNTHETIC 3-axis recording (not a measurement)")


def synthetic_field_recording(
    setup: Setup,
    angles: ArrayLike,
    azimuths: ArrayLike = (0.0,),
    *,
    samples_per_angle: int = 200,
    noise: float = 1e-7,
    background: ArrayLike = (0.0, 0.0, 0.0),
    exact_slices: int | None = None,
    rng: int | np.random.Generator | None = None,
) -> FieldRecording:
    """Simulate a 3-axis magnetometer at the sensing point while ``setup``'s cilium is tilted to
    each angle toward each azimuth (azimuth by azimuth, the angles in the order given).

    Parameters
    ----------
    setup : Setup
        The true cilium and placement (:meth:`~magcilia.Setup.field` with ``azimuth=φ``).
    angles : array-like, shape (a,)
        Tilt angles, rad.
    azimuths : array-like, shape (z,)
        Tilt directions, rad (0: toward +x, the paper's path; π/2: toward +y).
    samples_per_angle : int
        Samples recorded at each (azimuth, angle).
    noise : float
        White noise of each component per sample, T rms (a 3-axis Hall or magneto-resistive
        magnetometer: about 0.1 µT).
    background : array-like, shape (3,)
        Constant field added to every sample (the earth's and the lab's), T.
    exact_slices : int, optional
        None (default): the clean field from the setup's dipole layout; an int: from the exact
        body, a stack of that many magpylib cylinders (see :func:`clean_field`).
    rng : int, Generator or None
        Randomness; None (default) draws fresh entropy, an int repeats the recording.

    Returns
    -------
    FieldRecording
        ``z · a · samples_per_angle`` samples.
    """
    ang = v.finite_array("angles", angles, ndim=1, unit="rad")
    phis = v.finite_array("azimuths", azimuths, ndim=1, unit="rad")
    if ang.size < 1 or phis.size < 1:
        raise v.fail("angles" if ang.size < 1 else "azimuths", "an empty array",
                     "at least one value in rad")
    n = v.integer("samples_per_angle", samples_per_angle, 1)
    sigma = v.non_negative("noise", noise, "T", "field")
    bg = v.finite_array("background", background, ndim=1, unit="T")
    if bg.shape != (3,):
        raise v.fail("background", f"shape {bg.shape}", "3 components (B_x, B_y, B_z) in T")
    gen = np.random.default_rng(rng)
    clean = np.concatenate([clean_field(setup, ang, float(phi), exact_slices)
                            for phi in phis])  # (z·a, 3)
    field = np.repeat(clean, n, axis=0) + bg + sigma * gen.standard_normal((clean.shape[0] * n,
                                                                             3))
    return FieldRecording(np.tile(np.repeat(np.degrees(ang), n), phis.size),
                          np.repeat(np.degrees(phis), ang.size * n), field)
