"""Static planar elastica by spectral collocation (pure arrays; :func:`magcilia.bend` checks).

Inextensible, unshearable rod, clamped at s = 0 along +z, free at s = L; tangent angle θ(s) from +z
toward +x, position ``r(s) = ∫₀ˢ (sin θ, cos θ)``. With the internal force carried across a section
``N(s) = ∫ₛᴸ f dσ + F H(a − s)`` (distributed load f, dead point force F at arc length a), the
moment balance is ``E I(s) θ'(s) = M(s)`` with ``M(s) = ∫ₛᴸ (cos θ N_x − sin θ N_z) dσ``.

Integral form solved here: ``θ = C [ (R g(θ)) / EI ]``, ``g = cos θ N_x − sin θ N_z`` and
``N = R f + F H``, where ``C`` integrates from the base and ``R`` from the point to the tip.
θ(0) = 0 and M(L) = 0 are built in. A distributed couple per length c (a uniform field's
``μ t × B`` on the magnetized cilium, y-component ``μ (B_x cos θ − B_z sin θ)``) adds to g
itself, pointwise (M = ∫ₛᴸ (t × N + c)), and not to N: it is a couple, not a force.
``[0, L]`` is split at the load point (where M' jumps); on each piece θ is represented by its
values at Chebyshev (first-kind, interior) nodes, so the integrals are spectrally accurate and
nodes never sit where EI may vanish (a cone's tip). With the influence matrix
``P = C diag(1/EI) R`` (fixed per grid) the residual is ``θ − P g(θ)``; Newton's method with the
analytic Jacobian ``I − P diag(g'(θ))`` for the point load and the couple (O(N²) per step;
batched central differences for the shape-dependent drag), started from a guess (the caller's:
:func:`magcilia.bend` saturates the linear-beam solution), and load continuation with a secant
predictor and step halving when Newton fails. A point force alone (the common bend) runs the
same Newton iteration fused into a few array operations a step (:func:`_newton_point`; a bend
of the issue's tapered cilium then takes ~80 µs: four steps, three of them factorizing the
34 × 34 Jacobian). The dense solves are NumPy's LAPACK (:func:`dense_solve`), not SciPy's:
importing ``scipy.linalg`` would cost a first bend in a fresh process ~0.1 s.

The Chebyshev references (integration matrices on [-1, 1] for n nodes, and at the uniform
output points) are built in closed form from ``T_m(cos φ) = cos(m φ)`` and the nodes' discrete
orthogonality, once per node count: a new cilium's grid only scales them. The node counts most
first bends need are shipped instead (:mod:`magcilia.mechanics.chebyshev_tables`, the closed
forms' own output, read in one file read).
"""

from __future__ import annotations

import math
from collections.abc import Callable
from dataclasses import dataclass, field
from functools import lru_cache
from typing import Protocol, cast

import numpy as np
from numpy.typing import NDArray

from magcilia.mechanics import chebyshev_tables

F64 = NDArray[np.float64]


def _integrals(t: F64, n: int) -> F64:
    """Matrix (q, n): ``∫_{-1}^{x} T_k`` for k < n at q points x, from ``t`` = the matrix
    (q, n + 1) of ``T_m(x)``, m ≤ n: ``x + 1``, ``(x² − 1) / 2`` and, for k ≥ 2,
    ``T_{k+1} / (2(k+1)) − T_{k−1} / (2(k−1))`` less its value at −1 (exactly 0 at x = −1)."""
    out = np.empty((t.shape[0], n))
    out[:, 0] = t[:, 1] + 1.0
    if n > 1:
        out[:, 1] = 0.25 * (t[:, 2] - 1.0)  # (x² − 1) / 2 = (T_2 − 1) / 4
    if n > 2:
        k = np.arange(2.0, n)
        sign = np.where(k % 2.0 == 0.0, -1.0, 1.0)  # T_{k±1}(−1) = (−1)^{k+1}
        up, down = 0.5 / (k + 1.0), 0.5 / (k - 1.0)
        out[:, 2:] = (t[:, 3:] - sign) * up - (t[:, 1:n - 1] - sign) * down
    return out


def _at_nodes(n: int, degrees: int) -> F64:
    """Matrix (n, degrees): ``T_m(t_j)`` at the n Chebyshev nodes t_j (ascending) for m <
    ``degrees``. With ``t_j = cos φ_j``, ``φ_j = π (2i + 1) / (2n)`` (i = n − 1 − j), each
    ``m φ_j`` is a whole multiple of ``π / (2n)``: the values are read from one table of 4n
    cosines (as exact as the table, and no cosine of a large argument)."""
    odd = 2 * np.arange(n - 1, -1, -1) + 1  # 2i + 1, ascending nodes
    table = np.cos(np.arange(4 * n) * (np.pi / (2 * n)))
    return np.asarray(table[np.multiply.outer(odd, np.arange(degrees)) % (4 * n)],
                      dtype=np.float64)


@lru_cache(maxsize=64)
def _reference(n: int) -> tuple[F64, F64, F64]:
    """On [-1, 1]: the n Chebyshev (first-kind) nodes t (ascending), the matrix (n, n) of
    ∫_{-1}^{t} at them and the weights (n,) of ∫_{-1}^{1}, each of the interpolant of nodal
    values; read from the shipped tables (:mod:`.chebyshev_tables`) for their node counts, else
    in closed form (:func:`_closed_reference`); cached: a grid of any length scales them."""
    shipped = chebyshev_tables.read(n)
    if shipped is not None:
        return shipped[:3]
    return _closed_reference(n)


def _closed_reference(n: int) -> tuple[F64, F64, F64]:
    """:func:`_reference` in closed form: ∫ of the Chebyshev series through the map from nodal
    values to coefficients (:func:`_coefficients`)."""
    values = _at_nodes(n, n + 1)
    rows = np.empty((n + 1, n + 1))
    rows[:n], rows[n] = values, 1.0  # and T_m(1) = 1, for the weights
    integrals = _integrals(rows, n) @ _coefficients(n)
    t = values[:, 1].copy()  # T_1(t) = t
    for arr in (t, integrals):
        arr.setflags(write=False)
    return t, integrals[:n], integrals[n]


@lru_cache(maxsize=64)
def _coefficients(n: int) -> F64:
    """The map V⁻¹ (n, n) from values at the n nodes to Chebyshev coefficients, in closed form
    (the nodes' discrete orthogonality: ``V⁻¹ = diag(1/n, 2/n, …) Vᵀ``), read-only."""
    vinv = _at_nodes(n, n).T * (2.0 / n)
    vinv[0] *= 0.5
    vinv.setflags(write=False)
    return vinv


@lru_cache(maxsize=64)
def _uniform_reference(n: int, m: int) -> F64:
    """Matrix (m, n): ∫_{-1}^{x} of the interpolant of n nodal values at m uniform x from −1
    to 1 (cached: the output grid of every one-piece grid); read from the shipped tables
    (:mod:`.chebyshev_tables`) for their node counts and m, else in closed form."""
    shipped = chebyshev_tables.read(n)
    if shipped is not None and shipped[3].shape[0] == m:
        return shipped[3]
    return _closed_uniform_reference(n, m)


def _closed_uniform_reference(n: int, m: int) -> F64:
    """:func:`_uniform_reference` in closed form."""
    x = np.linspace(-1.0, 1.0, m)
    half = m // 2  # x ≥ 0 from here on; the rows before mirror them: T_k(−x) = (−1)^k T_k(x)
    values = np.empty((m, n + 1))
    values[half:] = np.cos(np.multiply.outer(np.arccos(x[half:]), np.arange(n + 1.0)))
    values[:half] = values[m - 1:m - 1 - half:-1] * np.where(np.arange(n + 1) % 2 == 0, 1.0,
                                                              -1.0)
    out = np.asarray(_integrals(values, n) @ _coefficients(n), dtype=np.float64)
    out.setflags(write=False)
    return out


def _cumulative(n: int, t_query: F64) -> F64:
    """Matrix (q, n): values at t_query of ∫_{-1}^t p, p the interpolant of nodal values."""
    phi = np.arccos(np.clip(t_query, -1.0, 1.0))
    values = np.cos(np.multiply.outer(phi, np.arange(n + 1.0)))  # T_m(cos φ) = cos(m φ)
    return np.asarray(_integrals(values, n) @ _coefficients(n), dtype=np.float64)


@dataclass(frozen=True)
class Grid:
    """Collocation grid on pieces [b_k, b_k+1] of [0, L] (m), n_k nodes each."""

    bounds: F64  # (p+1,)
    sizes: tuple[int, ...]
    s: F64  # (N,) nodes, m
    C: F64  # (N, N) ∫_0^s
    R: F64  # (N, N) ∫_s^L
    w: F64  # (N,) ∫_0^L quadrature weights
    piece: NDArray[np.int64]  # (N,) piece index of each node
    _memo: dict[int, tuple[F64, F64]] = field(default_factory=dict, repr=False, compare=False)

    @classmethod
    def build(cls, bounds: F64, sizes: tuple[int, ...]) -> Grid:
        """Assemble the global integration matrices (cached: grids are reused across solves)."""
        return _grid(tuple(float(b) for b in bounds), tuple(sizes))

    def uniform_output(self, m: int) -> tuple[F64, F64]:
        """Uniform arc lengths (m,) from 0 to L and their :meth:`cumulative_at` matrix (cached)."""
        if m not in self._memo:
            s_out = _uniform(float(self.bounds[-1]), m)
            if len(self.sizes) == 1:  # one piece: the reference's, scaled
                cum = 0.5 * float(self.bounds[1] - self.bounds[0]) * _uniform_reference(
                    self.sizes[0], m)
            else:
                cum = self.cumulative_at(s_out)
            for arr in (s_out, cum):
                arr.setflags(write=False)
            self._memo[m] = (s_out, cum)
        return self._memo[m]

    @classmethod
    def _assemble(cls, bounds: F64, sizes: tuple[int, ...]) -> Grid:
        if len(sizes) == 1:  # one piece: the reference scaled (a few operations)
            t, at_nodes, weights = _reference(sizes[0])
            h = 0.5 * float(bounds[1] - bounds[0])
            s = (t + 1.0) * h + float(bounds[0])
            C = h * at_nodes
            w = h * weights
            R = w - C  # ∫_s^L = ∫_0^L − ∫_0^s, row by row
            piece = np.zeros(sizes[0], dtype=np.int64)
            for arr in (s, C, R, w, piece):
                arr.setflags(write=False)
            return cls(bounds, sizes, s, C, R, w, piece)
        total = sum(sizes)
        C = np.zeros((total, total))
        s = np.empty(total)
        piece = np.empty(total, dtype=np.int64)
        w = np.empty(total)
        start = 0
        for k, n in enumerate(sizes):
            t, at_nodes, weights = _reference(n)
            h = 0.5 * (bounds[k + 1] - bounds[k])
            sl = slice(start, start + n)
            s[sl] = bounds[k] + h * (t + 1.0)
            piece[sl] = k
            C[sl, sl] = h * at_nodes
            w[sl] = h * weights
            C[start + n:, sl] = w[sl]  # later pieces see the whole of this one
            start += n
        R = w[None, :] - C
        for arr in (s, C, R, w, piece):
            arr.setflags(write=False)
        return cls(bounds, sizes, s, C, R, w, piece)

    def cumulative_at(self, s_query: F64) -> F64:
        """Matrix (q, N): ∫_0^{s_query} of the piecewise interpolant of nodal values."""
        out = np.zeros((s_query.size, self.s.size))
        which = np.clip(np.searchsorted(self.bounds, s_query, side="right") - 1,
                        0, len(self.sizes) - 1)
        start = 0
        for k, n in enumerate(self.sizes):
            cols = slice(start, start + n)
            out[which > k, cols] = self.w[cols]
            rows = np.nonzero(which == k)[0]
            if rows.size:
                b0, b1 = self.bounds[k], self.bounds[k + 1]
                h = 0.5 * (b1 - b0)
                out[rows, cols] = h * _cumulative(n, (s_query[rows] - b0) / h - 1.0)
            start += n
        return out


def _uniform(length: float, m: int) -> F64:
    """``m`` uniform arc lengths from 0 to ``length`` (m), shape (m,): ``numpy.linspace(0,
    length, m)`` to the last bit (the same arithmetic), without its checks and conversions (a
    first bend in a fresh process pays those ~15 µs)."""
    out = np.arange(m, dtype=np.float64)
    out *= length / (m - 1)
    out[-1] = length
    return out


@lru_cache(maxsize=128)
def _grid(bounds: tuple[float, ...], sizes: tuple[int, ...]) -> Grid:
    return Grid._assemble(np.array(bounds), sizes)


@dataclass(frozen=True)
class Problem:
    """A static load case on a collocation grid (all SI)."""

    grid: Grid
    ei: F64  # (N,) bending stiffness at the nodes, N·m²
    influence: F64  # (N, N) C diag(1/EI) R: nodal angles (rad) per moment density g (N)
    force: F64  # (2,) dead point force (F_x, F_z), N
    loaded: F64  # (N,) 1 where s < a (the point force is carried across the section)
    #: (cos θ, z) at the nodes, shape (b, N) each -> drag per length along the normal, N/m
    drag: Callable[[F64, F64], F64] | None = None
    #: (2, N) μ(s) (B_x, B_z) at the nodes, N: a uniform field's couple per length μ t × B, whose
    #: y-component μ (B_x cos θ − B_z sin θ) adds to g (no force: it is not in N)
    couple: F64 | None = None
    #: (N, N) ``P diag(loaded)``, rad per N: the influence of the point force
    #: alone, precomputed per grid (:func:`point_influence`); None: formed when first needed
    point: F64 | None = None

    @property
    def point_only(self) -> bool:
        """Whether the dead point force is the only load (no drag, no couple): the fast path."""
        return self.drag is None and self.couple is None

    def point_matrix(self) -> F64:
        """``P diag(loaded)`` (N, N), rad per N (:attr:`point`, formed on first use if not
        given)."""
        if self.point is None:
            object.__setattr__(self, "point", point_influence(self.influence, self.loaded))
        assert self.point is not None  # for mypy: set above
        return self.point

    def moment_density(self, theta: F64, scale: float = 1.0) -> F64:
        """g = cos θ N_x − sin θ N_z at the nodes, N, same shape as ``theta`` ((N,) or (b, N));
        ``scale`` multiplies the point force (the drag is that of the problem's flow)."""
        c, s = np.cos(theta), np.sin(theta)
        fx, fz = (scale * self.force).tolist()
        g = (fx * c - fz * s) * self.loaded
        if self.drag is not None:
            q = self.drag(c, c @ self.grid.C.T)
            g = g + c * ((q * c) @ self.grid.R.T) + s * ((q * s) @ self.grid.R.T)
        if self.couple is not None:
            g = g + self.couple[0] * c - self.couple[1] * s
        return np.asarray(g, dtype=np.float64)

    def residual(self, theta: F64, scale: float) -> F64:
        """θ − C[(R g)/EI] for nodal angles (N,) or a batch (b, N)."""
        return np.asarray(theta - self.moment_density(theta, scale) @ self.influence.T,
                          dtype=np.float64)

    def curvature(self, theta: F64, scale: float = 1.0) -> F64:
        """Curvature θ' = M / EI at the nodes, 1/m, same shape as ``theta``."""
        return np.asarray((self.moment_density(theta, scale) @ self.grid.R.T) / self.ei,
                          dtype=np.float64)

    def linear(self, scale: float) -> F64:
        """The small-deflection (Euler–Bernoulli) angles, rad (N,): the load of the straight rod
        integrated once, ``C[(R g(0))/EI]``."""
        return np.asarray(self.influence @ self.moment_density(np.zeros(self.ei.size), scale),
                          dtype=np.float64)

    def newton_step(self, theta: F64, scale: float, tol: float) -> tuple[float, F64 | None]:
        """Largest |residual| at ``theta`` (N,) and the Newton step (N,), rad; the step is None
        once the residual is below ``tol`` or not finite, or if the Jacobian is singular.

        Point load: analytic Jacobian ``I − P diag(g'(θ))`` (``P`` the influence matrix; O(N²)
        per step); with drag (shape-dependent): batched central differences. (:func:`newton`
        solves a point force alone by its fused loop instead; this stays its reference.)
        """
        r = self.residual(theta, scale)
        err = float(np.abs(r).max())
        if not tol <= err < math.inf:  # converged, or not finite
            return err, None
        n = theta.size
        if self.drag is None:  # −g'(θ) = F_x sin θ + F_z cos θ below the load
            fx, fz = (scale * self.force).tolist()
            jac = _identity(n) + self.influence * (
                (fx * np.sin(theta) + fz * np.cos(theta)) * self.loaded)
            if self.couple is not None:  # and μ (B_x sin θ + B_z cos θ) of a field's couple
                jac = jac + self.influence * (self.couple[0] * np.sin(theta)
                                              + self.couple[1] * np.cos(theta))
        else:
            h = 1e-7
            res = self.residual(theta + h * np.concatenate([_identity(n), -_identity(n)]), scale)
            jac = (res[:n] - res[n:]).T / (2.0 * h)
        step = dense_solve(jac, r)
        return err, (None if step is None else -step)


def point_influence(influence: F64, loaded: F64) -> F64:
    """``P diag(loaded)`` (N, N), rad per N, read-only: the influence of a point force on the
    nodes it loads."""
    out = influence * loaded
    out.setflags(write=False)
    return out


def dense_solve(matrix: F64, rhs: F64) -> F64 | None:
    """``matrix⁻¹ rhs`` (N,) by LAPACK's ``gesv`` through :func:`numpy.linalg.solve` (NumPy's own
    OpenBLAS: no SciPy import on a bend's path, ``scipy.linalg`` costing ~0.1 s on a first call),
    or None if ``matrix`` (N, N) is singular or the solution not finite."""
    try:
        out = cast(F64, np.linalg.solve(matrix, rhs))
    except np.linalg.LinAlgError:  # singular
        return None
    return out if math.isfinite(float(out @ out)) else None


@lru_cache(maxsize=8)
def _identity(n: int) -> F64:
    eye = np.eye(n)
    eye.setflags(write=False)
    return eye


@dataclass(frozen=True)
class Solution:
    """Converged nodal angles and Newton statistics."""

    theta: F64
    residual: float
    iterations: int


class Steppable(Protocol):
    """What :func:`newton` and :func:`solve` need of a load case: a planar :class:`Problem`, or
    the 3-D rod's (:mod:`magcilia.mechanics.rod`), on flat arrays of unknowns."""

    def residual(self, theta: F64, scale: float) -> F64: ...

    def newton_step(self, theta: F64, scale: float, tol: float) -> tuple[float, F64 | None]: ...


def newton(problem: Steppable, scale: float, guess: F64, tol: float = 1e-12,
           max_iter: int = 40) -> Solution | None:
    """Newton's method at one load factor; None if it does not converge.

    A planar :class:`Problem` with a point force alone (:attr:`Problem.point_only`) is solved by
    :func:`_newton_point`, the same iteration fused; every other load case by its
    :meth:`~Steppable.newton_step` (the reference the fused loop is tested against)."""
    if isinstance(problem, Problem) and problem.point_only:
        return _newton_point(problem, scale, guess, tol, max_iter)
    theta = guess
    prev = math.inf
    worse = 0
    for it in range(1, max_iter + 1):
        err, step = problem.newton_step(theta, scale, tol)
        if err < tol:
            return Solution(theta, err, it - 1)
        worse = worse + 1 if err > prev else 0
        if step is None or worse >= 3:  # diverging, singular or not finite
            return None
        prev = err
        size = float(np.abs(step).max())
        if size > 1.0:  # damp steps of more than a radian
            step *= 1.0 / size
        theta = theta + step
        if size < 1e-14:
            err = float(np.max(np.abs(problem.residual(theta, scale))))
            return Solution(theta, err, it) if err < 1e3 * tol else None
    return None


#: largest residual (rad) at which :func:`_newton_point` reuses the last full step's Jacobian (a
#: chord step, whose error is about the last step's size times this residual: below Newton's
#: tolerance here; the step after it is a full one again). 1e-6 cost a fifth step on some pushing
#: loads that Newton converges in four; 1e-8 none (tests/mechanics/test_newton_point.py)
CHORD_RESIDUAL = 1e-8


def _newton_point(problem: Problem, scale: float, guess: F64, tol: float,
                  max_iter: int) -> Solution | None:
    """:func:`newton` of a point force alone: :meth:`Problem.newton_step`'s iteration (steps
    damped to a radian, given up after three rising residuals, a singular Jacobian or a
    non-finite residual) in as few array operations as it takes (a bend's time is mostly these
    steps). The residual is negated in place into the right-hand side; the Jacobian
    ``I + P diag(loaded (F_x sin θ + F_z cos θ))`` is built into one buffer and solved by
    NumPy's ``gesv`` (:func:`dense_solve`'s, called directly: a singular Jacobian, or a step
    that is not finite, ends the loop; the error state is set once for the whole loop); below
    :data:`CHORD_RESIDUAL` a step after a full one reuses its Jacobian (no new one formed). The
    largest |entry| is taken through one scratch vector (a NaN propagates into it)."""
    point = problem.point_matrix()
    fx, fz = (scale * problem.force).tolist()
    if fz == 0.0:  # a horizontal force (the common case): F_x in the matrix, once
        point = point * fx
    with np.errstate(invalid="ignore"):  # a singular Jacobian: a NaN step, returned as None
        return _point_loop(problem, scale, point, fx, fz, guess, tol, max_iter)


def _point_loop(problem: Problem, scale: float, point: F64, fx: float, fz: float, guess: F64,
                tol: float, max_iter: int) -> Solution | None:
    """:func:`_newton_point`'s iteration (``point``: P diag(loaded), times F_x when F_z = 0)."""
    jac = np.empty_like(point)  # each full step's Jacobian
    diagonal = jac.reshape(-1, order="A")[:: guess.size + 1]  # a view of its diagonal
    scratch = np.empty_like(guess)  # |residual|, |step|
    theta = guess
    prev = math.inf
    worse = 0
    reuse = False  # whether ``jac`` holds the last step's Jacobian (a full step's)
    for it in range(1, max_iter + 1):
        cos = np.cos(theta)
        if fz == 0.0:
            sin = None
            minus = point @ cos
        else:
            sin = np.sin(theta)
            minus = point @ (fx * cos - fz * sin)
        minus -= theta  # −(θ − P g)
        err = float(np.abs(minus, out=scratch).max())
        if err < tol:
            return Solution(theta, err, it - 1)
        worse = worse + 1 if err > prev else 0
        if not err < math.inf or worse >= 3:  # not finite (NaN included), or diverging
            return None
        prev = err
        if reuse and err < CHORD_RESIDUAL:
            reuse = False
        else:
            # I + P diag(loaded) diag(F_x sin θ + F_z cos θ), into the buffer
            np.multiply(point, np.sin(theta) if sin is None else fx * sin + fz * cos, out=jac)
            diagonal += 1.0
            reuse = True
        try:  # dense_solve's gesv; a step that is not finite is caught below
            step = cast(F64, np.linalg.solve(jac, minus))
        except np.linalg.LinAlgError:  # singular
            return None
        size = float(np.abs(step, out=scratch).max())
        if not size < math.inf:  # not finite (NaN included)
            return None
        if not size <= 1.0:  # damp steps of more than a radian
            step *= 1.0 / size
        theta = theta + step
        if size < 1e-14:
            err = float(np.max(np.abs(problem.residual(theta, scale))))
            return Solution(theta, err, it) if err < 1e3 * tol else None
    return None


class ContinuationError(RuntimeError):
    """Newton failed even with small load steps; ``reached`` is the largest converged factor."""

    def __init__(self, reached: float) -> None:
        super().__init__(f"converged up to load factor {reached:.6g}")
        self.reached = reached


def solve(problem_at: Callable[[float], tuple[Steppable, float]], start: float, target: float,
          theta: F64, slope: F64 | None = None, min_step: float = 1e-3,
          tol: float = 1e-12) -> tuple[Solution, int]:
    """Continue the solution from load parameter ``start`` (solved: ``theta``) to ``target``.

    ``problem_at(p)`` returns the problem and load factor at parameter p (the same problem object
    can serve several p). Each Newton solve starts from the secant prediction
    ``theta + (p_trial − p) · slope``; ``slope`` (rad per unit of p, shape (N,)) is dθ/dp at
    ``start`` (default 0: start from ``theta``) and then the secant of the last two solutions;
    where a predicted start fails, the same step is retried from ``theta``. Returns the solution
    at ``target`` and the number of solves (a solution's iterations are those of all of them).
    Raises :class:`ContinuationError` with the last converged parameter on failure. ``tol`` is
    Newton's residual tolerance (rad).
    """
    p = start
    span = target - start
    step = 1.0  # fraction of the remaining span
    solves = 0
    total_iter = 0
    while True:
        trial = target if step >= 1.0 else p + step * (target - p)
        prob, scale = problem_at(trial)
        guess = theta if slope is None else theta + (trial - p) * slope
        sol = newton(prob, scale, guess) if tol == 1e-12 else newton(prob, scale, guess, tol)
        solves += 1
        if sol is None and slope is not None:  # the prediction misled Newton: retry from theta
            slope = None
            continue
        if sol is not None:
            total_iter += sol.iterations
            if trial != p:
                slope = (sol.theta - theta) / (trial - p)
            p, theta = trial, sol.theta
            if trial == target:
                return Solution(sol.theta, sol.residual, total_iter), solves
            step = min(1.0, 2.0 * step)
        else:
            step *= 0.5
            if step * abs(target - p) < min_step * abs(span):
                raise ContinuationError(p)
