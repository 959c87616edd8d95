"""The force-vector and array read-outs on the read-out protocol: inputs, rest, read(samples)
shapes, one Flag set, batched reads, tares (readout/biaxial.py, readout/array_readout.py)."""

from __future__ import annotations

import json

import numpy as np
import pytest

import magcilia as mc
from magcilia._atomic import json_text
from magcilia.device.array import CiliaArray
from magcilia.device.magnetometer import Magnetometer
from magcilia.readout.array import ArrayEstimate, ArrayEstimates, ArrayFlag, ArrayReadout
from magcilia.readout.biaxial import BiaxialReadout, ForceFlag
from magcilia.readout.protocol import FLAG_DTYPE, Flag, ReadoutValues, SensorReadout

PART = Magnetometer(field_range=5e-3, resolution=1.5e-7, noise=3e-7, rate=100.0, name="part")
ARRAY_SETUP = mc.Setup.paper(tip_radius=5e-5, youngs_modulus=1e6, position=(0.0, 0.0, 0.0))
SPAN = 2e-5
MAG = Magnetometer(field_range=1e-3, resolution=1e-10, noise=2e-8, rate=100.0, name="mag")


@pytest.fixture(scope="module")
def biaxial() -> BiaxialReadout:
    return BiaxialReadout(mc.Setup.paper(tip_radius=5e-5), MAG, span=1e-4, table_size=(17, 32))


@pytest.fixture(scope="module")
def array() -> ArrayReadout:
    return ArrayReadout(CiliaArray.grid(ARRAY_SETUP, 2, 2, 2e-3, sensor=PART), SPAN)


def _loads(rng: np.random.Generator, n: int) -> np.ndarray:
    mag = 0.8 * SPAN * np.sqrt(rng.uniform(0.0, 1.0, n))
    phi = rng.uniform(-np.pi, np.pi, n)
    return np.stack([mag * np.cos(phi), mag * np.sin(phi)], axis=1)


def test_former_flag_enums_are_the_one_flag_set() -> None:
    assert ForceFlag is Flag and ArrayFlag is Flag
    # the array's bits took the shared values (they were 1, 2 and 4)
    assert (ArrayFlag.SATURATED, ArrayFlag.BEYOND_SPAN, ArrayFlag.NOT_CONVERGED) == (4, 64, 512)
    assert ArrayFlag.BEYOND_SPAN is Flag.ABOVE_SPAN


def test_biaxial_readout_follows_the_protocol(biaxial: BiaxialReadout) -> None:
    assert isinstance(biaxial, SensorReadout)
    assert biaxial.inputs == ("mag.x", "mag.y", "mag.z")
    assert biaxial.rest.shape == (3,) and biaxial.baseline is None
    rng = np.random.default_rng(1)
    samples = biaxial.rest + 2e-8 * rng.standard_normal((5, 3))
    res = biaxial.read(samples)
    assert isinstance(res, ReadoutValues)
    assert res.value.shape == res.sigma.shape == (5, 2) and res.unit == "N"
    assert res.flags.shape == (5,) and res.flags.dtype == FLAG_DTYPE
    np.testing.assert_array_equal(res.value, np.stack([res.fx, res.fy], -1))
    np.testing.assert_array_equal(res.sigma, np.stack([res.sigma_fx, res.sigma_fy], -1))
    empty = biaxial.read(samples[:0])
    assert empty.value.shape == (0, 2) and empty.flags.shape == (0,)
    tared = biaxial.tare(samples)
    assert isinstance(tared, BiaxialReadout) and tared.baseline is not None
    assert tared.baseline.unit == "T" and tared.baseline.names == biaxial.inputs
    assert biaxial.baseline is None  # a copy


def test_array_readout_follows_the_protocol(array: ArrayReadout) -> None:
    assert isinstance(array, SensorReadout)
    names = [s.name for s in array.array.sensors]
    assert array.inputs == tuple(f"{n}.{a}" for n in names for a in "xyz")
    assert array.inputs[:3] == ("part r1c1.x", "part r1c1.y", "part r1c1.z")
    assert array.rest.shape == (12,) and array.baseline is None
    rng = np.random.default_rng(2)
    arr = array.array
    fields = np.array([mc.field_for_loads(arr, _loads(rng, 4)) for _ in range(3)])
    samples = arr.readings(fields, rng=rng).reshape(3, -1)
    res = array.read(samples)
    assert isinstance(res, ArrayEstimates) and isinstance(res, ReadoutValues)
    assert res.value.shape == res.sigma.shape == (3, 4, 2) and res.unit == "N"
    assert res.flags.shape == (3, 4) and res.flags.dtype == FLAG_DTYPE and len(res) == 3
    one = array.read(samples[0])
    assert isinstance(one, ArrayEstimate) and one.value.shape == (4, 2) and one.unit == "N"
    assert one.flags.dtype == FLAG_DTYPE
    doc = json.loads(json_text(res.to_dict()))
    assert np.asarray(doc["force_N"]).shape == (3, 4, 2)
    empty = array.read(samples[:0])  # no samples (a view's quiet moment): empty results
    assert isinstance(empty, ArrayEstimates) and empty.value.shape == (0, 4, 2)
    assert empty.flags.shape == (0, 4) and "0 samples" in empty.report()
    assert len(res.to_dataframe()) == 12 and "4 cilia in 3 samples" in res.report()


def test_batched_read_equals_reading_one_at_a_time(array: ArrayReadout) -> None:
    rng = np.random.default_rng(3)
    arr = array.array
    loads = np.array([_loads(rng, 4) for _ in range(6)])
    fields = np.array([mc.field_for_loads(arr, f) for f in loads])
    samples = arr.readings(fields, rng=rng).reshape(6, -1)
    batch = array.read(samples)
    assert isinstance(batch, ArrayEstimates)
    for i, y in enumerate(samples):
        one = array.read_one(y)
        scale = one.sigma.min()
        np.testing.assert_allclose(batch.force[i], one.force, rtol=0, atol=1e-4 * scale)
        np.testing.assert_allclose(batch.sigma[i], one.sigma, rtol=1e-6)
        np.testing.assert_array_equal(batch.flags[i], one.flags)
        blocks = one.covariance.reshape(4, 2, 4, 2)[np.arange(4), :, np.arange(4), :]
        np.testing.assert_allclose(batch.covariance[i], blocks, rtol=0,
                                   atol=1e-6 * np.abs(blocks).max())
        assert batch.chi2[i] == pytest.approx(one.chi2, rel=1e-6, abs=1e-6)
    # and the estimates are the loads, within the noise
    assert np.mean(np.abs(batch.force - loads) <= 2.0 * batch.sigma) > 0.85


def test_array_tare_removes_a_constant_field_offset(array: ArrayReadout) -> None:
    rng = np.random.default_rng(4)
    arr = array.array
    offset = np.tile([3e-5, -2e-5, 4.5e-5], arr.n_sensors)  # the earth's field on each sensor
    loads = _loads(rng, 4)
    clean = arr.to_sensor(mc.field_for_loads(arr, loads)).reshape(-1)
    baseline = array.rest + offset + 3e-7 * rng.standard_normal((400, 12))
    tared = array.tare(baseline)
    assert tared.baseline is not None and tared.baseline.unit == "T"
    assert tared.baseline.names == array.inputs and array.baseline is None
    np.testing.assert_allclose(tared.baseline.correction, -offset, rtol=0, atol=1e-7)
    est = tared.read_one(clean + offset)
    off = array.read_one(clean + offset)
    assert np.abs(off.force - loads).max() > 20.0 * off.sigma.max()  # untared: far off
    assert np.abs(est.force - loads).max() < 1.0 * est.sigma.min()  # tared: within σ
    # its measured spread is the noise, and its standard error (shared) enters σ
    np.testing.assert_allclose(tared.sigma, 3e-7, rtol=0.15)
    assert np.all(est.sigma > array.read_one(clean, noise=tared.sigma).sigma)
    # the batched read applies the tare alike
    batch = tared.read(np.stack([clean + offset] * 2))
    np.testing.assert_allclose(batch.force[1], est.force, rtol=0, atol=1e-4 * est.sigma.min())


def test_array_flags_missing_and_saturated_readings_in_a_batch(array: ArrayReadout) -> None:
    rng = np.random.default_rng(5)
    arr = array.array
    samples = arr.to_sensor(np.array([mc.field_for_loads(arr, _loads(rng, 4))] * 3)).reshape(3, -1)
    samples[1, 0] = np.nan
    samples[2, 3] = PART.field_range[0]  # clipped at its range
    res = array.read(samples)
    assert isinstance(res, ArrayEstimates)
    assert not res.flags[0].any() and np.all(np.isfinite(res.force))
    assert res.flags[1, 0] & Flag.MISSING and not np.any(res.flags[1] & Flag.SATURATED)
    assert res.flags[2, 1] & Flag.SATURATED and not np.any(res.flags[2] & Flag.MISSING)
    assert res.readings_used.tolist() == [12, 11, 11]
    np.testing.assert_allclose(res.force[1], res.force[0], rtol=0, atol=1e-6 * SPAN)


def test_array_noise_replaces_the_stated_noise(array: ArrayReadout) -> None:
    y = array.rest
    one = array.read_one(y)
    twice = array.read_one(y, noise=2.0 * array.sigma)
    np.testing.assert_allclose(twice.sigma_noise, 2.0 * one.sigma_noise, rtol=1e-6)
    with pytest.raises(mc.MagciliaError, match="noise"):
        array.read(y, noise=[1e-7, 2e-7])
    with pytest.raises(mc.MagciliaError, match=r"readings.*\(n, 12\)"):
        array.read(np.zeros((2, 5)))
