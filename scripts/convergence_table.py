"""Convergence of the distributed-dipole model to the exact body (writes docs/convergence.md).

For the paper's cilium (Table I optimized: cone, L = 3.2613 mm, r_b = 0.1801 mm) the model's
field at the sensing element is compared with the exact reference (a stack of 2000 magpylib
Cylinder slices, converged to ~1e-6) over the 33 tilt angles 0–85°, for the paper's placement and
for a close placement (base 0.71 mm above the element, 0.5 mm to the side). The error is
max over angles of |B_model − B_exact| / |B_exact| (vector norm).

The second part is the layout rule every path that predicts a field follows
(``Setup.resolve_layout``, :mod:`magcilia.model.convergence`): the error of a layout at the points
where a path evaluates the field, probed in rigid tilts 0–85° toward ±x and ±y against 500-slice
stacks, before (the layouts of commit 031a2e8) and after; then what a sensor under the base needs.

Run: python scripts/convergence_table.py [--out docs/convergence.md]
"""

from __future__ import annotations

import argparse
import warnings
from pathlib import Path

import numpy as np

import magcilia as mc
from magcilia._atomic import write_text
from magcilia.cli._common import load_setup_arg
from magcilia.model import convergence as cv

EXAMPLES = Path(__file__).resolve().parents[1] / "examples"

ANGLES = np.radians(np.linspace(0.0, 85.0, 33))
NS = (1, 2, 4, 8, 16, 32, 64)
KS = (1, 3, 5, 8)
PLACEMENTS = {
    "paper placement (1.47, 1.99, 0.38) mm": {},
    "close placement (0.5, 0, 0) mm": {"position": (0.5e-3, 0.0, 0.0)},
}


def max_error(setup: mc.Setup, exact: np.ndarray) -> float:
    b = setup.field(ANGLES)
    return float(np.max(np.linalg.norm(b - exact, axis=1) / np.linalg.norm(exact, axis=1)))


def _percent(x: float) -> str:
    return f"{100 * x:.2g} %"


def _array_points(array: mc.CiliaArray) -> tuple[mc.Setup, np.ndarray]:
    """The first cilium and every sensor offset of the array's cilia, as points around it (the
    probe :func:`magcilia.device.array.resolve_layouts` uses for a grid of copies)."""
    rep = array.cilia[0]
    offsets = np.concatenate([np.asarray(array.sensor_positions) - c.base_centre
                              for c in array.cilia])
    return rep, rep.base_centre + np.unique(offsets.round(12), axis=0)


def bent_error(setup: mc.Setup) -> tuple[float, float]:
    """The largest error of ``setup``'s layout at its element over shapes bent by tip forces up to
    its design range toward ±x and ±y (against 2000-slice stacks), and the force range, N."""
    top = mc.design_metrics(setup, points=31).force.range
    shapes = mc.bend_sweep(setup, forces=np.linspace(0.0, top, 12))
    worst = 0.0
    for phi in np.radians([0.0, 90.0, 180.0, 270.0]):
        turned = mc.SpatialCentreline.from_planar(shapes, float(phi))
        exact = mc.exact_field(setup, turned, n_slices=2000)
        worst = max(worst, max_error_of(setup.field(turned), exact))
    return worst, top


def max_error_of(b: np.ndarray, exact: np.ndarray) -> float:
    return float(np.max(np.linalg.norm(b - exact, axis=1) / np.linalg.norm(exact, axis=1)))


def rule_lines() -> list[str]:
    """The layout rule before and after, at the points of the predictions."""
    sensor = load_setup_arg("force-sensor")
    probe = sensor.layout_check()
    bent, top = bent_error(sensor)
    lines = [
        "## The layout rule where fields are predicted",
        "",
        ("Every path that predicts a field for a user (`field`, `bend`, arrays, the force-vector "
        "read-out, the read-out tables, `design`, `optimise`, `live`/`dashboard`, the simulated "
        "source) resolves the setup's layout at the points where it evaluates the field "
        "(`Setup.resolve_layout`, `magcilia.model.convergence`): `layout = \"paper\"` (the "
        "paper's model by name: `Setup.paper()`, the `paper` and `paper-initial` presets and "
        "files with Table I's layouts, a paper-model fit) is used as is, so that replication "
        "stays exact; `\"converged\"` gets the "
        f"smallest rms-ring layout (k = {cv.DIPOLES}) within {100 * cv.TOLERANCE:g} % of the "
        "exact body there; `\"given\"` is used as is and warned about when its error exceeds "
        f"{100 * cv.WARN_ABOVE:g} %. The probe: the points, in rigid tilts "
        f"{', '.join(f'{np.degrees(t):g}' for t in cv.TILTS)}° toward ±x and ±y, against "
        f"{cv.REFERENCE_SLICES}-slice stacks (their own error ~4e-6 here). Rigid tilts stand "
        "for bent shapes: for the `force-sensor` preset bent by tip forces of 0 to "
        f"{top * 1e3:.2g} mN toward ±x and ±y its {probe.n_loops} × {probe.dipoles_per_loop} "
        f"layout is {_percent(bent)} off, the probe says {_percent(probe.error)}."),
        "",
        "| where the field is predicted | before: layout | error | after: layout | error |",
        "|---|---|---|---|---|",
    ]
    paper = mc.Setup.paper()
    err = cv.layout_error(paper, 2, 5, "mean")
    lay = probe
    lines.append(f"| `paper` preset at its element (by name: replication) | 2×5 mean | "
                 f"{_percent(err)} | 2×5 mean, unchanged | {_percent(err)} |")
    old = cv.layout_error(sensor, 24, 4, "rms")
    lines.append("| `force-sensor` preset at its element: `bend`, `readout`, `design`, "
                 "`optimise`'s reference, `live`, `dashboard` and the simulated source "
                 "(their default), "
                 "`readout --biaxial` with a 3-axis part there | 24×4 rms, given | "
                 f"{_percent(old)} | {lay.n_loops}×{lay.dipoles_per_loop} rms, converged | "
                 f"{_percent(lay.error)} |")
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", mc.LayoutWarning)
        grid = mc.io.array_file.load_array_grid(EXAMPLES / "array.toml")
        assert grid is not None
        before = mc.CiliaArray.grid(grid.setup.replace(z=1e-3 - grid.setup.sensor.depth,
                                                       n_loops=2, dipoles_per_loop=5,
                                                       ring="mean"),
                                    4, 4, 2.5e-3, sensor=grid.sensor, depth=1e-3)
    rep, pts = _array_points(before)
    old = cv.layout_error(rep, 2, 5, "mean", points=pts)
    after = mc.load_array(EXAMPLES / "array.toml")
    rep, pts = _array_points(after)
    lay = rep.layout_check(pts)
    lines.append("| `examples/array.toml` at its 16 sensors | 2×5 mean, sensors 1 mm below the "
                 f"bases | {_percent(old)} | {lay.n_loops}×{lay.dipoles_per_loop} rms, "
                 f"converged, 1.5 mm below | {_percent(lay.error)} |")
    lines += [
        "",
        ("A sensor on the axis, under the base of the `force-sensor` cilium (base radius "
        "0.18 mm), needs many slices of the rms ring; the paper's layout is far off there. "
        "The cost of a converged layout is its number of dipoles n·k per cilium (the field's "
        "cost is linear in it; read-out tables are built once, so the per-reading paths do not "
        "change), and finding it costs one exact reference (milliseconds, once per geometry "
        "and points in a process):"),
        "",
        "| sensor below the base | 2×5 mean | converged layout | its error | n·k |",
        "|---|---|---|---|---|",
    ]
    for depth in (0.5e-3, 1.0e-3, 1.5e-3, 2.0e-3):
        s = mc.Setup.paper(tip_radius=5e-5, position=(0.0, 0.0, depth))
        point = s.base_centre - [0.0, 0.0, depth]
        lay = cv.converged_layout(s, points=[point])
        coarse = cv.layout_error(s, 2, 5, "mean", points=[point])
        note = "" if lay.converged else " (not reached)"
        lines.append(f"| {depth * 1e3:g} mm | {_percent(coarse)} | {lay.n_loops}×"
                     f"{lay.dipoles_per_loop} rms{note} | {_percent(lay.error)} | "
                     f"{lay.n_loops * lay.dipoles_per_loop} |")
    lines.append("")
    return lines


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--out", default="docs/convergence.md")
    args = parser.parse_args()
    lines = [
        "# Convergence of the distributed-dipole model",
        "",
        "Generated by `python scripts/convergence_table.py`. "
        + __doc__.split("\n\n")[1].replace("\n", " "),
        "",
    ]
    for title, overrides in PLACEMENTS.items():
        base = mc.Setup.paper(**overrides)
        exact = mc.exact_field(base, ANGLES, n_slices=2000)
        dist = np.linalg.norm(base.base_centre) * 1e3
        lines += [f"## {title} (element {dist:.2f} mm from the base centre)", ""]
        header = "| n \\ k | " + " | ".join(f"mean, k={k}" for k in KS) + " | " + " | ".join(
            f"rms, k={k}" for k in KS) + " |"
        lines += [header, "|" + "---|" * (1 + 2 * len(KS))]
        for n in NS:
            cells = []
            for ring in ("mean", "rms"):
                for k in KS:
                    s = base.replace(n_loops=n, dipoles_per_loop=k, ring=ring)
                    cells.append(f"{100 * max_error(s, exact):.3g} %")
            lines.append(f"| {n} | " + " | ".join(cells) + " |")
        lines.append("")
    lines += [
        "Reading:",
        "",
        "- The paper's fitted model (n = 2, k = 5, mean ring) is 17 % (paper placement) to 55 %",
        "  (close placement) away from the exact body; its fitted parameters absorb that error,",
        "  so Table I's geometry is model-dependent, not a measurement of the cilium.",
        "- The rms ring (sqrt<rho²>) converges to the exact body, roughly as O(1/n²) once k ≥ 5.",
        "- The paper's mean ring does *not* converge: it plateaus (≈ 0.25 % and ≈ 3.5 % here)",
        "  because a ring at the mean radius overstates each slice's second radial moment.",
        "- k = 1 never converges either: its single dipole sits off the axis, at azimuth 0.",
        "  Beyond k = 3 (mean) or k = 5 (rms), k hardly matters, as the paper found (fig. 11).",
        "",
    ]
    lines += rule_lines()
    write_text(Path(args.out), "\n".join(lines))
    print("\n".join(lines))


if __name__ == "__main__":
    main()
