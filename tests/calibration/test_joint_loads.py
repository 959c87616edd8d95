"""Load experiments in the joint calibration (issue 14, item 1): bending under known tip forces
and flow speeds, fitted together with tilt experiments, so that the Young's modulus is fitted too.

Synthetic data: the truth is the paper's placement with a 50 µm tip radius and E = 0.5 MPa (the
paper's polymer reads 0.37–0.62 MPa from its 300 % modulus; the presets' composite is
0.669 MPa ± 27 %, docs/stiffness.md). Every
experiment is generated with the dipole model at the converged layout (rms ring, n = 64, k = 5:
within 0.016 µT of the exact Cylinder stack for the tilts, 12x below the noise, see
test_joint.py), the load experiments from the bent shapes of ``bend_sweep``; 3-axis data with
0.2 µT of noise per condition and a per-experiment offset (Earth's field). Tilts: 2 azimuths x
17 angles; forces 0–20 µN (tip deflection up to 1.6 mm); flow speeds 0–0.3 m/s of water.
"""

from __future__ import annotations

import math

import numpy as np
import pytest

import magcilia as mc
from magcilia._errors import MagciliaError
from magcilia.calibration.joint import JOINT_PARAMETERS, PhysicalLayout, calibrate_joint
from magcilia.io.recordings import Measurement

E_TRUE = 0.5e6
TRUTH = mc.Setup.paper(ring="rms", tip_radius=5e-5, youngs_modulus=E_TRUE).replace(
    n_loops=64, dipoles_per_loop=5)
INITIAL = TRUTH.replace(height=3.0e-3, base_radius=0.2e-3, x=1.0e-3, y=1.5e-3, z=0.5e-3,
                        youngs_modulus=2.5e6)
LAYOUT = PhysicalLayout(64, 5)
ANGLES = np.radians(np.linspace(0.0, 80.0, 17))
FORCES = np.linspace(0.0, 2e-5, 9)  # N
SPEEDS = np.linspace(0.0, 0.3, 9)  # m/s
NOISE = 0.2e-6  # T
NAMES = (*JOINT_PARAMETERS, "youngs_modulus")


def _measurement(b: np.ndarray, rng: np.random.Generator, name: str, phi: float = 0.0,
                 angles: np.ndarray | None = None, **loads: np.ndarray) -> Measurement:
    a = b.shape[0]
    return Measurement(
        angles=np.zeros(a) if angles is None else angles, volts=np.full(a, np.nan),
        sem=np.full(a, np.nan), counts=np.full(a, 100), saturated=np.zeros(a, np.int64),
        nonfinite=np.zeros(a, np.int64), source=name, azimuths=np.full(a, phi),
        fields=b + rng.normal(0.0, 10e-6, 3) + rng.normal(0.0, NOISE, b.shape),
        field_sem=np.full((a, 3), NOISE), **loads)


@pytest.fixture(scope="module")
def data() -> dict[str, object]:
    rng = np.random.default_rng(1)
    tilts = [_measurement(TRUTH.field(ANGLES, azimuth=phi), rng, f"tilt{i}", phi, ANGLES)
             for i, phi in enumerate((0.0, math.pi / 2))]
    force = _measurement(TRUTH.field(mc.bend_sweep(TRUTH, forces=FORCES)), rng, "force",
                         forces=FORCES)
    flow = _measurement(TRUTH.field(mc.bend_sweep(TRUTH, speeds=SPEEDS, flow=mc.Flow.uniform(
        0.3, mc.WATER))), rng, "flow", speeds=SPEEDS, metadata={"fluid": "water"})
    return {"tilts": tilts, "force": force, "flow": flow}


def _truth() -> dict[str, float]:
    return {**TRUTH.params(), "youngs_modulus": E_TRUE}


def test_force_experiment_with_height_prior_recovers_modulus(data: dict, tmp_path) -> None:
    r = calibrate_joint([*data["tilts"], data["force"]], INITIAL, rng=0, layout=LAYOUT,
                        priors={"height": (3.3e-3, 0.15e-3)})
    truth = _truth()
    for name in NAMES:
        assert abs(r.values[name] - truth[name]) < 2 * r.stderr[name], name
    # the modulus is determined to ~12 %, from a start 5x off
    assert r.stderr["youngs_modulus"] < 0.15 * E_TRUE
    assert r.setup.youngs_modulus == pytest.approx(r.values["youngs_modulus"])
    # the fitted setup (file) carries the fitted E with its σ: a later read-out takes it as
    # measured, its force scale ± the standard error
    assert r.setup.youngs_modulus_sigma == pytest.approx(r.stderr["youngs_modulus"])
    mc.save_setup(r.setup, tmp_path / "fitted.toml")
    back = mc.load_setup(tmp_path / "fitted.toml")
    assert back.modulus.source == "measured"
    assert back.youngs_modulus_sigma == pytest.approx(r.stderr["youngs_modulus"], rel=1e-11)
    assert back.modulus.note().startswith("force scale from a measured modulus ±")
    fit = r.experiments[2]
    assert fit.load_kind == "force" and np.array_equal(fit.loads, FORCES)
    assert fit.chi2 < 3 * fit.values  # fits to within noise
    assert "20 µN" not in fit.line() and "9 forces 0..0.02 mN" in fit.line()
    assert fit.to_dict()["force_N"] == FORCES.tolist()
    assert r.bounds["youngs_modulus"] == (1e5, 1e7)


def test_force_and_flow_fix_the_size_without_a_prior(data: dict) -> None:
    """Tilt data alone leave the absolute size free (the field at one point is unchanged when
    every length scales by λ). A tip force's small deflection scales like F·L²/(E·I) ∝ F/(E·λ²)
    and a low-Re flow's like μU·L³/(E·I) ∝ μU/(E·λ), so each alone trades E against a power of
    the size and only the two together fix both. In practice each alone also breaks the scaling
    weakly (the tip radius is held, the deflections are large, the 0.3 m/s flow is beyond the
    low-Re range, the sensor depth is held): with force alone the height comes out to ~20 %,
    with flow alone ~35-55 %, with both to ~5 %, as good as a 0.15 mm manual measurement
    (the scaled Jacobian's smallest singular value: 3.6e-4 tilts only, 4.0e-3 with force, 1.6e-3
    with flow, 1.7e-2 with both)."""
    truth = _truth()
    tilts_only = calibrate_joint(data["tilts"], INITIAL, rng=0, layout=LAYOUT)
    force = calibrate_joint([*data["tilts"], data["force"]], INITIAL, rng=0, layout=LAYOUT)
    both = calibrate_joint([*data["tilts"], data["force"], data["flow"]], INITIAL, rng=0,
                           layout=LAYOUT)
    assert both.elapsed < 10.0  # ~1 s on an idle core
    for name in NAMES:
        assert abs(both.values[name] - truth[name]) < 2 * both.stderr[name], name
    assert both.stderr["height"] < 0.07 * truth["height"]
    assert both.stderr["youngs_modulus"] < 0.15 * E_TRUE
    # force alone: finite but ~4x wider; tilts alone: the size is not determined to 50 %
    assert force.stderr["height"] > 2.5 * both.stderr["height"]
    assert not tilts_only.stderr["height"] < 0.5 * truth["height"]
    assert [f.load_kind for f in both.experiments] == [None, None, "force", "flow"]


def test_load_measurement_round_trip_and_report(data: dict) -> None:
    flow = data["flow"]
    back = Measurement.from_dict(flow.to_dict())
    assert np.array_equal(back.speeds, SPEEDS) and back.forces is None and back.fluid == "water"
    assert back.load_kind == "flow" and np.array_equal(back.loads, SPEEDS)
    assert "9 loads: flow speeds (water) 0..300 mm/s toward azimuth 0 deg" in flow.report()
    assert "9 loads: forces 0..0.02 mN" in data["force"].report()
    assert list(data["force"].to_dataframe().columns[:3]) == ["angle_rad", "azimuth_rad",
                                                              "force_N"]
    assert data["tilts"][0].loads is None and data["tilts"][0].load_kind is None


def test_one_line_errors(data: dict) -> None:
    force = data["force"]
    a = len(force)
    with pytest.raises(MagciliaError, match="one kind of load per recording"):
        Measurement(force.angles, force.volts, force.sem, force.counts, force.saturated,
                    force.nonfinite, fields=force.fields, field_sem=force.field_sem,
                    forces=FORCES, speeds=SPEEDS)
    with pytest.raises(MagciliaError, match="zeros: a load experiment"):
        Measurement(np.full(a, 0.1), force.volts, force.sem, force.counts, force.saturated,
                    force.nonfinite, fields=force.fields, field_sem=force.field_sem,
                    forces=FORCES)
    with pytest.raises(MagciliaError, match=r"model='paper'.*force loads") as info:
        mc.calibrate(force, model="paper")
    assert "\n" not in str(info.value)
    honey = Measurement.from_dict({**data["flow"].to_dict(), "metadata": {"fluid": "honey"}})
    with pytest.raises(MagciliaError,
                       match=r"fluid must be one of air, glycerol, water.*honey") as info:
        calibrate_joint([*data["tilts"], honey], INITIAL, layout=LAYOUT)
    assert "\n" not in str(info.value)
    with pytest.raises(MagciliaError, match="tip_radius"):
        calibrate_joint([*data["tilts"], force], INITIAL.replace(tip_radius=0.0), layout=LAYOUT)
    with pytest.raises(MagciliaError, match=r"only with load experiments.*youngs_modulus"):
        calibrate_joint(data["tilts"], INITIAL, layout=LAYOUT,
                        bounds={"youngs_modulus": (1e5, 1e7)})
    with pytest.raises(MagciliaError, match="prior youngs_modulus"):
        calibrate_joint([*data["tilts"], force], INITIAL, layout=LAYOUT,
                        priors={"youngs_modulus": (5e7, 1e5)})


def test_load_recordings_from_csv_fit_as_the_arrays(data: dict, tmp_path) -> None:
    """The force and flow experiments written as CSV recordings (force in µN, speed in mm/s, two
    samples b ± 0.2 µT per condition: mean b, s.e. 0.2 µT) read back to the same conditions and
    give the same fit as the arrays."""
    force, flow = data["force"], data["flow"]

    def rows(loads: np.ndarray, fields: np.ndarray, scale: float) -> list[str]:
        return [f"{q * scale:.17g}," + ",".join(f"{x + d:.17g}" for x in b)
                for q, b in zip(loads, fields, strict=True) for d in (NOISE, -NOISE)]

    (tmp_path / "force.csv").write_text("\n".join(
        ["F [uN],field_x_T,field_y_T,field_z_T", *rows(FORCES, force.fields, 1e6)]) + "\n")
    (tmp_path / "flow.csv").write_text("\n".join(
        ["flow_mm_per_s,field_x_T,field_y_T,field_z_T", *rows(SPEEDS, flow.fields, 1e3)]) + "\n")
    f2 = mc.read_measurements(tmp_path / "force.csv", columns={"force": "F"})
    u2 = mc.read_measurements(tmp_path / "flow.csv", columns={"flow": "flow_mm_per_s"})
    np.testing.assert_allclose(f2.forces, FORCES, rtol=1e-12, atol=1e-18)
    np.testing.assert_allclose(u2.speeds, SPEEDS, rtol=1e-12)
    np.testing.assert_allclose(f2.fields, force.fields, rtol=1e-12)
    np.testing.assert_allclose(u2.field_sem, NOISE, rtol=1e-6)
    assert u2.fluid == "water" and f2.load_kind == "force"
    arrays = calibrate_joint([*data["tilts"], force, flow], INITIAL, rng=0, layout=LAYOUT)
    files = calibrate_joint([*data["tilts"], f2, u2], INITIAL, rng=0, layout=LAYOUT)
    for name in NAMES:
        assert files.values[name] == pytest.approx(arrays.values[name], rel=1e-4), name
