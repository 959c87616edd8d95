"""A start-up coil self-test: the device's own sensitivity, magnetization and stiffness estimated
from a few known applied fields, no rig, no known load, no photo — the ``self_test`` option of
:class:`magcilia.design.robust.RobustSpec` (``magcilia optimise --objective robust --self-test
coil``).

**The test** (:class:`CoilSelfTest`), at start-up with the hair unloaded: the AMR's set/reset
strap pulse (the bridge flips, its offset does not: the offset, as
:class:`magcilia.readout.recalibration_windows.StrapWindow`), a rest window (the unloaded level),
and four coil pulses of a uniform field ±B along the sensing axis x and ±B across it (y), each
window averaged for ``window`` seconds, the sequence repeated ``cycles`` times (the windows
averaged over the cycles): ``7 × window × cycles`` of coil and strap in all. ``B`` is
``level`` times the sensor's linear range (default ½: 3 G on the HMC1021Z, far below its 20 G flip
field and the cilium's; the hair's own ~0.5 G and the Earth's keep the total in range).

**The estimate** is :class:`magcilia.readout.recalibration.Recalibrator`'s model, with the nominal
design as "the calibration" and a device's departures as its drifts s (sensitivity), m
(magnetization) and k (stiffness, E) — solved in closed form for every device at once (the ±
pulses differenced, so the model's odd part)::

    o = strap level,   L = rest − o = S·s·m·B₀,
    X = S·s·(B + (m²/k)·r_x),   Y = S·s·(m²/k)·r_y

with S the nominal scale (V/T), B₀ the nominal hair's field at the element at rest and r_x, r_y
its exact field changes there under the pulses (odd parts), all from the nominal model. Then
``s·(m²/k) = Y/(S r_y)``, ``s = (X/S − r_x·s·m²/k)/B``, ``m = L/(S s B₀)``, ``k = m²/(m²/k)``.
The device's geometry and placement stay at the nominal values: what they change in L, X and Y
is taken for s, m, k — the self-test's residual error, which :func:`magcilia.design.robust
.calibration_free_error` measures.

**The read-out with it** (:meth:`~magcilia.readout.recalibration.Recalibration.correct`'s rule):
an output V becomes ``V' = V₀ + (V − V_rest)/(s·m)`` (tared; untared ``o₀ + (V − o)/(s·m)``),
read through the nominal table and multiplied by k (the elastica depends on F/EI only). A
self-test whose s, m or k comes out beyond ¼..4 (:data:`REACH`) has failed — the pulses could not
separate them, e.g. an element on a vertical plane of symmetry through the hair (x = 0 or
y = 0), where a y pulse does not change B_x —
and the device is read with the nominal model (counted in
:attr:`~magcilia.design.robust.CalibrationFreeError.self_test_failed`).

**Noise**: each window's mean carries the sensor's noise (:meth:`magcilia.Sensor.noise_rms`
between ``1/(2·total)`` and ``1/(2·window)`` Hz: the band of a window mean within the test, its
1/f part included, over √cycles), drawn per device from the spec's seed.
SI units: T, V, s.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Any

import numpy as np
from numpy.typing import NDArray

from magcilia import _validate as v
from magcilia._display import Display, Item
from magcilia.device.setup import Setup

F64 = NDArray[np.float64]

#: the self-test's windows: strap (set and reset), rest, +x, −x, +y, −y pulses
WINDOWS = 7


@dataclass(frozen=True, eq=False, repr=False)
class CoilSelfTest(Display):
    """A start-up coil self-test (module docstring).

    Attributes
    ----------
    level : float
        Pulse field as a fraction of the sensor's linear range (0 < level < 1; default 0.5).
    window : float
        Averaging time of each window, s (default 0.25).
    cycles : int
        Repetitions of the sequence, averaged (default 4: 7 s of test in all).
    noise : bool
        Whether the sensor's noise enters the windows (default True).
    """

    level: float = 0.5
    window: float = 0.25
    cycles: int = 4
    noise: bool = True

    def __post_init__(self) -> None:
        level = v.real("self-test level", self.level)
        if not 0.0 < level < 1.0:
            raise v.fail("self-test level", level, "a fraction of the sensor's range in (0, 1)")
        object.__setattr__(self, "level", level)
        object.__setattr__(self, "window", v.positive("self-test window", self.window, "s"))
        object.__setattr__(self, "cycles", v.integer("self-test cycles", self.cycles, 1))
        if not isinstance(self.noise, bool):
            raise v.fail("self-test noise", self.noise, "True or False")

    @property
    def duration(self) -> float:
        """The test's length, s: its windows' averaging times over every cycle."""
        return WINDOWS * self.window * self.cycles

    def pulse(self, setup: Setup) -> float:
        """The pulse field, T, for ``setup``'s sensor."""
        return self.level * float(setup.sensor.field_range)

    def window_noise(self, setup: Setup) -> float:
        """The standard deviation of one window's mean over the cycles, V (module docstring):
        the noise in the band of one window's mean, over √cycles."""
        sensor = setup.sensor
        band = sensor.noise_rms(1.0 / (2.0 * self.duration), 1.0 / (2.0 * self.window))
        return float(sensor.scale) * float(band) / float(np.sqrt(self.cycles))

    def fields(self, setup: Setup) -> F64:
        """The applied fields (5, 3), T: rest, +x, −x, +y, −y."""
        b = self.pulse(setup)
        return np.array([[0, 0, 0], [b, 0, 0], [-b, 0, 0], [0, b, 0], [0, -b, 0]],
                        dtype=np.float64)

    def to_dict(self) -> dict[str, Any]:
        """JSON-ready content."""
        return {"level": self.level, "window_s": self.window, "cycles": self.cycles,
                "duration_s": self.duration, "noise": self.noise}

    def report(self) -> str:
        """One line: the pulses and the time."""
        return (f"coil self-test: ±{self.level:.3g}× the sensor's range along x and y, "
                f"{self.window:.3g} s per window, {self.cycles} cycles, {self.duration:.3g} s "
                "in all"
                f"{'' if self.noise else ', noise-free'}")

    def _display_items(self) -> list[Item]:
        return [("pulses", f"±{self.level:.3g}× the range along x, y"),
                ("window", f"{self.window:.3g} s"), ("cycles", str(self.cycles)),
                ("duration", f"{self.duration:.3g} s"),
                ("noise", str(self.noise))]


def responses(setup: Setup, test: CoilSelfTest, prm: dict[str, F64], scale: F64
              ) -> tuple[F64, F64, F64]:
    """The self-test's windows of parameter sets ``prm`` (each (N,): height, base_radius, x, y,
    z, youngs_modulus, magnetization_scale; the calibration's batched coil model
    :func:`magcilia.calibration.coil_model.cilium_fields`), noise-free, relative to the sensor's
    offset and in field units times the sensitivity factor ``scale`` (N,): the rest level
    ``S s B₀`` (N,), V, and the odd parts of the x and y pulses, V (N,) each."""
    from magcilia.calibration.coil_model import cilium_fields

    fields = test.fields(setup)
    b = cilium_fields(setup, fields, prm)[:, :, 0]
    s = float(setup.sensor.scale) * scale
    rest = s * b[:, 0]
    x = s * (0.5 * (b[:, 1] - b[:, 2]) + fields[1, 0])
    y = s * 0.5 * (b[:, 3] - b[:, 4])
    return rest, x, y


def estimate(setup: Setup, test: CoilSelfTest, observed: tuple[F64, F64, F64, F64]
             ) -> dict[str, F64]:
    """Each device's sensitivity, magnetization and stiffness scales (s, m, k; (N,) each,
    relative to ``setup``'s) and offset (V) from its self-test windows ``observed`` = (strap
    offset, rest level, x pulse, y pulse), V, each (N,) — the closed form of the module
    docstring, the nominal ``setup``'s model for B₀, r_x and r_y; NaN or ±inf where the
    windows cannot determine them (r_y = 0: an element on a vertical plane of symmetry
    through the hair, x = 0 or y = 0)."""
    prm = {k: np.array([float(val)]) for k, val in (
        ("height", setup.cilium.height), ("base_radius", setup.cilium.base_radius),
        ("x", setup.value("x")), ("y", setup.value("y")), ("z", setup.value("z")),
        ("youngs_modulus", setup.youngs_modulus),
        ("magnetization_scale", setup.value("magnetization_scale")))}
    rest0, x0, y0 = (float(a[0]) for a in responses(setup, test, prm, np.ones(1)))
    scale = float(setup.sensor.scale)
    b = test.pulse(setup)
    b0, rx, ry = rest0 / scale, x0 / scale - b, y0 / scale
    offset, level, x, y = observed
    with np.errstate(divide="ignore", invalid="ignore"):  # r_y = 0: undetermined (inf, NaN)
        sq = y / (scale * ry)  # s·m²/k
        s = (x / scale - rx * sq) / b
        m = (level - offset) / (scale * s * b0)
        k = m * m * s / sq
    return {"offset": offset, "sensitivity": s, "magnetization": m, "stiffness": k}


def measure(setup: Setup, test: CoilSelfTest, prm: dict[str, F64], own: F64,
            gen: np.random.Generator) -> tuple[F64, F64, F64, F64]:
    """The self-test windows (strap offset, rest level, x and y pulses; V, (N,) each) of the
    devices ``prm`` (as :func:`responses`) whose moments are ``own`` (N,) times the model's
    (their magnetization relative to ``setup``'s), the sensor's noise from ``gen``."""
    n = own.size
    dev = {**prm, "magnetization_scale": own * float(setup.value("magnetization_scale"))}
    rest, x, y = responses(setup, test, dev, np.ones(n))
    offset = np.full(n, float(setup.sensor.offset))
    level = offset + rest
    out = [offset, level, x, y]
    if test.noise:
        sigma = test.window_noise(setup)
        # strap: mean of the set and reset windows; rest: one window; pulses: odd part of two
        factors = (np.sqrt(0.5), 1.0, np.sqrt(0.5), np.sqrt(0.5))
        out = [a + f * sigma * gen.standard_normal(n) for a, f in zip(out, factors, strict=True)]
    return out[0], out[1], out[2], out[3]


#: the read-out table reaches beyond the range to the softest device's estimated range (a device
#: less stiff than nominal maps the range onto nominal forces up to span/k), at most this far; a
#: self-test whose s, m or k is beyond 1/REACH .. REACH has failed (the device is read with the
#: nominal model)
REACH = 4.0
