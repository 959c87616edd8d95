"""The calibration's share of a single-output read-out's uncertainty: the output's 1 σ at the
table's nodes from a parameter covariance (linearised) or from posterior samples."""

from __future__ import annotations

import math

import numpy as np
from numpy.typing import NDArray

from magcilia import _validate as v
from magcilia.calibration import ParameterCovariance
from magcilia.calibration.posterior import Posterior
from magcilia.device.actuation import Actuation
from magcilia.device.parameters import PARAMETERS
from magcilia.device.setup import Setup
from magcilia.mechanics import Flow
from magcilia.readout.forward import model_output

F64 = NDArray[np.float64]

#: posterior samples a :class:`~magcilia.Readout` runs through the model for
#: ``sigma_calibration`` (the Monte-Carlo error of a standard deviation from n draws is about
#: 1/sqrt(2 n): 6 %)
POSTERIOR_DRAWS = 128


def calibration_sigma(setup: Setup, quantity: str, flow: Flow, nodes: F64,
                       calibration: ParameterCovariance | Posterior | None,
                       actuation: Actuation | None = None) -> F64:
    """1-σ output uncertainty (V) from the calibration covariance at the table ``nodes``, or
    from the spread of the model's output over posterior samples."""
    params = setup.params()
    if isinstance(calibration, Posterior):
        return _posterior_sigma(setup, quantity, flow, nodes, calibration, actuation)
    names, cov = _parameter_covariance(calibration, params)
    if not names:
        return np.zeros(nodes.size)
    q = np.linspace(nodes[0], nodes[-1], 33)
    jac = np.empty((q.size, len(names)))
    for j, name in enumerate(names):  # outputs are linear in the offset: any step is exact
        h = 1.0 if name == "offset" else 1e-3 * max(abs(params[name]), math.sqrt(cov[j, j]))
        up = model_output(setup.replace(**{name: params[name] + h}), quantity, q, flow,
                          actuation)
        down = model_output(setup.replace(**{name: params[name] - h}), quantity, q, flow,
                            actuation)
        jac[:, j] = (up - down) / (2.0 * h)
    var = np.einsum("qi,ij,qj->q", jac, cov, jac)
    return np.interp(nodes, q, np.sqrt(np.clip(var, 0.0, None)))


def _posterior_sigma(setup: Setup, quantity: str, flow: Flow, nodes: F64,
                     posterior: Posterior, actuation: Actuation | None = None) -> F64:
    """1-σ output spread (V) at the table ``nodes`` over :data:`POSTERIOR_DRAWS` posterior samples
    (evenly thinned: deterministic) of the setup's continuous parameters; the others keep the
    setup's values."""
    params = setup.params()
    cols = [i for i, n in enumerate(posterior.names)
            if n in params and PARAMETERS[n].domain != "integer"]
    if not cols:
        raise v.fail("calibration", f"a posterior of {', '.join(posterior.names)}",
                     "a posterior of setup parameters (height, base_radius, x, y, z, offset)")
    q = np.linspace(nodes[0], nodes[-1], 33)
    draws = posterior.draws(POSTERIOR_DRAWS)[:, cols]
    names = [posterior.names[i] for i in cols]
    out = np.array([model_output(setup.replace(**dict(zip(names, map(float, d), strict=True))),
                                 quantity, q, flow, actuation) for d in draws])
    spread = out.std(axis=0, ddof=1) if len(out) > 1 else np.zeros(q.size)
    return np.interp(nodes, q, spread)


def _parameter_covariance(cal: ParameterCovariance | None,
                          params: dict[str, float]) -> tuple[list[str], F64]:
    """Names of the continuous setup parameters with a finite covariance, and that covariance
    (SI; :meth:`ParameterCovariance.matrix`)."""
    if cal is None:
        return [], np.zeros((0, 0))
    all_names = list(cal.correlation_names)
    full = cal.matrix()
    keep = [i for i, n in enumerate(all_names)
            if n in params and PARAMETERS[n].domain != "integer"
            and math.isfinite(full[i, i]) and full[i, i] > 0.0]
    sub = full[np.ix_(keep, keep)]
    return [all_names[i] for i in keep], np.where(np.isfinite(sub), sub, 0.0)

