"""Bending modes of the cilium clamped at its base: natural frequencies, shapes, modal mass,
stiffness and damping, in vacuum or in a fluid, with or without its own weight (:func:`modes`).

The body is an Euler–Bernoulli beam of revolution on its real radius profile (frustum, finite
tip, or a measured profile; :mod:`magcilia.mechanics.beam`: Hermite cubic finite elements,
every matrix integrated exactly), Young's modulus ``setup.youngs_modulus`` and the composite's
density ``setup.material.density`` (cobalt and polymer by volume fraction).

* **Gravity** (``gravity=True``): the upright hair is a column under its own weight, less its
  buoyancy in a fluid. The axial compression ``N(s) = (ρ − ρ_f) g V_above(s)`` adds the
  geometric stiffness ``−∫ N w'² ds``, which softens every mode (the hair buckles under its own
  weight when the first eigenvalue reaches 0: an error says so).
* **Fluid** (``fluid=``): each section carries Sader's added mass and damping of an oscillating
  circular cylinder at its own radius (:mod:`magcilia.mechanics.hydrodynamic`), evaluated at the
  mode's own frequency: the frequency is found self-consistently (``ω² = λ_n(M + M_a(ω))``,
  secant iteration in log ω on the vacuum modes as a Ritz basis). The damping is reported as
  modal (the mode's projection of the damping matrix at its frequency, ``c_n = φᵀ C(ω_n) φ``;
  the modes' coupling through a non-proportional damping is neglected).
* **Material loss** (``loss_factor=η``): a hysteretic loss adds ``η k_n / ω_n`` to each mode's
  damping (ζ = η/2 in vacuum).

Every modal figure is referred to the tip: each shape is 1 at the tip, so a tip force F drives
each mode's coordinate q_n (its tip displacement) through ``m_n q̈ + c_n q̇ + k_n q = F``, and the
tip moves by ``Σ q_n``.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Any

import numpy as np
from numpy.typing import NDArray

from magcilia import _validate as v
from magcilia._display import Display, Item, Table, number, si
from magcilia.device.setup import Setup
from magcilia.mechanics.beam import Mesh, interpolate, mesh, weight_above
from magcilia.mechanics.drag import FLUIDS, Fluid
from magcilia.mechanics.hydrodynamic import added_mass_damping

F64 = NDArray[np.float64]

#: standard acceleration of gravity, m/s² (3rd CGPM 1901; the value of g_n in the SI brochure)
STANDARD_GRAVITY = 9.80665
#: default number of beam elements: the first three frequencies of the force-sensor cilium within
#: 8e-8, 1.9e-6 and 1.2e-5 of an independent shooting solution (docs/dynamics.md: the error falls
#: as E⁻⁴)
ELEMENTS = 24
#: most beam elements a caller may ask for: beyond ~100 the eigenproblem's round-off (its
#: condition grows as E⁴) outgrows the discretisation error (1.7e-6 at 200, 6e-4 at 1000)
MAX_ELEMENTS = 200
#: most modes a caller may ask for (higher ones leave the slender-beam theory: the wavelength
#: approaches the radius)
MAX_COUNT = 20
#: shape samples per beam element in :attr:`Modes.arc` (the nodes and the elements' cubics
#: between them)
SAMPLES_PER_ELEMENT = 4
#: vacuum modes kept as the Ritz basis of the fluid-loaded problem (besides the ``count`` asked)
_EXTRA_BASIS = 12


@dataclass(frozen=True, repr=False)
class Modes(Display):
    """The cilium's bending modes (from :func:`modes`; SI units, arrays read-only).

    Attributes
    ----------
    frequencies : ndarray, shape (count,)
        Undamped natural frequencies f_n, Hz, ascending (in a fluid: with its added mass at the
        mode's own frequency).
    damping_ratios : ndarray, shape (count,)
        ζ_n = c_n / (2 m_n ω_n), dimensionless (the fluid's viscous damping and any material
        loss; 0 in vacuum without loss); ζ ≥ 1 is overdamped.
    overdamped : ndarray of bool, shape (count,)
        ζ_n ≥ 1: the mode does not oscillate.
    damped_frequencies : ndarray, shape (count,)
        f_n √(1 − ζ_n²), Hz; 0 where overdamped (never NaN).
    arc : ndarray, shape (nodes,)
        Arc length of the shape samples, m: 0 at the base … L at the tip, uniform (the mesh's
        nodes and :data:`SAMPLES_PER_ELEMENT` − 1 points of each element's cubic between).
    shapes : ndarray, shape (count, nodes)
        Lateral displacement of each mode at ``arc``, normalised to 1 at the tip.
    modal_masses : ndarray, shape (count,)
        m_n = φᵀ (M + M_a) φ, kg, referred to the tip displacement (incl. the added mass).
    modal_stiffnesses : ndarray, shape (count,)
        k_n = φᵀ K φ = ω_n² m_n, N/m, referred to the tip displacement (incl. gravity's).
    modal_dampings : ndarray, shape (count,)
        c_n = φᵀ C(ω_n) φ (+ η k_n / ω_n), N·s/m, referred to the tip displacement.
    fluid : Fluid or None
        The surrounding fluid (None: vacuum).
    gravity : bool
        Whether the hair's own weight (upright, less buoyancy) was included.
    youngs_modulus : float
        E used, Pa.
    density : float
        The composite's density used, kg/m³.
    loss_factor : float
        Material loss factor η, dimensionless.
    elements : int
        Beam elements of the mesh.
    modulus_sigma : float
        Relative 1 σ of E (``setup.modulus``: the assumed modulus's ±27 %, a measured one's,
        0 if exact): in vacuum every frequency scales as √E, so it carries half of it.
    modulus_source : str
        Where E comes from: "assumed", "measured" or "exact".
    """

    frequencies: F64
    damping_ratios: F64
    overdamped: NDArray[np.bool_]
    damped_frequencies: F64
    arc: F64
    shapes: F64
    modal_masses: F64
    modal_stiffnesses: F64
    modal_dampings: F64
    fluid: Fluid | None
    gravity: bool
    youngs_modulus: float = 0.0
    density: float = 0.0
    loss_factor: float = 0.0
    elements: int = ELEMENTS
    modulus_sigma: float = 0.0
    modulus_source: str = "exact"

    def __post_init__(self) -> None:
        for name in ("frequencies", "damping_ratios", "overdamped", "damped_frequencies", "arc",
                     "shapes", "modal_masses", "modal_stiffnesses", "modal_dampings"):
            arr = np.array(getattr(self, name))
            arr.setflags(write=False)
            object.__setattr__(self, name, arr)

    @property
    def count(self) -> int:
        """Number of modes."""
        return int(self.frequencies.size)

    @property
    def angular_frequencies(self) -> F64:
        """ω_n = 2π f_n, rad/s, shape (count,)."""
        return 2.0 * math.pi * self.frequencies

    @property
    def quality_factors(self) -> F64:
        """Q_n = 1 / (2 ζ_n), dimensionless, shape (count,) (inf without damping)."""
        with np.errstate(divide="ignore"):
            return np.asarray(0.5 / self.damping_ratios, dtype=np.float64)

    @property
    def static_compliance(self) -> float:
        """Σ 1/k_n, m/N: the tip compliance of the modes kept (the exact static tip compliance
        as the count grows; the first mode alone carries ~97 % of it for a cantilever)."""
        return float(np.sum(1.0 / self.modal_stiffnesses))

    def table(self) -> list[dict[str, Any]]:
        """One row per mode (SI)."""
        return [{"mode": n + 1, "frequency_Hz": float(self.frequencies[n]),
                 "damping_ratio": float(self.damping_ratios[n]),
                 "overdamped": bool(self.overdamped[n]),
                 "damped_frequency_Hz": float(self.damped_frequencies[n]),
                 "modal_mass_kg": float(self.modal_masses[n]),
                 "modal_stiffness_N_per_m": float(self.modal_stiffnesses[n]),
                 "modal_damping_Ns_per_m": float(self.modal_dampings[n])}
                for n in range(self.count)]

    def to_dict(self) -> dict[str, Any]:
        """JSON-ready content (SI): the medium, the inputs used, one row per mode and the
        shapes."""
        fluid = None if self.fluid is None else {
            "name": self.fluid.name, "density_kg_per_m3": self.fluid.density,
            "viscosity_Pa_s": self.fluid.viscosity}
        return {"fluid": fluid, "gravity": self.gravity,
                "youngs_modulus_Pa": self.youngs_modulus, "density_kg_per_m3": self.density,
                "loss_factor": self.loss_factor, "elements": self.elements,
                "modulus_sigma_relative": self.modulus_sigma,
                "modulus_source": self.modulus_source,
                "modes": self.table(), "arc_m": self.arc.tolist(),
                "shapes": self.shapes.tolist()}

    def report(self) -> str:
        """A few lines: the medium and one line per mode (Hz, ζ, modal mass and stiffness)."""
        medium = "vacuum" if self.fluid is None else self.fluid.name
        head = (f"Bending modes in {medium}{' with gravity' if self.gravity else ''} "
                f"(E = {si(self.youngs_modulus, 'Pa')}, ρ = {number(self.density, 4)} kg/m³, "
                f"{self.elements} elements):")
        lines = [head]
        for n in range(self.count):
            state = ("overdamped" if self.overdamped[n]
                     else f"damped {number(self.damped_frequencies[n], 4)} Hz")
            lines.append(f"  mode {n + 1}: {number(self.frequencies[n], 4)} Hz, "
                         f"ζ = {number(self.damping_ratios[n], 3)} ({state}), "
                         f"m = {number(self.modal_masses[n], 3)} kg, "
                         f"k = {number(self.modal_stiffnesses[n], 3)} N/m")
        if self.modulus_sigma:
            article = "an" if self.modulus_source == "assumed" else "a"
            lines.append(f"  E from {article} {self.modulus_source} modulus "
                         f"±{100 * self.modulus_sigma:.2g} %: every frequency "
                         f"±{50 * self.modulus_sigma:.2g} % (f ∝ √E in vacuum)")
        return "\n".join(lines)

    def _display_items(self) -> list[Item]:
        hz = ", ".join(number(f, 4) for f in self.frequencies)
        return [("frequencies", f"{hz} Hz"),
                ("damping_ratios", ", ".join(number(z, 3) for z in self.damping_ratios)),
                ("fluid", "vacuum" if self.fluid is None else self.fluid.name),
                ("gravity", str(self.gravity))]

    def _display_table(self) -> Table | None:
        header = ["mode", "f (Hz)", "ζ", "f_d (Hz)", "m (kg)", "k (N/m)"]
        rows = [[str(n + 1), number(self.frequencies[n], 4), number(self.damping_ratios[n], 3),
                 number(self.damped_frequencies[n], 4), number(self.modal_masses[n], 3),
                 number(self.modal_stiffnesses[n], 3)] for n in range(self.count)]
        return header, rows


def as_fluid(fluid: object) -> Fluid | None:
    """``fluid`` as a Fluid: None (vacuum), a Fluid, or a name in FLUIDS (checked)."""
    if fluid is None or isinstance(fluid, Fluid):
        return fluid
    if isinstance(fluid, str) and fluid in FLUIDS:
        return FLUIDS[fluid]
    raise v.fail("fluid", fluid, "None (vacuum), a Fluid or one of "
                 + ", ".join(repr(k) for k in sorted(FLUIDS)))


def modes(setup: Setup, fluid: Fluid | str | None = None, gravity: bool = False, *,
          count: int = 3, elements: int | None = None, loss_factor: float = 0.0) -> Modes:
    """Bending modes of the setup's cilium, clamped at its base (the module notes).

    Parameters
    ----------
    setup : Setup
        The cilium's body (``setup.cilium``: frustum or measured profile), its Young's modulus
        (``setup.youngs_modulus``, Pa) and material (the composite's density,
        ``setup.material.density``, kg/m³).
    fluid : Fluid, str or None
        The surrounding fluid (a :class:`Fluid` or a name in ``FLUIDS``: "air", "water",
        "glycerol"); None: vacuum.
    gravity : bool
        Include the upright hair's own weight (less buoyancy) as an axial load (softening).
    count : int
        Number of modes, 1 … :data:`MAX_COUNT` (default 3).
    elements : int or None
        Hermite beam elements (default :data:`ELEMENTS`), 2 … :data:`MAX_ELEMENTS`.
    loss_factor : float
        Material loss factor η ≥ 0 (hysteretic damping, ζ = η/2 in vacuum); default 0.

    Returns
    -------
    Modes
        Frequencies (Hz), damping ratios, shapes and modal figures referred to the tip.

    Examples
    --------
    >>> import magcilia as mc
    >>> m = mc.modes(mc.Setup.paper(tip_radius=5e-5))
    >>> [round(float(f)) for f in m.frequencies]
    [152, 501, 1138]
    """
    if not isinstance(setup, Setup):
        raise v.fail("setup", type(setup).__name__, "a Setup")
    medium = as_fluid(fluid)
    if not isinstance(gravity, bool | np.bool_):
        raise v.fail("gravity", gravity, "True or False")
    count = v.integer("count", count, 1)
    if count > MAX_COUNT:
        raise v.fail("count", count, f"at most {MAX_COUNT} modes (MAX_COUNT)")
    n_el = ELEMENTS if elements is None else v.integer("elements", elements, 2)
    if n_el > MAX_ELEMENTS:
        raise v.fail("elements", n_el, f"at most {MAX_ELEMENTS} beam elements (MAX_ELEMENTS)")
    eta = v.non_negative("loss_factor", loss_factor, "", "loss factor")
    return modal_model(setup, medium, bool(gravity), count, n_el, eta).modes


@dataclass(frozen=True)
class ModalModel:
    """The modes and what a response needs of them (internal to mechanics: the frequency
    response, :mod:`magcilia.mechanics.response`).

    Attributes
    ----------
    modes : Modes
        The public result.
    grid : Mesh
        The beam mesh and its quadrature.
    vectors : ndarray, shape (count, dofs)
        The mode shapes as free-DOF vectors (deflection and slope at each node but the base),
        normalised to 1 at the tip.
    structural_masses : ndarray, shape (count,)
        φᵀ M φ of the body alone (no added mass), kg.
    """

    modes: Modes
    grid: Mesh
    vectors: F64
    structural_masses: F64

    def slopes(self, s: F64) -> F64:
        """The modes' slopes dφ/ds at arc lengths ``s`` (m, shape (m,)), 1/m, shape
        (count, m) (Hermite interpolation on the mesh)."""
        return interpolate(self.grid, self.vectors, s, "slopes")


def modal_model(setup: Setup, medium: Fluid | None, gravity: bool, count: int, n_el: int,
                eta: float) -> ModalModel:
    """:func:`modes` on checked arguments, with the internals a response needs."""
    n_el = max(n_el, (count + 1) // 2 + 1)  # at least as many free DOFs as modes
    modulus, density = setup.youngs_modulus, setup.material.density
    grid = mesh(setup.cilium, n_el)
    r2 = grid.radius ** 2
    stiff = grid.assemble(0.25 * math.pi * modulus * r2 * r2, "stiffness")
    if gravity:
        weight = density - (0.0 if medium is None else medium.density)
        axial = weight * STANDARD_GRAVITY * weight_above(setup.cilium, grid.s)
        stiff = stiff - grid.assemble(axial, "geometric")
    mass = grid.assemble(density * math.pi * r2, "mass")
    basis = min(grid.dofs, count + _EXTRA_BASIS)
    import scipy.linalg
    lam, vec = scipy.linalg.eigh(stiff, mass, subset_by_index=[0, basis - 1])
    if lam[0] <= 0.0:
        raise v.fail("gravity", True, "False for this hair: it buckles under its own weight "
                     f"(E = {modulus:.4g} Pa is too soft for its length; "
                     "a stiffer or shorter hair stands)")
    if medium is None:
        omega = np.sqrt(lam[:count])
        shapes = vec[:, :count].T
        dampings = np.zeros(count)
    else:
        omega, shapes, dampings = _fluid_modes(grid, lam, vec, medium, count)
    tip = shapes[:, -2].copy()
    shapes = shapes / tip[:, None]
    masses = np.einsum("ki,ij,kj->k", shapes, mass, shapes)
    stiffnesses = np.einsum("ki,ij,kj->k", shapes, stiff, shapes)
    if medium is not None:
        masses = stiffnesses / omega**2  # with the added mass at each mode's frequency
        dampings = dampings / tip**2
    dampings = dampings + eta * stiffnesses / omega
    zeta = dampings / (2.0 * masses * omega)
    over = zeta >= 1.0
    freq = omega / (2.0 * math.pi)
    damped = np.where(over, 0.0, freq * np.sqrt(np.clip(1.0 - zeta**2, 0.0, None)))
    arc = np.linspace(0.0, grid.nodes[-1], SAMPLES_PER_ELEMENT * n_el + 1)
    sampled = interpolate(grid, shapes, arc, "values")  # the elements' own cubics
    result = Modes(freq, zeta, over, damped, arc, sampled, masses, stiffnesses,
                   dampings, medium, bool(gravity), modulus, density, eta, n_el,
                   setup.modulus.relative, setup.modulus.source)
    return ModalModel(result, grid, shapes, np.einsum("ki,ij,kj->k", shapes, mass, shapes))


def _fluid_modes(grid: Mesh, lam: F64, vec: F64, fluid: Fluid,
                 count: int) -> tuple[F64, F64, F64]:
    """Fluid-loaded modes on the vacuum modes ``vec`` (M-orthonormal, eigenvalues ``lam``) as a
    Ritz basis: for each mode, the ω with ``ω² = λ_n(K, M + M_a(ω))`` (secant in log ω), its
    shape (free DOFs, unnormalised) and ``φᵀ C(ω) φ`` (N·s/m for that normalisation)."""
    import scipy.linalg
    from scipy.optimize import brentq
    at_q = grid.at_points(vec.T)  # (basis, q)
    weights = grid.weight

    def reduced(omega: float) -> tuple[F64, F64, F64]:
        added, damping = added_mass_damping(fluid.density, fluid.viscosity, grid.radius, omega)
        m_r = np.eye(lam.size) + (at_q * (weights * added)) @ at_q.T
        c_r = (at_q * (weights * damping)) @ at_q.T
        w2, x = scipy.linalg.eigh(np.diag(lam), m_r)
        return w2, x, c_r

    omegas, shapes, dampings = np.empty(count), np.empty((count, vec.shape[0])), np.empty(count)
    for n in range(count):
        # h(x) = x − ½ ln λ_n(eˣ) rises with slope ½ … 1 (the added mass falls at most as 1/ω)
        # and is ≥ 0 at the vacuum frequency: one root below it, found by the secant method
        def h(x: float, n: int = n) -> float:
            return x - 0.5 * math.log(reduced(math.exp(x))[0][n])

        top = 0.5 * math.log(lam[n])
        x0, h0 = top, h(top)
        x1 = x0 - h0
        for _ in range(60):
            h1 = h(x1)
            if abs(h1) < 1e-12 or h1 == h0:
                break
            x0, x1, h0 = x1, x1 - h1 * (x1 - x0) / (h1 - h0), h1
        if not abs(h1) < 1e-9:  # a safe fallback: bisection-like on the bracket
            x1 = float(brentq(h, top - 60.0, top, xtol=1e-13))
        omega = math.exp(x1)
        w2, x, c_r = reduced(omega)
        omegas[n] = math.sqrt(w2[n])
        shapes[n] = vec @ x[:, n]
        dampings[n] = float(x[:, n] @ c_r @ x[:, n])
    return omegas, shapes, dampings
