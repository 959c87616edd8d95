"""What a calibration's numbers do not say by themselves: warnings with a kind, the parameters
they concern and a plain-language text (value, cause, remedy).

Every warning of a :class:`~magcilia.calibration.CalibrationResult` is a
:class:`CalibrationWarning`; ``result.warnings`` holds their texts, ``result.diagnostics`` the
records, so code (and tests) match the ``kind``, people read the text. The kinds:

``"at_bound"``
    A fitted parameter within :data:`AT_BOUND_TOLERANCE` of the width of its search bound from
    that bound: the best fit may lie beyond it (widen the bound) or the data do not determine the
    parameter and the bound chose its value (fix it to a known value).
``"bias_absorbs_signal"``
    A polynomial bias of degree ≥ 1 whose variation over the angles is comparable to the model's
    (:data:`BIAS_SPAN_LIMIT`), or correlated with it (:data:`BIAS_CORRELATION_LIMIT`) while not
    small (:data:`BIAS_CORRELATED_SPAN`): the bias has absorbed signal shape and the geometry
    was fitted to what is left.
``"implausible_stderr"``
    A standard error the data cannot give: smaller than the noise allows (below
    :data:`STDERR_FLOOR_FRACTION` of σ/|∂output/∂p|, or a relative error below
    :data:`STDERR_RELATIVE_FLOOR` on noisy data), or larger than the parameter's whole bound
    width (the linearised error no longer means anything there).
``"weakly_determined"``
    A standard error above :data:`LOOSE_FRACTION` of the bound width.
``"undetermined"``
    Combinations of parameters along which the output does not change (the null space of the
    Jacobian): these parameters' standard errors are infinite. The text names what would
    determine them for these data (:func:`undetermined_warning`): for the scale symmetry (every
    length scaled together leaves the field unchanged, NOTES §8) a measured size or load data,
    never another tilt.
``"prior_only"``
    Combinations the data alone leave open and only the priors determine (the size, by the scale
    symmetry, given a measured height): their standard errors rest on the priors' σ.
``"correlated"``
    Two parameters correlated beyond :data:`CORRELATION_LIMIT`.
``"y_sign"``
    y and −y fit equally well (B_x is even in y).
``"ambiguous"``
    Another optimum fits as well (Δχ² ≤ 4) yet lies more than 2 standard errors away in some
    parameter (:data:`~magcilia.calibration.ambiguity.AMBIGUITY_CHI2`,
    :data:`~magcilia.calibration.ambiguity.AMBIGUITY_SIGMA`): the mirrored placement, another
    basin.
``"sensor_field"``
    The fitted placement puts a field on the single-axis element beyond its flip (disturbing)
    field or its linear range (of the total field, or on the sensitive axis): a real sensor there
    needs a set/reset pulse and does not read B_x faithfully (:meth:`magcilia.Setup.check_sensor`).
    The fit's starting point is a guess, not a placement, so it is not checked: Table I's initial
    placement puts 28–48 G on the element (``Setup.paper_initial().check_sensor(angles)`` says
    so; ``magcilia field``/``angle`` print it).
``"model_not_finite"``, ``"no_degrees_of_freedom"``, ``"integer_parameters"``
    No slope next to the optimum; as many parameters as angles; n and k carry no standard error.
"""

from __future__ import annotations

import math
from collections.abc import Mapping, Sequence
from dataclasses import dataclass
from typing import TYPE_CHECKING

import numpy as np
from numpy.typing import NDArray

from magcilia.device.parameters import PARAMETERS as REGISTRY
from magcilia.device.sensor import SensorFlag

if TYPE_CHECKING:
    from magcilia.device.setup import Setup

F64 = NDArray[np.float64]

#: a fitted value closer than this fraction of its bound's width to the bound is "at the bound"
#: (the polish ends on a bound face exactly; 1e-3 of the default 2 mm height range is 2 µm)
AT_BOUND_TOLERANCE = 1e-3
#: the polynomial bias's span over the angles (its non-constant part) at or above this fraction of
#: the model's own span: the bias shapes the fitted curve as much as the geometry does
BIAS_SPAN_LIMIT = 0.5
#: |correlation| between the bias's variation and the model's beyond which the two trade off; a
#: real drift is also smooth and monotonic over a tilt path, hence correlated with the model, so
#: this counts only together with a span of at least :data:`BIAS_CORRELATED_SPAN` of the model's
BIAS_CORRELATION_LIMIT = 0.9
#: see :data:`BIAS_CORRELATION_LIMIT`
BIAS_CORRELATED_SPAN = 0.25
#: a standard error below this fraction of σ/|∂output/∂p| (σ: the residual noise) is impossible:
#: the least variance a linear fit can give a parameter is σ²/|∂output/∂p|² (all other
#: parameters known); only a numerical failure of the covariance goes below it
STDERR_FLOOR_FRACTION = 0.5
#: a relative standard error σ_p/|p| below this on data whose residual RMS exceeds
#: :data:`NOISE_FLOOR` of the data's largest value is not credible for a sensor recording
STDERR_RELATIVE_FLOOR = 1e-6
#: see :data:`STDERR_RELATIVE_FLOOR` (residuals this small are float round-off: noiseless data)
NOISE_FLOOR = 1e-9
#: a standard error above this fraction of the bound width: weakly determined
LOOSE_FRACTION = 0.25
#: |correlation| beyond which two parameters are reported as strongly correlated
CORRELATION_LIMIT = 0.99
#: the lengths that scale together in the scale symmetry (NOTES §8), with the sensor depth
LENGTHS = ("height", "base_radius", "x", "y", "z")
#: the lengths the scale symmetry scales: the fitted ones and the held tip radius (a coil fit's
#: null-space test holds it free: an assumed tip radius must not fix the size)
SCALED = (*LENGTHS, "tip_radius")
#: a null space holds the scale direction when the part of that (unit) direction outside it is
#: below this (finite-difference noise tilts the null vectors slightly)
SCALE_TOLERANCE = 0.05

#: every kind a :class:`CalibrationWarning` can have (see the module docstring)
WARNING_KINDS = (
    "at_bound", "bias_absorbs_signal", "implausible_stderr", "weakly_determined",
    "undetermined", "correlated", "y_sign", "model_not_finite", "no_degrees_of_freedom",
    "integer_parameters", "layout", "chi2", "ambiguous", "sensor_field", "prior_only",
)
#: the sensor flags that make a placement's field a calibration warning (``"sensor_field"``)
SENSOR_FIELD_FLAGS = (SensorFlag.FLIPPED_RISK | SensorFlag.BEYOND_RANGE
                      | SensorFlag.TOTAL_BEYOND_RANGE)


@dataclass(frozen=True)
class CalibrationWarning:
    """One warning of a calibration.

    Attributes
    ----------
    kind : str
        One of :data:`WARNING_KINDS`.
    message : str
        The text people read (values in display units: mm, mV).
    parameters : tuple of str
        The parameters it concerns (may be empty).
    """

    kind: str
    message: str
    parameters: tuple[str, ...] = ()

    def __str__(self) -> str:
        return self.message


def shown(name: str, value: float) -> str:
    """``value`` (SI) of parameter ``name`` in its display unit, e.g. ``'3.1 mm'``."""
    p = REGISTRY.get(name)
    if p is None:
        return f"{value:.4g}"
    unit = f" {p.display}" if p.display else ""
    return f"{p.to_display(value):.4g}{unit}"


def _bound_text(name: str, lo: float, hi: float) -> str:
    """``lo:hi`` in the display unit (as ``--bound`` takes it)."""
    p = REGISTRY[name]
    return f"{p.to_display(lo):.4g}:{p.to_display(hi):.4g}"


def _widened(name: str, lo: float, hi: float, upper: bool) -> tuple[float, float]:
    """The bound widened by half its width on the side the value sits, within the limits."""
    p = REGISTRY[name]
    step = 0.5 * (hi - lo)
    if p.domain == "integer":
        step = max(1.0, math.ceil(step))
    if upper:
        return lo, min(hi + step, p.maximum)
    low = lo - step
    if p.domain == "integer":
        low = max(low, 1.0)
    elif p.domain in ("positive", "non_negative"):
        low = max(low, p.minimum, 0.5 * lo)
    else:
        low = max(low, -p.maximum)
    return low, hi


def _can_widen(name: str, lo: float, hi: float, upper: bool) -> bool:
    return _widened(name, lo, hi, upper) != (lo, hi)


def correlated(names: Sequence[str], corr: NDArray[np.float64]) -> list[CalibrationWarning]:
    """A ``correlated`` warning for each pair of ``names`` whose correlation (``corr``, (p, p),
    NaN where undefined) exceeds :data:`CORRELATION_LIMIT` in magnitude."""
    return [CalibrationWarning(
        "correlated", f"{names[i]} and {names[j]} are strongly correlated ({corr[i, j]:+.3f}): "
        "the data determine a combination of them, not each one", (names[i], names[j]))
        for i in range(len(names)) for j in range(i + 1, len(names))
        if np.isfinite(corr[i, j]) and abs(corr[i, j]) > CORRELATION_LIMIT]


def at_bound(values: Mapping[str, float], box: Mapping[str, tuple[float, float]],
             undetermined: frozenset[str] = frozenset()) -> list[CalibrationWarning]:
    """Warnings for the free parameters (lower < upper) whose fitted ``values`` (SI) sit within
    :data:`AT_BOUND_TOLERANCE` of the bound width from a bound of ``box`` (SI) that could be
    widened (n and k at 1 are at their smallest possible value, not at a bound)."""
    out = []
    for name, (lo, hi) in box.items():
        if not lo < hi or name not in values:
            continue
        value = values[name]
        tol = AT_BOUND_TOLERANCE * (hi - lo)
        for upper, edge in ((False, lo), (True, hi)):
            if abs(value - edge) > tol or not _can_widen(name, lo, hi, upper):
                continue
            side = "upper" if upper else "lower"
            wlo, whi = _widened(name, lo, hi, upper)
            unit = f" {REGISTRY[name].display}".rstrip()
            head = (f"{name} = {shown(name, value)} sits at its {side} bound "
                    f"({shown(name, edge)}; bounds {_bound_text(name, lo, hi)}{unit})")
            if name in undetermined:
                text = (f"{head}: the data do not determine it (see the undetermined "
                        "combination), so the bound, not the data, chose this value; fix it to "
                        f"a known value (--fix {name}=VALUE; API fixed={{'{name}': value}}) "
                        f"or widen the bound (--bound {name}={_bound_text(name, wlo, whi)})")
            else:
                text = (f"{head}: the best fit may lie beyond it; widen the bound "
                        f"(--bound {name}={_bound_text(name, wlo, whi)}) or fix it "
                        f"(--fix {name}=VALUE; API fixed={{'{name}': value}})")
            out.append(CalibrationWarning("at_bound", text, (name,)))
    return out


def bias_absorption(angles: F64, bias_coefficients: F64, model: F64) -> CalibrationWarning | None:
    """A warning when the non-constant part of a polynomial bias rivals the model's signal.

    Parameters
    ----------
    angles : ndarray, shape (a,)
        Tilt angles, rad.
    bias_coefficients : ndarray, shape (d + 1,)
        The bias polynomial in the angle, constant first (V, V/rad, …).
    model : ndarray, shape (a,)
        The fitted model's output without the bias, V.

    Returns
    -------
    CalibrationWarning or None
        Kind ``"bias_absorbs_signal"`` when the bias's span is at least :data:`BIAS_SPAN_LIMIT`
        of the model's, or at least :data:`BIAS_CORRELATED_SPAN` of it with
        \\|correlation\\| ≥ :data:`BIAS_CORRELATION_LIMIT`; None otherwise (and for degree 0).
    """
    degree = bias_coefficients.size - 1
    if degree < 1:
        return None
    curve = np.vander(angles, degree + 1, increasing=True)[:, 1:] @ bias_coefficients[1:]
    span_b, span_m = float(np.ptp(curve)), float(np.ptp(model))
    ratio = span_b / span_m if span_m > 0 else math.inf
    corr = float(np.corrcoef(curve, model)[0, 1]) if span_b > 0 and span_m > 0 else 0.0
    if not (ratio >= BIAS_SPAN_LIMIT
            or (abs(corr) >= BIAS_CORRELATION_LIMIT and ratio >= BIAS_CORRELATED_SPAN)):
        return None
    text = (f"the degree-{degree} bias polynomial varies by {span_b * 1e3:.3g} mV over the "
            f"angles, {ratio:.3g} x the model's own variation ({span_m * 1e3:.3g} mV), "
            f"correlation {corr:+.3f} with it: the bias has absorbed signal and the geometry was "
            "fitted to what is left; use a lower --bias-degree (0, a constant offset, unless "
            "the recording has a known drift of this size)")
    return CalibrationWarning("bias_absorbs_signal", text, tuple(
        ["offset"] + [f"bias_{d}" for d in range(1, degree + 1)]))


def stderr_checks(names: tuple[str, ...], values: Mapping[str, float], stderr: F64,
                  slopes: F64, sigma: float, rms: float, data_scale: float,
                  box: Mapping[str, tuple[float, float]]) -> list[CalibrationWarning]:
    """Warnings for standard errors the data cannot give, and for loose parameters.

    Parameters
    ----------
    names : tuple of str
        The covariance's parameters.
    values : mapping of str to float
        Their fitted values (SI; the magnetization scale relative or absolute, as ``stderr``).
    stderr : ndarray, shape (p,)
        Their standard errors (SI; inf where undetermined).
    slopes : ndarray, shape (p,)
        |∂output/∂p| over the angles (the Jacobian's column norms, V per SI unit).
    sigma : float
        The residual noise per angle, V (sqrt(cost / dof)).
    rms : float
        The RMS residual, V.
    data_scale : float
        The data's largest |output|, V.
    box : mapping of str to (float, float)
        Search bounds (SI) of the bounded parameters.
    """
    out: list[CalibrationWarning] = []
    noisy = rms > NOISE_FLOOR * data_scale
    for k, name in enumerate(names):
        se = float(stderr[k])
        if not math.isfinite(se):
            continue
        value = values.get(name, math.nan)
        floor = sigma / slopes[k] if slopes[k] > 0 else math.inf
        relative = se / abs(value) if value else math.inf
        if math.isfinite(floor) and se < STDERR_FLOOR_FRACTION * floor:
            out.append(CalibrationWarning("implausible_stderr", (
                f"the standard error of {name} ({shown(name, se)}) is below the least the noise "
                f"allows ({shown(name, floor)}: residual noise {sigma * 1e6:.3g} µV over its "
                "slope): a numerical artefact of a near-singular fit, not a measurement; treat "
                f"{name} as undetermined (fix or bound it)"), (name,)))
        elif noisy and relative < STDERR_RELATIVE_FLOOR:
            out.append(CalibrationWarning("implausible_stderr", (
                f"the standard error of {name} is {relative:.2g} of its value, more precise "
                f"than data with a {rms * 1e6:.3g} µV RMS residual can be: a numerical artefact; "
                f"treat {name} as undetermined (fix or bound it)"), (name,)))
        elif name in box:
            width = box[name][1] - box[name][0]
            if se > width:
                out.append(CalibrationWarning("implausible_stderr", (
                    f"{name} is not determined by the data: its standard error "
                    f"({shown(name, se)}) exceeds its whole bound width ({shown(name, width)}), "
                    "where the linearised error no longer holds; the bounds, not the data, "
                    "confine it: treat its value as arbitrary, or fix it"), (name,)))
            elif se > LOOSE_FRACTION * width:
                out.append(CalibrationWarning("weakly_determined", (
                    f"{name} is not determined by the data (standard error {shown(name, se)} "
                    f"vs a bound width of {shown(name, width)}); treat its value as arbitrary"),
                    (name,)))
    return out


def sensor_field(setup: Setup, angles: F64, which: str,
                 azimuths: F64 | None = None) -> CalibrationWarning | None:
    """A ``"sensor_field"`` warning when ``setup`` (the ``which`` = "initial" or "fitted"
    placement) puts a field beyond the element's flip field or linear range at any of the tilt
    ``angles`` (rad; toward ``azimuths``, rad, one per angle, default 0), else None; the text
    names the largest field, where it occurs and the fix."""
    angles = np.asarray(angles, dtype=np.float64).reshape(-1)
    azim = (np.zeros_like(angles) if azimuths is None
            else np.broadcast_to(np.asarray(azimuths, dtype=np.float64), angles.shape))
    fields, flags = np.zeros((angles.size, 3)), np.zeros(angles.size, dtype=np.uint8)
    for phi in np.unique(azim):
        at = azim == phi
        check = setup.check_sensor(angles[at], azimuth=float(phi))
        fields[at], flags[at] = check.field, check.flags
    bad = (flags & np.uint8(SENSOR_FIELD_FLAGS)) != 0
    if not bad.any():
        return None
    magnitude = np.linalg.norm(fields, axis=-1)
    i = int(np.argmax(np.where(bad, magnitude, -1.0)))
    s = setup.sensor
    b = fields[i]
    bx, by, bz = np.where(np.abs(b) > 1e-9 * magnitude[i], b, 0.0) / 1e-4  # no round-off
    what = []
    if int(flags[i]) & SensorFlag.FLIPPED_RISK:
        what.append(f"its {s.flip_field / 1e-4:.3g} gauss flip field")
    if int(flags[i]) & (SensorFlag.BEYOND_RANGE | SensorFlag.TOTAL_BEYOND_RANGE):
        what.append(f"its ±{s.field_range / 1e-4:.3g} gauss linear range")
    toward = f" toward {math.degrees(azim[i]):.3g} deg" if azim[i] else ""
    where = (f"|B| = {magnitude[i] / 1e-4:.3g} gauss on the {s.name}'s element at "
             f"{math.degrees(angles[i]):.3g} deg{toward} (B = ({bx:.3g}, {by:.3g}, {bz:.3g}) G; "
             f"{int(bad.sum())} of {bad.size} angles), beyond {' and '.join(what)}")
    text = (f"the {which} placement puts {where}: a sensor so placed needs a set/reset pulse "
            "and does not read B_x faithfully; check the recording (pulse set/reset before "
            "recording), the bounds of x, y, z, or the sensor's flip_field and range")
    return CalibrationWarning("sensor_field", text, ("x", "y", "z"))


def scale_direction(names: Sequence[str], values: Mapping[str, float], depth: float) -> F64:
    """The change of each parameter of ``names`` when every length grows by a factor 1 + ε,
    per ε (SI): the length itself (the base's height above the element, z + ``depth``, for z),
    0 for the others (offsets, scales, a modulus). Shape (p,)."""
    return np.array([(values[n] + depth if n == "z" else values[n]) if n in SCALED else 0.0
                     for n in names], dtype=np.float64)


def is_scale_symmetry(jac: F64, null: F64, names: Sequence[str], values: Mapping[str, float],
                      depth: float) -> bool:
    """Whether the combinations ``null`` (r, p) that the Jacobian ``jac`` (m, p) does not see
    (from :func:`magcilia.calibration.uncertainty.equilibrated_pinv`: rows in the columns'
    equilibrated units) include the scale direction (:func:`scale_direction`; its non-length
    parts free, e.g. a Young's modulus that trades against the size)."""
    s = scale_direction(names, values, depth)
    lengths = s != 0.0
    if not null.size or not lengths.any():
        return False
    slopes = np.linalg.norm(jac, axis=0)
    target = (s * np.where(slopes > 0, slopes, 1.0))[lengths]
    target /= np.linalg.norm(target)
    part = null[:, lengths]
    coef, *_ = np.linalg.lstsq(part.T, target, rcond=None)
    return bool(float(np.linalg.norm(part.T @ coef - target)) <= SCALE_TOLERANCE)


def undetermined_warning(jac: F64, null: F64, undetermined: NDArray[np.bool_],
                         names: Sequence[str], values: Mapping[str, float], depth: float,
                         data: str, scale_remedy: str, other_remedy: str) -> CalibrationWarning:
    """The ``"undetermined"`` warning for the null combinations ``null`` (r, p) of ``jac``
    (m, p), naming the parameters involved (``undetermined``, (p,)) and what determines them:
    ``scale_remedy`` when the scale symmetry is among them (:func:`is_scale_symmetry`; no tilt
    recording fixes the size), ``other_remedy`` for the rest; ``data`` names the data ("this
    tilt path")."""
    involved = tuple(n for n, u in zip(names, undetermined, strict=True) if u)
    count = len(null)
    head = (f"the data are (numerically) unchanged along {count} combination(s) of "
            f"{', '.join(involved)}: these parameters are not determined by {data} and their "
            "standard errors are infinite")
    if not is_scale_symmetry(jac, null, names, values, depth):
        return CalibrationWarning("undetermined", f"{head} ({other_remedy})", involved)
    text = (f"{head}. {'One of them is' if count > 1 else 'It is'} the scale symmetry: every "
            "length scaled together (height, base radius and the placement x, y, z + sensor "
            "depth) leaves the field unchanged, so no tilt or coil recording (a uniform field "
            "bends the cilium alike at any size), at any azimuth or with any field component, "
            f"fixes the size; what fixes it is {scale_remedy}")
    if count > 1:
        text += f"; for the other combination(s), {other_remedy}"
    return CalibrationWarning("undetermined", text, involved)


#: what fixes the size of a paper-model fit (the scale symmetry, NOTES §8)
PAPER_SCALE_REMEDY = ("a size measured by hand: hold it (--fix height=VALUE; API "
                      "fixed={'height': value}), or calibrate with --model physical and give it as "
                      "a prior (--prior height=VALUE:SIGMA) or add load (force or flow) data")


def scale_remedy(load_kinds: frozenset[str], modulus_free: bool) -> str:
    """What fixes the size of a physical-model fit whose experiments include loads of
    ``load_kinds`` (``"force"``, ``"flow"``; empty for tilts only), with the Young's modulus
    fitted without a prior (``modulus_free``): a tip force bends as F/(E·size²), a flow as
    U/(E·size), so one kind with a free modulus fixes only their product."""
    if load_kinds and modulus_free:
        other = ("flow" if load_kinds == {"force"} else "force" if load_kinds == {"flow"}
                 else None)
        load = ("the Young's modulus held at a measured value or given a prior"
                + (f", or a {other} recording beside the {min(load_kinds)} one" if other else ""))
    else:
        load = ("a load of known size: a force or flow recording (with the Young's modulus "
                "known, or both kinds together)")
    return ("a size measured by hand as a prior (--prior height=VALUE:SIGMA, or base_radius; "
            f"API priors={{'height': (value, sigma)}}), or {load}")


def undetermined_remedy(y_sign_known: bool) -> str:
    """What determines undetermined combinations other than the scale, for experiments that do
    (``y_sign_known``: another azimuth or field data) or do not go beyond one output path."""
    if not y_sign_known:
        return "a tilt toward another azimuth, 3-axis field data or a prior determine them"
    return "a prior (a measured value) or another kind of experiment determines them"


def placement_remedy(y_sign_known: bool) -> str:
    """What decides between equally good placements (the ``"ambiguous"`` warning), for
    experiments that do (``y_sign_known``) or do not go beyond one output path."""
    if not y_sign_known:
        return ("a tilt toward another azimuth, 3-axis field data or a prior on the placement "
                "(a measured x) would decide")
    return "a prior on the placement (a measured x, y or z) or another experiment would decide"


def prior_only_warning(jac: F64, null: F64, open_: NDArray[np.bool_], names: Sequence[str],
                       values: Mapping[str, float], depth: float,
                       priors: Sequence[str]) -> CalibrationWarning:
    """The ``"prior_only"`` note: the data's Jacobian ``jac`` (m, p), without the prior rows,
    leaves the combinations ``null`` (r, p) of the parameters ``open_`` (p,) open, and the
    priors on ``priors`` determine them."""
    involved = tuple(n for n, u in zip(names, open_, strict=True) if u)
    scale = (" (the scale symmetry: every length scaled together leaves the field unchanged)"
             if is_scale_symmetry(jac, null, names, values, depth) else "")
    return CalibrationWarning("prior_only", (
        f"the data alone leave {len(null)} combination(s) of {', '.join(involved)} open{scale}; "
        f"the prior on {', '.join(priors)} determines {'it' if len(null) == 1 else 'them'}, so "
        "the standard errors along it rest on the prior's σ, not on the data"), involved)

