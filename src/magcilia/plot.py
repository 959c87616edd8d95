"""The figures of magcilia for notebooks and scripts: each function draws on the matplotlib axes
you give it (``ax=``), or on a new figure when you give none, and returns the axes.

Display units (deg, gauss, mV, mm) appear only on the figures; every argument is SI or a
magcilia result. matplotlib is imported when a function draws, not at ``import magcilia``.

Calibration (the paper's Fig. 8)
    :func:`plot_fit` (measured field with 1 s.e. error bars and the fitted model, gauss; the
    output in mV on the right-hand axis), :func:`plot_residuals`, :func:`plot_initial`;
    :func:`fit_figure` builds the three as ``magcilia calibrate`` writes them (of a physical
    fit: one column per experiment, data ± 1 s.e., model and residuals).
Field model
    :func:`plot_field_vs_tilt` (B components, gauss), :func:`plot_output_vs_tilt` (mV),
    :func:`field_figure`.
Sensitivity
    :func:`plot_sweep_curves`, :func:`plot_sweep_measure` (one-at-a-time sweeps),
    :func:`plot_xy_map`, :func:`plot_sobol`.
Mechanics and design
    :func:`plot_shapes` (bent centrelines, mm), :func:`plot_design` (three axes: force, flow,
    angle), :func:`plot_pareto` (a design optimisation's front of range against resolution).
Arrays of cilia
    :func:`plot_array_map` (cilia, sensors, field and loads seen from above, mm),
    :func:`plot_crosstalk` (G/mN), :func:`array_figure`.
Photos
    :func:`plot_measurement` (a tilt measured in a photo).
Posterior
    :func:`plot_pairs` (a corner plot of posterior samples: marginals and 2-D histograms).
Style
    :func:`style` (``"screen"`` or ``"paper"``: serif, one journal column wide, print-sized
    fonts) around the code that builds and saves a figure; :func:`new_figure` sizes figures by
    it.

Examples
--------
>>> import numpy as np
>>> import magcilia as mc
>>> from magcilia import plot
>>> angles = np.radians(np.arange(0.0, 90.0, 5.0))
>>> setups = [mc.Setup.paper(), mc.Setup.paper_initial()]
>>> ax = plot.plot_output_vs_tilt(angles, [s.output(angles) for s in setups],
...                               ["paper", "initial"])
>>> ax.get_ylabel()
'sensor output (mV)'

A calibration in the paper's style, saved as a vector figure one column wide::

    result = mc.calibrate(mc.read_measurements("recording.csv"), initial=mc.Setup.paper_initial())
    with plot.style("paper"):
        fig, axes = plot.new_figure()
        plot.plot_fit(result, ax=axes[0, 0])
        fig.savefig("fig8.pdf")
"""

from __future__ import annotations

from magcilia.report.array import array_figure, plot_array_map, plot_crosstalk
from magcilia.report.calibration import (
    fit_figure,
    measured_field,
    plot_fit,
    plot_initial,
    plot_residuals,
)
from magcilia.report.design import plot_design
from magcilia.report.figures import (
    field_figure,
    new_figure,
    plot_field_vs_tilt,
    plot_output_vs_tilt,
)
from magcilia.report.mechanics import plot_shapes
from magcilia.report.optimise import pareto_figure, plot_pareto
from magcilia.report.photo import plot_measurement
from magcilia.report.posterior import plot_pairs
from magcilia.report.sensitivity import (
    plot_sobol,
    plot_sweep_curves,
    plot_sweep_measure,
    plot_xy_map,
)
from magcilia.report.style import use as style

__all__ = [
    "array_figure",
    "field_figure",
    "fit_figure",
    "measured_field",
    "new_figure",
    "pareto_figure",
    "plot_array_map",
    "plot_crosstalk",
    "plot_design",
    "plot_field_vs_tilt",
    "plot_fit",
    "plot_initial",
    "plot_measurement",
    "plot_output_vs_tilt",
    "plot_pairs",
    "plot_pareto",
    "plot_residuals",
    "plot_shapes",
    "plot_sobol",
    "plot_sweep_curves",
    "plot_sweep_measure",
    "plot_xy_map",
    "style",
]
