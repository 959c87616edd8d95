"""Make the coil calibration example (SYNTHETIC): examples/coil/coil_3axis.csv.

The force-sensor cilium of examples/coil/setup.toml, magnetized at 0.8 of φ·M_Co, under the
default coil sequence (:func:`magcilia.calibration.coil_model.default_sequence`: 43 applied fields
up to ¾ of the part's ±2 mT range), each bent by mc.bend(..., actuation=Actuation.uniform(B)) and
its field taken from the exact body (EXACT_SLICES magpylib cylinders), plus the applied field, a
constant background (the Earth's field and the part's offsets) and white noise of NOISE T RMS per
sample, SAMPLES samples per field. Columns: actuation_x_T, actuation_y_T, actuation_z_T,
field_x_T, field_y_T, field_z_T.

Run: python scripts/make_coil_recording.py
"""

from __future__ import annotations

import io
from pathlib import Path

import numpy as np

import magcilia as mc
from magcilia._atomic import write_text
from magcilia.calibration.coil_model import default_sequence
from magcilia.model.exact import exact_field

ROOT = Path(__file__).resolve().parents[1]
OUT = ROOT / "examples" / "coil" / "coil_3axis.csv"
SEED = 20261127
SAMPLES, NOISE, EXACT_SLICES = 10, 1.6e-9, 400
BACKGROUND = np.array([2e-5, -3e-5, 4e-5])  # T
MAGNETIZATION_SCALE = 0.8


def main() -> None:
    truth = mc.load_setup(ROOT / "examples" / "coil" / "setup.toml").replace(
        magnetization_scale=MAGNETIZATION_SCALE)
    applied = default_sequence(truth.sensor.field_range)
    rng = np.random.default_rng(SEED)
    rows = []
    for b in applied:
        shape = mc.bend(truth, 0.0, actuation=mc.Actuation.uniform(b))
        seen = exact_field(truth, shape, EXACT_SLICES)[0] + b + BACKGROUND
        for _ in range(SAMPLES):
            rows.append(np.concatenate([b, seen + NOISE * rng.standard_normal(3)]))
    text = io.StringIO()
    text.write("# SYNTHETIC coil recording (scripts/make_coil_recording.py): the force-sensor "
               "cilium of setup.toml, magnetization scale 0.8, exact body\n")
    text.write("actuation_x_T,actuation_y_T,actuation_z_T,field_x_T,field_y_T,field_z_T\n")
    for r in rows:
        text.write(",".join(f"{v:.9g}" for v in r) + "\n")
    write_text(OUT, text.getvalue())
    print(f"wrote {OUT.relative_to(ROOT)}: {len(rows)} samples, {applied.shape[0]} fields")


if __name__ == "__main__":
    main()
