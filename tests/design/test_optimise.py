"""Design optimisation: non-dominated sorting, constraints, the reference beaten, seeds, errors."""

from __future__ import annotations

import itertools
import json

import numpy as np
import pytest

import magcilia as mc
from magcilia._atomic import json_text
from magcilia.design import (
    DEFAULT_BOUNDS,
    FORCE,
    DesignOptimum,
    optimise_design,
    pareto_ranks,
    sensor_choices,
)
from magcilia.design.exact import ExactTask as _Task
from magcilia.design.exact import evaluate as _evaluate

#: the reference: the paper's Table I cilium and placement, a 0.05 mm tip radius (the paper's cone
#: is sharp: a tip force needs a finite tip), the Guth-Gold modulus of its 30/30 mg composite
#: (0.669 MPa, docs/stiffness.md) and a converged dipole model (24 x 4, rms ring), as
#: examples/force-sensor.toml
#: a resolution the best design must reach, N (the reference's is 0.12 µN: forces scale with E)
MIN_FORCE = 1e-7
REFERENCE = mc.Setup.paper(tip_radius=5e-5, n_loops=24, dipoles_per_loop=4, ring="rms")
FAST = {"n": 256, "refine": 16, "workers": 1, "points": 61}


def _brute_ranks(f: np.ndarray) -> list[int]:
    """Pareto ranks by definition: peel off the points no remaining point dominates."""
    left = set(range(len(f)))
    ranks = [-1] * len(f)
    rank = 0
    while left:
        front = [i for i in left if not any(
            all(f[j] <= f[i]) and any(f[j] < f[i]) for j in left if j != i)]
        for i in front:
            ranks[i] = rank
        left -= set(front)
        rank += 1
    return ranks


@pytest.mark.parametrize("seed", range(4))
def test_pareto_ranks_match_brute_force(seed: int) -> None:
    gen = np.random.default_rng(seed)
    f = gen.integers(0, 6, size=(120, 2 + seed % 2)).astype(float)  # many ties
    assert pareto_ranks(f).tolist() == _brute_ranks(f)
    big = gen.standard_normal((700, 2))  # more rows than one block of comparisons
    assert pareto_ranks(big).tolist() == _brute_ranks(big)


def test_pareto_ranks_limit_and_nan() -> None:
    f = np.array([[1.0, 4.0], [2.0, 2.0], [3.0, 3.0], [4.0, 1.0], [np.nan, 0.0], [5.0, 5.0]])
    assert pareto_ranks(f).tolist() == [0, 0, 1, 0, -1, 2]
    assert pareto_ranks(f, limit=2).tolist() == [0, 0, -1, 0, -1, -1]
    with pytest.raises(mc.MagciliaError, match="shape"):
        pareto_ranks([1.0, 2.0])


def test_exact_metric_of_the_single_axis_sensor_is_design_metrics() -> None:
    """The exact refinement reproduces design_metrics' force metric for the HMC1021Z."""
    choice = sensor_choices(("HMC1021Z",), REFERENCE)[0]
    got = _evaluate(_Task(REFERENCE, choice, FORCE, 0.0, (0.5, 500.0), mc.WATER, 151,
                          choice.rated_total))
    want = mc.design_metrics(REFERENCE).force
    assert got["minimum"] == pytest.approx(want.minimum, rel=1e-9)
    assert got["range"] == pytest.approx(want.range, rel=1e-9)
    assert got["limited_by"] == want.limited_by and got["reached"] == want.reached
    # near the element: the range ends where the total field reaches the rated 6 gauss
    near = REFERENCE.replace(position=(-1e-3, 0.0, 0.0))
    got = _evaluate(_Task(near, choice, FORCE, 0.0, (0.5, 500.0), mc.WATER, 151,
                          choice.rated_total))
    want = mc.design_metrics(near).force
    assert got["reached"] and want.reached and got["limited_by"] == want.limited_by
    assert got["range"] == pytest.approx(want.range, rel=1e-9)
    assert got["peak_field"] == pytest.approx(6e-4, rel=2e-2)


@pytest.fixture(scope="module")
def result() -> DesignOptimum:
    return optimise_design(REFERENCE, min_force=MIN_FORCE, rng=3, **FAST)  # type: ignore[arg-type]


def test_every_design_respects_the_bounds_and_constraints(result: DesignOptimum) -> None:
    assert result.front and result.best.eligible and result.best.rank >= 0
    for d in result.designs:
        for name, (lo, hi) in DEFAULT_BOUNDS.items():
            assert lo <= d.params[name] <= hi, (name, d.params[name])
        assert d.params["tip_radius"] <= d.params["base_radius"]
    for d in (*result.front, result.best):
        assert d.feasible and d.range > 0.0
        # the sensor's rated range (the total field, for the HMC1021Z) is the default constraint
        assert d.peak_field <= REFERENCE.sensor.field_range * (1 + 1e-9)
        mc.Setup.paper(**{k: d.params[k] for k in ("height", "base_radius", "tip_radius")},
                       position=tuple(d.params[k] for k in "xyz"))  # the element is outside
    assert result.best.minimum <= MIN_FORCE
    eligible = [d for d in result.designs if d.eligible]
    assert result.best.range == max(d.range for d in eligible)
    front = result.front  # non-dominated among the feasible ones, sorted by the minimum
    assert [d.minimum for d in front] == sorted(d.minimum for d in front)
    assert all(a.range < b.range for a, b in itertools.pairwise(front))


def test_the_best_design_against_the_papers_cilium(result: DesignOptimum) -> None:
    """A finer resolution than the paper's cilium at its placement, checked with design_metrics
    on the chosen setup itself; the paper's cilium never leaves the rated range or folds within
    its sweep, so its range is only a lower bound, and no range is claimed to beat it."""
    ref = mc.design_metrics(REFERENCE).force
    best = mc.design_metrics(result.best_setup).force
    assert best.minimum < ref.minimum
    assert best.range == pytest.approx(result.best.range, rel=1e-6)
    assert best.reached == result.best.reached
    assert not ref.reached and not result.reference.reached
    assert not result.beats_reference
    ratio = result.reference.minimum / result.best.minimum
    assert result.comparison.startswith(f"resolution {ratio:.3g}× finer; range not known to be "
                                        "larger (neither range reached: ≥ ")
    assert result.reference.minimum == pytest.approx(ref.minimum, rel=1e-9)
    assert result.best_setup.youngs_modulus == pytest.approx(REFERENCE.youngs_modulus)
    assert result.best_setup.layout == "converged"  # a new design: its layout converged


def test_the_comparison_states_what_is_known(result: DesignOptimum) -> None:
    """Each case of reached and not-reached ranges: a ratio where both are known, "at least"
    where the unreached one is the larger bound, "not known" otherwise; beats_reference only
    when both the range and the resolution are known to be better."""
    import dataclasses

    def vs(best: tuple[float, bool, float], ref: tuple[float, bool, float]) -> DesignOptimum:
        b, r = (dataclasses.replace(c, range=rng, reached=reached, minimum=m) for c, (
            rng, reached, m) in ((result.best, best), (result.reference, ref)))
        return dataclasses.replace(result, best=b, reference=r)

    both = vs((2e-4, True, 1e-7), (1e-4, True, 2e-7))
    assert both.comparison == "resolution 2× finer; range 2× larger" and both.beats_reference
    worse = vs((1e-4, True, 3e-7), (4e-4, True, 1e-7))
    assert worse.comparison == "resolution 3× coarser; range 4× smaller"
    assert not worse.beats_reference
    lower = vs((3e-4, False, 1e-7), (1e-4, True, 1e-7))
    assert lower.comparison == ("resolution the same; range at least 3× larger (the chosen "
                                "design's not reached: ≥ 0.3 mN against 0.1 mN)")
    assert not lower.beats_reference  # the resolution is not finer
    assert vs((3e-4, False, 5e-8), (1e-4, True, 1e-7)).beats_reference
    short = vs((1e-4, True, 1e-7), (3e-4, False, 2e-7))
    assert short.comparison.endswith("range at least 3× smaller (the reference's not reached: "
                                     "0.1 mN against ≥ 0.3 mN)")
    unknown = vs((3e-4, True, 1e-7), (1e-4, False, 2e-7))
    assert unknown.comparison.endswith("range not known to be larger (the reference's range "
                                       "not reached: 0.3 mN against ≥ 0.1 mN)")
    assert not unknown.beats_reference


def test_a_seed_repeats_the_result(result: DesignOptimum) -> None:
    again = optimise_design(REFERENCE, min_force=MIN_FORCE, rng=3, **FAST)  # type: ignore[arg-type]
    assert json_text(again.to_dict() | {"seconds": 0}) == json_text(
        result.to_dict() | {"seconds": 0})
    other = optimise_design(REFERENCE, min_force=MIN_FORCE, rng=4, **FAST)  # type: ignore[arg-type]
    assert other.best.params != result.best.params


def test_result_protocol(result: DesignOptimum) -> None:
    doc = json.loads(json_text(result.to_dict()))
    assert doc["objective"] == "force-range" and doc["unit"] == "N"
    assert len(doc["front"]) == len(result.front)
    rows = result.table()
    assert {"height_m", "x_m", "minimum_N", "range_N", "sensor"} <= set(rows[0])
    frame = result.to_dataframe()
    assert len(frame) == len(result.designs) and "range_N" in frame.columns
    assert f"compared with the reference: {result.comparison}" in result.report()
    assert "≥ " in result.report()  # ranges the sweep did not reach are lower bounds
    assert all(isinstance(d["range_reached"], bool) for d in doc["front"])
    assert len(repr(result)) <= 120


def test_fixed_bounds_fix_a_variable() -> None:
    r = optimise_design(REFERENCE, bounds={"height": (3e-3, 3e-3), "z": (2e-4, 4e-4)},
                        rng=0, **FAST)  # type: ignore[arg-type]
    assert {d.params["height"] for d in r.designs} == {3e-3}
    assert all(2e-4 <= d.params["z"] <= 4e-4 for d in r.designs)


def test_a_three_axis_sensor_can_be_chosen() -> None:
    r = optimise_design(REFERENCE, sensors=("HMC1021Z", "MMC5983MA"), rng=1,
                        **FAST)  # type: ignore[arg-type]
    assert {d.sensor for d in r.designs} == {"HMC1021Z", "MMC5983MA"}
    part = mc.Magnetometer.preset("MMC5983MA")
    sigma = np.sqrt(np.asarray(part.noise) ** 2 + np.asarray(part.resolution) ** 2 / 12.0)
    single = REFERENCE.sensor.noise_rms(0.5, 500.0)
    for d in r.designs:
        if d.sensor == "MMC5983MA":  # three axes: between the best and the worst axis alone
            assert sigma.min() / d.sensitivity * (1 - 1e-9) <= d.minimum
            assert d.minimum <= sigma.max() / d.sensitivity * (1 + 1e-9)
        else:  # one axis: noise over slope
            assert d.minimum == pytest.approx(single / d.sensitivity, rel=1e-12)


def test_flow_objective_resolves_at_the_speed() -> None:
    r = optimise_design(REFERENCE, "flow-sensitivity", speed=0.2, rng=0,
                        **FAST)  # type: ignore[arg-type]
    assert r.quantity == "flow" and r.best.range >= 0.2
    eligible = [d for d in r.designs if d.eligible]
    assert r.best.minimum == min(d.minimum for d in eligible)


@pytest.mark.parametrize(("kwargs", "message"), [
    ({"min_force": 1e-12}, "min_force must be reachable within the bounds; it eliminated all"),
    ({"bounds": {"x": (0.0, 0.0), "y": (0.0, 0.0), "z": (0.0, 0.0),
                 "base_radius": (4e-4, 4e-4)}},
     "the 'sensor range at zero load' constraint eliminated all 256 screened designs"),
    ({"bounds": {"x": (0.0, 0.0), "y": (0.0, 0.0), "z": (0.0, 0.0),
                 "base_radius": (4e-4, 4e-4)}, "constraints": {"field": 1e-2}},
     "the 'flip field' constraint eliminated all 256 screened designs"),
    ({"bounds": {"x": (1e-3, 1e-3), "y": (0.0, 0.0), "z": (0.0, 0.0),
                 "magnetization_scale": (20.0, 20.0)}},
     "the 'sensor range at zero load' constraint eliminated all 256 screened designs"),
    ({"objective": "flow-sensitivity"}, "speed must be a flow speed"),
    ({"objective": "pressure"}, "objective must be one of"),
    ({"bounds": {"colour": (1.0, 2.0)}}, "bounds key must be one of"),
    ({"sensors": ("XYZ123",)}, "sensor must be HMC1021Z"),
    ({"constraints": {"range": 1.0}}, "'range' eliminated"),
])
def test_infeasible_or_bad_input_is_one_line(kwargs: dict, message: str) -> None:
    with pytest.raises(mc.MagciliaError, match=message) as info:
        optimise_design(REFERENCE, **{**FAST, **kwargs})
    assert "\n" not in str(info.value)


def test_a_measured_profile_scales_with_its_base_radius() -> None:
    cilium = mc.Cilium.from_profile([0.0, 1.5e-3, 3.2e-3], [2e-4, 1.2e-4, 5e-5])
    setup = mc.Setup.paper(cilium=cilium, n_loops=12, dipoles_per_loop=4, ring="rms")
    r = optimise_design(setup, n=64, refine=8, rng=0, workers=1, points=61)
    assert "tip_radius" not in r.best.params
    best = r.best_setup.cilium
    assert best.profile == cilium.profile  # the measured shape, scaled
    assert best.tip_radius == pytest.approx(best.base_radius * 0.25)
    with pytest.raises(mc.MagciliaError, match="bounds key must be left out"):
        optimise_design(setup, bounds={"tip_radius": (1e-5, 2e-5)}, n=64)


def test_a_screen_in_chunks_gives_the_same_result(result: DesignOptimum,
                                                  monkeypatch: pytest.MonkeyPatch) -> None:
    """Past SCREEN_CHUNK designs the screen runs as tasks, chunk by chunk: same result."""
    from magcilia.design import optimise

    monkeypatch.setattr(optimise, "SCREEN_CHUNK", 64)
    chunked = optimise_design(REFERENCE, min_force=MIN_FORCE, rng=3, **FAST)  # type: ignore[arg-type]
    assert json_text(chunked.to_dict() | {"seconds": 0}) == json_text(
        result.to_dict() | {"seconds": 0})


def test_polishing_only_adds_designs(result: DesignOptimum) -> None:
    plain = optimise_design(REFERENCE, min_force=MIN_FORCE, rng=3, polish=0,
                            **FAST)  # type: ignore[arg-type]
    assert len(result.designs) > len(plain.designs)
    assert [d.params for d in result.designs[:len(plain.designs)]] == [
        d.params for d in plain.designs]
    assert result.best.range >= plain.best.range


def test_the_rated_range_can_be_raised() -> None:
    """With the total field's rated range raised to the flip field (20 gauss), designs may put
    more than 6 gauss on the element; their ranges still end within B_x's ±6 gauss."""
    r = optimise_design(REFERENCE, min_force=5e-7, rng=3, constraints={"field": 2e-3},
                        **FAST)  # type: ignore[arg-type]
    assert max(d.peak_field for d in r.designs if d.feasible) > REFERENCE.sensor.field_range
    assert all(d.peak_field <= 2e-3 * (1 + 1e-9) for d in r.designs if d.feasible)
