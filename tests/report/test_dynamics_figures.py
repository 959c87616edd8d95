"""Figures of the cilium in time (report/dynamics.py), checked in both styles as the CLI's
figures are."""

from __future__ import annotations

import importlib.util
from pathlib import Path

import numpy as np
import pytest

import magcilia as mc
from magcilia.report import style
from magcilia.report.dynamics import bode_figure, modes_figure

_spec = importlib.util.spec_from_file_location(
    "magcilia_test_figures", Path(__file__).with_name("test_figures.py"))
assert _spec is not None
assert _spec.loader is not None
_figures = importlib.util.module_from_spec(_spec)
_spec.loader.exec_module(_figures)

SETUP = mc.presets.load("force-sensor")


@pytest.mark.parametrize("kind", ["screen", "paper"])
def test_dynamics_figures_pass_the_checks(kind: str) -> None:
    freq = np.geomspace(1.0, 5000.0, 60)
    curves = [mc.frequency_response(SETUP, freq, fluid=f) for f in ("air", "water", "glycerol")]
    with style.use(kind):
        bode = bode_figure(curves)
        assert _figures.problems(bode) == []
        shapes = modes_figure(mc.modes(SETUP, "water", count=4))
        assert _figures.problems(shapes) == []
    assert len(bode.axes) == 2 and len(bode.axes[0].get_lines()) >= 3
    assert len(shapes.axes[0].get_lines()) == 5  # four modes and the axis
