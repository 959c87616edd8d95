"""The biaxial read-out's figure, rendered in both styles and checked as
tests/report/test_figures.py checks every CLI figure (texts inside the canvas, no overlapping
tick labels, legends that stand for drawn data, real minus signs)."""

from __future__ import annotations

import importlib.util
from pathlib import Path

import numpy as np
import pytest

import magcilia as mc
from magcilia._atomic import save_figure
from magcilia._errors import MagciliaError
from magcilia.device.magnetometer import Magnetometer
from magcilia.report import style
from magcilia.report.biaxial import force_vector_figure, plot_force_vectors, plot_pulls

_spec = importlib.util.spec_from_file_location(
    "magcilia_test_figures", Path(__file__).with_name("test_figures.py"))
assert _spec is not None and _spec.loader is not None
_figures = importlib.util.module_from_spec(_spec)
_spec.loader.exec_module(_figures)

SETUP = mc.Setup.paper(tip_radius=5e-5, youngs_modulus=2e6)
SENSOR = Magnetometer(field_range=1e-3, resolution=1e-9, noise=1.5e-7, rate=100.0)


@pytest.fixture(scope="module")
def case() -> tuple[np.ndarray, mc.ForceVectorResult]:
    r = mc.BiaxialReadout(SETUP, SENSOR, span=1e-4, table_size=(17, 32))
    phi = np.radians(np.arange(24) * 15.0)
    mags = np.array([0.0, 0.3, 0.9]) * 1e-4  # the rest row has no direction: left out
    truth = np.stack([np.outer(mags, np.cos(phi)), np.outer(mags, np.sin(phi))], -1)
    fields = SENSOR.measure(SENSOR.to_board(r.model(truth[..., 0], truth[..., 1])), rng=0)
    return truth, r.read(fields)


@pytest.mark.parametrize("name", ["screen", "paper"])
def test_force_vector_figure_renders_cleanly(case: tuple[np.ndarray, mc.ForceVectorResult],
                                             name: str, tmp_path: Path) -> None:
    truth, result = case
    assert np.isnan(result.direction[0]).sum() > 20  # near zero: no direction
    with style.use(name):
        fig = force_vector_figure(truth, result, ellipse_scale=2.0)
        assert _figures.problems(fig) == []
        for suffix, magic in ((".png", b"\x89PNG\r\n\x1a\n"), (".pdf", b"%PDF-")):
            path = tmp_path / f"biaxial{suffix}"
            save_figure(fig, path, dpi=style.dpi())
            data = path.read_bytes()
            assert data.startswith(magic) and len(data) > 2000
    assert "without a direction" in fig._suptitle.get_text()
    legend = {t.get_text() for t in fig.legends[0].get_texts()}
    assert {"true load", "estimate", "2σ ellipse (×2)", "magnitude pull"} <= legend


def test_panels_alone_and_bad_truth(case: tuple[np.ndarray, mc.ForceVectorResult]) -> None:
    truth, result = case
    ax = plot_force_vectors(truth, result)
    assert ax.get_legend() is not None and len(ax.patches) == int(result.estimated.sum())
    assert _figures.problems(ax.figure) == []
    ax = plot_pulls(truth, result)
    assert _figures.problems(ax.figure) == []
    with pytest.raises(MagciliaError, match=r"truth must be shape \(3, 24, 2\)"):
        force_vector_figure(truth[:2], result)
