"""How far a design's sweeps go, and the fields along them.

A force sweep runs to the elastica's large-deflection limit: the force whose *linear* tip
deflection would be :data:`DEFLECTION_LIMIT` cilium heights, ``3 L / C`` (C the small-load tip
compliance, :func:`magcilia.mechanics.tip_compliance`), where the cilium is bent far over
(:func:`force_limit`). A flow sweep runs to the speed whose drag on the upright cilium is that
force, or to the drag law's Reynolds limit, whichever is lower (:func:`flow_limit`). Both the
design metrics and the optimiser's exact metrics and screen end their sweeps here; a range that
the sweep does not reach is a lower bound (:mod:`magcilia.design.ranges`).
"""

from __future__ import annotations

from typing import Any

import numpy as np
from numpy.typing import NDArray

from magcilia._errors import MagciliaError
from magcilia.device.setup import Setup
from magcilia.mechanics import Flow, Fluid, bend_sweep
from magcilia.mechanics.drag import max_speed

F64 = NDArray[np.float64]

#: the large-deflection limit: linear tip deflection in cilium heights, where every sweep ends
DEFLECTION_LIMIT = 3.0
#: what ends a sweep of each measurand before its read-out ends (the range is then a lower bound)
SWEEP_ENDS = {"force": "the sweep ends at a tip deflection ≈ L",
              "flow": "the sweep ends where the cilium is strongly bent",
              "drag": "the drag law ends at Re 2e5", "angle": "the sweep ends at 90 deg"}


def force_limit(height: Any, compliance: Any) -> Any:
    """The end of a force sweep, N: the force whose linear tip deflection is
    :data:`DEFLECTION_LIMIT` heights, ``3 L / C`` (``height`` L in m, ``compliance`` C in m/N;
    arrays broadcast)."""
    return DEFLECTION_LIMIT * height / compliance


def flow_limit(force: Any, diameter: Any, height: Any, fluid: Fluid) -> tuple[Any, Any]:
    """The end of a flow sweep, m/s: the lower of the speed whose drag on the upright cilium
    (``½ ρ (U/2)² d L``) is ``force`` (N, :func:`force_limit`) and the drag law's Reynolds limit
    past ``diameter`` (m; :func:`magcilia.mechanics.drag.max_speed`); ``height`` L in m, arrays
    broadcast. Also whether the drag law's limit is the lower one (the sweep then ends there:
    ``SWEEP_ENDS["drag"]``)."""
    u_drag = 2.0 * np.sqrt(force / (0.5 * fluid.density * diameter * height))
    u_re = max_speed(diameter, fluid)
    return np.minimum(u_drag, u_re), u_re <= u_drag


def sweep_fields(setup: Setup, values: F64, flow: Flow | None) -> tuple[F64, F64, str]:
    """The field at the element along an increasing sweep of tip forces (``flow`` None, N) or
    flow speeds (m/s), in chunks, stopping at the first load the solver does not converge for.

    Returns
    -------
    values : ndarray, shape (c,)
        The loads reached (c ≤ the loads given).
    fields : ndarray, shape (c, 3)
        B at the element, T.
    note : str
        Why the sweep stopped early ("" if it did not).
    """
    done_q: list[F64] = []
    done_b: list[F64] = []
    note = ""
    for chunk in np.array_split(values, max(1, values.size // 25)):
        try:
            shapes = bend_sweep(setup, forces=chunk) if flow is None else \
                bend_sweep(setup, speeds=chunk, flow=flow)
        except MagciliaError as exc:
            note = f"solver limit ({exc})"
            break
        done_q.append(chunk)
        done_b.append(setup.field(shapes))
    if not done_q:
        return np.zeros(0), np.zeros((0, 3)), note
    return np.concatenate(done_q), np.concatenate(done_b), note
