"""Physical constants and unit factors (SI), with their sources.

Fundamental constants are CODATA 2022 (Mohr et al., *CODATA Recommended Values of the
Fundamental Physical Constants: 2022*, NIST, 2024), the values :mod:`scipy.constants` holds from
SciPy 1.15 on and magpylib uses through it, so the two agree to the last digit (a test checks it).
They are written here, not imported: ``scipy.constants`` costs most of a second at start-up for
two numbers.
"""

from __future__ import annotations

import math

MU0: float = 1.25663706127e-6
"""Vacuum permeability, T·m/A (CODATA 2022)."""

MU_B: float = 9.2740100657e-24
"""Bohr magneton, A·m² (= J/T) (CODATA 2022)."""

GAUSS: float = 1e-4
"""One gauss in tesla."""

MU0_OVER_4PI: float = MU0 / (4.0 * math.pi)
"""μ0/4π, T·m/A."""

COBALT_DENSITY: float = 8.90e3
"""Density of cobalt, kg/m³ (CRC Handbook of Chemistry and Physics, 97th ed.)."""

COBALT_ATOM_DENSITY: float = 9.09e28
"""Number density of atoms in hcp cobalt, m⁻³ (Kittel, *Introduction to Solid State Physics*,
8th ed., table 1.3 atomic concentrations: 8.97e22 cm⁻³ ≈ ρ N_A / M = 8.90 g/cm³ · 6.022e23 /
58.93 g/mol = 9.09e22 cm⁻³; the paper's n_Co)."""

COBALT_MOMENT_PER_ATOM: float = 1.72
"""Saturation moment per cobalt atom at 0 K, in Bohr magnetons (Kittel, 8th ed., table 11.2)."""

SIS_DENSITY: float = 0.92e3
"""Density of SIS block copolymer (Kraton D1163), kg/m³ (typical datasheet value)."""
