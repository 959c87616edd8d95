"""Biaxial read-out: force vectors round-trip through bend → field → read-out; honest σ under
noise; the flags (undetermined, ambiguous, near zero, beyond the span, saturated, missing); bad
input as one-line errors.

The truth is computed independently of the read-out's grid: each shape by :func:`magcilia.bend`
(one solve per magnitude), its field by the setup's own model turned by the azimuth
(``Setup.field(shape, azimuth=φ)`` at the element; elsewhere the same turn by hand: the base
placement and the observer turned by −φ, the field turned back).
"""

from __future__ import annotations

import json
import math

import numpy as np
import pytest

import magcilia as mc
from magcilia._atomic import json_text
from magcilia._errors import MagciliaError
from magcilia.device.magnetometer import Magnetometer
from magcilia.model.azimuth import field_from_tilt_frame, placement_in_tilt_frame
from magcilia.readout.biaxial import (
    NO_VECTOR,
    BiaxialReadout,
    Channel,
    ChannelTare,
    ForceFlag,
    ForceVectorResult,
    channels,
)

SETUP = mc.Setup.paper(tip_radius=5e-5, youngs_modulus=2e6)
SPAN = 1e-4  # N: the tip moves ~1.5 mm; the field at the element by ~10 %
AZIMUTHS = np.radians(np.arange(24) * 15.0)
MAG = Magnetometer(field_range=1e-3, resolution=1e-10, noise=2e-8, rate=100.0, name="mag")


def truth(setup: mc.Setup, force: float, azimuths: np.ndarray,
          point: tuple[float, float, float] = (0.0, 0.0, 0.0)) -> np.ndarray:
    """Board-frame field (len(azimuths), 3), T, at ``point`` for a tip force ``force`` toward
    each azimuth."""
    shape = mc.bend(setup, force)
    out = []
    for phi in azimuths:
        if point == (0.0, 0.0, 0.0):
            out.append(setup.field(shape, azimuth=float(phi))[0])
            continue
        x, y = placement_in_tilt_frame(setup.position[0], setup.position[1], phi)
        turned = setup.replace(position=(float(x), float(y), setup.position[2]))
        px, py = placement_in_tilt_frame(point[0], point[1], phi)
        b = turned.field_at([float(px), float(py), point[2]], shape)[0]
        out.append(field_from_tilt_frame(b, phi)[0])
    return np.array(out)


def angle_error(a: np.ndarray, b: np.ndarray) -> np.ndarray:
    return np.abs((a - b + math.pi) % (2.0 * math.pi) - math.pi)


@pytest.fixture(scope="module")
def readout() -> BiaxialReadout:
    return BiaxialReadout(SETUP, MAG, span=SPAN, table_size=(33, 64))


@pytest.mark.parametrize("fraction", [0.1, 0.5, 0.97])
def test_round_trip_24_azimuths(readout: BiaxialReadout, fraction: float) -> None:
    """The issue's criterion: within 1e-3 of the span in magnitude and 0.1° in direction."""
    force = fraction * SPAN
    est = readout.estimate(MAG.to_sensor(truth(SETUP, force, AZIMUTHS)))
    assert est.shape == (24, 2)
    mag = np.hypot(est[:, 0], est[:, 1])
    assert np.max(np.abs(mag - force)) < 1e-3 * SPAN
    assert np.degrees(np.max(angle_error(np.arctan2(est[:, 1], est[:, 0]), AZIMUTHS))) < 0.1
    res = readout.read(MAG.to_sensor(truth(SETUP, force, AZIMUTHS)))
    assert np.all(res.flags == 0)
    np.testing.assert_allclose(res.vector, est, rtol=0, atol=1e-12)


def test_table_error_is_measured_and_small(readout: BiaxialReadout) -> None:
    assert 0.0 < readout.table_error < 1e-4 * SPAN
    finer = BiaxialReadout(SETUP, MAG, span=SPAN, table_size=(65, 128))
    assert finer.table_error < readout.table_error


def test_model_matches_the_truth_between_nodes(readout: BiaxialReadout) -> None:
    phi = np.radians([7.3, 100.1, 222.2])
    force = 0.413 * SPAN
    model = readout.model(force * np.cos(phi), force * np.sin(phi))
    np.testing.assert_allclose(model, MAG.to_sensor(truth(SETUP, force, phi)), rtol=0,
                               atol=1e-6 * float(np.max(np.abs(model))))


def test_rest_is_the_unloaded_field(readout: BiaxialReadout) -> None:
    np.testing.assert_allclose(readout.rest, SETUP.field([0.0])[0], rtol=1e-5)


def test_pulls_under_noise_are_unit_normal(readout: BiaxialReadout) -> None:
    """Seeded noise at forces well above the resolution: (estimate − truth)/σ has sd ≈ 1 and
    ~95 % lie within 2σ, for Fx, Fy, the magnitude and the direction."""
    rng = np.random.default_rng(7)
    force = 0.5 * SPAN
    clean = MAG.to_sensor(truth(SETUP, force, AZIMUTHS))
    res = readout.read(clean[None] + rng.standard_normal((300, 24, 3)) * MAG.sigma)
    assert np.all(res.flags == 0)
    pulls = {
        "fx": (res.fx - force * np.cos(AZIMUTHS)) / res.sigma_fx,
        "fy": (res.fy - force * np.sin(AZIMUTHS)) / res.sigma_fy,
        "magnitude": (res.magnitude - force) / res.sigma_magnitude,
        "direction": ((res.direction - AZIMUTHS + math.pi) % (2 * math.pi) - math.pi)
        / res.sigma_direction,
    }
    for name, p in pulls.items():  # 7200 draws: sd within ~±2.5 %, coverage within ±1 %
        assert abs(float(np.std(p)) - 1.0) < 0.05, name
        assert abs(float(np.mean(np.abs(p) < 2.0)) - 0.9545) < 0.012, name
        assert abs(float(np.mean(p))) < 0.05, name
    # the covariance's correlation is honest too: the Mahalanobis distance is χ²(2)
    d = np.stack([res.fx - force * np.cos(AZIMUTHS), res.fy - force * np.sin(AZIMUTHS)], -1)
    maha = np.einsum("...i,...ij,...j->...", d, np.linalg.inv(res.covariance), d)
    assert abs(float(np.mean(maha)) - 2.0) < 0.1


def test_two_single_axis_sensors_turned_90_degrees() -> None:
    sensor = SETUP.sensor
    pair = [Channel.of_sensor(sensor, axis=(1, 0, 0), name="HMC x"),
            Channel.of_sensor(sensor, axis=(0, 1, 0), name="HMC y")]
    r = BiaxialReadout(SETUP, pair, span=SPAN, table_size=(33, 64))
    b = truth(SETUP, 0.6 * SPAN, AZIMUTHS)
    res = r.read(b[:, :2])
    assert np.all(res.flags == 0)
    assert np.max(np.abs(res.magnitude - 0.6 * SPAN)) < 1e-3 * SPAN
    assert np.degrees(np.max(angle_error(res.direction, AZIMUTHS))) < 0.1
    # the HMC's noise over the default bandwidth, in T
    assert pair[0].sigma == pytest.approx(sensor.noise_rms(*mc.device.sensor.DEFAULT_BANDWIDTH))


def test_two_single_axis_sensors_at_two_positions() -> None:
    point = (0.0, 3.0e-3, 0.0)
    pair = [Channel((0.0, 0.0, 0.0), (1, 0, 0), 1e-8, name="a"),
            Channel(point, (1, 0, 0), 1e-8, name="b")]
    r = BiaxialReadout(SETUP, pair, span=SPAN, table_size=(33, 64))
    fields = np.stack([truth(SETUP, 0.7 * SPAN, AZIMUTHS)[:, 0],
                       truth(SETUP, 0.7 * SPAN, AZIMUTHS, point)[:, 0]], -1)
    res = r.read(fields)
    good = res.flags == 0
    assert good.sum() >= 20  # a few directions may be ambiguous for two x-axes: flagged
    assert np.max(np.abs(res.magnitude[good] - 0.7 * SPAN)) < 1e-3 * SPAN
    assert np.degrees(np.max(angle_error(res.direction[good], AZIMUTHS[good]))) < 0.1
    bad = ~good
    assert np.all(res.flags[bad] & (ForceFlag.AMBIGUOUS | ForceFlag.UNDETERMINED))
    assert np.all(np.isnan(res.direction[bad]))


def test_the_papers_single_axis_sees_one_projection() -> None:
    """The HMC at the element sees only B_x: no force vector, and says so."""
    r = BiaxialReadout(SETUP, Channel.of_sensor(SETUP.sensor), span=SPAN, table_size=(17, 32))
    res = r.read(truth(SETUP, 0.5 * SPAN, AZIMUTHS)[:, :1])
    assert np.all(res.flags & ForceFlag.UNDETERMINED)
    for arr in (res.fx, res.fy, res.magnitude, res.direction):
        assert np.all(np.isnan(arr))
    assert "one projection" in r.report()
    with pytest.raises(MagciliaError, match="do not determine both components"):
        r.estimate(truth(SETUP, 0.5 * SPAN, AZIMUTHS[:1])[:, :1])


def test_an_axially_symmetric_view_is_ambiguous_or_undetermined() -> None:
    """Below the base centre, B_x and B_z are the same for φ and −φ (the mirror through the
    x–z plane of the base): two minima, flagged AMBIGUOUS, no direction invented; B_z alone
    depends on |F| only: UNDETERMINED."""
    below = (SETUP.base_centre[0], SETUP.base_centre[1], 0.0)
    pair = [Channel(below, (1, 0, 0), 1e-8, name="x"), Channel(below, (0, 0, 1), 1e-8, name="z")]
    r = BiaxialReadout(SETUP, pair, span=SPAN, table_size=(33, 64))
    phi = np.radians([40.0, 75.0, 130.0, -60.0])
    b = truth(SETUP, 0.6 * SPAN, phi, below)
    res = r.read(b[:, [0, 2]])
    assert np.all(res.flags & ForceFlag.AMBIGUOUS)
    assert np.all(np.isnan(res.direction)) and np.all(np.isinf(res.sigma_direction))
    only_z = BiaxialReadout(SETUP, pair[1:] * 1 + [Channel(below, (0, 0, 1), 1e-8, name="z2")],
                            span=SPAN, table_size=(17, 32))
    res_z = only_z.read(np.stack([b[:, 2], b[:, 2]], -1))
    assert np.all(res_z.flags & ForceFlag.UNDETERMINED)


def test_near_zero_has_no_direction(readout: BiaxialReadout) -> None:
    rng = np.random.default_rng(3)
    rest = MAG.to_sensor(SETUP.field([0.0]))
    res = readout.read(rest + rng.standard_normal((400, 3)) * MAG.sigma)
    near = (res.flags & ForceFlag.NEAR_ZERO) != 0
    assert near.mean() > 0.95
    assert np.all(np.isnan(res.direction[near])) and np.all(np.isinf(res.sigma_direction[near]))
    assert np.all(np.isfinite(res.fx[near])) and np.all(
        res.magnitude[near] < 3.0 * np.hypot(res.sigma_fx, res.sigma_fy)[near])


def test_beyond_the_span(readout: BiaxialReadout) -> None:
    phi = np.radians([20.0, 200.0])
    just = readout.read(MAG.to_sensor(truth(SETUP, 1.03 * SPAN, phi)))
    assert np.all(just.flags == ForceFlag.EXTRAPOLATED | ForceFlag.ABOVE_SPAN)
    np.testing.assert_allclose(just.magnitude, 1.03 * SPAN, rtol=1e-4)
    far = readout.read(MAG.to_sensor(truth(SETUP, 1.5 * SPAN, phi)))
    assert np.all(far.flags & ForceFlag.OUTSIDE_SPAN) and np.all(np.isnan(far.fx))
    with pytest.raises(MagciliaError, match=r"fields\[0\].*beyond the span's reach"):
        readout.estimate(MAG.to_sensor(truth(SETUP, 1.5 * SPAN, phi)))


def test_saturated_and_missing_channels_are_left_out(readout: BiaxialReadout) -> None:
    b = MAG.to_sensor(truth(SETUP, 0.5 * SPAN, AZIMUTHS[:4]))
    sat = b.copy()
    sat[:, 2] = 2e-3  # z beyond ±1 mT
    nan = b.copy()
    nan[:, 2] = np.nan
    for fields, flag in ((sat, ForceFlag.SATURATED), (nan, ForceFlag.MISSING)):
        res = readout.read(fields)
        assert np.all(res.flags & flag)
        est = res.estimated
        # x and y alone may or may not fix the vector here; where they do, it is right
        assert np.all(np.abs(res.magnitude[est] - 0.5 * SPAN) < 1e-3 * SPAN)
    every = np.full((2, 3), 5e-3)
    res = readout.read(every)
    assert np.all(res.flags & ForceFlag.OUTSIDE_SPAN) and np.all(res.flags & ForceFlag.SATURATED)
    with pytest.raises(MagciliaError, match=r"fields\[0, 0\] must be within mag.x's range"):
        readout.estimate(every)
    with pytest.raises(MagciliaError, match=r"fields\[0, 2\] must be a finite reading"):
        readout.estimate(nan)


def test_bad_input_is_one_line(readout: BiaxialReadout) -> None:
    cases = [
        (lambda: readout.read(np.zeros((4, 2))), r"fields must be shape \(\.\.\., 3\)"),
        (lambda: readout.estimate(5.0), r"fields must be shape \(\.\.\., 3\)"),
        (lambda: readout.read([["a", "b", "c"]]), "fields must be numbers"),
        (lambda: BiaxialReadout(SETUP, MAG, span=-1.0), "span must be a positive force"),
        (lambda: BiaxialReadout(SETUP, [], span=SPAN), "sensors must be at least one"),
        (lambda: BiaxialReadout(SETUP, ["x"], span=SPAN), r"sensors\[0\] must be a Magnetometer"),
        (lambda: BiaxialReadout(mc.Setup.paper(), MAG, span=SPAN), "tip_radius must be positive"),
        (lambda: BiaxialReadout(SETUP, MAG, span=SPAN, table_size=(4, 64)),
         r"table_size\[0\] must be"),
        (lambda: Channel((0, 0, 0), (0, 0, 0), 1e-8), "axis must be a non-zero direction"),
        (lambda: Channel((0, 0, 0), (1, 0, 0), 0.0), "sigma must be a positive noise"),
        (lambda: readout.model(2 * SPAN, 0.0), "force must be a finite magnitude"),
        (lambda: readout.tare(np.zeros((1, 3))), "tare needs at least 2 finite readings"),
    ]
    for call, message in cases:
        with pytest.raises(MagciliaError, match=message) as info:
            call()
        assert "\n" not in str(info.value)


def test_a_sensor_inside_the_bent_cilium_is_refused() -> None:
    # a point the tip sweeps through when bent toward +y by the span
    tip = SETUP.base_centre + mc.bend(SETUP, SPAN).tip[[1, 0, 2]] * [1, 1, 1]
    inside = Channel(tuple(SETUP.base_centre + [0.0, 0.0, 1.0e-3]), (1, 0, 0), 1e-8, name="in")
    with pytest.raises(MagciliaError, match="sensors must be sensors outside the cilium"):
        BiaxialReadout(SETUP, [inside, Channel((0, 0, 0), (0, 1, 0), 1e-8)], span=SPAN,
                       table_size=(17, 32))
    assert tip.shape == (3,)


def test_tare_removes_offsets_and_measures_noise(readout: BiaxialReadout) -> None:
    rng = np.random.default_rng(11)
    offset = np.array([3e-7, -2e-7, 5e-7])  # the earth's field, the board's magnets
    rest = MAG.to_sensor(SETUP.field([0.0]))[0]
    base = rest + offset + rng.standard_normal((200, 3)) * MAG.sigma
    tared = readout.tare(base)
    assert isinstance(tared.baseline, ChannelTare) and readout.baseline is None
    np.testing.assert_allclose(tared.sigma, MAG.sigma, rtol=0.15)
    b = MAG.to_sensor(truth(SETUP, 0.5 * SPAN, AZIMUTHS)) + offset
    res = tared.read(b)
    assert np.all(res.flags == 0)
    # the tare's error is shared: it widens σ but the estimate is within a few of them
    assert np.max(np.abs(res.magnitude - 0.5 * SPAN) / res.sigma_magnitude) < 4.0
    untared = readout.read(b)
    assert np.nanmax(np.abs(untared.magnitude - 0.5 * SPAN)) > 10 * np.max(res.sigma_magnitude)
    assert "tare" in tared.report()
    # the tare's standard error σ/√n is shared: with the same spread, the covariance is the
    # noise's times (1 + 1/n) exactly
    pattern = np.array([1.0, -1.0, 1.0, -1.0])[:, None]
    sigmas = []
    for repeat in (1, 100):
        p = np.tile(pattern, (repeat, 1))
        p = p / p.std(ddof=1)
        sigmas.append(readout.tare(rest + offset + p * MAG.sigma).read(b).sigma_fx)
    np.testing.assert_allclose(sigmas[0] / sigmas[1], math.sqrt(1.25 / 1.0025), rtol=1e-9)


def test_result_protocol(readout: BiaxialReadout) -> None:
    b = MAG.to_sensor(truth(SETUP, 0.5 * SPAN, AZIMUTHS[:3]))
    res = readout.read(np.stack([b, b]))
    assert isinstance(res, ForceVectorResult) and res.fx.shape == (2, 3)
    assert res.covariance.shape == (2, 3, 2, 2)
    doc = json.loads(json_text(res.to_dict()))
    assert doc["units"] == "SI" and len(doc["fx"]) == 2
    frame = res.to_dataframe()
    assert list(frame.columns)[:4] == ["fx_N", "fy_N", "magnitude_N", "direction_rad"]
    assert "sigma_direction_rad" in frame.columns and len(frame) == 6
    assert "3" in res.report() or "6/6" in res.report()
    assert len(repr(res)) <= 120 and "<table" in res._repr_html_()
    doc_r = json.loads(json_text(readout.to_dict()))
    assert doc_r["table_size"] == [33, 64] and len(doc_r["channels"]) == 3
    assert len(repr(readout)) <= 120
    assert "force-vector read-out" in readout.report()


def test_measured_noise_replaces_the_stated(readout: BiaxialReadout) -> None:
    b = MAG.to_sensor(truth(SETUP, 0.5 * SPAN, AZIMUTHS[:3]))
    stated = readout.read(b)
    twice = readout.read(b, noise=2.0 * MAG.sigma)
    np.testing.assert_allclose(twice.sigma_fx, 2.0 * stated.sigma_fx, rtol=1e-9)
    np.testing.assert_allclose(twice.vector, stated.vector, atol=1e-12)
    with pytest.raises(MagciliaError, match="noise must be a positive RMS noise"):
        readout.read(b, noise=[1e-8, 0.0, 1e-8])


def test_channels_of_a_turned_magnetometer() -> None:
    turn = np.array([[0.0, -1.0, 0.0], [1.0, 0.0, 0.0], [0.0, 0.0, 1.0]])  # 90° about z
    m = MAG.replace(rotation=turn, noise=(1e-8, 2e-8, 3e-8))
    ch = channels([m, Channel((0, 0, 0), (1, 1, 0), 1e-8)])
    assert len(ch) == 4 and ch[0].axis == (0.0, 1.0, 0.0) and ch[1].axis == (-1.0, 0.0, 0.0)
    assert [c.sigma for c in ch[:3]] == [1e-8, 2e-8, 3e-8]
    assert ch[3].axis == pytest.approx((math.sqrt(0.5), math.sqrt(0.5), 0.0))
    r = BiaxialReadout(SETUP, m, span=SPAN, table_size=(17, 32))
    est = r.estimate(m.to_sensor(truth(SETUP, 0.4 * SPAN, AZIMUTHS[:5])))
    np.testing.assert_allclose(np.hypot(est[:, 0], est[:, 1]), 0.4 * SPAN, atol=1e-3 * SPAN)


def test_read_agrees_with_estimate_in_blocks(readout: BiaxialReadout) -> None:
    rng = np.random.default_rng(5)
    n = 9000  # more than one block
    f = rng.uniform(0.2, 0.9, n) * SPAN
    phi = rng.uniform(-math.pi, math.pi, n)
    fields = readout.model(f * np.cos(phi), f * np.sin(phi))
    est = readout.estimate(fields)
    np.testing.assert_allclose(np.hypot(est[:, 0], est[:, 1]), f, atol=1e-6 * SPAN)
    res = readout.read(fields)
    assert np.all(res.flags == 0)
    np.testing.assert_allclose(res.vector, est, atol=1e-12)
    assert not np.any(res.flags & np.uint16(NO_VECTOR))
