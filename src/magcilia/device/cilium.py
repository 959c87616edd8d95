"""The cilium's body: a body of revolution (cone, frustum or a measured radius profile) and its
slicing into n equal-length slices.

Arc length ``s`` runs from the base (s = 0) to the tip (s = height). The radius varies linearly
from ``base_radius`` to ``tip_radius``, or piecewise linearly through a measured profile that is
stored normalised (``u = s/height``, ``rho = r/base_radius``), so that ``height`` and
``base_radius`` keep scaling the measured shape (calibration and sensitivity vary them).
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np
from numpy.typing import ArrayLike, NDArray

from magcilia import _validate as v
from magcilia._display import Display, Item, count, scaled
from magcilia.device.parameters import MAX_LENGTH, MIN_LENGTH, PARAMETERS
from magcilia.model import body

#: most points of a measured profile (a profile is a handful to a few hundred measured radii; the
#: slicing's cost grows linearly with the number of knots, the bending's not at all: a profile
#: of many points is resampled onto the solver's grid, :mod:`magcilia.mechanics.sections`)
MAX_PROFILE_POINTS = 10_000


@dataclass(frozen=True, repr=False)
class Cilium(Display):
    """A cilium of revolution: a frustum (a cone when ``tip_radius`` is 0, the paper's case) or
    a measured radius profile (:meth:`from_profile`).

    Parameters
    ----------
    height : float
        Length along the axis (arc length when bent), m.
    base_radius : float
        Radius at the base, m.
    tip_radius : float
        Radius at the tip, m; 0 (default) is a sharp cone. Must not exceed ``base_radius``.
    youngs_modulus : float or None
        Young's modulus, Pa, for mechanics; None means "derive it from the material" (see
        :attr:`magcilia.Setup.youngs_modulus`).
    youngs_modulus_sigma : float or None
        1 σ of a measured or fitted ``youngs_modulus``, Pa; None (or 0) takes the given modulus
        as exact (:attr:`magcilia.Setup.modulus`). Only with ``youngs_modulus``.
    profile : (tuple of float, tuple of float) or None
        A measured shape, normalised: knots ``u`` (0 … 1 along the length, increasing) and radii
        ``rho`` relative to ``base_radius`` (``rho[0]`` = 1), linear in between. With a profile,
        ``tip_radius`` follows from it (``base_radius · rho[-1]``). Build it with
        :meth:`from_profile`.
    """

    height: float
    base_radius: float
    tip_radius: float = 0.0
    youngs_modulus: float | None = None
    profile: tuple[tuple[float, ...], tuple[float, ...]] | None = None
    youngs_modulus_sigma: float | None = None

    def __post_init__(self) -> None:
        for name in ("height", "base_radius"):
            object.__setattr__(self, name, PARAMETERS[name].check(getattr(self, name)))
        if self.profile is not None:
            u, rho = _check_profile(self.profile)
            _check_profile_radii(self.base_radius * rho)
            object.__setattr__(self, "profile", (tuple(u.tolist()), tuple(rho.tolist())))
            object.__setattr__(self, "tip_radius", self.base_radius * float(rho[-1]))
        tip = PARAMETERS["tip_radius"].check(self.tip_radius)
        if tip > self.base_radius and self.profile is None:
            raise v.fail("tip_radius", tip, f"at most base_radius ({self.base_radius:.6g} m)")
        object.__setattr__(self, "tip_radius", tip)
        if self.youngs_modulus is not None:
            modulus = PARAMETERS["youngs_modulus"].check(self.youngs_modulus)
            object.__setattr__(self, "youngs_modulus", modulus)
        if self.youngs_modulus_sigma is not None:
            if self.youngs_modulus is None:
                raise v.fail("youngs_modulus_sigma", self.youngs_modulus_sigma,
                             "left out without a youngs_modulus (the material's modulus "
                             "carries its own uncertainty)")
            sigma = PARAMETERS["youngs_modulus_sigma"].check(self.youngs_modulus_sigma)
            object.__setattr__(self, "youngs_modulus_sigma", sigma)

    @classmethod
    def from_profile(cls, s: ArrayLike, radius: ArrayLike,
                     youngs_modulus: float | None = None,
                     youngs_modulus_sigma: float | None = None) -> Cilium:
        """A cilium with a measured radius profile, linear between the points.

        Parameters
        ----------
        s : array-like, shape (q,)
            Arc lengths from the base, m, increasing from 0; the last one is the height.
        radius : array-like, shape (q,)
            Radii at ``s``, m (≥ 0; the base radius ``radius[0]`` must be positive).
        youngs_modulus : float, optional
            Pa (None: from the material).
        youngs_modulus_sigma : float, optional
            Its 1 σ, Pa (None: exact).
        """
        s_arr = v.finite_array("profile s", s, ndim=1, unit="m")
        r_arr = v.finite_array("profile radius", radius, ndim=1, unit="m")
        _check_profile_size(s_arr.size)
        if s_arr.size < 2 or s_arr.size != r_arr.size:
            raise v.fail("profile", f"{s_arr.size} arc lengths and {r_arr.size} radii",
                         "at least two (s, radius) pairs of equal count")
        if s_arr[0] != 0.0 or np.any(np.diff(s_arr) <= 0.0):
            raise v.fail("profile s", _head(s_arr), "arc lengths increasing from 0 (m)")
        height = float(s_arr[-1])
        base = v.positive("profile radius at the base", float(r_arr[0]))
        if np.any(r_arr[:-1] <= 0.0) or r_arr[-1] < 0.0:
            raise v.fail("profile radius", _head(r_arr),
                         "positive radii in m (only the tip may be 0)")
        _check_profile_radii(r_arr)
        return cls(height=height, base_radius=base, youngs_modulus=youngs_modulus,
                   profile=(tuple((s_arr / height).tolist()), tuple((r_arr / base).tolist())),
                   youngs_modulus_sigma=youngs_modulus_sigma)

    @property
    def shape(self) -> tuple[NDArray[np.float64], NDArray[np.float64]]:
        """Normalised knots (s / height) and radii (r / base_radius), shapes (q,): a frustum is
        the two-knot shape ``(0, 1), (1, taper)``."""
        if self.profile is None:
            return body.frustum_shape(self.taper)
        return np.asarray(self.profile[0]), np.asarray(self.profile[1])

    @property
    def max_radius(self) -> float:
        """Largest radius of the body, m."""
        return self.base_radius * float(self.shape[1].max())

    @property
    def taper(self) -> float:
        """lambda = tip_radius / base_radius (0 for a cone, 1 for a cylinder)."""
        return self.tip_radius / self.base_radius

    @property
    def volume(self) -> float:
        """Volume, m³ (a frustum: pi h/3 (r_b² + r_b r_t + r_t²))."""
        return body.volume(self.height, self.base_radius, *self.shape)

    def radius(self, s: ArrayLike) -> NDArray[np.float64]:
        """Radius at arc length ``s`` (m, any shape) -> same shape, m."""
        t = np.asarray(s, dtype=np.float64) / self.height
        if self.profile is None:  # a frustum: linear, clamped to the ends as radius_at is
            t = np.minimum(np.maximum(t, 0.0), 1.0)
            out: NDArray[np.float64] = self.base_radius + (self.tip_radius - self.base_radius) * t
            return out
        return self.base_radius * body.radius_at(*self.shape, t)

    def second_moment(self, s: ArrayLike) -> NDArray[np.float64]:
        """Second moment of area of the cross-section, I(s) = pi r(s)⁴ / 4, m⁴."""
        return 0.25 * math.pi * self.radius(s) ** 4

    def slice_edges(self, n: int) -> NDArray[np.float64]:
        """Arc lengths of the n + 1 slice boundaries, m, shape (n + 1,)."""
        return np.linspace(0.0, self.height, n + 1)

    def slice_volumes(self, n: int) -> NDArray[np.float64]:
        """Volumes of the n equal-length slices, m³, shape (n,); they sum to the volume."""
        mean2, _ = body.slice_means(*self.shape, n)
        return math.pi * (self.height / n) * self.base_radius**2 * mean2

    def ring_radii(self, n: int, ring: str = "mean") -> NDArray[np.float64]:
        """Radius of each slice's dipole ring, m, shape (n,) (rules: see
        :func:`magcilia.model.body.slice_rings`)."""
        return self.base_radius * body.slice_rings(*self.shape, n, ring)[0]

    def contains(self, axial: ArrayLike, radial: ArrayLike) -> NDArray[np.bool_]:
        """Whether points given in the body frame (axial coordinate from the base, m; distance
        from the axis, m) lie inside or on the body. Broadcasts."""
        return body.contains(self.height, self.base_radius, *self.shape, axial, radial)

    def _display_items(self) -> list[Item]:
        items = [(n, PARAMETERS[n].text(getattr(self, n)))
                 for n in ("height", "base_radius", "tip_radius")]
        if self.youngs_modulus is not None:
            text = PARAMETERS["youngs_modulus"].text(self.youngs_modulus)
            if self.youngs_modulus_sigma:
                text += f" ± {PARAMETERS['youngs_modulus'].text(self.youngs_modulus_sigma)}"
            items.append(("youngs_modulus", text))
        if self.profile is not None:
            items.append(("profile", count(len(self.profile[0]), "point")))
        return [*items, ("volume", scaled(self.volume, 1e-9, "mm³"))]


def _head(values: NDArray[np.float64], count: int = 8) -> str:
    """The first ``count`` values, for a message about a long profile."""
    shown = ", ".join(f"{x:.6g}" for x in values[:count])
    return f"[{shown}{', …' if values.size > count else ''}] ({values.size} values)"


def _check_profile_size(size: int) -> None:
    if size > MAX_PROFILE_POINTS:
        raise v.fail("profile", f"{size} points",
                     f"at most {MAX_PROFILE_POINTS} points (MAX_PROFILE_POINTS); resample the "
                     "measured shape")


def _check_profile_radii(radii: NDArray[np.float64]) -> None:
    """Radii in m of a profile within the registry's limits (MIN_LENGTH … MAX_LENGTH; the tip may
    be 0)."""
    big = radii > MAX_LENGTH
    small = np.zeros_like(big)
    small[:-1] = radii[:-1] < MIN_LENGTH
    if big.any() or small.any():
        raise v.fail("profile radius", float(radii[np.argmax(big | small)]),
                     f"radii within [{MIN_LENGTH:g}, {MAX_LENGTH:g}] m (only the tip may be 0)")


def _check_profile(profile: object) -> tuple[NDArray[np.float64], NDArray[np.float64]]:
    """Validate a normalised profile (u, rho): u from 0 to 1 increasing, rho ≥ 0, rho[0] = 1."""
    if not isinstance(profile, tuple | list) or len(profile) != 2:
        raise v.fail("profile", type(profile).__name__, "a pair (u, rho) of equal-length sequences")
    u_raw, rho_raw = profile
    u = v.finite_array("profile u", u_raw, ndim=1)
    rho = v.finite_array("profile rho", rho_raw, ndim=1)
    _check_profile_size(max(u.size, rho.size))
    if u.size < 2 or u.size != rho.size:
        raise v.fail("profile", f"{u.size} knots and {rho.size} radii",
                     "at least two knots with one radius each")
    if u[0] != 0.0 or abs(u[-1] - 1.0) > 1e-12 or np.any(np.diff(u) <= 0.0):
        raise v.fail("profile u", _head(u), "knots increasing from 0 to 1 (s / height)")
    if np.any(rho[:-1] <= 0.0) or rho[-1] < 0.0 or abs(rho[0] - 1.0) > 1e-12:
        raise v.fail("profile rho", _head(rho),
                     "radii / base_radius starting at 1, positive (only the tip may be 0)")
    u[-1], rho[0] = 1.0, 1.0
    return u, rho
