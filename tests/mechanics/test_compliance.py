"""The small-load tip compliance in its home (mechanics.compliance) and the cobalt fraction in
its (device.material), as the optimiser's screen calls them for many designs at once."""

from __future__ import annotations

import math

import numpy as np
import pytest

import magcilia as mc
from magcilia.device.material import Material, volume_fraction
from magcilia.mechanics import frustum_compliance, tip_compliance


def test_a_cylinder_is_euler_bernoulli() -> None:
    length, radius, modulus = 3e-3, 2e-4, 7e5
    second_moment = math.pi * radius**4 / 4
    assert frustum_compliance(length, radius, radius, modulus) == pytest.approx(
        length**3 / (3 * modulus * second_moment), rel=1e-14)


def test_a_tapered_cilium_bends_as_its_compliance_says() -> None:
    setup = mc.Setup.paper(height=3e-3, base_radius=2e-4, tip_radius=5e-5, youngs_modulus=2e6)
    force = 1e-9  # linear
    assert mc.bend(setup, force=force).tip[0] / force == pytest.approx(
        tip_compliance(setup), rel=1e-6)


def test_many_designs_at_once_are_each_designs_own() -> None:
    gen = np.random.default_rng(2)
    h, rb = gen.uniform(2e-3, 4e-3, 20), gen.uniform(1e-4, 3e-4, 20)
    rt, e = rb * gen.uniform(0.1, 1.0, 20), gen.uniform(3e5, 2e6, 20)
    many = frustum_compliance(h, rb, rt, e)
    one = [tip_compliance(mc.Setup.paper(height=a, base_radius=b, tip_radius=c,
                                         youngs_modulus=d))
           for a, b, c, d in zip(h, rb, rt, e, strict=True)]
    np.testing.assert_allclose(many, one, rtol=1e-14, atol=0)  # NumPy's power vs Python's
    cobalt = gen.uniform(10e-6, 50e-6, 20)
    m = Material()
    phi = volume_fraction(cobalt, m.polymer_mass, m.cobalt_density, m.polymer_density)
    np.testing.assert_allclose(phi, [Material(cobalt_mass=c).volume_fraction for c in cobalt],
                               rtol=1e-15, atol=0)
    assert math.isinf(tip_compliance(mc.Setup.paper(tip_radius=0.0)))  # a sharp cone
