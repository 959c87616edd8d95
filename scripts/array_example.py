"""The numbers behind examples/array.toml and the README's array section, from the exact body.

For the example (a 4 × 4 grid of the paper's cilium, 4 mm pitch, MMC5983MA sensing points 1.5 mm
below the bases) and for the geometry it replaced (2.5 mm pitch, 1 mm below the bases, the
paper's 2 × 5 mean-ring layout), the field at every sensor at rest from the exact body (a stack
of 2000 magpylib cylinders per cilium, :func:`magcilia.exact_field`) against the dipole model the
array uses, the largest field on any sensor axis against the part's ±8 gauss, and the rest field
when the height of the sensing points is off by ±0.25 mm. For the example under its span (the
``magcilia array`` default, 0.02 mN, with the file's modulus: the presets' assumed 0.669 MPa):
the tip's deflection and tilt, the gap left between neighbours bent toward each other, the
change of a cilium's own sensor against the part's noise, and the exact body's field with every
cilium bent by the span in 8 directions (the model's error there, and a bound on any load
within the span: the rest field plus, per sensor and axis, the largest change each cilium makes
in any of the 8 directions, summed over the cilia).

Run: python scripts/array_example.py
"""

from __future__ import annotations

from pathlib import Path

import numpy as np

import magcilia as mc
from magcilia.cli.array import DEFAULT_SPAN
from magcilia.constants import GAUSS
from magcilia.model.exact import exact_field
from magcilia.readout.array import field_for_loads

EXAMPLE = Path(__file__).resolve().parents[1] / "examples" / "array.toml"
#: cylinder slices per cilium of the exact reference (converged to ~1e-7 here)
SLICES = 2000


def exact(array: mc.CiliaArray) -> np.ndarray:
    """The exact body's field at every sensor at rest, T, (S, 3): all cilia superposed."""
    pts = np.asarray(array.sensor_positions)
    return np.asarray(sum(exact_field(c, np.array([0.0]), n_slices=SLICES, points=pts)[0]
                          for c in array.cilia))


def describe(title: str, array: mc.CiliaArray) -> None:
    b_exact = exact(array)
    b_model = array.field()
    err = np.linalg.norm(b_model - b_exact, axis=1) / np.linalg.norm(b_exact, axis=1)
    part = array.sensors[0]
    full = float(np.asarray(part.field_range)[0])
    c = array.cilia[0]
    print(f"{title}")
    print(f"  model: {c.n_loops}×{c.dipoles_per_loop} {c.ring} ({c.layout}); largest error "
          f"against the exact body at the sensors {100 * err.max():.3g} % (median "
          f"{100 * np.median(err):.3g} %)")
    print(f"  exact B_z at the sensors {b_exact[:, 2].min() / GAUSS:.3g} to "
          f"{b_exact[:, 2].max() / GAUSS:.3g} gauss (the model: {b_model[:, 2].min() / GAUSS:.3g} "
          f"to {b_model[:, 2].max() / GAUSS:.3g}); largest |B_i| on any axis "
          f"{np.abs(b_exact).max() / GAUSS:.3g} gauss, the {part.name.rsplit(' ', 1)[0]}'s range ±"
          f"{full / GAUSS:.3g} gauss: {int(np.sum(np.any(np.abs(b_exact) > full, axis=1)))} of "
          f"{array.n_sensors} sensors saturate")


def under_span(array: mc.CiliaArray, pitch: float, span: float = DEFAULT_SPAN) -> None:
    """The example under its span: deflection, neighbours' gap, own-sensor change against the
    noise, and the exact body's field with every cilium bent by the span (see the docstring)."""
    c = array.cilia[0]
    print(f"under the span {span * 1e3:.3g} mN ({c.modulus.note()}):")
    soft = c.youngs_modulus * (1.0 - c.modulus.relative)
    for label, setup in (("", c), (f" (E {soft / 1e6:.2g} MPa, 1 sigma softer)",
                                   c.replace(youngs_modulus=soft))):
        s = np.linspace(0.0, setup.cilium.height, 257)
        xz = mc.bend(setup, force=span).frames(s)[0][0][:, [0, 2]]
        reach = float(np.max(xz[:, 0] + setup.spec.radius(s)))  # horizontal reach, bent body
        tip = xz[-1]
        print(f"  tip deflection{label} {tip[0] * 1e3:.3g} mm (base to tip "
              f"{np.degrees(np.arctan2(*tip)):.3g} deg from vertical); two neighbours bent "
              f"toward each other leave {(pitch - 2 * reach) * 1e3:.3g} mm between them (pitch "
              f"{pitch * 1e3:.3g} mm)")
    pts = np.asarray(array.sensor_positions)
    rest = exact(array)
    noise = float(np.max(array.sigma))
    worst_model, changes, largest = 0.0, [], 0.0
    for phi in np.radians(np.arange(0.0, 360.0, 45.0)):
        force = (span * np.cos(phi), span * np.sin(phi), 0.0)
        each = np.stack([exact_field(k, mc.bend(k, force=force), n_slices=SLICES,
                                     points=pts)[0] for k in array.cilia])  # (C, S, 3)
        changes.append(each - np.stack([exact_field(k, np.array([0.0]), n_slices=SLICES,
                                                    points=pts)[0] for k in array.cilia]))
        total = each.sum(axis=0)
        largest = max(largest, float(np.abs(total).max()))
        model = field_for_loads(array, np.tile(force[:2], (len(array), 1)))
        err = np.linalg.norm(model - total, axis=1) / np.linalg.norm(total, axis=1)
        worst_model = max(worst_model, float(err.max()))
    change = np.stack(changes)  # (8, C, S, 3)
    own = np.linalg.norm(change[:, np.arange(len(array)), np.arange(len(array))], axis=-1)
    own_text = (f"{own.min() / GAUSS:.3g}" if np.ptp(own) < 1e-3 * own.max() else
                f"{own.min() / GAUSS:.3g}-{own.max() / GAUSS:.3g}")
    bound = np.abs(rest) + np.abs(change).max(axis=0).sum(axis=0)  # (S, 3)
    full = float(np.asarray(array.sensors[0].field_range)[0])
    print(f"  a cilium's own sensor moves by {own_text} gauss ({own.min() / noise:.3g}x or more "
          f"the part's {noise / GAUSS * 1e3:.2g} mG noise)")
    print(f"  every cilium bent by the span in one of 8 directions: largest |B_i| "
          f"{largest / GAUSS:.3g} gauss; the model is {100 * worst_model:.2g} % from the exact body"
          f" there; any loads within the span (bound): |B_i| <= {bound.max() / GAUSS:.3g} gauss"
          f" of the part's ±{full / GAUSS:.3g}")


def main() -> None:
    array = mc.load_array(EXAMPLE)
    describe(f"{EXAMPLE.name}: 4 × 4, 4 mm pitch, sensing points 1.5 mm below the bases", array)
    grid = mc.io.array_file.load_array_grid(EXAMPLE)
    assert grid is not None
    assert grid.depth is not None
    for shift in (-0.25e-3, 0.25e-3):
        depth = grid.depth + shift
        moved = mc.CiliaArray.grid(grid.setup.replace(z=grid.setup.position[2] + shift),
                                   grid.rows, grid.cols, grid.pitch, sensor=grid.sensor,
                                   depth=depth)
        print(f"  sensing points {depth * 1e3:.3g} mm below the bases: largest |B_i| "
              f"{np.abs(exact(moved)).max() / GAUSS:.3g} gauss")
    under_span(array, grid.pitch[0])
    print()
    old = grid.setup.replace(z=1e-3 - grid.setup.sensor.depth)
    for label, setup in (("the paper's layout (2 × 5 mean, as given)",
                          old.replace(n_loops=2, dipoles_per_loop=5, ring="mean")),
                         ("a converged layout", old.replace(layout="converged"))):
        import warnings

        with warnings.catch_warnings():
            warnings.simplefilter("ignore", mc.LayoutWarning)  # its error is printed below
            former = mc.CiliaArray.grid(setup, 4, 4, 2.5e-3, sensor=grid.sensor, depth=1e-3)
        describe(f"the former example (2.5 mm pitch, 1 mm below the bases), {label}", former)


if __name__ == "__main__":
    main()
