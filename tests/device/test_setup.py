"""The distributed-dipole model of a cilium on its sensor: the paper preset, eq. (1), the frame,
convergence to the exact body, the far field, invariants and bad input."""

from __future__ import annotations

import itertools
import math

import numpy as np
import pytest
from hypothesis import given
from hypothesis import strategies as st

import magcilia as mc
from magcilia.constants import GAUSS
from magcilia.model.batch import tilt_field_batch, tilt_output_batch
from magcilia.model.exact import single_dipole_field
from magcilia.model.kernels import dipole_field

ANGLES = np.radians(np.linspace(0.0, 85.0, 33))


def test_paper_preset_numbers() -> None:
    s = mc.Setup.paper()
    assert s.material.volume_fraction == pytest.approx(0.0937, abs=5e-5)
    assert s.material.cobalt_magnetization == pytest.approx(1.450e6, rel=1e-3)
    assert s.material.magnetization_scale == 1.0
    assert s.sensor.scale == pytest.approx(75.0)
    assert s.sensor.depth == pytest.approx(0.71e-3)
    assert s.sensor.field_range == pytest.approx(6 * GAUSS)
    assert s.params()["height"] == 3.2613e-3
    assert s.n_loops == 2 and s.dipoles_per_loop == 5
    np.testing.assert_allclose(s.base_centre, [1.4727e-3, 1.9891e-3, 0.71e-3 + 0.3804e-3])


def test_public_call_of_the_issue() -> None:
    setup = mc.Setup.paper(height=3.2613e-3, base_radius=0.1801e-3,
                           position=(1.4727e-3, 1.9891e-3, 0.3804e-3), n_loops=2,
                           dipoles_per_loop=5)
    b = setup.field(ANGLES)
    v = setup.output(ANGLES)
    assert b.shape == (33, 3) and v.shape == (33,)
    np.testing.assert_allclose(v, 75.0 * b[:, 0], rtol=1e-14)


@pytest.mark.parametrize("n", [1, 2, 3, 7])
@pytest.mark.parametrize("k", [1, 2, 5])
@pytest.mark.parametrize("ring", ["mean", "rms"])
def test_total_moment_is_eq1(n: int, k: int, ring: str) -> None:
    s = mc.Setup.paper(n_loops=n, dipoles_per_loop=k, ring=ring, tip_radius=2e-5)
    phi = s.material.volume_fraction
    m_c = phi * s.cilium.volume * s.material.atom_density * s.material.moment_per_atom
    _, mom = s.dipoles(np.radians([0.0, 40.0]))
    assert mom.shape == (2, n * k, 3)
    np.testing.assert_allclose(np.linalg.norm(mom.sum(axis=1), axis=-1), m_c, rtol=1e-12)


def test_dipole_layout_follows_the_convention() -> None:
    # one slice, k = 4: dipoles at mid-height on the mean radius, azimuth 0 along the tilt (+x)
    s = mc.Setup.paper(n_loops=1, dipoles_per_loop=4, position=(0.0, 2e-3, 0.0))
    pos, mom = s.dipoles([0.0])
    h, rb = s.cilium.height, s.cilium.base_radius
    base = s.base_centre
    np.testing.assert_allclose(pos[0, 0], base + [rb * 0.5, 0.0, h / 2], atol=1e-15)
    np.testing.assert_allclose(pos[0, 1], base + [0.0, rb * 0.5, h / 2], atol=1e-15)
    assert np.all(mom[0, :, 2] > 0) and np.allclose(mom[0, :, :2], 0.0)
    # tilting moves the tip toward +x and turns the moments to (sin, 0, cos)
    pos_t, mom_t = s.dipoles([math.radians(30.0)])
    assert pos_t[0, :, 0].mean() > base[0]
    np.testing.assert_allclose(mom_t[0, 0] / np.linalg.norm(mom_t[0, 0]),
                               [0.5, 0.0, math.sqrt(3) / 2], atol=1e-12)


def test_tilt_path_equals_centreline_path() -> None:
    s = mc.Setup.paper(n_loops=5, dipoles_per_loop=3)
    line = mc.Centreline.straight(s.cilium.height, ANGLES)
    np.testing.assert_allclose(s.field(ANGLES), s.field(line), rtol=1e-11, atol=1e-18)
    np.testing.assert_allclose(s.field_at([[0.0, 0.0, 0.0]], ANGLES)[:, 0, :], s.field(ANGLES),
                               rtol=1e-11, atol=1e-18)


def test_field_map_on_many_points_matches_the_element_field() -> None:
    # a grid large enough to take the blocked-kernel path; its first point is the element
    s = mc.Setup.paper(n_loops=8, dipoles_per_loop=4)
    grid = np.stack(np.meshgrid(np.linspace(-1e-3, 1e-3, 20), np.linspace(-1e-3, 1e-3, 20),
                                [0.0], indexing="ij"), axis=-1).reshape(-1, 3)
    grid = np.vstack([[0.0, 0.0, 0.0], grid])
    b = s.field_at(grid, ANGLES[:3])
    assert b.shape == (3, grid.shape[0], 3)
    np.testing.assert_allclose(b[:, 0, :], s.field(ANGLES[:3]), rtol=1e-12)
    small = s.field_at(grid[:5], ANGLES[:3])
    np.testing.assert_allclose(b[:, :5, :], small, rtol=1e-12)


def test_batch_evaluation_matches_setups() -> None:
    base = mc.Setup.paper()
    params = {"height": np.array([3e-3, 3.3e-3, 2.5e-3]),
              "base_radius": np.array([2e-4, 1.5e-4, 3e-4]),
              "x": np.array([1e-3, 1.5e-3, -1e-3]), "n_loops": np.array([2, 3, 2]),
              "dipoles_per_loop": np.array([5, 4, 5]), "offset": np.array([0.0, 1e-3, -2e-3])}
    out = tilt_output_batch(base, params, ANGLES)
    b = tilt_field_batch(base, params, ANGLES)
    for i in range(3):
        one = base.replace(height=params["height"][i], base_radius=params["base_radius"][i],
                           x=params["x"][i], n_loops=int(params["n_loops"][i]),
                           dipoles_per_loop=int(params["dipoles_per_loop"][i]),
                           offset=params["offset"][i])
        np.testing.assert_allclose(out[i], one.output(ANGLES), rtol=1e-12, atol=1e-15)
        np.testing.assert_allclose(b[i], one.field(ANGLES), rtol=1e-12, atol=1e-18)


@pytest.mark.parametrize("tilt_deg", [0.0, 45.0, 85.0])
def test_rms_ring_converges_to_the_exact_slice_stack(tilt_deg: float) -> None:
    s = mc.Setup.paper(ring="rms", dipoles_per_loop=8)
    theta = [math.radians(tilt_deg)]
    exact = mc.exact_field(s, theta, n_slices=400)[0]
    errors = []
    for n in (2, 8, 32, 128):
        b = s.replace(n_loops=n).field(theta)[0]
        errors.append(np.linalg.norm(b - exact) / np.linalg.norm(exact))
    assert errors[-1] < 1e-3
    assert all(e2 < e1 for e1, e2 in itertools.pairwise(errors))


def test_exact_stack_converges_quadratically() -> None:
    s = mc.Setup.paper()
    theta = [0.3]
    ref = mc.exact_field(s, theta, n_slices=1600)[0]
    e1 = np.linalg.norm(mc.exact_field(s, theta, n_slices=50)[0] - ref)
    e2 = np.linalg.norm(mc.exact_field(s, theta, n_slices=100)[0] - ref)
    assert 3.0 < e1 / e2 < 5.0  # O(1/n^2)


def test_far_field_tends_to_a_single_dipole() -> None:
    # move the cilium far from the element: the distributed model approaches one dipole
    errs = []
    for dist in (10e-3, 40e-3, 160e-3):
        s = mc.Setup.paper(n_loops=10, dipoles_per_loop=6, position=(dist, 0.0, 0.0))
        b = s.field([0.2])[0]
        one = single_dipole_field(s, [0.2])[0]
        errs.append(np.linalg.norm(b - one) / np.linalg.norm(one))
    assert errs[-1] < 1e-3
    assert errs[0] > errs[1] > errs[2]


@given(scale=st.floats(0.1, 10.0))
def test_scaling_all_lengths_leaves_the_field_unchanged(scale: float) -> None:
    # fixed magnetization: moment ~ L^3, field ~ m / L^3
    s = mc.Setup.paper()
    p = s.params()
    scaled = s.replace(height=scale * p["height"], base_radius=scale * p["base_radius"],
                       x=scale * p["x"], y=scale * p["y"], z=scale * p["z"],
                       depth=scale * s.sensor.depth)
    np.testing.assert_allclose(scaled.field(ANGLES[:5]), s.field(ANGLES[:5]), rtol=1e-10)


def test_mirror_in_y_flips_by_only() -> None:
    s = mc.Setup.paper()
    m = s.replace(y=-s.position[1])
    b, bm = s.field(ANGLES), m.field(ANGLES)
    np.testing.assert_allclose(bm[:, [0, 2]], b[:, [0, 2]], rtol=1e-12)
    np.testing.assert_allclose(bm[:, 1], -b[:, 1], rtol=1e-12)


def test_rotation_about_z_of_the_whole_scene() -> None:
    # rotating cilium and element together by 90 deg about z: the element at the origin sees
    # the field of a cilium at (-y, x) rotated; compare with field_at of the unrotated scene
    s = mc.Setup.paper(position=(1.2e-3, 0.0, 0.2e-3))
    line = mc.Centreline.straight(s.cilium.height, [0.4])
    pos, mom = s.dipoles(line)

    rot = np.array([[0.0, -1.0, 0.0], [1.0, 0.0, 0.0], [0.0, 0.0, 1.0]])
    obs = np.array([[0.3e-3, -0.2e-3, 0.1e-3]])
    direct = dipole_field(obs, pos[0], mom[0])
    rotated = dipole_field(obs @ rot.T, pos[0] @ rot.T, mom[0] @ rot.T)
    np.testing.assert_allclose(rotated, direct @ rot.T, rtol=1e-12)


@pytest.mark.parametrize(
    ("kwargs", "match"),
    [
        ({"height": -3e-3}, "height must be a positive length"),
        ({"height": 0.0}, "height must be a positive length"),
        ({"base_radius": float("nan")}, "base_radius must be a positive length"),
        ({"tip_radius": 3e-4, "base_radius": 2e-4}, "tip_radius must be at most base_radius"),
        ({"n_loops": 0}, "n_loops must be an integer >= 1"),
        ({"dipoles_per_loop": 2.5}, "dipoles_per_loop must be an integer >= 1"),
        ({"n_loops": True}, "n_loops must be an integer"),
        ({"position": (0.0, 0.0, -1e-3)}, "sensing element outside the cilium"),
        ({"position": (0.0, 0.0)}, "position must be three numbers"),
        ({"ring": "max"}, "ring must be one of"),
        ({"bridge_voltage": -1.0}, "bridge_voltage must be a positive voltage"),
        ({"gain": 0.0}, "gain must be a non-zero"),
        ({"cobalt_mass": -1.0}, "cobalt_mass must be a positive mass"),
        ({"youngs_modulus": -2e6}, "youngs_modulus must be a positive modulus"),
        ({"colour": "red"}, "keyword must be a setup parameter"),
    ],
    ids=lambda x: str(x)[:40],
)
def test_bad_setup_parameters(kwargs: dict, match: str) -> None:
    with pytest.raises(mc.MagciliaError, match=match):
        mc.Setup.paper(**kwargs)


def test_bad_poses() -> None:
    s = mc.Setup.paper()
    with pytest.raises(mc.MagciliaError, match="tilt must be finite"):
        s.output([0.0, float("nan")])
    with pytest.raises(mc.MagciliaError, match="tilt must be an array with 1"):
        s.output([[0.0, 1.0]])
    with pytest.raises(mc.MagciliaError, match="centreline length"):
        s.output(mc.Centreline.straight(1e-3, [0.0]))
    # an element close to the base is inside the cilium once it tilts far enough
    near = mc.Setup.paper(position=(0.5e-3, 0.0, -0.7e-3))
    with pytest.raises(mc.MagciliaError, match="inside at tilt"):
        near.output(np.radians([0.0, -100.0]))
    with pytest.raises(mc.MagciliaError, match="points must be observer positions outside"):
        s.field_at(s.base_centre + np.array([0.0, 0.0, 1e-3]), [0.0])
