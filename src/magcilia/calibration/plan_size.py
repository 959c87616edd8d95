"""How large a calibration plan may be (:mod:`magcilia.calibration.plan`): the D-optimal search
is Fedorov's exchange from a greedy and several random starts, and its cost grows as the square
of the budget and of the number of candidates; a plan is refused, in one line naming the limit
and the largest budget that fits, before any work when it would take more than about a minute."""

from __future__ import annotations

from magcilia import _validate as v

#: most work a plan may ask of the exchange, in units of p³ (one p × p log det is ~p³/3 flops):
#: :func:`exchange_work`, an upper bound about twice the work done (a random start needs up to
#: N swaps, each evaluating all c candidates against each of up to min(N, c) design points).
#: At the limit about a minute on one core (0.5 µs per 7 × 7 log det, batched): with the
#: default 70 candidates of ``magcilia plan`` (p = 7) a budget of up to 2,974 readings
MAX_WORK = 6e10
#: most entries c · p² of the candidates' information matrices held at once (0.4 GB)
MAX_INFORMATION = 50_000_000


def exchange_work(budget: int, candidates: int, parameters: int,
                  restarts: int) -> float:
    """The work bound of :func:`~magcilia.calibration.doptimal.d_optimal` (units of p³,
    compared with :data:`MAX_WORK`):
    ``(restarts + 2) · N · min(N, c) · c · p³`` for N readings, c candidates and p parameters
    (the greedy start, its exchange and each random start's)."""
    n, c, p = float(budget), float(candidates), float(max(parameters, 1))
    return (restarts + 2) * n * min(n, c) * c * p**3


def _largest_budget(candidates: int, parameters: int, restarts: int) -> int:
    """The largest budget whose :func:`exchange_work` is within :data:`MAX_WORK`."""
    lo, hi = 0, 1
    while exchange_work(hi, candidates, parameters, restarts) <= MAX_WORK:
        lo, hi = hi, 2 * hi
    while hi - lo > 1:
        mid = (lo + hi) // 2
        lo, hi = (mid, hi) if exchange_work(mid, candidates, parameters,
                                           restarts) <= MAX_WORK else (lo, mid)
    return lo


def check_plan_size(budget: int, candidates: int, parameters: int,
                    restarts: int) -> None:
    """Refuse (a one-line error naming the limit and the fix) a plan beyond :data:`MAX_WORK`
    or :data:`MAX_INFORMATION`, before any work."""
    if candidates * parameters**2 > MAX_INFORMATION:
        raise v.fail("candidates", f"{candidates} candidates of {parameters} parameters",
                     f"at most {MAX_INFORMATION:,} entries of information matrices "
                     "(MAX_INFORMATION, candidates × parameters²): offer fewer angles (a larger "
                     "step) or azimuths")
    if exchange_work(budget, candidates, parameters, restarts) > MAX_WORK:
        most = _largest_budget(candidates, parameters, restarts)
        raise v.fail("budget", budget,
                     f"at most {most} readings for {candidates} candidates and {parameters} "
                     "parameters (MAX_WORK: Fedorov's exchange grows as budget² × candidates²;"
                     " about a minute at the limit): plan fewer readings, or offer fewer angles "
                     "(a larger step) or azimuths")
