"""A measured radius profile: geometry, field model, exact reference, bending and setup files."""

from __future__ import annotations

import itertools
import math
from pathlib import Path

import numpy as np
import pytest
from scipy.integrate import quad

import magcilia as mc
from magcilia.mechanics import tip_compliance
from magcilia.model.batch import tilt_output_batch

L, RB, RT, E = 3e-3, 2e-4, 5e-5, 2e6
ANGLES = np.radians(np.linspace(0.0, 85.0, 9))
# a measured-looking shape: a bulge above the base, then a taper to a rounded tip
S_BULGE = np.array([0.0, 0.4e-3, 1.0e-3, 2.2e-3, 3.0e-3])
R_BULGE = np.array([2.0e-4, 2.3e-4, 2.0e-4, 1.0e-4, 0.4e-4])


def frustum_as_profile(points: int = 7) -> tuple[mc.Cilium, mc.Cilium]:
    s = np.linspace(0.0, L, points)
    frustum = mc.Cilium(L, RB, RT, youngs_modulus=E)
    return frustum, mc.Cilium.from_profile(s, RB + (RT - RB) * s / L, youngs_modulus=E)


def test_profile_of_a_frustum_is_the_frustum() -> None:
    frustum, profile = frustum_as_profile()
    assert profile.height == L and profile.base_radius == RB
    assert profile.tip_radius == pytest.approx(RT, rel=1e-14)
    assert profile.volume == pytest.approx(frustum.volume, rel=1e-14)
    for n in (1, 3, 8):
        np.testing.assert_allclose(profile.slice_volumes(n), frustum.slice_volumes(n), rtol=1e-13)
        for ring in ("mean", "rms"):
            np.testing.assert_allclose(profile.ring_radii(n, ring), frustum.ring_radii(n, ring),
                                       rtol=1e-13)
    s = np.linspace(0.0, L, 31)
    np.testing.assert_allclose(profile.radius(s), frustum.radius(s), rtol=1e-14)


def test_profile_volumes_are_exact_integrals() -> None:
    c = mc.Cilium.from_profile(S_BULGE, R_BULGE)
    exact = sum(quad(lambda s: math.pi * float(c.radius(s)) ** 2, a, b)[0]
                for a, b in itertools.pairwise(S_BULGE))
    assert c.volume == pytest.approx(exact, rel=1e-12)
    vols = c.slice_volumes(5)
    edges = c.slice_edges(5)
    knots = np.union1d(edges, S_BULGE)
    for i in range(5):
        inner = knots[(knots >= edges[i]) & (knots <= edges[i + 1])]
        ref = sum(quad(lambda s: math.pi * float(c.radius(s)) ** 2, a, b)[0]
                  for a, b in itertools.pairwise(inner))
        assert vols[i] == pytest.approx(ref, rel=1e-12)
    assert c.max_radius == pytest.approx(2.3e-4)
    assert c.tip_radius == pytest.approx(0.4e-4)


def test_setup_with_a_profile_matches_the_frustum_and_the_batch_path() -> None:
    frustum, profile = frustum_as_profile()
    a = mc.Setup.paper(cilium=frustum, ring="rms", n_loops=8, dipoles_per_loop=4)
    b = mc.Setup.paper(cilium=profile, ring="rms", n_loops=8, dipoles_per_loop=4)
    np.testing.assert_allclose(b.output(ANGLES), a.output(ANGLES), rtol=1e-12, atol=1e-18)
    assert b.cilium.height == L  # the paper's Table I values do not override a given cilium
    bulge = b.replace(cilium=mc.Cilium.from_profile(S_BULGE, R_BULGE))
    params = {"height": np.array([L, 1.1 * L]), "base_radius": np.array([RB, 0.9 * RB]),
              "x": np.array([1.4e-3, 1.6e-3])}
    batch = tilt_output_batch(bulge, params, ANGLES)
    for i in range(2):  # height and base radius scale the measured shape
        one = bulge.replace(height=params["height"][i], base_radius=params["base_radius"][i],
                            x=params["x"][i])
        assert one.cilium.profile == bulge.cilium.profile
        np.testing.assert_allclose(batch[i], one.output(ANGLES), rtol=1e-12, atol=1e-18)


def test_dipole_model_of_a_profile_converges_to_the_exact_body() -> None:
    setup = mc.Setup.paper(cilium=mc.Cilium.from_profile(S_BULGE, R_BULGE), ring="rms",
                           position=(1.0e-3, 0.5e-3, 0.2e-3), n_loops=60, dipoles_per_loop=8)
    exact = mc.exact_field(setup, ANGLES, n_slices=600)
    model = setup.field(ANGLES)
    err = np.linalg.norm(model - exact, axis=1) / np.linalg.norm(exact, axis=1)
    assert err.max() < 2e-3
    coarse = setup.replace(n_loops=2, dipoles_per_loop=8).field(ANGLES)
    assert (np.linalg.norm(coarse - exact, axis=1)
            / np.linalg.norm(exact, axis=1)).max() > 5 * err.max()


def test_bending_a_profile() -> None:
    frustum, profile = frustum_as_profile()
    a = mc.Setup.paper(cilium=frustum, n_loops=8, dipoles_per_loop=4)
    b = mc.Setup.paper(cilium=profile, n_loops=8, dipoles_per_loop=4)
    np.testing.assert_allclose(mc.bend(b, force=1e-4).tip, mc.bend(a, force=1e-4).tip, rtol=1e-9)
    assert tip_compliance(b) == pytest.approx(tip_compliance(a), rel=1e-10)
    bulge = b.replace(cilium=mc.Cilium.from_profile(S_BULGE, R_BULGE, youngs_modulus=E))
    # small load: the solver's tip deflection equals ∫ (L − s)² / (E I(s)) ds · P
    force = 1e-7
    assert mc.bend(bulge, force=force).tip[0] / force == pytest.approx(tip_compliance(bulge),
                                                                        rel=1e-6)
    shape = mc.bend(bulge, force=2e-4)  # large deflection converges and is inextensible
    seg = np.diff(shape.points[0], axis=0)
    assert np.sum(np.linalg.norm(seg, axis=1)) == pytest.approx(L, rel=1e-4)


def test_profile_in_setup_files(tmp_path: Path) -> None:
    setup = mc.Setup.paper(cilium=mc.Cilium.from_profile(S_BULGE, R_BULGE, youngs_modulus=E))
    path = tmp_path / "measured.toml"
    mc.save_setup(setup, path)
    text = path.read_text()
    assert "profile_s" in text and "height" not in text
    back = mc.load_setup(path)
    assert back.cilium == setup.cilium
    np.testing.assert_allclose(back.output(ANGLES), setup.output(ANGLES), rtol=1e-12)
    only_s = text.replace("profile_r", "# profile_r", 1).split("# profile_r")[0] + "\n"
    path.write_text(only_s)
    with pytest.raises(mc.MagciliaError, match=r"profile_s / profile_r must be both lists") as err:
        mc.load_setup(path)
    assert str(err.value).count(str(path)) == 1  # the file is named once
    path.write_text('[cilium]\nheight = "3 mm"\nprofile_s = ["0 mm", "3 mm"]\n'
                    'profile_r = ["0.2 mm", "0.05 mm"]\n')
    with pytest.raises(mc.MagciliaError, match=r"cilium\.height must be left out"):
        mc.load_setup(path)
    path.write_text('[cilium]\nprofile_s = ["0 mm", "3"]\nprofile_r = ["0.2 mm", "0.05 mm"]\n')
    with pytest.raises(mc.MagciliaError, match=r"profile_s\[1\]"):
        mc.load_setup(path)


@pytest.mark.parametrize(
    ("s", "r", "match"),
    [
        ([0.0, 2e-3, 1e-3], [2e-4, 1e-4, 5e-5], "arc lengths increasing from 0"),
        ([1e-4, 3e-3], [2e-4, 5e-5], "arc lengths increasing from 0"),
        ([0.0, 3e-3], [0.0, 5e-5], "profile radius at the base must be a positive length"),
        ([0.0, 1e-3, 3e-3], [2e-4, 0.0, 5e-5], "only the tip may be 0"),
        ([0.0, 3e-3], [2e-4], "at least two"),
        ([0.0, float("nan")], [2e-4, 1e-4], "finite"),
    ],
    ids=["decreasing", "not-from-0", "zero-base", "zero-inside", "counts", "nan"],
)
def test_bad_profiles(s: list[float], r: list[float], match: str) -> None:
    with pytest.raises(mc.MagciliaError, match=match):
        mc.Cilium.from_profile(s, r)


def test_sharp_profile_tip_needs_a_tip_radius_for_a_tip_load() -> None:
    sharp = mc.Setup.paper(cilium=mc.Cilium.from_profile([0.0, 1e-3, 3e-3], [2e-4, 1.5e-4, 0.0]))
    with pytest.raises(mc.MagciliaError, match="tip_radius"):
        mc.bend(sharp, force=1e-5)


def test_tip_radius_of_a_profile_comes_from_the_profile() -> None:
    setup = mc.Setup.paper(cilium=mc.Cilium.from_profile(S_BULGE, R_BULGE))
    with pytest.raises(mc.MagciliaError, match="tip_radius must be left out for a cilium with a"):
        setup.replace(tip_radius=1e-5)
    assert setup.replace(base_radius=1e-4).cilium.tip_radius == pytest.approx(0.2e-4)


def test_reynolds_limit_uses_the_widest_section() -> None:
    """A bulge wider than the base reaches the drag law's Re limit at a lower speed."""
    bulge = mc.Setup.paper(cilium=mc.Cilium.from_profile(S_BULGE, R_BULGE, youngs_modulus=E))
    water = mc.WATER
    u_base = 2e5 * water.viscosity / (water.density * 2 * RB)
    u_widest = 2e5 * water.viscosity / (water.density * 2 * R_BULGE.max())
    assert u_widest < 0.95 * u_base
    with pytest.raises(mc.MagciliaError, match="drag law"):
        mc.bend(bulge, flow=mc.Flow.uniform(0.5 * (u_base + u_widest), water))
