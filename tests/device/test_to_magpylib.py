"""``Setup.to_magpylib``: the model's dipoles handed to magpylib give the model's field."""

from __future__ import annotations

import magpylib as magpy
import numpy as np
import pytest

import magcilia as mc

SETUPS = {
    "paper 2x5": mc.Setup.paper(),
    "initial 6x3": mc.Setup.paper_initial(),
    "tapered 7x4 rms": mc.Setup.paper(tip_radius=5e-5, n_loops=7, dipoles_per_loop=4,
                                      ring="rms", offset=1e-3),
    "1x1": mc.Setup.paper(n_loops=1, dipoles_per_loop=1),
}


def _close(actual: object, expected: np.ndarray) -> None:
    """Equal to 1e-12 relative to the field's magnitude (components that cancel to round-off,
    B_x and B_y of an upright cilium above the element, are compared at that scale)."""
    expected = np.asarray(expected)
    np.testing.assert_allclose(actual, expected, rtol=0,
                               atol=1e-12 * float(np.max(np.linalg.norm(expected, axis=-1))))


@pytest.mark.parametrize("name", sorted(SETUPS))
@pytest.mark.parametrize("angle", [0.0, 0.3, -0.7, 1.4])
def test_magpylib_field_equals_the_model(name: str, angle: float) -> None:
    setup = SETUPS[name]
    collection = setup.to_magpylib(angle)
    assert len(collection.sources) == setup.n_loops * setup.dipoles_per_loop
    assert all(isinstance(s, magpy.misc.Dipole) for s in collection.sources)
    (sensor,) = collection.sensors
    np.testing.assert_array_equal(sensor.position, [0.0, 0.0, 0.0])
    expected = setup.field([angle])[0]
    _close(collection.getB(), expected)
    _close(magpy.getB(collection.sources, sensor, sumup=True), expected)
    bare = setup.to_magpylib(angle, sensor=False)
    assert bare.sensors == []
    _close(bare.getB((0.0, 0.0, 0.0)), expected)


def test_dipoles_sit_where_the_model_puts_them() -> None:
    setup = SETUPS["tapered 7x4 rms"]
    positions, moments = setup.dipoles([0.5])
    collection = setup.to_magpylib(0.5, sensor=False)
    np.testing.assert_allclose([s.position for s in collection.sources], positions[0],
                               rtol=1e-15, atol=0)
    np.testing.assert_allclose([s.moment for s in collection.sources], moments[0], rtol=1e-15)
    total = np.sum([s.moment for s in collection.sources], axis=0)
    assert np.linalg.norm(total) == pytest.approx(setup.moment, rel=1e-12)


def test_a_bent_shape_is_handed_over() -> None:
    setup = mc.Setup.paper(tip_radius=5e-5, n_loops=8, dipoles_per_loop=4)
    shape = mc.bend(setup, force=1e-4)
    collection = setup.to_magpylib(shape)
    _close(collection.getB(), setup.field(shape)[0])
    # away from the sensor as well
    point = np.array([1e-3, -2e-3, -1e-3])
    _close(magpy.getB(collection.sources, point, sumup=True),
           setup.field_at(point, shape).reshape(3))


def test_one_pose_only() -> None:
    setup = mc.Setup.paper()
    with pytest.raises(mc.MagciliaError, match="pose"):
        setup.to_magpylib(setup.centreline([0.1, 0.2]))
    with pytest.raises(mc.MagciliaError, match="pose"):
        setup.to_magpylib("0.3")  # type: ignore[arg-type]
