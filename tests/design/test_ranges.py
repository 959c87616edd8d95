"""The one range rule (design.ranges.range_end, readout.branch.first_turn) and the measurands."""

from __future__ import annotations

import math

import numpy as np
import pytest

import magcilia as mc
from magcilia.design import FLOW, FORCE, OBJECTIVES, RangeEnd, range_end
from magcilia.design.measurands import BY_OBJECTIVE
from magcilia.design.ranges import read_range
from magcilia.readout.branch import first_turn


def _scalar_range_end(q: np.ndarray, ratio: np.ndarray, signal: np.ndarray
                      ) -> tuple[float, RangeEnd, int]:
    """The rule written out for one sweep: the first saturated point (interpolated) or the first
    step against the signal's first direction, whichever comes first, else the sweep's end."""
    n = q.size
    sat = next((k for k in range(n) if ratio[k] > 1.0), None)
    steps = [signal[k + 1] - signal[k] for k in range(n - 1)]
    direction = next((math.copysign(1.0, d) for d in steps if d != 0.0), 0.0)
    fold = next((k for k, d in enumerate(steps) if d * direction < 0.0), None)
    if sat is not None and (fold is None or sat <= fold):
        if sat == 0:
            return 0.0, RangeEnd.ZERO, 0
        t = (1.0 - ratio[sat - 1]) / (ratio[sat] - ratio[sat - 1])
        return q[sat - 1] + t * (q[sat] - q[sat - 1]), RangeEnd.SATURATED, sat - 1
    if fold is not None:
        return q[fold], RangeEnd.FOLD, fold
    return q[-1], RangeEnd.END, n - 1


@pytest.mark.parametrize("seed", range(6))
def test_range_end_of_many_sweeps_is_the_rule_of_each(seed: int) -> None:
    gen = np.random.default_rng(seed)
    rows, c = 40, 12
    q = np.cumsum(gen.uniform(0.1, 1.0, (rows, c)), axis=1)
    ratio = np.cumsum(gen.uniform(0.0, 0.25, (rows, c)), axis=1)
    signal = np.cumsum(gen.choice([-1.0, 0.0, 1.0, 1.0, 1.0], (rows, c)), axis=1)
    value, kind, last = range_end(q, ratio, signal)
    for i in range(rows):
        want = _scalar_range_end(q[i], ratio[i], signal[i])
        one = range_end(q[i], ratio[i], signal[i])
        assert (float(value[i]), RangeEnd(int(kind[i])), int(last[i])) == pytest.approx(want)
        assert (float(one[0]), int(one[1]), int(one[2])) == (value[i], kind[i], last[i])


def test_range_end_kinds_and_the_sweeps_end() -> None:
    q = np.array([0.0, 1.0, 2.0, 3.0])
    assert RangeEnd(int(range_end(q, np.full(4, 2.0), q)[1])) is RangeEnd.ZERO
    value, kind, last = range_end(q, np.zeros(4), q, end=3.5)  # not reached: the given end
    assert (float(value), int(kind), int(last)) == (3.5, RangeEnd.END, 3)
    # a flat step is no fold for a range; it ends an inverse table's branch
    flat = np.array([0.0, 1.0, 1.0, 2.0])
    assert int(first_turn(flat)) == 3 and int(first_turn(flat, flat=True)) == 1
    assert int(range_end(q, np.zeros(4), flat)[1]) == RangeEnd.END


def test_read_range_names_what_ends_it() -> None:
    q = np.linspace(0.0, 1.0, 5)
    b = np.zeros((5, 3))
    b[:, 0] = np.linspace(0.0, 1e-3, 5)  # crosses 6 gauss on B_x between points 2 and 3
    scale = np.array([6e-4, math.inf, math.inf])
    value, why, last, reached = read_range(q, b, b, scale, math.inf, b[:, 0], 1, "end")
    assert value == pytest.approx(0.6) and reached and last == 2
    assert why == "sensor range (±6 gauss on B_x)"
    value, why, _, reached = read_range(q, b * 0.1, b * 0.1, scale, math.inf, b[:, 0], 1, "E")
    assert value == 1.0 and not reached and why == "not reached: E"


def test_measurands_hold_what_differs() -> None:
    assert tuple(BY_OBJECTIVE) == OBJECTIVES
    assert (BY_OBJECTIVE["force-range"], BY_OBJECTIVE["flow-sensitivity"]) == (FORCE, FLOW)
    assert FORCE.quantity.unit == "N" and FLOW.unit_token == "m_per_s"
    with pytest.raises(mc.MagciliaError, match="speed"):
        FLOW.requirements(None, None)
    with pytest.raises(mc.MagciliaError, match="force-range"):
        FORCE.requirements(None, 0.1)

    class D:
        def __init__(self, minimum: float, range_: float) -> None:
            self.minimum, self.range = minimum, range_

    designs = [D(1.0, 5.0), D(0.5, 2.0), D(0.5, 3.0)]
    assert FORCE.best(designs) is designs[0]  # the largest range
    assert FLOW.best(designs) is designs[2]  # the finest resolution, then the larger range
    assert FORCE.eligible(designs[1], {"min_force": 0.6})
    assert not FLOW.eligible(designs[1], {"speed": 2.5})


def test_design_metrics_and_the_optimiser_sweep_the_same_loads() -> None:
    setup = mc.Setup.paper(tip_radius=5e-5, n_loops=24, dipoles_per_loop=4, ring="rms")
    metrics = mc.design_metrics(setup, points=21)
    for metric, measurand in ((metrics.force, FORCE), (metrics.flow, FLOW)):
        sweep = measurand.sweep(setup, mc.WATER, 21)
        assert np.array_equal(metric.curve[:, 0], sweep.values)
