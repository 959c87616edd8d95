"""Bent shapes as poses of the field model: the issue's public calls, the straight limit, the
rigid-tilt limit, the exact (magpylib) field of the bent body, and batch sweeps."""

from __future__ import annotations

import math

import numpy as np
import pytest

import magcilia as mc
from magcilia.mechanics import Flow

POSITION = (1.4727e-3, 1.9891e-3, 0.3804e-3)


@pytest.fixture(scope="module")
def setup() -> mc.Setup:
    return mc.Setup.paper(height=3e-3, base_radius=2e-4, tip_radius=5e-5, youngs_modulus=2.0e6,
                          position=POSITION, n_loops=12, dipoles_per_loop=4)


def test_public_calls_of_the_issue(setup: mc.Setup) -> None:
    shape = mc.bend(setup, force=1e-4)
    assert isinstance(shape, mc.BentShape) and isinstance(shape, mc.Centreline)
    assert shape.tip.shape == (3,) and len(shape) == 1
    assert shape.tip[0] > 0.0 and shape.tip[1] == 0.0 and 0.0 < shape.tip[2] < 3e-3
    np.testing.assert_array_equal(shape.tip, shape.points[0, -1])
    assert isinstance(shape.tip_angle, float) and shape.tip_angle > 0.0
    assert shape.load.force == 1e-4 and shape.load.at == 3e-3
    out = setup.output(shape)
    assert out.shape == (1,) and out[0] != setup.output([0.0])[0]
    volts = setup.output(shape)
    est = mc.Readout(setup, quantity="force", span=(0.0, 2e-4)).estimate(volts)
    assert est.shape == volts.shape and est[0] == pytest.approx(1e-4, rel=1e-6)


def test_zero_force_output_equals_the_straight_cilium(setup: mc.Setup) -> None:
    straight = mc.bend(setup, force=0.0)
    np.testing.assert_allclose(setup.output(straight), setup.output([0.0]), rtol=1e-12)
    np.testing.assert_allclose(setup.field(straight), setup.field([0.0]), rtol=1e-11,
                               atol=1e-18)


def test_kink_at_the_base_approaches_a_rigid_tilt(setup: mc.Setup) -> None:
    # a load just above the base bends only a short stub of length a: the rest is a rigid tilt,
    # and the output tends to the rigid-tilt output as a -> 0 (same load parameter F a² / EI)
    errors = []
    for fraction in (1e-2, 2e-3):
        at = fraction * setup.cilium.height
        shape = mc.bend(setup, force=4.0 * (1e-2 / fraction) ** 2, at=at)
        theta = shape.tip_angle
        assert 0.2 < theta < 1.4
        rigid = setup.output([theta])[0]
        swing = abs(rigid - setup.output([0.0])[0])
        assert swing > 1e-4
        errors.append(abs(setup.output(shape)[0] - rigid) / swing)
    assert errors[0] < 2e-2
    assert errors[1] < 0.3 * errors[0]


def test_bent_field_matches_the_exact_body() -> None:
    # the converged dipole model of the bent shape vs magpylib's cylinder stack along it
    fine = mc.Setup.paper(tip_radius=5e-5, youngs_modulus=2e6, n_loops=24, dipoles_per_loop=8,
                          ring="rms")
    shape = mc.bend(fine, force=1e-4)
    assert shape.tip_angle > 0.5  # strongly bent
    exact = mc.exact_field(fine, shape, n_slices=200)[0]
    model = fine.field(shape)[0]
    assert model[0] == pytest.approx(exact[0], rel=1e-3)
    np.testing.assert_allclose(model, exact, atol=2e-3 * np.linalg.norm(exact))
    # and it differs from the rigid tilt of the same tip angle
    assert abs(fine.field([shape.tip_angle])[0, 0] - exact[0]) > 0.05 * abs(exact[0])


def test_sweep_matches_single_solves(setup: mc.Setup) -> None:
    forces = np.array([0.0, 5e-5, 1e-4, 2e-4])
    batch = mc.bend_sweep(setup, forces=forces)
    assert isinstance(batch, mc.Centreline) and len(batch) == 4
    for i, f in enumerate(forces):
        np.testing.assert_allclose(batch.points[i], mc.bend(setup, force=f).points[0],
                                   rtol=1e-9, atol=1e-15)
    np.testing.assert_allclose(setup.output(batch)[2], setup.output(mc.bend(setup, force=1e-4)),
                               rtol=1e-9)
    speeds = np.array([0.1, 0.5])
    flows = mc.bend_sweep(setup, speeds=speeds, flow=Flow.uniform(1.0))
    for i, u in enumerate(speeds):
        np.testing.assert_allclose(flows.tip[i], mc.bend(setup, flow=Flow.uniform(u)).tip,
                                   rtol=1e-9)


def test_force_and_flow_together_add_up_in_the_linear_regime(setup: mc.Setup) -> None:
    f, flow = 1e-7, Flow.uniform(5e-3)
    both = mc.bend(setup, force=f, flow=flow).deflection
    parts = mc.bend(setup, force=f).deflection + mc.bend(setup, flow=flow).deflection
    assert both == pytest.approx(parts, rel=1e-4)


def test_direction_tension_stiffens_like_a_beam_column() -> None:
    # a nearly axial pull: lateral part Q, tension P; linear beam-column theory gives
    # δ = Q / (P k) (kL − tanh kL), k² = P / EI (exact for small Q)
    r, length, e = 1e-4, 3e-3, 2e6
    cyl = mc.Setup.paper(height=length, base_radius=r, tip_radius=r, youngs_modulus=e)
    ei = e * math.pi * r**4 / 4.0
    angle = 1e-3
    f = 2.0 * ei / length**2  # kL = sqrt(2)
    q, p = f * math.sin(angle), f * math.cos(angle)
    k = math.sqrt(p / ei)
    expected = q / (p * k) * (k * length - math.tanh(k * length))
    shape = mc.bend(cyl, force=f, direction=angle)
    assert shape.deflection == pytest.approx(expected, rel=1e-5)
    assert shape.deflection < q * length**3 / (3 * ei)  # stiffer than without the pull


def test_sweep_errors(setup: mc.Setup) -> None:
    with pytest.raises(mc.MagciliaError, match="given forces or speeds"):
        mc.bend_sweep(setup)
    with pytest.raises(mc.MagciliaError, match="flow must be a Flow"):
        mc.bend_sweep(setup, speeds=[0.1])
    with pytest.raises(mc.MagciliaError, match="tip compliance is infinite"):
        mc.bend_sweep(mc.Setup.paper(), forces=[1e-5])
