"""The numbers behind examples/array.toml and the README's array section, from the exact body.

For the example (a 4 × 4 grid of the paper's cilium, 4 mm pitch, MMC5983MA sensing points 1.5 mm
below the bases) and for the geometry it replaced (2.5 mm pitch, 1 mm below the bases, the
paper's 2 × 5 mean-ring layout), the field at every sensor at rest from the exact body (a stack
of 2000 magpylib cylinders per cilium, :func:`magcilia.exact_field`) against the dipole model the
array uses, the largest field on any sensor axis against the part's ±8 gauss, and the rest field
when the height of the sensing points is off by ±0.25 mm.

Run: python scripts/array_example.py
"""

from __future__ import annotations

from pathlib import Path

import numpy as np

import magcilia as mc
from magcilia.constants import GAUSS
from magcilia.model.exact import exact_field

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
