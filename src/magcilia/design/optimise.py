"""Design optimisation: the cilium's geometry, material, placement and sensor for a named objective,
with the Pareto front of range against resolution.

Three objectives (:data:`OBJECTIVES`), each a pair of goals and a choice on the pair's front (the
objective's measurand, :mod:`magcilia.design.measurands`, holds what differs between them):

* ``"force-range"``: maximise the tip-force range and minimise the minimum detectable force; the
  chosen design has the largest range among those that resolve ``min_force`` (default: the
  given setup's own minimum detectable force, so the choice resolves at least as finely).
* ``"flow-sensitivity"``: minimise the smallest detectable change of flow speed at the speed
  ``speed`` (the noise over the slope dB/dU there, i.e. the best flow sensitivity) and maximise
  the flow range; the chosen design has the finest resolution at ``speed`` among those whose
  range reaches ``speed``.
* ``"robust"``: the tip force read *without a per-device calibration*: among the designs that
  resolve ``min_force`` (as ``"force-range"``), the one with the smallest calibration-free read-out
  error under fabrication and placement ``tolerances`` (a Monte Carlo of devices read with the
  nominal model, tared at rest, through the exact forward model: :mod:`magcilia.design.robust`).
  The screen cannot estimate that error: its candidates are the feasible screened designs that meet
  the requirement, in the Sobol' sample's order (spread over the bounds), and the given setup's own
  variables (within the bounds); the exact refinement measures each one's error, and the polishing
  rounds centre on the smallest. The front is still range against resolution; single-axis sensor
  only.

**Definitions** (the same as :func:`magcilia.design_metrics`, which the exact metrics reproduce
for a single-axis sensor). The *minimum detectable* value is the field noise of one reading over
the field's slope, combined over the sensor's axes as ``1 / sqrt(Σ (s_i / σ_i)²)`` (s: dB/dF or
dB/dU on axis i, σ_i its RMS noise; one axis for the HMC1021Z: ``σ / |s|``, as design_metrics).
The *range* is the measurand's value where the read-out ends (:func:`~magcilia.design.ranges.
read_range`, as design_metrics; :mod:`magcilia.design.ranges`), the first of

1. the sensor's rated range: an axis's |B_i| reaches its full scale (±6 gauss on the HMC1021Z's
   sensitive axis; ±8 gauss per axis on the MMC5983MA), or the total field |B| reaches the rated
   range of the total field (the HMC1021Z's datasheet states its ±6 gauss for the total applied
   field; ``constraints["field"]`` sets another), interpolated between sweep points;
2. a fold: the reading ``Σ w_i B_i`` with the zero-load weights ``w_i = s_i / σ_i²`` (the best
   linear read-out; for one axis the output itself) turns back, so readings become ambiguous.

The sweep runs to the elastica's large-deflection limit, the force ``3 L / C`` whose *linear* tip
deflection would be three cilium heights (C = :func:`magcilia.mechanics.tip_compliance`),
where the cilium is bent far over; for flow, to the speed whose drag on the upright cilium is
that force, or the drag law's Reynolds limit, whichever is lower (:mod:`magcilia.design.sweeps`).
When the sweep ends before the read-out does, the range is *not reached*: its value is the
sweep's end, a lower bound (``Candidate.reached`` is False, reports print "≥ X"), and a range
comparison with it says so.

**Constraints.** Every returned design lies within ``bounds`` (fabrication limits: the registry's
calibration bounds by default, :data:`DEFAULT_BOUNDS`), has ``tip_radius ≤ base_radius``, keeps
the sensing element outside the cilium, starts within the sensor's rated range at zero load
(the total field included: the rated range is the default constraint), keeps |B| below the
single-axis part's flip (disturbing) field over its whole range, and meets any of
``constraints``: ``{"range": lowest range, "minimum": largest minimum detectable value,
"field": the rated range of |B| at the element}`` (SI: N for force, m/s for flow, T; "field"
replaces the sensor's own, e.g. 20 gauss to let the HMC1021Z's total field go up to its flip
field). The Pareto front is that of these feasible designs; the chosen design also meets the
objective's own requirement (``min_force``; for flow, a range that reaches ``speed``): it is
*eligible*.

**Layouts.** Each design's field comes from a layout converged at the sensing element
(:meth:`magcilia.Setup.resolve_layout`): the candidates are new designs, so their layouts are
converged unless the setup asks for the paper's by name (``layout="paper"``: the candidates keep
it); the reference keeps its own rule (a given layout is used as is, warned about above 1 %).

**Algorithm.** A scrambled Sobol' sample (``scipy.stats.qmc``, seeded by ``rng``) of ``n``
designs over the bounds (rounded up to a power of two), screened with cheap, vectorised
metrics: the tilt model of all designs at once (:class:`magcilia.model.TiltBatch`) at the
equivalent rigid tilt ``θ = atan(C F / L)`` (the chord of a tip-loaded cantilever, exact for
small loads), the closed-form tip compliance of each frustum, and for flow the cylinder drag
per length (tip-equivalent force 3/8 of the total) (:mod:`magcilia.design.proxy`,
:mod:`magcilia.design.screen`). Non-dominated sorting of the screened designs by the objective's
two goals (:func:`~magcilia.design.pareto.pareto_ranks`) picks the fronts' designs (rank by
rank, ``refine`` of them) and the screen's best candidates for the chosen design; each is
then measured with the exact metrics (large-deflection :func:`magcilia.bend_sweep` and the full
field model), as tasks through :mod:`magcilia.execution` (a local pool, or a Dask cluster with
``scheduler``; :mod:`magcilia.design.exact`); ``polish`` rounds then measure 16 designs each
in a shrinking Sobol' box around the chosen design, and the exact fronts and the chosen design
come from all of those. Screens of more than :data:`~magcilia.design.screen.SCREEN_CHUNK`
designs run in chunks, as tasks too. NSGA-II (pymoo) was not used: for two goals a dense
quasi-random screen covers the front, and the exact refinement decides; no heavy dependency is
needed.
"""

from __future__ import annotations

import logging
import math
import time
from collections.abc import Callable, Mapping, Sequence
from dataclasses import dataclass, replace
from typing import Any

import numpy as np
from numpy.typing import NDArray

from magcilia import _validate as v
from magcilia._errors import MagciliaError
from magcilia.design.exact import ExactTask, dynamics, evaluate_many
from magcilia.design.measurands import BY_OBJECTIVE, Measurand
from magcilia.design.pareto import pareto_ranks
from magcilia.design.results import Candidate, DesignOptimum
from magcilia.design.robust import RobustSpec, Tolerances
from magcilia.design.screen import REASONS, SCREEN_CHUNK, Screen, screen, screen_chunk
from magcilia.design.self_test import CoilSelfTest
from magcilia.design.sensors import SINGLE_AXIS, SensorChoice, sensor_choices
from magcilia.device.magnetometer import Magnetometer
from magcilia.device.parameters import PARAMETERS
from magcilia.device.sensor import DEFAULT_BANDWIDTH, Sensor
from magcilia.device.setup import Setup
from magcilia.execution import run_tasks
from magcilia.mechanics import WATER, Fluid

F64 = NDArray[np.float64]
logger = logging.getLogger(__name__)

#: the objectives :func:`optimise_design` knows (each names its measurand:
#: :data:`~magcilia.design.measurands.BY_OBJECTIVE`)
OBJECTIVES = tuple(BY_OBJECTIVE)
#: the design variables (registry names), in table order
VARIABLES = ("height", "base_radius", "tip_radius", "magnetization_scale", "cobalt_mass",
             "x", "y", "z")
#: default search bounds, SI: the registry's calibration bounds of the geometry and placement,
#: and a tip radius of 0.02–0.1 mm (a tip force needs a finite tip); the material stays the
#: setup's unless magnetization_scale or cobalt_mass is given a bound
DEFAULT_BOUNDS: dict[str, tuple[float, float]] = {
    "height": PARAMETERS["height"].bound,  # type: ignore[dict-item]
    "base_radius": PARAMETERS["base_radius"].bound,  # type: ignore[dict-item]
    "tip_radius": (2e-5, 1e-4),
    "x": PARAMETERS["x"].bound,  # type: ignore[dict-item]
    "y": PARAMETERS["y"].bound,  # type: ignore[dict-item]
    "z": PARAMETERS["z"].bound,  # type: ignore[dict-item]
}
#: exact evaluations run in process (no pool) when no more than this many designs are measured
#: and no scheduler is given: ~0.5 s of work, less than a process pool's start
SMALL_BATCH = 16
#: with ``workers=None``, a pool (one process per core) measures batches of at least this many
#: designs; smaller ones run in process (measured here: 96 designs took 2.4 s in process, 4.1 s
#: with a pool of 2 that has to start)
POOL_FROM = 256
#: designs per screening chunk: ~30 MB of fields each; more chunks run as tasks through the


def _run(fn: Callable[[Any], Any], tasks: list[tuple[str, Any]], workers: int | None,
         scheduler: str | None, progress: bool) -> list[Any]:
    """Run ``tasks`` through the execution layer (:func:`magcilia.execution.run_tasks`); the
    values in order, a failed task re-raised."""
    results = run_tasks(fn, tasks, workers=workers, scheduler=scheduler, progress=progress)
    values = []
    for r in results:
        if r.error:
            raise MagciliaError(f"design task {r.key} failed: {r.error}")
        values.append(r.value)
    return values


# -- the search -----------------------------------------------------------------------------------
def _bounds(setup: Setup, bounds: Mapping[str, Sequence[float]] | None
            ) -> tuple[dict[str, tuple[float, float]], dict[str, float]]:
    """Searched bounds (SI) and the fixed values of the other variables."""
    given = dict(bounds or {})
    for name in given:
        v.choice("bounds key", name, VARIABLES)
        if name == "tip_radius" and setup.cilium.profile is not None:
            raise v.fail("bounds key", name, "left out for a cilium with a measured profile "
                         "(height and base_radius scale the measured shape)")
    out: dict[str, tuple[float, float]] = {}
    for name in VARIABLES:
        if name in given:
            pair = given[name]
            lo, hi = (float(x) for x in pair)
            PARAMETERS[name].check_range(lo, hi, f"bounds[{name!r}]")
            if not lo <= hi:
                raise v.fail(f"bounds[{name!r}]", (lo, hi), "a range with low <= high")
            out[name] = (lo, hi)
        elif name in DEFAULT_BOUNDS and not (name == "tip_radius"
                                             and setup.cilium.profile is not None):
            out[name] = DEFAULT_BOUNDS[name]
    fixed = {n: float(setup.value(n)) for n in VARIABLES if n not in out}
    return out, fixed


def _sample(bounds: dict[str, tuple[float, float]], fixed: dict[str, float], n: int,
            n_sensors: int, gen: np.random.Generator) -> tuple[dict[str, F64], NDArray[np.int64]]:
    """A scrambled Sobol' sample of 2^ceil(log2 n) designs: every variable (SI, (N,) arrays)
    and the sensor index (N,)."""
    from scipy.stats import qmc

    names = list(bounds)
    dims = len(names) + (1 if n_sensors > 1 else 0)
    m = max(1, math.ceil(math.log2(n)))
    u = qmc.Sobol(dims, scramble=True, rng=gen).random_base2(m) if dims else np.zeros((2**m, 0))
    values: dict[str, F64] = {}
    for j, name in enumerate(names):
        lo, hi = bounds[name]
        values[name] = lo + (hi - lo) * u[:, j]
    for name, val in fixed.items():
        values[name] = np.full(u.shape[0], val)
    index = np.minimum((u[:, -1] * n_sensors).astype(np.int64), n_sensors - 1) \
        if n_sensors > 1 else np.zeros(u.shape[0], dtype=np.int64)
    return values, index


def _design_setup(setup: Setup, params: Mapping[str, float]) -> Setup:
    """The setup with a design's variables."""
    changes = {k: val for k, val in params.items()
               if not (k == "tip_radius" and setup.cilium.profile is not None)}
    return setup.replace(**changes)


def optimise_design(setup: Setup | None = None, objective: str = "force-range", *,
                    min_force: float | None = None, speed: float | None = None,
                    constraints: Mapping[str, float] | None = None,
                    bounds: Mapping[str, Sequence[float]] | None = None,
                    sensors: Sequence[str | Sensor | Magnetometer] = (SINGLE_AXIS,),
                    n: int = 1024, refine: int = 32, polish: int = 2,
                    rng: int | np.random.Generator | None = None,
                    workers: int | None = None, scheduler: str | None = None,
                    bandwidth: tuple[float, float] = DEFAULT_BANDWIDTH, fluid: Fluid = WATER,
                    points: int = 151, progress: bool = False,
                    tolerances: Tolerances | None = None, samples: int = 128,
                    tare: bool = True, self_test: CoilSelfTest | None = None
                    ) -> DesignOptimum:
    """Search geometry, material, placement and sensor for an objective; return the Pareto
    front of range against resolution and the chosen design (module docstring).

    Parameters
    ----------
    setup : Setup, optional
        The starting design: material, model (n, k, ring), sensor and every variable not
        searched; also the reference the result compares against. Default: the paper's
        Table I cilium with a 0.05 mm tip radius and a converged model (``layout="converged"``).
    objective : {"force-range", "flow-sensitivity", "robust"}
        ``"robust"``: the smallest calibration-free read-out error (:mod:`magcilia.design.robust`)
        among the designs that resolve ``min_force`` (single-axis sensor only).
    min_force : float, optional
        Force and robust objectives: the minimum detectable force the chosen design must reach,
        N (default: the reference's own).
    speed : float, optional
        Flow objective (required there): the flow speed U, m/s, whose sensitivity counts.
    constraints : mapping, optional
        ``{"range": lowest range, "minimum": largest minimum detectable value}`` (SI: N or
        m/s), ``"field"``: the rated range of |B| at the element, T, where a design's range
        ends (default each sensor's own: the HMC1021Z's 6 gauss, whose datasheet states its
        range for the total field; none for a 3-axis part, rated per axis), and the dynamics
        of the response to the measurand in ``fluid`` (:func:`magcilia.frequency_response`):
        ``"bandwidth"``, the lowest −3 dB bandwidth, Hz, and ``"settling"``, the longest 2 %
        settling time of a step, s (refined designs only: the screen does not know them).
    bounds : mapping of str to (low, high), optional
        Searched variables (:data:`VARIABLES`) and their bounds, SI; the defaults
        (:data:`DEFAULT_BOUNDS`) for the others; pass ``(v, v)`` to fix one.
    sensors : sequence
        Sensor choices (:func:`sensor_choices`): ``"HMC1021Z"`` (the setup's own), 3-axis
        preset names such as ``"MMC5983MA"``, or sensor objects.
    n : int
        Designs screened (rounded up to a power of two, ≥ 16).
    refine : int
        Screened designs measured exactly (≥ 4): the screen's fronts rank by rank, plus the
        screen's best candidates for the choice.
    polish : int
        Rounds of exact polishing (≥ 0): 16 designs in a Sobol' box around the chosen design,
        ±10 % of each bound's width, half that in each further round (the box clipped to the
        bounds); they join the refined designs.
    rng : int, Generator or None
        Seed of the Sobol' sample: an int repeats the result exactly.
    workers, scheduler
        How the exact refinement runs (:func:`magcilia.execution.run_tasks`): worker processes
        (None: in this process below :data:`POOL_FROM` designs measured at once, else one per
        core; 1: in this process) or a Dask scheduler address (every batch goes to it).
    bandwidth : (float, float)
        Noise band of the single-axis sensor, Hz (a magnetometer's noise is at its rate).
    fluid : Fluid
        Fluid of the flow objective.
    points : int
        Sweep points of each exact metric (≥ 11; 151 as design_metrics).
    progress : bool
        Show the execution layer's progress bar.
    tolerances : Tolerances, optional
        Robust objective: the fabrication and placement tolerances (default: the issue's,
        :class:`~magcilia.design.robust.Tolerances`).
    samples : int
        Robust objective: devices drawn per design (≥ 2; the same draws, seeded by ``rng``, for
        every design).
    tare : bool
        Robust objective: each device tared at rest before it is read (the default, what a user
        does).
    self_test : CoilSelfTest, optional
        Robust objective: each device read after a start-up coil self-test that estimates its
        sensitivity, magnetization and stiffness (:mod:`magcilia.design.self_test`; default
        none: the nominal model as it is).

    Returns
    -------
    DesignOptimum

    Raises
    ------
    MagciliaError
        Bad input, or no design meets the constraints (the message names the constraint that
        eliminated the last designs).
    """
    start = time.perf_counter()
    if setup is None:
        setup = Setup.paper(tip_radius=5e-5, layout="converged")
    if not isinstance(setup, Setup):
        raise v.fail("setup", type(setup).__name__, "a magcilia.Setup")
    objective = v.choice("objective", objective, OBJECTIVES)
    measurand = BY_OBJECTIVE[objective]
    n = v.integer("n", n, 16)
    refine = v.integer("refine", refine, 4)
    polish = v.integer("polish", polish, 0)
    points = v.integer("points", points, 11)
    if not isinstance(fluid, Fluid):
        raise v.fail("fluid", type(fluid).__name__, "a magcilia Fluid (AIR, WATER, …)")
    fixed_c = measurand.requirements(min_force, speed)
    for key, value in (constraints or {}).items():
        v.choice("constraints key", key, ("range", "minimum", "field", "bandwidth", "settling"))
        unit = {"field": "T", "bandwidth": "Hz", "settling": "s"}.get(
            key, measurand.quantity.unit)
        fixed_c[key] = v.positive(f"constraints[{key!r}]", value, unit, "value")
    choices = sensor_choices(sensors, setup)
    searched, fixed = _bounds(setup, bounds)
    gen = np.random.default_rng(rng)
    robust = _robust_spec(measurand, choices, tolerances, samples, tare, gen, self_test)

    # the reference: the given setup with the first sensor choice
    base = _task(setup, choices[0], measurand, fixed_c, bandwidth, fluid, points, robust)
    ref_metrics = evaluate_many([base])[0]
    # a measured profile's tip scales with its base radius: no tip_radius of its own
    shown = [k for k in VARIABLES if not (k == "tip_radius" and setup.cilium.profile is not None)]
    ref_params = {k: float(setup.value(k)) for k in shown}
    reference = _design(ref_params, choices[0].name, ref_metrics, "")
    measurand.default_requirements(fixed_c, reference)

    # the screen
    values, index = _sample(searched, fixed, n, len(choices), gen)
    total = values["height"].size
    eliminated: dict[str, int] = {}
    geometry_ok = np.ones(total, dtype=bool)
    if setup.cilium.profile is None:  # a measured profile scales with the base radius
        geometry_ok = (values["tip_radius"] <= values["base_radius"]) & (values["tip_radius"] > 0)
    args = (setup, choices, measurand, fixed_c.get("speed", 0.0), bandwidth, fluid,
            fixed_c.get("field"))
    if total <= SCREEN_CHUNK:
        screened = screen(setup, values, index, *args[1:])
    else:  # chunks, as tasks through the execution layer
        tasks = [(f"screen-{k:08d}", (setup, {name: a[k:k + SCREEN_CHUNK]
                                               for name, a in values.items()},
                                      index[k:k + SCREEN_CHUNK], *args[1:]))
                 for k in range(0, total, SCREEN_CHUNK)]
        parts = _run(screen_chunk, tasks, workers, scheduler, progress)
        screened = Screen(*(np.concatenate([getattr(p, f) for p in parts])
                            for f in ("minimum", "range", "violated")))
    codes = np.where(geometry_ok, screened.violated, 1)
    tally = np.bincount(codes, minlength=len(REASONS))
    eliminated.update({REASONS[c]: int(tally[c]) for c in range(1, len(REASONS)) if tally[c]})
    ok = codes == 0
    if not ok.any():
        worst = max(eliminated, key=lambda k: eliminated[k])
        share = (f"all {total}" if eliminated[worst] == total else
                 f"{eliminated[worst]} of {total} (all: {_counts(eliminated)})")
        raise MagciliaError(f"bounds must leave designs that meet the constraints; the "
                            f"{worst!r} constraint eliminated {share} screened designs; widen "
                            "or move the bounds")
    goals = np.stack([screened.minimum, -screened.range], axis=1)
    goals[~ok] = np.nan
    ranks = pareto_ranks(goals, limit=refine)
    order = np.argsort(np.where(ranks >= 0, ranks, np.iinfo(np.int64).max), kind="stable")
    chosen = [int(i) for i in order[:refine] if ranks[i] >= 0]
    chosen += measurand.candidates(screened.minimum, screened.range, ok, fixed_c,
                                   measurand.candidate_count(refine))
    chosen = list(dict.fromkeys(chosen))
    logger.info("optimise: %d designs screened, %d feasible, %d refined", total,
                int(ok.sum()), len(chosen))

    # the exact refinement, in chunks of designs per task; the candidates are new designs: their
    # layouts converge (each at its element, in the task) unless the paper's is asked for by name
    designs_from = setup if setup.layout != "given" else setup.replace(layout="converged")
    measure = _Measure(designs_from, measurand, fixed_c, (float(bandwidth[0]), float(bandwidth[1])),
                       fluid, points, workers, scheduler, progress, robust)
    entries = [({k: float(values[k][i]) for k in shown}, choices[int(index[i])])
               for i in chosen]
    if robust is not None and all(lo <= ref_params[k] <= hi for k, (lo, hi) in searched.items()):
        entries.append((dict(ref_params), choices[0]))  # the error to beat is the reference's
    designs = measure(entries)
    # polish: small exact Sobol' boxes around the chosen design, each half the last's size
    by_name = {c.name: c for c in choices}
    for level in range(polish):
        if not any(d.eligible for d in designs):
            break
        centre = measurand.best([d for d in designs if d.eligible])
        half = 0.1 / 2**level
        u = _qmc_sample(len(searched), 4, gen)
        entries = []
        for row in u:
            params = dict(centre.params)
            for j, (name, (lo, hi)) in enumerate(searched.items()):
                params[name] = float(np.clip(params[name] + (2.0 * row[j] - 1.0) * half
                                             * (hi - lo), lo, hi))
            if "tip_radius" not in params or 0.0 < params["tip_radius"] <= params["base_radius"]:
                entries.append((params, by_name[centre.sensor]))
        designs += measure(entries)
    feasible = [d for d in designs if d.feasible]
    if not feasible:
        counts: dict[str, int] = {}
        for d in designs:
            counts[d.violated] = counts.get(d.violated, 0) + 1
        worst = max(counts, key=lambda k: counts[k])
        finest = min((d.minimum for d in designs), default=math.inf)
        raise MagciliaError(
            f"constraints must leave a design; {worst!r} eliminated {counts[worst]} of "
            f"{len(designs)} refined designs ({_counts(counts)}; the finest resolves "
            f"{measurand.quantity.text(finest, 4)}); relax it or widen the bounds")
    if not any(d.eligible for d in designs):
        need = measurand.requirement
        q = measurand.quantity
        raise MagciliaError(
            f"{need} must be reachable within the bounds; it eliminated all {len(feasible)} "
            f"feasible refined designs ({measurand.closest(feasible)}, {need} "
            f"{q.text(fixed_c[need], 4)}); relax "
            f"{need} or widen the bounds")
    ranks_exact = pareto_ranks([[d.minimum, -d.range] for d in feasible])
    ranked = {id(d): int(r) for d, r in zip(feasible, ranks_exact, strict=True)}
    designs = [replace(d, rank=ranked.get(id(d), -1)) for d in designs]
    best = measurand.best([d for d in designs if d.eligible])
    # the dynamics of the designs shown (the front, the chosen one, the reference) when no
    # constraint needed them for every design
    shown_ids = {id(d) for d in designs if d.rank == 0} | {id(best)}
    by_id = {id(d): _dynamic(d, designs_from, measurand, fixed_c, fluid, by_name)
             for d in designs if id(d) in shown_ids}
    designs = [by_id.get(id(d), d) for d in designs]
    best = by_id[id(best)]
    reference = _dynamic(reference, setup, measurand, fixed_c, fluid, by_name)
    best_setup = _design_setup(designs_from, best.params).resolve_layout()
    return DesignOptimum(
        objective=objective, measurand=measurand, designs=tuple(designs), best=best,
        reference=reference, best_setup=best_setup, bounds=searched,
        fixed=fixed_c, screened=total, eliminated=eliminated,
        seconds=time.perf_counter() - start, robust=robust)


def _robust_spec(measurand: Measurand, choices: Sequence[SensorChoice],
                 tolerances: Tolerances | None, samples: int, tare: bool,
                 gen: np.random.Generator, self_test: CoilSelfTest | None = None
                 ) -> RobustSpec | None:
    """The robust objective's Monte Carlo (None for the others); its draws' seed comes from
    ``gen`` (the search's ``rng``), so an int ``rng`` repeats them."""
    if measurand.objective != "robust":
        if tolerances is not None:
            raise v.fail("tolerances", tolerances.report(), "None unless the objective is "
                         "'robust' (the others do not use them)")
        if self_test is not None:
            raise v.fail("self_test", self_test.report(), "None unless the objective is "
                         "'robust' (the others do not use it)")
        return None
    if any(c.name != SINGLE_AXIS for c in choices):
        raise v.fail("sensors", [c.name for c in choices], f"({SINGLE_AXIS!r},) for the robust "
                     "objective (its read-out error is the single-axis sensor's)")
    return RobustSpec(tolerances or Tolerances(), samples=samples,
                      seed=int(gen.integers(2**31)), tare=tare, self_test=self_test)


@dataclass(frozen=True)
class _Measure:
    """The exact metrics of designs, as tasks through the execution layer (chunks of designs
    per task), with each design's constraint verdict and eligibility."""

    setup: Setup
    measurand: Measurand
    fixed: dict[str, float]
    bandwidth: tuple[float, float]
    fluid: Fluid
    points: int
    workers: int | None
    scheduler: str | None
    progress: bool
    robust: RobustSpec | None = None

    def __call__(self, entries: Sequence[tuple[dict[str, float], SensorChoice]]
                 ) -> list[Candidate]:
        setups = []
        for params, choice in entries:
            try:
                setups.append((params, choice, _design_setup(self.setup, params)))
            except MagciliaError:  # a design the setup refuses (the element inside): skipped
                continue
        per = max(1, math.ceil(len(setups) / 32))
        tasks: list[tuple[str, Any]] = []
        for k in range(0, len(setups), per):
            chunk = [_task(s, ch, self.measurand, self.fixed, self.bandwidth, self.fluid,
                           self.points, self.robust) for _, ch, s in setups[k:k + per]]
            tasks.append((f"designs-{k:05d}", chunk))
        # a few designs (a polishing round; up to POOL_FROM by default) cost less in process
        # than starting a pool
        small = len(setups) <= SMALL_BATCH or (self.workers is None
                                               and len(setups) < POOL_FROM)
        workers = 1 if small and self.scheduler is None else self.workers
        chunks = _run(evaluate_many, tasks, workers, self.scheduler, self.progress) \
            if tasks else []
        measured = [m for chunk in chunks for m in chunk]
        designs = [_design(p, ch.name, m, _violation(m, self.fixed, ch))
                   for (p, ch, _), m in zip(setups, measured, strict=True)]
        return [replace(d, eligible=d.feasible and self.measurand.eligible(d, self.fixed))
                for d in designs]


def _qmc_sample(dims: int, log2: int, gen: np.random.Generator) -> F64:
    """A scrambled Sobol' sample of 2**log2 points in the unit cube, shape (2**log2, dims)."""
    from scipy.stats import qmc

    if dims == 0:
        return np.zeros((2**log2, 0))
    return np.asarray(qmc.Sobol(dims, scramble=True, rng=gen).random_base2(log2),
                      dtype=np.float64)


def _task(setup: Setup, choice: SensorChoice, measurand: Measurand, fixed: dict[str, float],
          bandwidth: tuple[float, float], fluid: Fluid, points: int,
          robust: RobustSpec | None = None) -> ExactTask:
    return ExactTask(setup, choice, measurand, fixed.get("speed", 0.0),
                 (float(bandwidth[0]), float(bandwidth[1])), fluid, points,
                 choice.total_limit(fixed.get("field")),
                 dynamics="bandwidth" in fixed or "settling" in fixed, robust=robust)


def _dynamic(d: Candidate, base: Setup, measurand: Measurand, fixed: dict[str, float],
             fluid: Fluid, by_name: Mapping[str, SensorChoice]) -> Candidate:
    """``d`` with its bandwidth and settling time measured (when not yet)."""
    if not math.isnan(d.bandwidth) or d.sensor not in by_name:
        return d
    try:
        setup = _design_setup(base, d.params).resolve_layout()
    except MagciliaError:
        return d
    task = _task(setup, by_name[d.sensor], measurand, fixed, DEFAULT_BANDWIDTH, fluid, 11)
    band, settle = dynamics(task)
    return replace(d, bandwidth=band, settling_time=settle)



def _design(params: dict[str, float], sensor: str, m: dict[str, Any],
            violated: str) -> Candidate:
    return Candidate(params=params, sensor=sensor, sensitivity=float(m["sensitivity"]),
                     minimum=float(m["minimum"]), range=float(m["range"]),
                     limited_by=str(m["limited_by"]), peak_field=float(m["peak_field"]),
                     violated=violated, reached=bool(m["reached"]),
                     bandwidth=float(m.get("bandwidth", math.nan)),
                     settling_time=float(m.get("settling_time", math.nan)),
                     error=float(m.get("error", math.nan)),
                     error_p95=float(m.get("error_p95", math.nan)))


def _violation(m: dict[str, Any], fixed: dict[str, float], choice: SensorChoice) -> str:
    """The first constraint an exactly measured design breaks ("" for none; the rated range
    ends the range, so a design beyond it at zero load has none)."""
    if str(m["limited_by"]).startswith("model error"):
        return "model error"
    if m["range"] <= 0.0:
        return "sensor range at zero load"
    if not math.isfinite(m["minimum"]):
        return "resolution (no slope)"
    if m["peak_field"] > choice.flip:
        return "flip field"
    if "minimum" in fixed and m["minimum"] > fixed["minimum"]:
        return "minimum"
    if "range" in fixed and m["range"] < fixed["range"]:
        return "range"
    band, settle = m.get("bandwidth", math.nan), m.get("settling_time", math.nan)
    if "bandwidth" in fixed and not band >= fixed["bandwidth"]:  # NaN (not known) fails
        return "bandwidth"
    if "settling" in fixed and not settle <= fixed["settling"]:
        return "settling"
    return ""



def _counts(counts: Mapping[str, int]) -> str:
    return ", ".join(f"{k}: {c}" for k, c in sorted(counts.items(), key=lambda kv: -kv[1]))
