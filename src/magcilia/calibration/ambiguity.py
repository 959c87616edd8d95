"""Solutions that fit as well as the best one: the known mirrored basins and the search's other
optima, looked for and reported (the ``"ambiguous"`` warning).

A local fit ends in the basin it starts in, and a global search that happens to sample one side
of a symmetry well never looks on the other. Two near-symmetries of a tilt calibration are known
in advance:

* the **x mirror**: the cilium on the other side of the sensing element (x → −x). A tilt toward
  +x then moves the tip toward the element instead of away from it, so the curve is not the same,
  but with the offset (and the other lengths) free it can come close;
* the **y sign**: B_x along tilts toward azimuth 0 or π is even in y, so y → −y fits exactly as
  well; the ``"y_sign"`` warning says so, and the posterior samples both signs. With another
  azimuth or 3-axis field data the sign is determined, yet the mirrored basin may still fit
  nearly as well, so it is searched like the x mirror.

After the global search, local fits start in the mirrored basins of the best solution
(:func:`mirror_starts`). Every optimum found (those and the search's own) whose χ² lies within
:data:`AMBIGUITY_CHI2` of the best and which lies more than :data:`AMBIGUITY_SIGMA` standard errors
from it in some parameter is an alternative the data cannot exclude (:func:`alternatives`); the
calibration names them in one ``"ambiguous"`` warning (:func:`ambiguity_warning`) and samples each
as a mode of the posterior. Optima within the standard errors of the best (a flat valley the
local fits stopped in at different points) are the same solution. A mirrored optimum that fits
better than the search's best replaces it (the caller decides: :func:`best_of`).

The exact scale symmetry (every length scaled together: NOTES §8) is not a basin but a direction
along which nothing changes; the ``"undetermined"`` warning reports it
(:func:`magcilia.calibration.diagnostics.undetermined_warning`).
"""

from __future__ import annotations

import math
from collections.abc import Mapping, Sequence
from dataclasses import dataclass

import numpy as np
from numpy.typing import NDArray

from magcilia.calibration.diagnostics import CalibrationWarning, scale_direction, shown

F64 = NDArray[np.float64]

#: another optimum whose χ² is at most this much above the best fits as well (Δχ² ≤ 4: the data
#: exclude it at less than 2σ)
AMBIGUITY_CHI2 = 4.0
#: … and counts as another solution when it lies more than this many standard errors of the best
#: away in some parameter
AMBIGUITY_SIGMA = 2.0


@dataclass(frozen=True)
class Alternative:
    """An optimum that fits as well as the best one.

    Attributes
    ----------
    point : ndarray, shape (p,)
        Its parameters (SI), in the order of the search vector.
    chi2 : float
        Its χ² (the best one's scale: for an unweighted fit, the cost over the residual variance).
    differs : tuple of str
        The parameters in which it lies more than :data:`AMBIGUITY_SIGMA` standard errors from the
        best solution.
    """

    point: F64
    chi2: float
    differs: tuple[str, ...]


def mirror_starts(x: F64, names: Sequence[str], bounds: F64, y_sign: bool) -> F64:
    """Starting points (m, p) in the mirrored basins of ``x`` (p,): x → −x, and, when the data
    can tell the sign of y (``y_sign``), also y → −y and both; a point whose mirrored value lies
    outside ``bounds`` (p, 2) is left out (the bounds exclude that side)."""
    flips: list[tuple[str, ...]] = [("x",)]
    if y_sign:
        flips += [("x", "y"), ("y",)]
    out = []
    for flip in flips:
        if not all(n in names for n in flip):
            continue
        start = np.array(x, dtype=np.float64)
        for n in flip:
            start[names.index(n)] *= -1.0
        if np.array_equal(start, x) or not np.all((bounds[:, 0] <= start)
                                                  & (start <= bounds[:, 1])):
            continue
        out.append(start)
    return np.array(out, dtype=np.float64).reshape(-1, len(names))


def best_of(points: F64, chi2: F64) -> tuple[F64, float]:
    """The point of ``points`` (s, p) with the smallest finite ``chi2`` (s,), and that χ²."""
    cost = np.where(np.isfinite(chi2), chi2, np.inf)
    i = int(np.argmin(cost))
    return np.asarray(points[i], dtype=np.float64), float(cost[i])


def at_size_of(point: F64, best: F64, names: Sequence[str], depth: float) -> F64:
    """``point`` (p,) moved along the scale symmetry to ``best``'s height: every length (height,
    base radius, x, y, and z + ``depth``, the base's height above the element) times
    h_best / h_point (along :func:`~magcilia.calibration.diagnostics.scale_direction`). The
    field, hence the fit to tilt data, does not change (NOTES §8)."""
    if "height" not in names:
        return point
    k = names.index("height")
    step = scale_direction(names, dict(zip(names, point.tolist(), strict=True)), depth)
    return np.asarray(point + (best[k] / point[k] - 1.0) * step, dtype=np.float64)


def alternatives(best: F64, best_chi2: float, points: F64, chi2: F64, names: Sequence[str],
                 stderr: Mapping[str, float], fold_y: bool = False,
                 depth: float | None = None) -> list[Alternative]:
    """The distinct optima among ``points`` (s, p) that fit as well as ``best`` (p,).

    Parameters
    ----------
    best : ndarray, shape (p,)
        The solution reported, SI.
    best_chi2 : float
        Its χ².
    points, chi2 : ndarray, shapes (s, p) and (s,)
        Other optima and their χ² (same scale).
    names : sequence of str
        Parameter names of the p columns.
    stderr : mapping of str to float
        The best solution's standard errors (SI; a name missing or inf never "differs").
    fold_y : bool
        The data cannot tell the sign of y: compare y by its magnitude (the y mirror is reported
        by its own warning).
    depth : float, optional
        The sensor depth (m), given when nothing fixes the size (no length held or given a
        prior): each optimum is first moved along the scale symmetry to the best's height
        (:func:`at_size_of`), so that where a local fit stopped along that exactly flat
        direction does not decide whether it counts as another solution.

    Returns
    -------
    list of Alternative
        By increasing χ²; each more than :data:`AMBIGUITY_SIGMA` standard errors from ``best`` and
        from every better alternative in some parameter, with χ² ≤ ``best_chi2`` +
        :data:`AMBIGUITY_CHI2`.
    """
    se = np.array([stderr.get(n, math.inf) for n in names], dtype=np.float64)
    se = np.where(np.isfinite(se) & (se >= 0.0), se, np.inf)
    k = names.index("y") if fold_y and "y" in names else -1
    found: list[Alternative] = []
    for i in np.argsort(np.where(np.isfinite(chi2), chi2, np.inf), kind="stable"):
        c = float(chi2[i])
        if not c <= best_chi2 + AMBIGUITY_CHI2:
            break
        point = np.array(points[i], dtype=np.float64)
        if depth is not None:
            point = at_size_of(point, best, names, depth)
        if k >= 0:
            point[k] = math.copysign(point[k], best[k])
        far = np.abs(point - best) > AMBIGUITY_SIGMA * se
        if not far.any() or any(not (np.abs(point - a.point) > AMBIGUITY_SIGMA * se).any()
                                for a in found):
            continue
        found.append(Alternative(point, c, tuple(n for n, f in zip(names, far, strict=True)
                                                 if f)))
    return found


def ambiguity_warning(found: Sequence[Alternative], best_chi2: float, names: Sequence[str],
                      remedy: str) -> CalibrationWarning | None:
    """One ``"ambiguous"`` warning naming every alternative (the parameters in which it differs,
    in display units, and its χ²), or None when there is none; ``remedy`` says what data would
    decide between them."""
    if not found:
        return None
    parts = []
    for a in found:
        where = ", ".join(f"{n} {shown(n, float(a.point[names.index(n)]))}" for n in a.differs)
        parts.append(f"{where} (chi2 {a.chi2:.4g})")
    involved = tuple(dict.fromkeys(n for a in found for n in a.differs))
    count = "another solution fits" if len(found) == 1 else f"{len(found)} other solutions fit"
    text = (f"ambiguous: {count} as well as the best (chi2 {best_chi2:.4g}; within "
            f"{AMBIGUITY_CHI2:g}) and lie{'s' if len(found) == 1 else ''} more than "
            f"{AMBIGUITY_SIGMA:g} standard errors from it: {'; '.join(parts)}. The data do not "
            "choose between them, and the standard errors describe the best one only; "
            f"{remedy}")
    return CalibrationWarning("ambiguous", text, involved)
