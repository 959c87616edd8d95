"""The checks an array's read-out makes at construction: cilia that would touch, sensors within a
cilium's reach, and problems the sensors cannot solve (one-line errors naming cilia and sensors).
Each takes the :class:`~magcilia.ArrayReadout` being built (its array, spans, kinds and crosstalk
matrix).
"""

from __future__ import annotations

from typing import Any

import numpy as np
from numpy.typing import NDArray

from magcilia import _validate as v
from magcilia._display import si
from magcilia.mechanics import bend, bend_sweep

F64 = NDArray[np.float64]


def check_reach(readout: Any) -> None:
    """Refuse cilia that touch when bent toward each other by their spans' loads, and sensors
    within a cilium's reach (:func:`check_sensor_reach`)."""
    arr = readout.array
    b = arr.bases
    reach = np.empty(len(arr))
    shapes = []
    solved: dict[int, tuple[F64, F64]] = {}  # one shape per kind (the kind holds the span)
    for c, setup in enumerate(arr.cilia):
        kind = int(readout.kinds[c])
        if kind not in solved:
            s = np.linspace(0.0, setup.cilium.height, 65)
            solved[kind] = (bend(setup, force=float(readout.span[c])).frames(s)[0],
                            setup.spec.radius(s))
        pts, radius = solved[kind]
        shapes.append((pts[0, :, 0], pts[0, :, 2] + b[c, 2], radius))
        reach[c] = float(np.max(pts[0, :, 0] + radius))
    check_sensor_reach(readout)
    dist = np.hypot(b[:, None, 0] - b[None, :, 0], b[:, None, 1] - b[None, :, 1])
    close = np.argwhere(np.triu(dist < reach[:, None] + reach[None], 1))
    for i, j in close.tolist():
        xa, za, ra = shapes[i]
        xb, zb, rb = shapes[j]
        gap = np.hypot((dist[i, j] - xb)[None, :] - xa[:, None], zb[None, :] - za[:, None])
        gap -= ra[:, None] + rb[None, :]
        if gap.min() < 0.0:
            raise v.fail("span", f"{si(float(readout.span[i]), 'N')} for cilia "
                         f"{arr.names[i]} and {arr.names[j]} ({dist[i, j] * 1e3:.4g} mm apart)",
                         "loads the cilia can take without touching: bent toward each "
                         "other by it they meet; use a larger pitch or a smaller span")

def check_sensor_reach(readout: Any) -> None:
    """No sensor within the region a cilium sweeps under loads up to its span in any
    direction: the closest approach of a cilium bent in the vertical plane through a point is
    when it bends toward the point, so each sensor is tested in that plane against the
    shapes at 9 loads from 0 to the span (point-to-segment distances less the radius)."""
    arr = readout.array
    near = arr._within_reach  # (C, S)
    if not near.any():
        return
    pts = np.asarray(arr.sensor_positions)
    sweeps: dict[int, tuple[F64, F64, F64]] = {}
    for c in np.nonzero(near.any(axis=1))[0].tolist():
        setup, kind = arr.cilia[c], int(readout.kinds[c])
        if kind not in sweeps:
            loads = np.linspace(0.0, float(readout.span[c]), 9)
            s = np.linspace(0.0, setup.cilium.height, 129)
            shapes = bend_sweep(setup, forces=loads)
            sweeps[kind] = (shapes.frames(s)[0][..., [0, 2]], setup.spec.radius(s), loads)
        xz, radius, loads = sweeps[kind]  # (9, 129, 2), (129,), (9,)
        rel = pts[near[c]] - arr.bases[c]
        q = np.stack([np.hypot(rel[:, 0], rel[:, 1]), rel[:, 2]], axis=1)  # (o, 2)
        a, seg = xz[:, :-1], np.diff(xz, axis=1)  # (9, 128, 2)
        d = q[:, None, None, :] - a[None]
        t = np.clip(np.einsum("olmi,lmi->olm", d, seg) / np.einsum("lmi,lmi->lm", seg, seg),
                    0.0, 1.0)
        gap = np.linalg.norm(d - t[..., None] * seg[None], axis=-1) \
            - (radius[:-1] + t * np.diff(radius))
        if gap.min() <= 0.0:
            o, load, _ = np.unravel_index(int(np.argmin(gap)), gap.shape)
            s_idx = int(np.nonzero(near[c])[0][o])
            raise v.fail("sensors", f"sensor {s_idx + 1} at "
                         f"({', '.join(f'{x * 1e3:.4g}' for x in pts[s_idx])}) mm",
                         f"sensing points clear of the cilia under load; cilium "
                         f"{arr.names[c]} bent toward it by {si(float(loads[load]), 'N')} "
                         "reaches it: move the sensor or use a smaller span")

def check_singular(readout: Any) -> None:
    """Refuse problems with fewer readings than unknowns, a cilium whose full-span load moves no
    reading by one σ in some direction, or cilia whose loads the sensors cannot tell apart."""
    arr = readout.array
    c_n, rows = len(arr), 3 * arr.n_sensors
    if rows < 2 * c_n:
        raise v.fail("sensors", f"{arr.n_sensors} sensors ({rows} readings)",
                     f"at least as many readings as unknowns: {2 * c_n} (Fx, Fy of "
                     f"{c_n} cilia); add sensors")
    jw = readout.jacobian / arr.sigma.reshape(-1)[:, None] * np.repeat(readout.span, 2)[None, :]
    if not np.isfinite(jw).all():  # a span so small that its finite differences underflow
        raise v.fail("span", si(float(readout.span.min()), "N"),
                     "a span the model resolves (its finite differences are not finite "
                     "here), e.g. 2e-5 N")
    for c in range(c_n):
        sv = np.linalg.svd(jw[:, 2 * c:2 * c + 2], compute_uv=False)
        if sv[-1] < 1.0:
            raise v.fail("array", f"cilium {arr.names[c]}",
                         f"cilia whose load reaches a sensor; a full-span load "
                         f"({si(float(readout.span[c]), 'N')}) on {arr.names[c]} moves no "
                         f"reading by more than {sv[-1]:.3g} σ in its weakest direction: "
                         "move a sensor closer to it, or remove it")
    _, sv, vt = np.linalg.svd(jw, full_matrices=False)
    if sv[-1] < 1.0:
        weights = np.hypot(vt[-1, 0::2], vt[-1, 1::2])
        a, b = (arr.names[int(k)] for k in np.argsort(weights)[::-1][:2])
        raise v.fail("array", f"cilia {a} and {b}",
                     f"cilia whose loads the sensors can tell apart; the loads of {a} and "
                     f"{b} differ at the sensors by less than one σ per span (singular "
                     f"value {sv[-1]:.3g}): add or move sensors, or widen the span")
