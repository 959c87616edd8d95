"""The calibration-free read-out error of a force-sensor design under fabrication and placement
tolerances: the metric of the ``"robust"`` objective of :func:`magcilia.optimise_design`.

**What is measured.** A device is drawn from the tolerances (:class:`Tolerances`): its placement x,
y, z each off by ``placement`` (m), its height, base radius, magnetization and Young's modulus each
off by their relative tolerance. It is read with the *nominal* design's model (no per-device
calibration): a reading ``V`` of the device under a tip force ``F`` is turned into the force
``F_read`` whose nominal output is ``V`` (linear interpolation in a table of :data:`TABLE_SIZE`
forces over the range, as :class:`magcilia.Readout`'s). With ``tare`` (the default: what a user
does before a measurement, :meth:`magcilia.Readout.tare`) the device's own output at rest is taken
as the nominal model's zero first, which removes every offset of the output; without, the raw
output is read. A reading beyond the nominal curve's ends is reported at the end (the span's end of
a clipping read-out). The error of one reading is ``(F_read − F) / R``, ``R`` the nominal design's
force range (:func:`magcilia.design_metrics`'s, the one ``optimise`` reports), at ``points`` forces
evenly spaced over ``[0, R]``; the figure of merit is its **RMS over the devices and the forces**
(a smooth statistic for the search; :attr:`CalibrationFreeError.p95`, the 95th percentile of
``|F_read − F| / R``, and the worst reading are reported beside it).

**Distribution.** Each tolerance is one standard deviation: a placement coordinate is
``x_i + placement · z``, a relative one multiplies (log-normal, as a positive material or size
factor is): ``h · exp(0.05 z)``, ``E · exp(0.30 z)``, …, with ``z`` standard-normal draws
truncated at ±3 σ. The draws come from ``seed`` once and are the same for every design (common
random numbers), so the search compares designs on the same devices and sees a smooth
objective.

**Forward model.** The exact one: every device's large-deflection bend under every force in one
batched Newton solve and the full dipole field model at the sensing element
(:func:`magcilia.calibration.load_model.load_fields`, the calibration's load model, equal to
:func:`magcilia.bend_sweep` and :meth:`magcilia.Setup.field` device by device); the
magnetization scales the cilium's moment, so its field, exactly; the sensor's output is
:meth:`magcilia.Sensor.voltage` of the field along its axis. The nominal curve is the same call
with no perturbation, so with zero tolerances the error is exactly 0.

A tolerance that only scales the force (the modulus: ``F ∝ E`` at a fixed shape) gives an
error no placement can remove: :func:`tolerance_shares` computes each tolerance's error alone.
SI units: m, N, V; relative tolerances as fractions.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field, replace
from typing import Any

import numpy as np
from numpy.typing import NDArray

from magcilia import _validate as v
from magcilia._display import Display, Item
from magcilia.design.self_test import REACH, CoilSelfTest, estimate, measure
from magcilia.device.setup import Setup

F64 = NDArray[np.float64]

#: the tolerances, in table order (placement in m; the others relative)
TOLERANCES = ("placement", "height", "base_radius", "magnetization", "modulus")
#: draws are truncated at this many standard deviations
TRUNCATE = 3.0
#: forces of the nominal read-out table (as :class:`magcilia.Readout`'s default table)
TABLE_SIZE = 257
#: the columns of the standard-normal draws: which parameter each perturbs, and by which tolerance
_COLUMNS = (("height", "height"), ("base_radius", "base_radius"), ("x", "placement"),
            ("y", "placement"), ("z", "placement"), ("youngs_modulus", "modulus"),
            ("magnetization", "magnetization"))


@dataclass(frozen=True, eq=False, repr=False)
class Tolerances(Display):
    """Fabrication and placement tolerances, each one standard deviation (module docstring).

    Defaults are the issue's: placement ±50 µm (each of x, y, z), height ±5 %, base radius ±5 %,
    magnetization ±10 %, Young's modulus ±30 %.

    Attributes
    ----------
    placement : float
        m, on each of x, y and z.
    height, base_radius, magnetization, modulus : float
        Relative (0.05 is 5 %; the standard deviation of the factor's logarithm), each below 1.
    """

    placement: float = 50e-6
    height: float = 0.05
    base_radius: float = 0.05
    magnetization: float = 0.10
    modulus: float = 0.30

    def __post_init__(self) -> None:
        for name in TOLERANCES:
            value = v.real(f"tolerance {name}", getattr(self, name), "m" if name == "placement"
                           else "")
            if value < 0.0:
                raise v.fail(f"tolerance {name}", value, "a value >= 0")
            if name != "placement" and value >= 1.0:
                raise v.fail(f"tolerance {name}", value, "a relative tolerance below 1 (100 %)")
            object.__setattr__(self, name, value)

    def only(self, name: str) -> Tolerances:
        """These tolerances with every one but ``name`` set to 0."""
        v.choice("tolerance", name, TOLERANCES)
        return Tolerances(**{n: (getattr(self, n) if n == name else 0.0) for n in TOLERANCES})

    def to_dict(self) -> dict[str, Any]:
        """JSON-ready content (placement in m, the others as fractions)."""
        return {"placement_m": self.placement, "height": self.height,
                "base_radius": self.base_radius, "magnetization": self.magnetization,
                "modulus": self.modulus}

    def report(self) -> str:
        """One line: ``placement ±50 µm, height ±5 %, …``."""
        return ", ".join(_tolerance_text(n, getattr(self, n)) for n in TOLERANCES)

    def _display_items(self) -> list[Item]:
        return [(n, _tolerance_text(n, getattr(self, n)).split(" ", 1)[1]) for n in TOLERANCES]


def _tolerance_text(name: str, value: float) -> str:
    if name == "placement":
        return f"placement ±{value * 1e6:.3g} µm"
    return f"{name} ±{value * 100:.3g} %"


@dataclass(frozen=True, eq=False)
class RobustSpec:
    """How the calibration-free error is estimated (picklable: it travels with each design's
    task): the tolerances, the devices drawn (``samples``, from ``seed``), whether each device
    is tared at rest, the forces per device (``points`` over the range), and a start-up
    ``self_test`` each device is read with (None: none, the nominal model as it is; a
    :class:`magcilia.design.self_test.CoilSelfTest`: its estimated sensitivity, magnetization and
    stiffness correct the read-out). ``draws`` (samples, 7) are the truncated standard-normal
    draws, the same for every design."""

    tolerances: Tolerances = field(default_factory=Tolerances)
    samples: int = 128
    seed: int = 0
    tare: bool = True
    points: int = 33
    self_test: CoilSelfTest | None = None
    self_test_failed: int = 0
    draws: F64 = field(init=False, repr=False)

    def __post_init__(self) -> None:
        if not isinstance(self.tolerances, Tolerances):
            raise v.fail("tolerances", type(self.tolerances).__name__,
                         "a magcilia.design.robust.Tolerances")
        object.__setattr__(self, "samples", v.integer("samples", self.samples, 2))
        object.__setattr__(self, "points", v.integer("points", self.points, 3))
        if not isinstance(self.tare, bool):
            raise v.fail("tare", self.tare, "True or False")
        if self.self_test is not None and not isinstance(self.self_test, CoilSelfTest):
            raise v.fail("self_test", type(self.self_test).__name__,
                         "None or a magcilia.design.self_test.CoilSelfTest")
        gen = np.random.default_rng(v.integer("seed", self.seed, 0))
        draws = np.clip(gen.standard_normal((self.samples, len(_COLUMNS))), -TRUNCATE, TRUNCATE)
        draws.setflags(write=False)
        object.__setattr__(self, "draws", draws)

    def with_tolerances(self, tolerances: Tolerances) -> RobustSpec:
        """The same draws (seed, samples) under other tolerances."""
        return replace(self, tolerances=tolerances)


def device_parameters(setup: Setup, spec: RobustSpec) -> dict[str, F64]:
    """The drawn devices' parameters, SI, each (samples,): height, base_radius, x, y, z (m),
    youngs_modulus (Pa) and magnetization_scale (the setup's times the draw's factor)."""
    tol = spec.tolerances
    nominal = {"height": setup.cilium.height, "base_radius": setup.cilium.base_radius,
               "x": setup.value("x"), "y": setup.value("y"), "z": setup.value("z"),
               "youngs_modulus": setup.youngs_modulus,
               "magnetization": setup.value("magnetization_scale")}
    out: dict[str, F64] = {}
    for j, (name, which) in enumerate(_COLUMNS):
        step = getattr(tol, which) * spec.draws[:, j]
        base = float(nominal[name])
        out[name] = base + step if which == "placement" else base * np.exp(step)
    out["magnetization_scale"] = out.pop("magnetization")
    return out


def _outputs(setup: Setup, forces: F64, prm: dict[str, F64], scale: F64) -> F64:
    """The output (sets, a), V, of parameter sets ``prm`` (each (sets,): height, base_radius,
    x, y, z, youngs_modulus) under tip ``forces`` (a,), N, their fields scaled by ``scale``
    (sets,): the calibration's batched load model (NaN rows where it refuses a set)."""
    from magcilia.calibration.load_model import load_fields
    from magcilia.io.measurement import Measurement

    a = forces.size
    zeros = np.zeros(a)
    counts = np.ones(a, dtype=np.int64)
    load = Measurement(zeros, zeros, zeros, counts, 0 * counts, 0 * counts, forces=forces)
    b = load_fields(setup, [(0, 0.0, forces, 0)], [load], {}, prm).reshape(-1, a, 3)
    return np.asarray(setup.sensor.voltage(b[:, :, 0] * scale[:, None]), dtype=np.float64)


def _nominal(setup: Setup) -> dict[str, F64]:
    return {k: np.array([float(val)]) for k, val in (
        ("height", setup.cilium.height), ("base_radius", setup.cilium.base_radius),
        ("x", setup.value("x")), ("y", setup.value("y")), ("z", setup.value("z")),
        ("youngs_modulus", setup.youngs_modulus))}


def nominal_table(setup: Setup, span: float, size: int = TABLE_SIZE) -> tuple[F64, F64]:
    """The nominal design's read-out table: ``size`` tip forces evenly over ``[0, span]``, N,
    and its outputs there, V (the model a calibration-free read-out inverts)."""
    forces = np.linspace(0.0, span, size)
    return forces, _outputs(setup, forces, _nominal(setup), np.ones(1))[0]


def device_outputs(setup: Setup, forces: F64, spec: RobustSpec) -> tuple[F64, F64]:
    """The nominal design's output (a,) and every drawn device's (samples, a), V, under tip
    ``forces`` (a,), N, along +x: the exact model (module docstring); NaN rows for devices the
    model refuses (the element inside the cilium, a bend that does not converge)."""
    forces = np.asarray(forces, dtype=np.float64)
    prm, own = _devices(setup, spec)
    nominal = _nominal(setup)
    both = {k: np.concatenate([nominal[k], prm[k]]) for k in nominal}
    volts = _outputs(setup, forces, both, np.concatenate([[1.0], own]))
    return volts[0], volts[1:]


def _devices(setup: Setup, spec: RobustSpec) -> tuple[dict[str, F64], F64]:
    """The drawn devices' geometry and modulus (as :func:`_nominal`'s, (samples,) each) and
    their moments relative to the model's (the setup's, its magnetization scale included)."""
    dev = device_parameters(setup, spec)
    own = dev.pop("magnetization_scale") / float(setup.value("magnetization_scale"))
    return dev, own


def read_errors(forces: F64, table: tuple[F64, F64], devices: F64, span: float,
                tare: bool) -> F64:
    """The relative reading errors ``(F_read − F) / span`` (samples, a) of devices' outputs
    ``devices`` (samples, a; V) at ``forces`` (a,; N, the first at rest), read through the
    nominal ``table`` (forces (t,), N, from rest, and outputs (t,), V, monotone: linear
    interpolation, a reading beyond its ends at the end); ``tare``: each device's output at
    rest shifted onto the table's."""
    t_forces, t_volts = table
    sign = 1.0 if t_volts[-1] >= t_volts[0] else -1.0
    curve = np.maximum.accumulate(sign * t_volts)  # monotone to round-off: a valid table
    out = devices - devices[:, :1] + t_volts[0] if tare else devices
    read = np.interp(sign * out, curve, t_forces)
    read[~np.isfinite(out)] = np.nan
    return np.asarray((read - forces[None, :]) / span, dtype=np.float64)


@dataclass(frozen=True, eq=False, repr=False)
class CalibrationFreeError(Display):
    """The calibration-free read-out error of one design (module docstring).

    Attributes
    ----------
    rms : float
        RMS of ``(F_read − F) / R`` over the devices and the forces (a fraction of the range;
        the ``"robust"`` objective's figure of merit; NaN when fewer than half the devices could
        be modelled).
    p95 : float
        95th percentile of ``|F_read − F| / R`` over the same readings.
    worst : float
        The largest ``|F_read − F| / R``.
    span : float
        The range R, N.
    tare : bool
        Whether each device was tared at rest.
    samples : int
        Devices drawn.
    failed : int
        Devices the model refused (left out of the figures).
    tolerances : Tolerances
    self_test : CoilSelfTest or None
        The start-up self-test each device was read with (None: none).
    self_test_failed : int
        Devices whose self-test failed (read with the nominal model instead).
    """

    rms: float
    p95: float
    worst: float
    span: float
    tare: bool
    samples: int
    failed: int
    tolerances: Tolerances
    self_test: CoilSelfTest | None = None
    self_test_failed: int = 0

    def to_dict(self) -> dict[str, Any]:
        """JSON-ready content (errors as fractions of the range; the range in N)."""
        return {"rms": self.rms, "p95": self.p95, "worst": self.worst, "span_N": self.span,
                "tare": self.tare, "samples": self.samples, "failed": self.failed,
                "tolerances": self.tolerances.to_dict(),
                "self_test": None if self.self_test is None else self.self_test.to_dict(),
                "self_test_failed": self.self_test_failed}

    def report(self) -> str:
        """One line: RMS, 95th percentile and worst, in % of the range."""
        tared = "tared at rest" if self.tare else "untared"
        failed = f", {self.failed} refused by the model" if self.failed else ""
        return (f"calibration-free error {self.rms * 100:.3g} % RMS of the range "
                f"({self.span * 1e3:.4g} mN; 95th percentile {self.p95 * 100:.3g} %, worst "
                f"{self.worst * 100:.3g} %; {self.samples} devices, {tared}{failed}) under "
                f"{self.tolerances.report()}"
                + ("" if self.self_test is None else f"; read after a {self.self_test.report()}"
                   f" ({self.self_test_failed} failed)"))

    def _display_items(self) -> list[Item]:
        return [("rms", f"{self.rms * 100:.3g} %"), ("p95", f"{self.p95 * 100:.3g} %"),
                ("range", f"{self.span * 1e3:.4g} mN"), ("tare", str(self.tare)),
                ("devices", str(self.samples))]


def calibration_free_error(setup: Setup, span: float,
                           spec: RobustSpec | None = None) -> CalibrationFreeError:
    """The calibration-free read-out error of ``setup`` over the tip forces ``[0, span]``.

    Parameters
    ----------
    setup : Setup
        The nominal design (a tip radius > 0; single-axis sensor); its layout resolved at the
        element (:meth:`magcilia.Setup.resolve_layout`).
    span : float
        The force range R, N (the design's range: :func:`magcilia.design_metrics`).
    spec : RobustSpec, optional
        Tolerances, devices, tare and forces (default: the issue's tolerances, 128 devices,
        seed 0, tared, 33 forces: nodes of the table).

    Returns
    -------
    CalibrationFreeError
    """
    if not isinstance(setup, Setup):
        raise v.fail("setup", type(setup).__name__, "a magcilia.Setup")
    span = v.positive("span", span, "N", "force range")
    spec = spec or RobustSpec()
    setup = setup.resolve_layout()
    forces = np.linspace(0.0, span, spec.points)
    self_failed = 0
    if spec.self_test is None:
        table = nominal_table(setup, span)
        devices = device_outputs(setup, forces, spec)[1]
        errors = read_errors(forces, table, devices, span, spec.tare)
    else:
        prm, own = _devices(setup, spec)
        devices = _outputs(setup, forces, prm, own)
        errors, table, self_failed = _self_tested_errors(setup, span, forces, spec, prm, own,
                                                        devices)
    good = np.isfinite(errors).all(axis=1)
    failed = int(np.count_nonzero(~good))
    if not np.isfinite(table[1]).all() or good.sum() < 0.5 * spec.samples:
        rms = p95 = worst = math.nan
    else:
        e = np.abs(errors[good])
        rms = float(np.sqrt(np.mean(e**2)))
        p95 = float(np.percentile(e, 95.0))
        worst = float(e.max())
    return CalibrationFreeError(rms, p95, worst, span, spec.tare, spec.samples, failed,
                                spec.tolerances, spec.self_test, self_failed)


def _self_tested_errors(setup: Setup, span: float, forces: F64, spec: RobustSpec,
                        prm: dict[str, F64], own: F64, devices: F64
                        ) -> tuple[F64, tuple[F64, F64], int]:
    """The relative reading errors (samples, a) of devices ``prm`` (moments ``own`` times the
    model's) with outputs ``devices`` (samples, a; V) at ``forces`` (a,; N), each read after
    its self-test (``spec.self_test``; noise from ``spec.seed``), the nominal table used
    (forces, N; outputs, V), and the count of failed self-tests (an estimated scale beyond
    ``1/REACH .. REACH``: read with the nominal model instead)."""
    test = spec.self_test
    assert test is not None  # (the caller's branch)
    gen = np.random.default_rng([spec.seed, 1])
    est = estimate(setup, test, measure(setup, test, prm, own, gen))
    scales = np.stack([est["sensitivity"], est["magnetization"], est["stiffness"]])
    failed = ~np.all(np.isfinite(scales) & (scales >= 1.0 / REACH) & (scales <= REACH), axis=0)
    # a failed self-test (a scale beyond 1/REACH..REACH, as a real instrument rejects it): the
    # device is read with the nominal model, as without the self-test
    scales[:, failed] = 1.0
    k = scales[2]
    gain = scales[0] * scales[1]
    bad = ~np.isfinite(devices).all(axis=1)
    t_forces = np.linspace(0.0, span, TABLE_SIZE)
    soft = float(np.min(k[~bad])) if np.any(~bad) else 1.0
    if soft < 1.0:  # nodes over [0, span] kept: with zero tolerances nothing changes
        reach = min(1.02 / soft, REACH)
        extra = span * np.linspace(1.0, reach, int(np.ceil(64 * (reach - 1.0))) + 2)[1:]
        t_forces = np.concatenate([t_forces, extra])
    t_volts = _outputs(setup, t_forces, _nominal(setup), np.ones(1))[0]
    end = np.flatnonzero(~np.isfinite(t_volts))
    if end.size and end[0] > TABLE_SIZE - 1:
        t_forces, t_volts = t_forces[:end[0]], t_volts[:end[0]]
    if spec.tare:
        corrected = t_volts[0] + (devices - devices[:, :1]) / gain[:, None]
    else:
        corrected = float(setup.sensor.offset) + (devices - est["offset"][:, None]) / gain[:, None]
    corrected[bad] = np.nan
    table = (t_forces, t_volts)
    read = read_errors(forces, table, corrected, span, False) * span + forces[None, :]
    errors = np.asarray((k[:, None] * read - forces[None, :]) / span, dtype=np.float64)
    return errors, table, int(np.count_nonzero(failed & ~bad))


def tolerance_shares(setup: Setup, span: float, spec: RobustSpec | None = None
                     ) -> dict[str, CalibrationFreeError]:
    """The calibration-free error each tolerance causes alone (the others 0, the same draws),
    and all together under ``"all"``: which tolerances a design can act on and which only a
    calibration removes (:func:`calibration_free_error`'s arguments)."""
    spec = spec or RobustSpec()
    out = {name: calibration_free_error(setup, span,
                                        spec.with_tolerances(spec.tolerances.only(name)))
           for name in TOLERANCES}
    out["all"] = calibration_free_error(setup, span, spec)
    return out

