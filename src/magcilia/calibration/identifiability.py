"""Which parameters a calibration determines, from its Fisher information (issue 29, item 1).

The information of a set of experiments is the sum of each experiment's ``JᵀJ`` (rows divided by
the noise σ) with its own offsets profiled out (the Schur complement: offsets are never shared
between experiments), plus a prior's ``1/σ²`` on the diagonal (a prior row ``(p − μ)/σ``,
:class:`~magcilia.calibration.experiments.Prior`). :func:`identify` reads it in *relative units*
(each parameter's change as a fraction of its own size: the lengths of the scale family, z as the
element-to-base distance ``depth + z``). A direction is **undetermined** when it is in the null
space of the data's information (a symmetry of the model: no number of readings fixes it) and
no prior touches it; each one is named in parameter
terms (:func:`name_direction`: "all lengths together", "magnetization_scale / youngs_modulus",
…) with what would determine it. A parameter with a share of an undetermined direction has no
standard error; the others' σ are the square roots of the inverse's diagonal over the determined
directions (large ones mean weakly determined: more readings or a prior help).
"""

from __future__ import annotations

import math
from collections.abc import Mapping, Sequence
from dataclasses import dataclass
from typing import Any

import numpy as np
from numpy.typing import ArrayLike, NDArray

from magcilia import _validate as v
from magcilia._display import Display, Item
from magcilia.calibration.coil_rows import LENGTHS
from magcilia.calibration.doptimal import NULL_COMPONENT
from magcilia.device.parameters import PARAMETERS
from magcilia.device.setup import Setup

F64 = NDArray[np.float64]

#: an eigenvalue of the correlation-scaled information (unit diagonal) below this is a null
#: direction of the model (a symmetry): over the identifiability table's twelve information
#: matrices (coil, rig, both; two cilia; two sensors) the exact symmetries leave |λ| ≤ 2e-11 (the
#: bend's own tolerance through the differences), the weakest real direction is 4e-10 (a single
#: tilt path's), the next 1e-8 (magnetization against modulus from the bending)
STRUCTURAL_TOLERANCE = 1e-10
#: a component of a direction below this fraction of its largest is left out of its name
NAME_COMPONENT = 0.15
#: what determines a combination that involves these parameters
REMEDIES = {
    "length": "a size measurement (a photo with a scale, a caliper: --prior height=VALUE:SIGMA) "
              "or a load of known size",
    "youngs_modulus": "a ring-down (its modulus as a prior: magcilia ringdown --json, "
                      "--prior youngs_modulus=VALUE:SIGMA) or a known load",
    "sensitivity": "a coil experiment (the applied field seen directly fixes the sensor's "
                   "sensitivity) or a known sensitivity",
    "magnetization_scale": "a coil experiment with a size and a modulus (the bending under a "
                           "known field) or a known magnetization",
}


def unit_of(setup: Setup, name: str) -> float:
    """The size a relative change of ``name`` is measured against, SI: its value (z: the
    element-to-base distance ``depth + z``, what scales with the other lengths; a position
    near zero: 1 mm)."""
    from magcilia.calibration.coil_rows import nominal

    value = nominal(setup, name)
    if name == "z":
        value += setup.sensor.depth
    if name in LENGTHS:
        return 1e-3 if abs(value) < 1e-6 else abs(value)
    return abs(value) if value else 1.0


def profile(information: F64, interest: int) -> F64:
    """The information about the first ``interest`` parameters once the rest (an experiment's
    offsets) are profiled out: the Schur complement, shape (interest, interest)."""
    M = 0.5 * (information + information.T)
    a, b, c = M[:interest, :interest], M[:interest, interest:], M[interest:, interest:]
    if c.size == 0:
        return np.asarray(a, dtype=np.float64)
    return np.asarray(a - b @ np.linalg.pinv(c, rcond=1e-14, hermitian=True) @ b.T,
                      dtype=np.float64)


def experiment_information(rows: ArrayLike, noise: float, counts: ArrayLike | None = None
                           ) -> F64:
    """The Fisher information of one experiment, its offsets (one per row of a reading: per axis)
    profiled out.

    Parameters
    ----------
    rows : array-like, shape (c, r, q)
        Each candidate reading's sensitivities (SI),
        :func:`~magcilia.calibration.coil_rows.calibration_rows`.
    noise : float
        σ of one reading (V or T per component).
    counts : array-like of int, shape (c,), optional
        How often each candidate is read (default once each).

    Returns
    -------
    ndarray, shape (q, q)
    """
    J = np.asarray(rows, dtype=np.float64)
    c, r, q = J.shape
    n = np.ones(c) if counts is None else np.asarray(counts, dtype=np.float64)
    full = np.concatenate([J, np.broadcast_to(np.eye(r), (c, r, r))], axis=2) / noise
    info = np.einsum("c,cri,crj->ij", n, full, full)
    return profile(info, q)


def prior_information(names: Sequence[str], priors: Mapping[str, float]) -> F64:
    """The information of Gaussian priors (name → σ, SI): ``diag(1/σ²)``, shape (q, q)."""
    out = np.zeros((len(names), len(names)))
    for n, sd in priors.items():
        if n not in names:
            raise v.fail("priors", n, "parameters among " + ", ".join(names))
        out[list(names).index(n), list(names).index(n)] = 1.0 / v.positive(
            f"prior σ of {n}", sd, "SI", "σ") ** 2
    return out


def name_direction(names: Sequence[str], direction: ArrayLike) -> str:
    """A combination of relative changes (a unit vector over ``names``) in parameter terms:
    "all lengths together (…)" for the scale symmetry, "A / B" or "A · B" for two parameters that
    only the ratio or the product of is fixed, "A" alone, else the relative weights."""
    d = np.asarray(direction, dtype=np.float64)
    d = d / (float(np.max(np.abs(d))) or 1.0)
    big = [i for i in range(d.size) if abs(d[i]) >= NAME_COMPONENT]
    if d[big[0]] < 0:
        d = -d
    sig = [names[i] for i in big]
    if set(sig) == set(LENGTHS) and np.allclose(d[big], d[big[0]], rtol=0.3):
        return ("all lengths together (height, base radius, x, y, z by one factor: the scale "
                "symmetry)")
    if len(big) == 1:
        return sig[0]
    if len(big) == 2:
        a, b = float(d[big[0]]), float(d[big[1]])
        k = abs(a / b)
        power = "" if math.isclose(k, 1.0, rel_tol=0.25) else f"^{k:.2g}"
        if a * b > 0:
            return f"{sig[0]}{power} ∝ {sig[1]} (only {sig[0]}{power}/{sig[1]} is fixed)"
        return f"{sig[0]}{power} · {sig[1]} (only the product is fixed)"
    return "relative changes " + ", ".join(f"{names[i]} {d[i]:+.2f}" for i in big)


def _candidates(names: Sequence[str]) -> list[F64]:
    """Named directions tried first (relative units): the scale symmetry, single parameters,
    and pairs of non-length parameters with exponent ratios 1, 2 and 1/2."""
    q = len(names)
    out = [np.array([1.0 if n in LENGTHS else 0.0 for n in names])]
    out += [np.eye(q)[i] for i in range(q)]
    others = [i for i, n in enumerate(names) if n not in LENGTHS]
    for ii, i in enumerate(others):
        for j in others[ii + 1:]:
            for a, b in ((1, 1), (1, -1), (1, 2), (2, 1), (1, -2), (2, -1)):
                d = np.zeros(q)
                d[i], d[j] = a, b
                out.append(d)
    return [d / np.linalg.norm(d) for d in out if np.any(d)]


def canonical_basis(names: Sequence[str], null: F64) -> F64:
    """A basis of the undetermined subspace (columns of ``null``, orthonormal, relative units)
    made of named directions where they lie in it (:func:`_candidates`, within 5 %), the rest
    as they come; shape (k, q)."""
    k = null.shape[1]
    if k == 0:
        return np.zeros((0, len(names)))
    basis = null.copy()
    chosen: list[F64] = []
    for d in _candidates(names):
        if len(chosen) == k:
            break
        inside = basis @ (basis.T @ d)
        if np.linalg.norm(d - inside) < 0.05:
            chosen.append(d)
            # deflate: the rest of the subspace, orthogonal to d
            rest = basis - np.outer(d, d @ basis)
            u, _, _ = np.linalg.svd(rest, full_matrices=False)
            basis = u[:, : k - len(chosen)] if k - len(chosen) else np.zeros((len(names), 0))
    chosen += [basis[:, i] for i in range(basis.shape[1])]
    return np.asarray(chosen, dtype=np.float64)


def remedy(names: Sequence[str], direction: ArrayLike) -> str:
    """What would determine a combination (:data:`REMEDIES` of its larger components)."""
    d = np.abs(np.asarray(direction, dtype=np.float64))
    d = d / (float(np.max(d)) or 1.0)
    involved = [names[i] for i in range(d.size) if d[i] >= NAME_COMPONENT]
    keys = []
    if any(n in LENGTHS and d[i] >= 0.5 for i, n in enumerate(names)):
        keys.append("length")
    keys += [n for n in ("youngs_modulus", "sensitivity", "magnetization_scale")
             if n in involved]
    if "length" in keys or "youngs_modulus" in keys:
        keys = [k for k in keys if k != "magnetization_scale"]
    if "sensitivity" in keys and "magnetization_scale" in involved:
        keys = ["sensitivity"]
    return "; or ".join(REMEDIES[k] for k in keys)


@dataclass(frozen=True, repr=False, eq=False)
class Identifiability(Display):
    """What a calibration determines, from its Fisher information.

    Attributes
    ----------
    names : tuple of str
        The parameters, length q.
    values : ndarray, shape (q,)
        Their values, SI.
    units : ndarray, shape (q,)
        The sizes relative changes are measured against (:func:`unit_of`), SI.
    stderr : ndarray, shape (q,)
        Expected standard errors, SI; inf for a parameter in an undetermined combination.
    rank : int
        Directions the data and priors determine, of q (the rest: :attr:`undetermined`).
    undetermined : tuple of str
        Each undetermined combination, named (:func:`name_direction`).
    remedies : tuple of str
        What would determine each, in the same order.
    directions : ndarray, shape (k, q)
        The undetermined directions (relative units, unit length).
    """

    names: tuple[str, ...]
    values: F64
    units: F64
    stderr: F64
    rank: int
    undetermined: tuple[str, ...]
    remedies: tuple[str, ...]
    directions: F64

    def relative(self) -> F64:
        """σ relative to each parameter's size (:attr:`units`), shape (q,)."""
        return np.asarray(self.stderr / self.units, dtype=np.float64)

    def to_dict(self) -> dict[str, Any]:
        """JSON-ready, SI."""
        return {"units": "SI", "rank": self.rank, "parameters": len(self.names),
                "stderr": {n: (float(s) if math.isfinite(s) else None)
                           for n, s in zip(self.names, self.stderr, strict=True)},
                "values": dict(zip(self.names, self.values.tolist(), strict=True)),
                "undetermined": [{"combination": c, "determined_by": r}
                                 for c, r in zip(self.undetermined, self.remedies, strict=True)]}

    def report(self) -> str:
        """Rank, σ of each parameter (display units) and the undetermined combinations."""
        lines = [f"Identifiability: rank {self.rank}/{len(self.names)}"]
        lines += [f"  σ {n} = {sigma_text(n, float(s), size=float(u))}"
                  for n, s, u in zip(self.names, self.stderr, self.units, strict=True)]
        lines += [f"  undetermined: {c}: add {r}"
                  for c, r in zip(self.undetermined, self.remedies, strict=True)]
        return "\n".join(lines)

    def _display_items(self) -> list[Item]:
        return [("rank", f"{self.rank}/{len(self.names)}"),
                *((f"σ {n}", sigma_text(n, float(s), size=float(u)))
                  for n, s, u in zip(self.names, self.stderr, self.units, strict=True)),
                *(("undetermined", c) for c in self.undetermined)]


def sigma_text(name: str, value: float, digits: int = 2, size: float | None = None) -> str:
    """A σ in display units (mm, MPa, a factor as %; the sensitivity as % of ``size``, its
    value), "—" where undetermined."""
    if not math.isfinite(value):
        return "—"
    p = PARAMETERS.get(name)
    if name == "sensitivity" and size:
        return f"{100 * value / size:.{digits}g} %"
    if p is None or p.what == "factor":
        return f"{100 * value:.{digits}g} %"
    return p.text(value, digits)


def identify(information: ArrayLike, names: Sequence[str], setup: Setup,
             priors: Mapping[str, float] | None = None) -> Identifiability:
    """Read a Fisher information (SI, offsets already profiled out) over ``names``
    (:data:`~magcilia.calibration.coil_rows.CALIBRATION_PARAMETERS`) at the setup's values, with
    Gaussian priors (name → σ, SI) added: rank, standard errors and the undetermined
    combinations, named.

    The data's null space is found on the correlation-scaled information (eigenvalues below
    :data:`STRUCTURAL_TOLERANCE`: a symmetry of the model, not a lack of readings); a prior on a
    parameter that takes part in it removes the part it touches."""
    from magcilia.calibration.coil_rows import nominal

    names = tuple(names)
    info = np.asarray(information, dtype=np.float64)
    q = len(names)
    if info.shape != (q, q) or not np.all(np.isfinite(info)):
        raise v.fail("information", f"shape {info.shape}", f"a finite ({q}, {q}) matrix")
    P = prior_information(names, priors or {})
    d = np.sqrt(np.maximum(np.diag(info), 0.0))
    d = np.where(d > 0, d, 1.0)
    lam, vec = np.linalg.eigh(0.5 * (info + info.T) / np.outer(d, d))
    null = vec[:, lam <= STRUCTURAL_TOLERANCE]  # y = d · δp coordinates
    given = [i for i in range(q) if P[i, i] > 0]
    if null.shape[1] and given:
        _, sv, vt = np.linalg.svd(null[given, :])
        keep = np.concatenate([sv, np.zeros(vt.shape[0] - sv.size)]) <= 1e-6
        null = null @ vt[keep].T
    Y = (info + P) / np.outer(d, d)
    proj = np.eye(q) - null @ null.T
    cov = np.linalg.pinv(proj @ Y @ proj, rcond=1e-14, hermitian=True)
    share = np.sum(null**2, axis=1)
    stderr = np.where(share > NULL_COMPONENT, np.inf,
                      np.sqrt(np.maximum(np.diag(cov), 0.0)) / d)
    units = np.array([unit_of(setup, n) for n in names])
    rel = null / (d * units)[:, None]
    if rel.shape[1]:
        rel, _ = np.linalg.qr(rel)
    directions = canonical_basis(names, rel)
    return Identifiability(names=names, values=np.array([nominal(setup, n) for n in names]),
                           units=units, stderr=stderr, rank=q - null.shape[1],
                           undetermined=tuple(name_direction(names, x) for x in directions),
                           remedies=tuple(remedy(names, x) for x in directions),
                           directions=directions)


__all__ = ["NAME_COMPONENT", "REMEDIES", "STRUCTURAL_TOLERANCE", "Identifiability",
           "experiment_information", "identify", "name_direction", "prior_information",
           "profile", "remedy", "sigma_text", "unit_of"]
