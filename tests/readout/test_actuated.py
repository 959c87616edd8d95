"""Sensing while actuating: the compensated read-out (Readout(actuation=), ActuatedReadout).

Readings go through the full model: the cilium bent by the external force and the actuation
(``bend(..., actuation=)``), its field plus the actuation's direct field at the element, the
sensor's volts; the compensated read-out must recover the force at least 10× better than the
uncompensated one (the issue's done-when; both printed, ``pytest -s``).
"""

from __future__ import annotations

import math

import magpylib
import numpy as np
import pytest

import magcilia as mc
from magcilia._errors import MagciliaError
from magcilia.device.sensor import SensorFlag
from magcilia.mechanics import output_at
from magcilia.readout.actuated import ActuatedReadout, measure_coupling
from magcilia.readout.inverse import InverseTable, ReadoutFlag, model_output

SETUP = mc.Setup.paper(tip_radius=5e-5, n_loops=24, dipoles_per_loop=4, ring="rms")
SPAN = (0.0, 2e-4)
FORCES = np.linspace(0.0, 2e-4, 13)


def _rms(estimate: np.ndarray, truth: np.ndarray) -> float:
    assert np.all(np.isfinite(estimate))
    return float(np.sqrt(np.mean((estimate - truth) ** 2)))


# -- no actuation: today's read-out, bit for bit -------------------------------------------------


def test_without_actuation_the_table_is_todays_bit_for_bit() -> None:
    r = mc.Readout(SETUP, "force", SPAN, table_size=33)
    grid = np.linspace(*SPAN, 2 * 33 - 1)
    ref = InverseTable.build(grid, output_at(SETUP, "force", grid), "force")
    for name in ("quantity", "output", "volts", "values", "slope", "cell_start", "cell_step"):
        assert np.array_equal(getattr(r.table, name), getattr(ref, name)), name
    assert r.table.error == ref.error
    assert r.actuation is None and r.sensor_flags == 0
    assert "actuation" not in r.to_dict() and "compensating" not in r.report()
    # model_output without an actuation is output_at exactly
    assert np.array_equal(model_output(SETUP, "force", FORCES), output_at(SETUP, "force", FORCES))


def test_a_zero_actuation_reads_as_the_plain_readout() -> None:
    """The actuated path (each shape solved on its own, output from the field) agrees with the
    plain one when the field is zero."""
    plain = mc.Readout(SETUP, "force", SPAN, table_size=33)
    zero = mc.Readout(SETUP, "force", SPAN, table_size=33,
                      actuation=mc.Actuation.uniform((0.0, 0.0, 0.0)))
    np.testing.assert_allclose(zero.table_output, plain.table_output, rtol=1e-9, atol=0.0)
    volts = output_at(SETUP, "force", FORCES)
    np.testing.assert_allclose(zero.estimate(volts), plain.estimate(volts), rtol=0, atol=1e-11)


# -- the done-when: compensated ≥ 10× better than uncompensated ----------------------------------


@pytest.mark.parametrize("case", ["helmholtz-x", "helmholtz-z", "magnet"])
def test_compensation_is_at_least_ten_times_better(case: str) -> None:
    if case == "helmholtz-x":
        act, size = mc.Actuation.uniform((2e-4, 0.0, 0.0)), 129
    elif case == "helmholtz-z":
        act, size = mc.Actuation.uniform((0.0, 0.0, 5e-4)), 129
    else:
        magnet = magpylib.magnet.Cuboid(polarization=(0.0, 0.0, 1.0), dimension=(2e-3,) * 3,
                                        position=(15e-3, 0.0, 0.0))
        act, size = mc.Actuation.magpylib(magnet), 17
    forces = FORCES if case != "magnet" else FORCES[::3]
    volts = model_output(SETUP, "force", forces, None, act)  # the full model's readings
    rest = model_output(SETUP, "force", np.zeros(1), None, act)[0]
    plain = mc.Readout(SETUP, "force", SPAN, table_size=size)
    # uncompensated at its best: zeroed on unloaded readings taken under the actuation
    tared = plain.tare(rest + np.array([-1e-9, 1e-9]))
    uncompensated = _rms(tared.read(volts).value, forces)
    compensated = _rms(mc.Readout(SETUP, "force", SPAN, table_size=size,
                                  actuation=act).read(volts).value, forces)
    print(f"{case}: RMS force error uncompensated (tared) {uncompensated * 1e3:.3e} mN, "
          f"compensated {compensated * 1e3:.3e} mN, ratio {uncompensated / compensated:.3g}")
    assert uncompensated >= 10.0 * compensated
    assert uncompensated > 1e-7  # the actuation's bending matters at 0.05 % of the span


def test_a_raw_plain_readout_sees_nothing_under_a_field_along_x() -> None:
    act = mc.Actuation.uniform((2e-4, 0.0, 0.0))  # 15 mV of direct output: far beyond the span
    volts = model_output(SETUP, "force", FORCES, None, act)
    res = mc.Readout(SETUP, "force", SPAN, table_size=33).read(volts)
    assert np.all(res.flags & ReadoutFlag.OUTSIDE_SPAN)


def test_a_varying_coil_current_is_compensated_per_reading() -> None:
    coil = mc.Actuation.uniform((2e-4, 0.0, 0.0))  # 2 G along x per ampere
    rng = np.random.default_rng(15)
    current = rng.uniform(-1.0, 1.0, FORCES.size)
    volts = np.array([model_output(SETUP, "force", [f], None, coil.scaled(i))[0]
                      for f, i in zip(FORCES, current, strict=True)])
    r = ActuatedReadout(SETUP, "force", SPAN, coil, levels=np.linspace(-1.0, 1.0, 9),
                        table_size=65)
    assert r.model_coupling == pytest.approx(SETUP.sensor.scale * 2e-4, rel=1e-12)
    compensated = _rms(r.read(volts, level=current).value, FORCES)
    # the practical alternative: subtract M·I only, no model of the actuation's bending
    plain = mc.Readout(SETUP, "force", SPAN, table_size=65)
    direct_only = _rms(plain.read(volts - r.model_coupling * current).value, FORCES)
    print(f"coil: RMS force error M·I only {direct_only * 1e3:.3e} mN, compensated "
          f"{compensated * 1e3:.3e} mN, ratio {direct_only / compensated:.3g}")
    assert direct_only >= 10.0 * compensated
    # the stated errors bound what is seen (noise-free readings)
    assert compensated <= r.level_error + max(x.table_error for x in r.readouts) + 1e-12
    # estimate agrees with read, and a constant level reads as Readout(actuation=) does
    np.testing.assert_array_equal(r.estimate(volts, current), r.read(volts, current).value)
    at_node = r.read(volts, level=r.levels[6]).value
    np.testing.assert_allclose(at_node, r.readouts[6].read(
        volts - r.coupling * r.levels[6] + r.model_coupling * r.levels[6]).value, rtol=0, atol=0)


def test_measured_coupling_replaces_the_modelled_one() -> None:
    coil = mc.Actuation.uniform((2e-4, 0.0, 0.0))
    model = SETUP.sensor.scale * 2e-4
    rng = np.random.default_rng(3)
    levels = np.repeat(np.linspace(-1.0, 1.0, 11), 20)
    # the cilium clamped: only the direct field changes; a 2 % coupling error of the model
    clamped = 3e-3 + 1.02 * model * levels + rng.normal(0.0, 1e-6, levels.size)
    c = measure_coupling(levels, clamped)
    assert abs(c.slope - 1.02 * model) < 4.0 * c.sigma_slope
    assert c.residual == pytest.approx(1e-6, rel=0.2)
    r = ActuatedReadout(SETUP, "force", SPAN, coil, levels=[-1.0, 0.0, 1.0], coupling=c,
                        table_size=33)
    assert r.coupling == c.slope and r.measured is c
    # readings whose direct coupling is the measured one read right with it
    current = np.linspace(-1.0, 1.0, FORCES.size)
    volts = np.array([model_output(SETUP, "force", [f], None, coil.scaled(i))[0]
                      for f, i in zip(FORCES, current, strict=True)])
    volts = volts + (c.slope - model) * current
    est = r.read(volts, current).value
    assert _rms(est, FORCES) < 1e-3 * SPAN[1]
    assert "measured" in r.report()


def test_tare_at_a_level_removes_an_offset() -> None:
    coil = mc.Actuation.uniform((0.0, 0.0, 5e-4))
    r = ActuatedReadout(SETUP, "force", SPAN, coil, levels=[-1.0, 0.0, 1.0], table_size=33)
    offset = 2e-3  # a bridge offset the model does not know
    rest = model_output(SETUP, "force", np.zeros(1), None, coil.scaled(0.5))[0] + offset
    tared = r.tare(rest + np.array([-1e-7, 1e-7, 0.0]), level=0.5)
    volts = model_output(SETUP, "force", FORCES, None, coil.scaled(-0.5)) + offset
    res = tared.read(volts, level=-0.5)
    assert _rms(res.value, FORCES) < 1e-3 * SPAN[1]
    assert np.all(res.sigma_calibration > 0.0)  # the tare's standard error is shared
    assert tared.baseline is not None and r.baseline is None


def test_a_rigid_tilt_sees_only_the_direct_field() -> None:
    act = mc.Actuation.uniform((1e-4, 5e-5, 0.0))
    angles = np.radians([0.0, 10.0, 30.0])
    volts = SETUP.output(angles) + SETUP.sensor.scale * 1e-4
    np.testing.assert_array_equal(model_output(SETUP, "angle", angles, None, act), volts)
    r = mc.Readout(SETUP, "angle", (0.0, 0.6), actuation=act)
    np.testing.assert_allclose(r.estimate(volts), angles, rtol=0, atol=1e-6)


# -- the sensor's range under the actuation ------------------------------------------------------


def test_a_field_beyond_the_flip_field_is_refused() -> None:
    with pytest.raises(MagciliaError, match=r"^actuation must be a field that keeps \|B\| at the "
                                            r"element within the HMC1021Z's 20 G flip field"):
        mc.Readout(SETUP, "force", SPAN, table_size=9,
                   actuation=mc.Actuation.uniform((0.0, 0.0, 2.5e-3)))


def test_a_field_saturating_the_element_over_the_span_is_refused() -> None:
    with pytest.raises(MagciliaError, match=r"keeps B_x within the HMC1021Z's ±6 G range"):
        mc.Readout(SETUP, "force", SPAN, table_size=9,
                   actuation=mc.Actuation.uniform((8e-4, 0.0, 0.0)))


def test_a_total_field_beyond_range_is_flagged_not_refused() -> None:
    act = mc.Actuation.uniform((0.0, 0.0, 7e-4))  # 7 G along z: |B| > 6 G, B_x fine
    r = mc.Readout(SETUP, "force", SPAN, table_size=9, actuation=act)
    assert r.sensor_flags & SensorFlag.TOTAL_BEYOND_RANGE
    assert not r.sensor_flags & SensorFlag.FLIPPED_RISK
    assert "TOTAL_BEYOND_RANGE" in r.report()
    assert r.to_dict()["direct_field_T"] == pytest.approx([0.0, 0.0, 7e-4])


@pytest.mark.parametrize(
    ("kwargs", "match"),
    [
        ({"levels": [0.0]}, "levels must be at least 2 increasing"),
        ({"levels": [1.0, 0.0]}, "levels must be at least 2 increasing"),
        ({"levels": [0.0, math.nan]}, "levels"),
        ({"levels": [0.0, 1.0], "actuation": "coil"}, "actuation must be a magcilia Actuation"),
    ],
)
def test_bad_actuated_readouts(kwargs: dict[str, object], match: str) -> None:
    args: dict[str, object] = {"actuation": mc.Actuation.uniform((1e-4, 0.0, 0.0)),
                               "table_size": 9, **kwargs}
    with pytest.raises(MagciliaError, match=match):
        ActuatedReadout(SETUP, "force", SPAN, **args)  # type: ignore[arg-type]


def test_levels_outside_the_table() -> None:
    coil = mc.Actuation.uniform((1e-4, 0.0, 0.0))
    r = ActuatedReadout(SETUP, "force", SPAN, coil, levels=[-1.0, 1.0], table_size=17)
    volts = model_output(SETUP, "force", [1e-4], None, coil)
    res = r.read(np.repeat(volts, 2), level=[1.0, 1.5])
    assert np.isfinite(res.value[0]) and np.isnan(res.value[1])
    assert res.flags[1] & ReadoutFlag.OUTSIDE_SPAN
    with pytest.raises(MagciliaError, match="level must be within the tabulated levels"):
        r.estimate(volts, 1.5)
    with pytest.raises(MagciliaError, match="level must be one level per reading"):
        r.read(np.zeros(3), level=[0.0, 0.5])
    with pytest.raises(MagciliaError, match="levels must be at least 3 readings"):
        measure_coupling([1.0, 1.0, 1.0], [0.0, 1.0, 2.0])
    assert "level -1…1 (2 levels)" in r.report()
    assert r.to_dict()["model_coupling_V"] == pytest.approx(SETUP.sensor.scale * 1e-4)


# -- the force vector while actuating (BiaxialReadout(actuation=)) -------------------------------


@pytest.mark.parametrize(("field", "grid"), [((0.0, 0.0, 5e-4), (33, 64)),
                                             ((2e-4, 1e-4, 3e-4), (9, 16))])
def test_biaxial_compensation_is_at_least_ten_times_better(
        field: tuple[float, float, float], grid: tuple[int, int]) -> None:
    from magcilia.device.magnetometer import Magnetometer

    sensor = Magnetometer.preset("MMC5983MA")
    act = mc.Actuation.uniform(field)
    rng = np.random.default_rng(7)
    f, phi = rng.uniform(0.2e-4, 1.8e-4, 6), rng.uniform(-np.pi, np.pi, 6)
    truth = np.stack([f * np.cos(phi), f * np.sin(phi)], -1)

    def reading(force: float, azimuth: float) -> np.ndarray:
        shape = mc.bend(SETUP, force, azimuth=azimuth, actuation=act)
        return np.asarray(sensor.to_sensor(SETUP.field(shape)[0] + np.asarray(field)))

    b = np.array([reading(fi, p) for fi, p in zip(f, phi, strict=True)])
    comp = mc.BiaxialReadout(SETUP, sensor, 2e-4, table_size=grid, actuation=act)
    np.testing.assert_allclose(comp.direct, sensor.to_sensor(np.asarray(field)), rtol=1e-12)
    rest = reading(0.0, 0.0)
    plain = mc.BiaxialReadout(SETUP, sensor, 2e-4, table_size=grid).tare(
        np.stack([rest + 1e-12, rest - 1e-12]))
    err = [float(np.sqrt(np.mean(np.sum((np.stack([r.fx, r.fy], -1) - truth) ** 2, -1))))
           for r in (plain.read(b), comp.read(b))]
    print(f"biaxial {field} T: RMS vector error tared {err[0] * 1e3:.3e} mN, compensated "
          f"{err[1] * 1e3:.3e} mN, ratio {err[0] / err[1]:.3g}")
    assert err[0] >= 10.0 * err[1]
    assert "compensating" in comp.report() and "actuation" in comp.to_dict()


def test_biaxial_refuses_a_direct_field_beyond_a_channel() -> None:
    from magcilia.device.magnetometer import Magnetometer

    sensor = Magnetometer.preset("LIS3MDL")  # ±4 G
    with pytest.raises(MagciliaError, match=r"a direct field of 5 G on LIS3MDL \(±4 G\)\.z"):
        mc.BiaxialReadout(SETUP, sensor, 2e-4, table_size=(9, 16),
                          actuation=mc.Actuation.uniform((0.0, 0.0, 5e-4)))
