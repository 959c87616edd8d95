"""Bandwidth and settling time as figures of merit of design_metrics and optimise_design
(issue 28, item 2)."""

from __future__ import annotations

import math

import pytest

import magcilia as mc
from magcilia import MagciliaError

SETUP = mc.Setup.paper(tip_radius=5e-5, layout="converged")


def test_design_metrics_carry_the_response_of_a_tip_force() -> None:
    m = mc.design_metrics(SETUP, fluid=mc.AIR, points=11)
    r = mc.frequency_response(SETUP, [0.0], fluid=mc.AIR)
    assert m.response_bandwidth == pytest.approx(r.bandwidth, rel=1e-9)
    assert m.settling_time == pytest.approx(r.settling_time, rel=1e-9)
    assert "−3 dB bandwidth" in m.report().splitlines()[0]
    assert m.to_dict()["response_bandwidth_Hz"] == m.response_bandwidth
    cone = mc.design_metrics(mc.Setup.paper(), points=11)  # no tip radius: not known
    assert math.isnan(cone.response_bandwidth) and "bandwidth" not in cone.report()


def test_optimise_reports_and_filters_by_the_dynamics() -> None:
    kwargs = {"n": 32, "refine": 4, "polish": 0, "rng": 0, "workers": 1, "points": 31}
    result = mc.optimise_design(SETUP, **kwargs)  # type: ignore[arg-type]
    for d in (result.best, result.reference, *result.front):
        assert d.bandwidth > 0 and d.settling_time > 0, d
    assert result.best.row("N")["bandwidth_Hz"] == result.best.bandwidth
    with pytest.raises(MagciliaError, match="bandwidth") as info:
        mc.optimise_design(SETUP, constraints={"bandwidth": 1e6}, **kwargs)  # type: ignore[arg-type]
    assert "\n" not in str(info.value)
