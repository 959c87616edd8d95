"""``fit.png`` of a physical-model calibration (issue 30, item 7): per experiment a data panel
(the data ± their standard errors and the fitted model) above a residual panel (measured −
fitted ± the standard errors), for every kind of experiment (tilt paths of an output or a 3-axis
field, tip forces, flow, coil fields) and for a mix; the arrays drawn are checked against the
experiment's own, and a real fit's figure is drawn by the helper process as ``calibrate``
draws it."""

from __future__ import annotations

import dataclasses
import importlib.util
import json
import os
import subprocess
import sys
from pathlib import Path
from typing import Any

import numpy as np
import pytest
from matplotlib.axes import Axes
from matplotlib.container import ErrorbarContainer

import magcilia
import magcilia as mc
from magcilia.calibration.experiment_fit import ExperimentFit
from magcilia.constants import GAUSS
from magcilia.report import style as st
from magcilia.report.calibration import fit_figure, joint_fit_figure, write_calibration_files
from magcilia.report.calibration_physical import physical_fit_figure
from magcilia.report.figure_process import FigureWriter

EARLIER = Path(__file__).resolve().parents[1] / "calibration" / "earlier_results" / "joint"
SRC = Path(magcilia.__file__).resolve().parents[1]
#: display units per SI unit of the names the panels' labels may carry
PER_SI = {"mV": 1e3, "µV": 1e6, "nV": 1e9, "gauss": 1.0 / GAUSS, "mG": 1e3 / GAUSS,
          "µG": 1e6 / GAUSS, "nG": 1e9 / GAUSS}


def _unit(ax: Axes) -> float:
    """The display units per SI unit of ``ax``'s y label ("... (mG)")."""
    return PER_SI[ax.get_ylabel().rsplit("(", 1)[1].rstrip(")")]


@pytest.fixture(scope="module")
def result() -> mc.CalibrationResult:
    """A physical fit as magcilia wrote it (tilt output + 3-axis field); its experiments are
    replaced per test."""
    return mc.CalibrationResult.load(EARLIER / "result.json")


def _fit(kind: str, observable: str, seed: int, sem: float | None = None,
         scale: float = 1e3) -> ExperimentFit:
    """A seeded experiment of ``kind`` (tilt, force, flow, coil) with model, data = model +
    noise of ``sem`` (default: 1 µV or 2 µT) and offsets; tilts toward two azimuths; a coil's
    output sees the applied B_x times ``scale`` (V/T: the setup's sensor scale)."""
    rng = np.random.default_rng(seed)
    a = 12
    shape = (a,) if observable == "output" else (a, 3)
    s = sem if sem is not None else (1e-6 if observable == "output" else 2e-6)
    offsets = rng.normal(0.0, 1e-3 if observable == "output" else 2e-5, shape[1:] or (1,))
    curve = np.linspace(0.0, 1.0, a)
    amplitude = 2e-3 if observable == "output" else 5e-5
    model = amplitude * (np.sin(3.0 * curve)[:, None] * np.array([1.0, 0.6, -0.4])[: (
        1 if observable == "output" else 3)])
    model = (model[:, 0] if observable == "output" else model) + (
        offsets[0] if observable == "output" else offsets)
    measured = model + rng.normal(0.0, s, shape)
    angles = np.radians(np.tile(np.linspace(0.0, 80.0, a // 2), 2)) if kind == "tilt" else (
        np.zeros(a))
    azimuths = np.repeat([0.0, np.pi / 2], a // 2) if kind == "tilt" else np.zeros(a)
    loads = None if kind in ("tilt", "coil") else np.linspace(0.0, 2e-5 if kind == "force"
                                                              else 0.3, a)
    actuation = rng.normal(0.0, 5e-4, (a, 3)) if kind == "coil" else None
    if actuation is not None:
        actuation[3] = 0.0  # the cilium at rest
        applied = actuation[:, 0] * scale if observable == "output" else actuation
        model, measured = model + applied, measured + applied
    r = measured - model
    return ExperimentFit(
        source=f"/lab/{kind}_{observable}.csv", observable=observable, angles=angles,
        azimuths=azimuths, measured=measured, fitted=model, residuals=r,
        offsets=np.atleast_1d(offsets), rms=float(np.sqrt(np.mean(r ** 2))),
        chi2=float(np.sum((r / s) ** 2)), values=int(r.size),
        load_kind=None if loads is None else kind, loads=loads, actuation=actuation,
        sem=np.full(shape, s))


def _with(result: mc.CalibrationResult, *fits: ExperimentFit) -> mc.CalibrationResult:
    return dataclasses.replace(result, experiments=fits)


def _pairs(fig: object) -> list[tuple[list[Axes], Axes]]:
    """Per experiment, in order: its data axes (one, or one per field component, top to
    bottom) and its residual axes right below them, all on one shared x axis."""
    axes = list(fig.axes)  # type: ignore[attr-defined]
    residual = [ax for ax in axes if ax.get_ylabel().startswith("residual")]
    data = [ax for ax in axes if ax not in residual]
    pairs = []
    for bottom in residual:
        tops = [ax for ax in data if ax.get_shared_x_axes().joined(ax, bottom)]
        assert len(tops) in (1, 3)
        heights = [ax.get_position().y0 for ax in [*tops, bottom]]
        assert heights == sorted(heights, reverse=True)  # stacked, the residuals at the foot
        pairs.append((tops, bottom))
    assert sum(len(t) + 1 for t, _ in pairs) == len(axes)  # no other axes
    return pairs


def _legend(ax: Axes) -> str:
    """The legend's title and entries, one string."""
    legend = ax.get_legend()
    return " | ".join([legend.get_title().get_text(), *(t.get_text() for t in legend.texts)])


def _bars(ax: Axes) -> list[tuple[np.ndarray, np.ndarray, np.ndarray]]:
    """Each error-bar series of ``ax``: x, y and the half-length of each bar."""
    out = []
    for c in ax.containers:
        if isinstance(c, ErrorbarContainer):
            line, _, (segments, *_) = c.lines
            x, y = (np.asarray(d, dtype=np.float64) for d in line.get_data())
            ends = np.asarray(segments.get_segments())
            out.append((x, y, (ends[:, 1, 1] - ends[:, 0, 1]) / 2.0))
    return out


KINDS = [("tilt", "output"), ("tilt", "field"), ("force", "field"), ("flow", "output"),
         ("coil", "field"), ("coil", "output")]


@pytest.mark.parametrize(("kind", "observable"), KINDS, ids=[f"{k}-{o}" for k, o in KINDS])
def test_each_kind_has_data_and_residual_panels_with_error_bars(
        result: mc.CalibrationResult, kind: str, observable: str) -> None:
    e = _fit(kind, observable, seed=3, scale=result.setup.sensor.scale)
    fig = physical_fit_figure(_with(result, e))
    [(tops, bottom)] = _pairs(fig)
    components = 1 if observable == "output" else 3
    assert len(tops) == components  # a field's components each on their own scale
    unit, res_unit = _unit(tops[0]), _unit(bottom)
    assert {_unit(top) for top in tops} == {unit}
    series = 2 if kind == "tilt" else 1  # the tilts go toward two azimuths
    data, residual = [b for top in tops for b in _bars(top)], _bars(bottom)
    assert all(len(_bars(top)) == series for top in tops)
    assert len(data) == len(residual) == components * series
    # every value drawn once, with its standard error as the bar
    assert sum(x.size for x, _, _ in data) == sum(x.size for x, _, _ in residual) == 12 * components
    sem = float(np.asarray(e.sem).flat[0])
    for (_, _, half), scale in [*((d, unit) for d in data), *((r, res_unit) for r in residual)]:
        np.testing.assert_allclose(half, sem * scale, rtol=1e-9)
    # the residual panel draws measured − fitted, exactly
    drawn = np.sort(np.concatenate([y for _, y, _ in residual]))
    np.testing.assert_allclose(drawn, np.sort((e.measured - e.fitted).ravel() * res_unit),
                               rtol=1e-12, atol=1e-12 * res_unit)
    # the data panel: data − model (the lines or dashes drawn at the same x) = residual
    model = [line for top in tops for line in top.get_lines() if line.get_color() == "0.15"]
    assert len(model) == components * series
    differences = np.concatenate([d[1] - np.asarray(m.get_ydata()) for d, m in
                                  zip(data, model, strict=True)])
    assert all(np.array_equal(d[0], m.get_xdata()) for d, m in zip(data, model, strict=True))
    np.testing.assert_allclose(np.sort(differences) / unit * res_unit, drawn,
                               rtol=1e-9, atol=1e-9 * res_unit)
    # the title names the experiment and its file, the axes their units
    title = tops[0].get_title()
    assert f"{kind}_{observable}.csv" in title
    assert {"tilt": "tilt path", "force": "tip forces", "flow": "flow", "coil": "coil"}[kind] \
        in title
    assert bottom.get_xlabel().endswith({"tilt": "(deg)", "force": "(mN)", "flow": "(m/s)",
                                         "coil": "(rank)"}[kind])
    # the paper-mode units: the data in mV or gauss, the residuals in µV or mG (2 µT: 20 mG)
    for top, name in zip(tops, ["output"] if observable == "output" else ["B_x", "B_y", "B_z"],
                         strict=True):
        assert name in top.get_ylabel()
        assert top.get_ylabel().endswith("(mV)" if observable == "output" else "(gauss)")
    assert bottom.get_ylabel() == ("residual (µV)" if observable == "output"
                                   else "residual (mG)")


def test_a_mix_has_one_pair_per_experiment_in_order(result: mc.CalibrationResult) -> None:
    fits = [_fit(k, o, seed=i, scale=result.setup.sensor.scale) for i, (k, o) in enumerate(KINDS)]
    fig = physical_fit_figure(_with(result, *fits))
    pairs = _pairs(fig)
    assert len(pairs) == len(fits)
    for (tops, bottom), e in zip(pairs, fits, strict=True):
        assert Path(e.source).name in tops[0].get_title()
        assert len(tops) == (1 if e.observable == "output" else 3)
        drawn = np.sort(np.concatenate([y for _, y, _ in _bars(bottom)]))
        np.testing.assert_allclose(drawn, np.sort(e.residuals.ravel() * _unit(bottom)),
                                   rtol=1e-12, atol=1e-12)
    # six experiments wrap into two bands of three columns
    assert len({round(tops[0].get_position().x0, 6) for tops, _ in pairs}) == 3


def test_bars_within_symbols_are_said(result: mc.CalibrationResult) -> None:
    small = physical_fit_figure(_with(result, _fit("tilt", "output", 1, sem=1e-9)))
    large = physical_fit_figure(_with(result, _fit("tilt", "output", 1, sem=2e-4)))
    ([top_small], _), = _pairs(small)
    ([top_large], _), = _pairs(large)
    assert "± 1 s.e. (bars within symbols)" in _legend(top_small)
    assert "± 1 s.e." in _legend(top_large) and "within" not in _legend(top_large)


def test_a_quiet_sensor_steps_the_units_down(result: mc.CalibrationResult) -> None:
    """nT-level noise (a 3-axis part's) reads in µG, not as 0.00x mG; a µV-scale output in
    µV."""
    field = _fit("coil", "field", 4, sem=0.5e-9)
    output = _fit("force", "output", 5, sem=2e-6)  # then scaled to µV: 2 nV noise
    output = dataclasses.replace(output, measured=output.measured * 1e-3,
                                 fitted=output.fitted * 1e-3, residuals=output.residuals * 1e-3,
                                 offsets=output.offsets * 1e-3, sem=np.full(12, 2e-9))
    (_, f_bottom), ([o_top], o_bottom) = _pairs(physical_fit_figure(_with(result, field,
                                                                         output)))
    assert f_bottom.get_ylabel() == "residual (µG)"
    assert o_top.get_ylabel().endswith("(µV)") and o_bottom.get_ylabel() == "residual (nV)"
    for bottom, e in ((f_bottom, field), (o_bottom, output)):
        drawn = np.sort(np.concatenate([y for _, y, _ in _bars(bottom)]))
        np.testing.assert_allclose(drawn, np.sort(e.residuals.ravel()) * _unit(bottom),
                                   rtol=1e-9)
        assert 0.1 <= float(np.max(np.abs(drawn))) < 1000.0


def test_a_result_without_standard_errors_says_so(result: mc.CalibrationResult) -> None:
    """A result.json written before the standard errors were kept draws no bars and says so."""
    assert all(e.sem is None for e in result.experiments)
    fig = physical_fit_figure(result)
    pairs = _pairs(fig)
    assert len(pairs) == 2
    for tops, _ in pairs:
        assert "s.e. not kept" in _legend(tops[0])


def test_fit_figure_and_the_earlier_name_draw_it_in_both_styles(
        result: mc.CalibrationResult) -> None:
    r = _with(result, _fit("tilt", "field", 0), _fit("force", "output", 1))
    for style, build in zip(st.STYLES, (fit_figure, joint_fit_figure), strict=True):
        with st.use(style):
            assert len(_pairs(build(r))) == 2


def test_the_standard_errors_round_trip_through_result_json(tmp_path: Path) -> None:
    e = _fit("coil", "field", 2)
    back = ExperimentFit.from_dict(json.loads(json.dumps(e.to_dict())))
    assert back.sem is not None and e.sem is not None
    np.testing.assert_array_equal(back.sem, e.sem)
    old = {k: v for k, v in e.to_dict().items() if not k.startswith("sem_")}
    assert ExperimentFit.from_dict(old).sem is None


def test_the_physical_figures_go_through_the_figure_writer(result: mc.CalibrationResult,
                                                            tmp_path: Path) -> None:
    """``calibrate``'s writer (here in-process) draws the physical fit's ``fit.png``, as it draws
    a paper fit's (the paper style's PDF beside it: ``test_figures.py``)."""
    submitted: list[str] = []

    class Spy(FigureWriter):
        def submit(self, task: Any, *args: Any) -> None:
            submitted.append(args[0].__name__)
            super().submit(task, *args)

    r = _with(result, _fit("tilt", "field", 0), _fit("coil", "output", 1,
                                                     scale=result.setup.sensor.scale))
    write_calibration_files(r, tmp_path, "screen", writer=Spy())
    assert submitted == ["joint_fit_figure"]
    assert (tmp_path / "fit.png").read_bytes().startswith(b"\x89PNG")
    assert "![data and fitted model per experiment](fit.png)" in (
        tmp_path / "report.md").read_text()


_CALIBRATE = """
import json, sys
import numpy as np
import magcilia as mc
import magcilia.report.figure_process as fp
from magcilia.acquire.synthetic import synthetic_field_recording
forked = []
submit = fp.FigureWriter.submit
def spy(self, task, *args):
    forked.append((self.forked, args[0].__name__))
    return submit(self, task, *args)
fp.FigureWriter.submit = spy
truth = mc.Setup.paper(ring="rms", n_loops=16, dipoles_per_loop=5)
paths = []
for i, phi in enumerate((0.0, np.pi / 2)):
    rec = synthetic_field_recording(truth, np.radians(np.linspace(0.0, 80.0, 9)), (phi,),
                                    samples_per_angle=20, noise=1e-6, rng=i)
    paths.append(f"{OUT}/az{i}.csv")
    rec.write_csv(paths[-1])
from magcilia.cli import main
code = main(["-q", "calibrate", *paths, "--model", "physical", "--setup", "paper",
             "--prior", "height=3.3:0.15", "--starts", "4", "--out", f"{OUT}/fit"])
print(json.dumps([code, forked]))
"""


@pytest.mark.slow  # (a fit in a fresh interpreter: 16 s on the loaded 2-core VM)
@pytest.mark.skipif(os.name != "posix" or sys.platform == "darwin",
                    reason="the helper process is forked on POSIX but macOS")
def test_calibrate_physical_draws_fit_png_in_the_helper_process(tmp_path: Path) -> None:
    env = {**os.environ, "MAGCILIA_FIGURE_PROCESS": "1", "PYTHONPATH": os.pathsep.join(
        [str(SRC), *filter(None, [os.environ.get("PYTHONPATH")])])}
    code = f"OUT = {str(tmp_path)!r}\n" + _CALIBRATE
    done = subprocess.run([sys.executable, "-c", code],
                          capture_output=True, text=True, env=env, timeout=300, check=False)
    assert done.stdout, done.stderr
    code, forked = json.loads(done.stdout.splitlines()[-1])
    assert code == 0, done.stderr
    assert forked == [[True, "joint_fit_figure"]]
    png = (tmp_path / "fit" / "fit.png").read_bytes()
    assert png.startswith(b"\x89PNG") and len(png) > 10_000
    doc = json.loads((tmp_path / "fit" / "result.json").read_text())
    assert all(len(e["sem_T"]) == 9 for e in doc["experiments"])


def _figure_checks() -> Any:
    """``problems(fig)`` of ``test_figures.py``: the checks every CLI figure passes (texts and
    legends inside, ticks apart, real minus signs, error-bar data filling their frames)."""
    spec = importlib.util.spec_from_file_location(
        "_figure_checks", Path(__file__).with_name("test_figures.py"))
    assert spec is not None and spec.loader is not None
    module = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(module)
    return module.problems


def test_a_mix_passes_the_figure_checks(result: mc.CalibrationResult) -> None:
    """The checks of every CLI figure, on three kinds side by side (two azimuths in one field
    experiment, the densest legend) in the paper style, the tighter one (the screen style:
    ``test_figures.py``'s physical calibrate). Check (e) is left out for the residual panels:
    residuals are noise about zero, and one azimuth's six of them need not span a quarter of a
    panel scaled to all of them and their bars (the CLI's own physical fit passes it too)."""
    problems = _figure_checks()
    scale = result.setup.sensor.scale
    mix = _with(result, _fit("tilt", "field", 0), _fit("force", "output", 1),
                _fit("coil", "field", 2, sem=1e-9, scale=scale))
    with st.use("paper"):
        found = problems(physical_fit_figure(mix))
    assert not [p for p in found if not p.startswith("(e) the data of 'residual")]
