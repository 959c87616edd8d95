"""A calibration on synthetic data beside its known truth: :func:`truth_comparison` explains how
the fit and the true parameters compare (``magcilia demo``, ``CalibrationResult.with_truth``)."""

from __future__ import annotations

import math
from collections.abc import Mapping
from typing import Any, Protocol

import numpy as np
from numpy.typing import NDArray

from magcilia._errors import MagciliaError
from magcilia.calibration.diagnostics import CalibrationWarning
from magcilia.calibration.problem import INTEGER, PARAMETERS
from magcilia.device.setup import Setup
from magcilia.io.recordings import Measurement


class Fit(Protocol):
    """What the comparison reads of a :class:`~magcilia.calibration.result.CalibrationResult`."""

    @property
    def truth(self) -> dict[str, float] | None: ...
    @property
    def data(self) -> Measurement | None: ...
    @property
    def rms(self) -> float: ...
    @property
    def diagnostics(self) -> tuple[CalibrationWarning, ...]: ...
    @property
    def fixed(self) -> dict[str, float]: ...
    @property
    def stderr(self) -> dict[str, float]: ...
    @property
    def values(self) -> dict[str, float]: ...
    @property
    def initial(self) -> Setup: ...
    @property
    def bias_coefficients(self) -> NDArray[np.float64]: ...

#: the parameters that carry the size (undetermined together by the scale symmetry)
SIZES = frozenset(("height", "base_radius"))


def truth_comparison(result: Fit) -> list[str]:
    """Plain-text lines comparing the fit with :attr:`truth` ([] without one): how well the
    fit and the truth reproduce the data, which parameters agree within 3 standard errors,
    which the data leave undetermined, and what would pin them down."""
    if result.truth is None or result.data is None:
        return []
    data = result.data
    noise = math.sqrt(float(np.mean(data.sem**2)))
    lines = ["fit versus truth (the recording is synthetic, so its true parameters are known):"]
    close = result.rms <= 1.5 * noise
    fit_line = (f"- the fit {'reproduces' if close else 'does not reproduce'} the data to the "
                f"noise level: RMS residual {result.rms * 1e6:.3g} µV against {noise * 1e6:.3g} "
                "µV of noise in each angle's mean")
    true_rms = truth_rms(result, result.truth)
    if true_rms is not None and true_rms <= 1.5 * max(result.rms, noise):
        fit_line += (f"; the true parameters give {true_rms * 1e6:.3g} µV: the data cannot "
                     "tell the two sets apart")
    elif true_rms is not None:
        fit_line += (f"; the true parameters give {true_rms * 1e6:.3g} µV, worse than the "
                     "fit: the recording holds effects the model lacks (a slow drift, "
                     "correlated noise) and the free parameters absorbed them")
    lines.append(fit_line)
    undetermined = [n for w in result.diagnostics if w.kind == "undetermined"
                    for n in w.parameters if n in result.truth and n not in result.fixed]
    agree: list[str] = []
    differ: list[str] = []
    for name in (*PARAMETERS, "magnetization_scale", "offset"):
        se = result.stderr.get(name, math.nan)
        if name not in result.truth or name in result.fixed or not math.isfinite(se):
            continue
        z = (result.values[name] - result.truth[name]) / se if se > 0 else math.inf
        (agree if abs(z) <= 3.0 else differ).append(f"{name} ({z:+.1f} s.e.)")
    size = bool(SIZES & set(undetermined))
    if undetermined:
        why = ("every length scaled together leaves the field unchanged (the scale symmetry)"
               if size else "one field component along one tilt path leaves them "
               "undetermined (the output does not change along a combination of them)")
        lines.append(f"- {', '.join(undetermined)} differ from the truth yet fit as well: "
                     f"{why}, so the search returned one of many equally good sets")
    if agree:
        lines.append(f"- within 3 standard errors of the truth: {', '.join(agree)}")
    if differ:
        lines.append(f"- beyond 3 standard errors of the truth: {', '.join(differ)} (a "
                     "linearised error understates the spread along poorly determined "
                     "combinations; see the correlations in the warnings)")
    ints = [n for n in INTEGER if n in result.truth and n not in result.fixed]
    if ints:
        pairs = ", ".join(f"{n} {result.values[n]:g} (truth {result.truth[n]:g})" for n in ints)
        lines.append(f"- {pairs}: modelling choices of the search, not measured quantities")
    elif any(n not in result.truth and n not in result.fixed for n in INTEGER):
        lines.append("- the recording comes from a body without a dipole layout (the exact "
                     "body): n_loops and dipoles_per_loop are modelling choices of the search, "
                     "and the paper model's lengths are effective values that absorb its "
                     "model error (calibrate --model physical fits the hair's dimensions)")
    if undetermined and size:
        lines.append("- what pins them down is a size: no second tilt path or field "
                     "component can (the scale symmetry); a measured height held with --fix "
                     "height=VALUE (API fixed=...), or --model physical with it as a prior "
                     "(--prior height=VALUE:SIGMA) or load data; see the README's "
                     "Calibration section")
    elif undetermined:
        lines.append("- what pins them down is information this tilt path lacks: another "
                     "experiment (a second tilt path or field component) or prior knowledge, "
                     f"e.g. a measured {undetermined[0]} held with --fix "
                     f"{undetermined[0]}=VALUE (API fixed=...); see the README's Calibration "
                     "section")
    return lines

def truth_rms(result: Fit, truth: Mapping[str, float]) -> float | None:
    """RMS residual of the true parameters with their best bias (and the truth's scale), V;
    None if the truth does not give every fitted parameter."""
    if result.data is None or not all(n in truth for n in PARAMETERS):
        return None
    changes: dict[str, Any] = {n: (round(truth[n]) if n in INTEGER else truth[n])
                               for n in PARAMETERS}
    if "magnetization_scale" in truth:
        changes["magnetization_scale"] = truth["magnetization_scale"]
    try:
        curve = result.initial.replace(offset=0.0, **changes).output(result.data.angles)
    except MagciliaError:
        return None
    r = result.data.volts - curve
    if result.bias_coefficients.size:
        basis = np.vander(result.data.angles, result.bias_coefficients.size, increasing=True)
        coef, *_ = np.linalg.lstsq(basis, r, rcond=None)
        r = r - basis @ coef
    return math.sqrt(float(np.mean(r**2)))
