"""The fundamental constants written in magcilia.constants are scipy.constants' (CODATA 2022),
the values magpylib uses, so fields agree with magpylib to the last digit."""

from __future__ import annotations

from scipy import constants

from magcilia.constants import MU0, MU0_OVER_4PI, MU_B


def test_constants_are_scipys_codata_2022() -> None:
    assert constants.mu_0 == MU0
    assert constants.physical_constants["Bohr magneton"][0] == MU_B
    assert MU0_OVER_4PI == MU0 / (4.0 * 3.141592653589793)

