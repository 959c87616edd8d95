"""The one layout rule (model/convergence.py, Setup.layout, Setup.resolve_layout): the paper's
layout by name is used as is, a converged one is within 0.5 % of the exact body where the field
is predicted, a given coarse one is warned about with its error; the array example against an
independent stack of magpylib Cylinder objects; saturated readings flagged."""

from __future__ import annotations

import warnings
from pathlib import Path

import numpy as np
import pytest

import magcilia as mc
from magcilia.cli import main
from magcilia.constants import GAUSS, MU0
from magcilia.device.magnetometer import Magnetometer
from magcilia.model import convergence

EXAMPLES = Path(__file__).resolve().parents[2] / "examples"


def cylinder_stack(setup: mc.Setup, points: np.ndarray, tilt: float = 0.0,
                   slices: int = 200) -> np.ndarray:
    """B (T, (o, 3)) of an upright or rigidly tilted (about y, toward +x) frustum of ``setup``
    at ``points``, from magpylib Cylinder objects: each of ``slices`` equal-length slices a
    cylinder of the same volume, polarised along the axis (independent of magcilia's exact
    reference, which calls magpylib's functional core)."""
    import magpylib as magpy
    from scipy.spatial.transform import Rotation

    c = setup.cilium
    h, rb, rt = c.height, c.base_radius, c.tip_radius
    edges = np.linspace(0.0, h, slices + 1)
    r = rb + (rt - rb) * edges / h
    r_eq = np.sqrt((r[:-1] ** 2 + r[:-1] * r[1:] + r[1:] ** 2) / 3.0)
    axis = np.array([np.sin(tilt), 0.0, np.cos(tilt)])
    turn = Rotation.from_rotvec([0.0, tilt, 0.0])
    j = MU0 * setup.spec.magnetization
    parts = [magpy.magnet.Cylinder(polarization=(0.0, 0.0, j), dimension=(2.0 * re, h / slices),
                                   position=setup.base_centre + (k + 0.5) * h / slices * axis,
                                   orientation=turn)
             for k, re in enumerate(r_eq)]
    return np.asarray(magpy.getB(parts, np.asarray(points, dtype=float), sumup=True))


def _error(model: np.ndarray, exact: np.ndarray) -> float:
    return float(np.max(np.linalg.norm(model - exact, axis=-1)
                        / np.linalg.norm(exact, axis=-1)))


# -- what a setup says its layout is ---------------------------------------------------------------
def test_the_modes_of_constructors_replace_and_files(tmp_path: Path) -> None:
    assert mc.Setup.paper().layout == mc.Setup.paper_initial().layout == "paper"
    # the paper's layout by name is Table I's; other keys are a layout given by the user
    assert mc.Setup.paper(n_loops=6, dipoles_per_loop=3).layout == "paper"
    assert mc.Setup.paper(n_loops=8).layout == "given"
    assert mc.Setup.paper(n_loops=8, layout="paper").layout == "paper"  # said by name
    assert mc.Setup.paper(ring="rms", n_loops=32).layout == "given"
    conv = mc.Setup.paper(tip_radius=5e-5, layout="converged")
    assert conv.ring == "rms" and conv.dipoles_per_loop == convergence.DIPOLES
    assert conv.replace(height=3e-3).layout == "converged"  # n × k kept: paths converge again
    assert conv.replace(n_loops=40).layout == "given"
    assert mc.Setup.paper().replace(ring="rms").layout == "given"
    # files: the key, else given keys mean "given", none mean "converged"
    path = tmp_path / "s.toml"
    path.write_text('[cilium]\ntip_radius = "0.05 mm"\n')
    loaded = mc.load_setup(path)
    assert loaded.layout == "converged" and (loaded.n_loops, loaded.ring) == (conv.n_loops, "rms")
    path.write_text('[model]\nn_loops = 12\nring = "rms"\n')
    assert mc.load_setup(path).layout == "given"
    assert mc.load_setup(EXAMPLES / "paper.toml").layout == "paper"
    assert mc.load_setup(EXAMPLES / "force-sensor.toml").layout == "converged"
    # a converged setup's file leaves n, k and ring to the rule; it reads back the same
    mc.save_setup(conv, path)
    text = path.read_text()
    assert 'layout = "converged"' in text and "n_loops" not in text
    back = mc.load_setup(path)
    assert (back.n_loops, back.dipoles_per_loop, back.ring) == (
        conv.n_loops, conv.dipoles_per_loop, conv.ring)


@pytest.mark.parametrize(("build", "match"), [
    (lambda: mc.Setup.paper(layout="converged", n_loops=4),
     "n_loops must be left out with layout='converged'"),
    (lambda: mc.Setup.paper(layout="paper", ring="rms"), "layout must be 'paper' only with"),
    (lambda: mc.Setup.paper(layout="exact"), "layout must be one of 'paper', 'converged'"),
])
def test_contradictions_are_one_line_errors(build, match: str) -> None:  # type: ignore[no-untyped-def]
    with pytest.raises(mc.MagciliaError, match=match) as info:
        build()
    assert "\n" not in str(info.value)


def test_the_paper_models_fit_keeps_the_papers_layout_by_name() -> None:
    data = mc.read_measurements(mc.io.example_path())
    fit = mc.calibrate(data, initial=mc.Setup.paper_initial(), rng=0, starts=16)
    assert fit.setup.layout == "paper" and fit.setup.ring == "mean"


def test_a_file_that_both_converges_and_gives_n_names_the_key(tmp_path: Path) -> None:
    path = tmp_path / "s.toml"
    path.write_text('[model]\nlayout = "converged"\nn_loops = 12\n')
    with pytest.raises(mc.MagciliaError, match=r"s\.toml: n_loops must be left out"):
        mc.load_setup(path)


# -- the rule at the sensing element ---------------------------------------------------------------
@pytest.mark.parametrize("position", [(1.4727e-3, 1.9891e-3, 0.3804e-3), (0.5e-3, 0.0, 0.0)],
                         ids=["paper placement", "close"])
def test_a_converged_layout_is_within_the_tolerance_of_an_independent_stack(
        position: tuple[float, float, float]) -> None:
    setup = mc.Setup.paper(tip_radius=5e-5, position=position, layout="converged")
    lay = setup.layout_check()
    assert lay.converged and lay.error <= convergence.TOLERANCE
    origin = np.zeros((1, 3))
    for tilt in np.radians([0.0, 30.0, 60.0, 85.0]):
        exact = cylinder_stack(setup, origin, tilt).reshape(1, 3)
        model = setup.field([tilt])
        assert _error(model, exact) <= convergence.TOLERANCE * 1.05
    # toward another azimuth too (the probe turns the element about the base)
    phi = np.radians(90.0)
    turned = setup.replace(position=(position[0] * np.cos(phi) + position[1] * np.sin(phi),
                                     -position[0] * np.sin(phi) + position[1] * np.cos(phi),
                                     position[2]))
    exact = cylinder_stack(turned, origin, np.radians(60.0)).reshape(1, 3)
    assert _error(turned.field([np.radians(60.0)]), exact) <= convergence.TOLERANCE * 1.05


def test_the_paper_layout_is_used_as_is_and_never_warned_about() -> None:
    paper = mc.Setup.paper(tip_radius=5e-5)
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        readout = mc.Readout(paper, "force", (0.0, 1e-4), table_size=17)
        same = paper.resolve_layout()
    assert readout.setup is paper and same is paper
    assert np.isnan(paper.layout_check().error)  # not estimated: the paper's model by name


def test_a_coarse_given_layout_is_warned_about_with_its_error() -> None:
    coarse = mc.Setup.paper(tip_radius=5e-5, ring="rms", n_loops=3)
    error = convergence.layout_error(coarse, 3, 5, "rms")
    assert error > convergence.WARN_ABOVE
    with pytest.warns(mc.LayoutWarning, match=rf"3×5 rms, {100 * error:.2g} % from the exact "
                                              "body at the sensing element"):
        readout = mc.Readout(coarse, "force", (0.0, 1e-4), table_size=17)
    assert readout.setup is coarse  # used as given
    fine = mc.Setup.paper(tip_radius=5e-5, ring="rms", n_loops=48)
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        assert fine.resolve_layout() is fine


def test_the_cli_prints_the_warning(capsys: pytest.CaptureFixture[str], tmp_path: Path) -> None:
    path = tmp_path / "coarse.toml"
    path.write_text('[cilium]\ntip_radius = "0.05 mm"\n[model]\nn_loops = 2\ndipoles_per_loop = 5'
                    '\nring = "mean"\n')
    assert main(["field", "--setup", str(path), "--angles", "0:10:10"]) == 0
    err = capsys.readouterr().err
    assert err.startswith("magcilia: warning: the given dipole layout 2×5 mean")
    assert err.count("\n") == 1


def test_the_simulated_source_and_design_converge() -> None:
    from magcilia.acquire import SimulatedSource

    setup = mc.Setup.paper(tip_radius=5e-5, layout="converged").replace(height=3e-3)
    source = SimulatedSource(setup, 0.0, rng=0)
    want = setup.layout_check()
    assert (source.setup.n_loops, source.setup.ring) == (want.n_loops, "rms")
    assert mc.design_metrics(setup, points=21).setup.n_loops == want.n_loops


# -- arrays ---------------------------------------------------------------------------------------
def test_the_array_example_is_within_2_percent_of_the_exact_body() -> None:
    arr = mc.load_array(EXAMPLES / "array.toml")
    exact = sum(cylinder_stack(c, np.asarray(arr.sensor_positions)) for c in arr.cilia)
    model = arr.field()
    err = np.linalg.norm(model - exact, axis=1) / np.linalg.norm(exact, axis=1)
    assert err.max() < 0.02
    # what a lab can read: every exact field within the MMC5983MA's ±8 gauss, with margin
    assert np.abs(exact).max() < 0.5 * 8 * GAUSS
    assert not arr.saturated(arr.readings(model, noisy=False)).any()


def test_the_old_array_geometry_saturates_and_is_flagged(capsys: pytest.CaptureFixture[str],
                                                         tmp_path: Path) -> None:
    """The example's former geometry (sensors 1 mm below the bases, 2.5 mm pitch): the exact
    body puts 9–10 gauss along z on every MMC5983MA; the converged model says so, and every
    saturated reading is flagged (forward map, read-out, CLI)."""
    text = (EXAMPLES / "array.toml").read_text().replace('pitch = "4 mm"', 'pitch = "2.5 mm"')
    text = text.replace('centre = ["0 mm", "0 mm", "1.5 mm"]', 'centre = ["0 mm", "0 mm", "1 mm"]')
    text = text.replace('depth = "1.5 mm"', 'depth = "1 mm"')
    path = tmp_path / "near.toml"
    path.write_text(text)
    arr = mc.load_array(path)
    exact = sum(cylinder_stack(c, np.asarray(arr.sensor_positions)) for c in arr.cilia)
    assert np.abs(exact[:, 2]).min() > 8 * GAUSS
    assert _error(arr.field(), exact) < 0.02
    readings = arr.readings(arr.field(), rng=0)
    assert arr.saturated(readings)[:, 2].all()
    estimate = mc.ArrayReadout(arr, 2e-5, table_size=9).read(readings)
    assert np.all(estimate.flags & np.uint8(mc.ArrayFlag.SATURATED))
    assert main(["array", str(path)]) == 0
    out, err = capsys.readouterr()
    assert "16 saturated readings" in out
    assert "magcilia: warning: 16 of 16 sensor readings have an axis at or beyond" in err


def test_one_saturation_rule_for_every_sensor() -> None:
    from magcilia.device.sensor import beyond_range
    from magcilia.readout.biaxial import Channel

    part = Magnetometer.preset("MMC5983MA")
    full = 8 * GAUSS
    lsb = part.resolution[0]
    clipped = part.measure([[2 * full, 0.0, 0.0]], noisy=False)  # what the part reports
    assert part.saturated_reading(clipped).tolist() == [[True, False, False]]
    assert beyond_range(full - 0.4 * lsb, full, lsb) and not beyond_range(full - lsb, full, lsb)
    assert not mc.Setup.paper().sensor.in_range([6.1e-4]).any()
    # a 3-axis channel of the force-vector read-out carries its LSB and flags a clipped reading
    (cx, _, _) = Channel.of_magnetometer(part)
    assert cx.resolution == lsb
    setup = mc.Setup.paper(tip_radius=5e-5, layout="converged")
    vectors = mc.BiaxialReadout(setup, part, span=1e-4, table_size=(9, 16))
    result = vectors.read(np.array([[float(clipped[0, 0]), 0.0, 0.0]]))
    assert result.flags[0] & np.uint16(mc.ForceFlag.SATURATED)
