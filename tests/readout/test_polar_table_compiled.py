"""The polar table's compiled twins (readout/polar_table.py) against their NumPy references, and
the biaxial read-out's estimates, σ and flags the same on both paths."""

from __future__ import annotations

import numpy as np
import pytest

import magcilia as mc
from magcilia.device.magnetometer import Magnetometer
from magcilia.model import compiled
from magcilia.readout.biaxial import BiaxialReadout
from magcilia.readout.polar_table import evaluate, evaluate_numpy

SETUP = mc.Setup.paper(tip_radius=5e-5, youngs_modulus=2e6)
SPAN = 1e-4
MAG = Magnetometer(field_range=1e-3, resolution=1e-10, noise=1.5e-7, rate=100.0, name="mag")


@pytest.fixture(scope="module")
def readout() -> BiaxialReadout:
    return BiaxialReadout(SETUP, MAG, span=SPAN, table_size=(17, 32))


def _forces(n: int, seed: int, reach: float) -> tuple[np.ndarray, np.ndarray]:
    rng = np.random.default_rng(seed)
    f = reach * np.sqrt(rng.uniform(0.0, 1.0, n))
    phi = rng.uniform(-np.pi, np.pi, n)
    fx, fy = f * np.cos(phi), f * np.sin(phi)
    fx[:3], fy[:3] = 0.0, 0.0  # zero, the first cell, a node, the edge
    fx[1], fy[2] = 1e-3 * reach, -1e-12 * reach
    fx[3], fy[3] = reach, 0.0
    return fx, fy


def test_evaluate_matches_the_numpy_reference(readout: BiaxialReadout) -> None:
    coef, h_f = readout._coef, float(readout.forces[1])
    fx, fy = _forces(500, 0, float(readout.forces[-1]))
    got = evaluate(coef, h_f, fx, fy)
    ref = evaluate_numpy(coef, h_f, fx, fy)
    for a, b in zip(got, ref, strict=True):
        np.testing.assert_allclose(a, b, rtol=0, atol=1e-12 * np.abs(b).max())
    alone = evaluate(coef, h_f, fx, fy, derivatives=False)[0]
    np.testing.assert_allclose(alone, ref[0], rtol=0, atol=1e-13 * np.abs(ref[0]).max())


def test_the_coarse_search_matches_the_numpy_reference(readout: BiaxialReadout) -> None:
    rng = np.random.default_rng(1)
    fx, fy = _forces(400, 2, SPAN)
    y = readout.model(fx, fy) + rng.normal(0.0, 3.0 * MAG.noise[0], (fx.size, 3))
    y[:50] = readout.rest + rng.normal(0.0, 1e-6, (50, 3))  # flat χ²: many local minima
    w = np.broadcast_to(1.0 / readout.sigma**2, y.shape)
    best, second = readout._coarse.search(y, w)
    ref_best, ref_second = readout._coarse.search_numpy(y, w)
    np.testing.assert_array_equal(best, ref_best)
    np.testing.assert_array_equal(second, ref_second)
    assert (second >= 0).any() and (second < 0).any()


def test_read_is_the_same_on_both_paths(readout: BiaxialReadout,
                                        monkeypatch: pytest.MonkeyPatch) -> None:
    rng = np.random.default_rng(3)
    fx, fy = _forces(300, 4, float(readout.forces[-1]))
    y = readout.model(fx, fy) + rng.normal(0.0, MAG.noise[0], (fx.size, 3))
    y[:20] *= 1.01  # beyond the span's reach
    y[5, 1] = np.nan
    fast = readout.read(y)
    monkeypatch.setattr(compiled, "ENABLED", False)
    slow = readout.read(y)
    np.testing.assert_array_equal(fast.flags, slow.flags)
    assert fast.flags.any() and not fast.flags.all()
    ok = fast.estimated
    scale = np.nanmax(np.abs(slow.sigma_fx))
    np.testing.assert_allclose(fast.vector[ok], slow.vector[ok], rtol=0, atol=1e-6 * scale)
    np.testing.assert_allclose(fast.sigma[ok], slow.sigma[ok], rtol=1e-6)


def test_the_fits_stop_at_the_least_squares_minimum(readout: BiaxialReadout) -> None:
    """The fit's stopping rules (FIT_FTOL, FIT_XTOL, and FIT_ATOL on χ²) leave each estimate
    where SciPy's least_squares, run to its tightest tolerances on the same interpolant from
    the same estimate, finds the minimum: within 1e-4 σ, and χ² within 1e-6."""
    from scipy.optimize import least_squares

    rng = np.random.default_rng(11)
    fx, fy = _forces(40, 12, 0.95 * SPAN)
    y = readout.model(fx, fy) + rng.normal(0.0, MAG.noise[0], (fx.size, 3))
    res = readout.read(y)
    sig = readout.sigma
    for i in np.flatnonzero(res.flags == 0)[:25]:
        ref = least_squares(lambda p, i=i: (readout.model(p[0], p[1]) - y[i]) / sig,
                            res.vector[i], x_scale=SPAN * 1e-3, xtol=1e-15, ftol=1e-15,
                            gtol=1e-15)
        np.testing.assert_allclose(res.vector[i], ref.x, rtol=0,
                                   atol=1e-4 * float(np.min(res.sigma[i])))
        assert abs(res.chi2[i] - 2.0 * ref.cost) <= 1e-6 * max(1.0, res.chi2[i])
