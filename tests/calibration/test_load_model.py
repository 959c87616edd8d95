"""The load experiments' model for many parameter sets at once
(:func:`magcilia.calibration.load_model.load_fields`) against the loop it replaces: per set,
``Setup.field(bend_sweep(...), azimuth=φ)``, NaN where that raises (an invalid geometry, the element
inside the bent cilium). Blocks of forces and of flow, toward azimuth 0 and π/2."""

from __future__ import annotations

import math
from types import SimpleNamespace

import numpy as np
import pytest

import magcilia as mc
from magcilia.calibration.load_model import load_fields

BASE = mc.Setup.paper(ring="rms", tip_radius=5e-5, youngs_modulus=0.5e6).replace(
    n_loops=16, dipoles_per_loop=4)
FORCES = np.linspace(0.0, 2e-5, 5)
SPEEDS = np.linspace(0.0, 0.3, 4)
MEASUREMENTS = [SimpleNamespace(forces=FORCES), SimpleNamespace(forces=None)]
FLUIDS = {1: mc.WATER}
BLOCKS = [(0, 0.0, FORCES, 0), (1, math.pi / 2, SPEEDS, 3 * FORCES.size)]


def _loop(prm: dict[str, np.ndarray], base: mc.Setup = BASE) -> np.ndarray:
    rows = []
    for i in range(prm["x"].size):
        try:
            s = base.replace(**{k: float(val[i]) for k, val in prm.items()})
            rows.append(np.concatenate([
                s.field(mc.bend_sweep(s, forces=FORCES)).ravel(),
                s.field(mc.bend_sweep(s, speeds=SPEEDS, flow=mc.Flow.uniform(0.3, mc.WATER)),
                        azimuth=math.pi / 2).ravel()]))
        except mc.MagciliaError:
            rows.append(np.full(3 * (FORCES.size + SPEEDS.size), np.nan))
    return np.array(rows)


@pytest.fixture(scope="module")
def prm() -> dict[str, np.ndarray]:
    rng = np.random.default_rng(7)
    n = 6
    cols = {"height": rng.uniform(2.8e-3, 3.6e-3, n), "base_radius": rng.uniform(1.5e-4, 2e-4, n),
            "x": rng.uniform(1e-3, 2e-3, n), "y": rng.uniform(1.5e-3, 2.5e-3, n),
            "z": rng.uniform(0.3e-3, 0.5e-3, n),
            "youngs_modulus": np.exp(rng.uniform(np.log(3e5), np.log(1e6), n))}
    cols["base_radius"][1] = 4e-5  # below the tip radius: no such setup
    cols["x"][2], cols["y"][2], cols["z"][2] = 0.0, 0.0, -BASE.sensor.depth + 0.1e-3  # the
    # element 0.1 mm above the base, under the bent tip's path: the exact check runs
    cols["x"][3], cols["y"][3], cols["z"][3] = -1.6e-3, 0.0, -BASE.sensor.depth - 0.5e-3
    return cols


def test_the_fields_of_the_loop(prm: dict[str, np.ndarray]) -> None:
    ref = _loop(prm)
    got = load_fields(BASE, BLOCKS, MEASUREMENTS, FLUIDS, prm)  # type: ignore[arg-type]
    assert got.shape == ref.shape
    np.testing.assert_array_equal(np.isnan(got), np.isnan(ref))
    assert np.isnan(got[1]).all()  # the invalid geometry
    assert np.isfinite(got[[0, 4, 5]]).all()
    scale = np.nanmax(np.abs(ref))
    np.testing.assert_allclose(got, ref, rtol=0.0, atol=1e-9 * scale)
    assert not np.allclose(got[0, :3], got[0, 12:15])  # the force bends the cilium

def test_later_populations_start_from_the_last(prm: dict[str, np.ndarray]) -> None:
    """With a problem's dict of earlier solutions, a nearby population (Newton from them) and a
    far one (swept again) give the loop's fields."""
    starts: dict = {}
    keep = [0, 3, 4, 5]
    first = {k: v[keep] for k, v in prm.items()}
    load_fields(BASE, BLOCKS, MEASUREMENTS, FLUIDS, first, starts)  # type: ignore[arg-type]
    assert set(starts) == {0, 1} and starts[0]["theta"].shape[:2] == (4, FORCES.size)
    for factor in (1.004, 1.5):
        nxt = {**first, "youngs_modulus": first["youngs_modulus"] * factor}
        got = load_fields(BASE, BLOCKS, MEASUREMENTS, FLUIDS, nxt, starts)  # type: ignore[arg-type]
        ref = _loop(nxt)
        np.testing.assert_allclose(got, ref, rtol=0.0, atol=1e-9 * np.abs(ref).max())


def test_sets_the_setup_refuses_and_a_measured_profile() -> None:
    """Sets that the vectorised checks cannot show valid go through ``Setup.replace``: the element
    inside the upright cilium and a non-finite height are NaN rows, a base below the element but
    beside it is fine; a measured profile (every set checked by ``Setup.replace``, its normalised
    shape scaled by each set) gives the loop's fields too."""
    depth = BASE.sensor.depth
    cols = {"height": np.array([3.2e-3, 3.2e-3, np.nan, 3.0e-3]),
            "base_radius": np.array([1.8e-4, 1.8e-4, 1.8e-4, 1.6e-4]),
            "x": np.array([0.0, 0.5e-3, 1.5e-3, 1.2e-3]), "y": np.array([0.0, 0.0, 2e-3, 2e-3]),
            "z": np.array([-depth - 0.5e-3, -depth - 0.5e-3, 0.4e-3, 0.4e-3]),
            "youngs_modulus": np.array([5e5, 5e5, 5e5, 8e5])}
    got = load_fields(BASE, BLOCKS, MEASUREMENTS, FLUIDS, cols)  # type: ignore[arg-type]
    ref = _loop(cols)
    np.testing.assert_array_equal(np.isnan(got), np.isnan(ref))
    assert np.isnan(got[[0, 2]]).all() and np.isfinite(got[[1, 3]]).all()
    np.testing.assert_allclose(got, ref, rtol=0.0, atol=1e-9 * np.nanmax(np.abs(ref)))

    profiled = BASE.replace(cilium=mc.Cilium.from_profile(
        [0.0, 1.0e-3, 3.2e-3], [1.8e-4, 1.5e-4, 0.6e-4], youngs_modulus=0.5e6))
    prof = {k: v[[1, 3]] for k, v in cols.items()}
    got = load_fields(profiled, BLOCKS, MEASUREMENTS, FLUIDS, prof)  # type: ignore[arg-type]
    ref = _loop(prof, profiled)
    assert np.isfinite(got).all()
    np.testing.assert_allclose(got, ref, rtol=0.0, atol=1e-9 * np.abs(ref).max())
