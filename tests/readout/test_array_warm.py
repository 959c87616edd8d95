"""The array inverse warm-started from the frame before (readout/array_inverse, array_stream)."""

from __future__ import annotations

import numpy as np
import pytest

import magcilia as mc
from magcilia._errors import MagciliaError
from magcilia.device.array import CiliaArray
from magcilia.device.magnetometer import Magnetometer
from magcilia.live.readouts import live_sensor
from magcilia.readout import array_readout
from magcilia.readout.array import ArrayReadout, ArrayStream, field_for_loads
from magcilia.readout.protocol import SensorReadout

PART = Magnetometer(field_range=5e-3, resolution=1.5e-7, noise=3e-7, rate=100.0, name="part")
SETUP = mc.Setup.paper(tip_radius=5e-5, youngs_modulus=1e6, position=(0.0, 0.0, 0.0))
SPAN = 2e-5


@pytest.fixture(scope="module")
def readout() -> ArrayReadout:
    return ArrayReadout(CiliaArray.grid(SETUP, 3, 3, 2e-3, sensor=PART), SPAN)


@pytest.fixture(scope="module")
def frames(readout: ArrayReadout) -> tuple[np.ndarray, np.ndarray]:
    """24 frames of a slowly turning load (exact elastica at every frame) and noisy readings."""
    array = readout.array
    rng = np.random.default_rng(5)
    amp = rng.uniform(0.3, 0.8, len(array)) * SPAN
    phase = rng.uniform(-np.pi, np.pi, len(array))
    t = np.arange(24) * 0.02
    ang = phase[None, :] + t[:, None]
    forces = np.stack([amp * np.cos(ang), amp * np.sin(ang)], axis=-1)  # (24, C, 2)
    fields = np.array([field_for_loads(array, f) for f in forces])
    return forces, array.readings(fields, rng=rng).reshape(len(t), -1)


def test_warm_and_cold_starts_give_the_same_estimates(readout: ArrayReadout,
                                                     frames: tuple[np.ndarray, np.ndarray]) -> None:
    forces, y = frames
    array = readout.array
    exact = array.to_sensor(field_for_loads(array, forces[3])).reshape(-1)
    cold = readout.read(exact)
    warm = readout.read(exact, start=forces[2])
    assert warm.converged and cold.converged
    np.testing.assert_allclose(warm.force, forces[3], rtol=0, atol=1e-6 * SPAN)
    for k in range(1, len(y)):
        a = readout.read(y[k])
        b = readout.read(y[k], start=forces[k - 1])
        # both stop within the fit's tolerance of the one minimum
        assert np.abs(a.force - b.force).max() <= 0.05 * a.sigma.min()
        np.testing.assert_allclose(b.covariance, a.covariance, rtol=1e-2,
                                   atol=1e-2 * np.abs(a.covariance).max())


def test_warm_starts_take_fewer_iterations(readout: ArrayReadout,
                                          frames: tuple[np.ndarray, np.ndarray]) -> None:
    _, y = frames
    cold = [readout.read(y[k]).iterations for k in range(1, len(y))]
    warm = []
    last = readout.read(y[0]).force
    for k in range(1, len(y)):
        est = readout.read(y[k], start=last)
        last = est.force
        warm.append(est.iterations)
    assert np.mean(warm) < np.mean(cold)


def test_a_batch_of_frames_chained_block_by_block_matches_frames_read_alone(
        readout: ArrayReadout, frames: tuple[np.ndarray, np.ndarray],
        monkeypatch: pytest.MonkeyPatch) -> None:
    _, y = frames
    monkeypatch.setattr(array_readout, "BLOCK", 5)  # 5 blocks, each warm from the one before
    batch = readout.read(y)
    assert batch.converged.all()
    for k in range(0, len(y), 4):
        alone = readout.read(y[k])
        assert np.abs(batch.force[k] - alone.force).max() <= 0.05 * alone.sigma.min()
        np.testing.assert_allclose(batch.sigma[k], alone.sigma, rtol=1e-2)


def test_a_bad_start_is_refused_in_one_line(readout: ArrayReadout) -> None:
    y = readout.rest
    with pytest.raises(MagciliaError, match=r"start must be forces of shape \(9, 2\)"):
        readout.read(y, start=np.zeros((9, 3)))
    with pytest.raises(MagciliaError, match="start"):
        readout.read(y, start=np.full((9, 2), np.nan))


def test_the_stream_starts_each_call_from_the_last(readout: ArrayReadout,
                                                  frames: tuple[np.ndarray, np.ndarray]) -> None:
    _, y = frames
    stream = readout.stream()
    assert isinstance(stream, ArrayStream) and isinstance(stream, SensorReadout)
    assert stream.inputs == readout.inputs and stream.last is None
    first = stream.read(y[:6])
    assert stream.last is not None
    np.testing.assert_array_equal(stream.last, first.force[-1])
    nxt = stream.read(y[6])
    alone = readout.read(y[6])
    assert np.abs(nxt.force - alone.force).max() <= 0.05 * alone.sigma.min()
    np.testing.assert_array_equal(stream.last, nxt.force)
    tared = stream.tare(np.tile(readout.rest, (4, 1)) + 1e-7 * np.arange(4)[:, None])
    assert isinstance(tared, ArrayStream) and tared.last is None
    assert tared.baseline is not None and stream.baseline is None
    # a call that does not converge leaves the next to start cold
    one = ArrayReadout(readout.array, SPAN, max_iterations=1).stream()
    est = one.read(y[3])
    assert not est.converged and one.last is None


def test_the_live_views_read_an_array_as_a_stream(readout: ArrayReadout) -> None:
    sensor = live_sensor(readout)
    assert isinstance(sensor.view, ArrayStream) and sensor.view.readout is readout
