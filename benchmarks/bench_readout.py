"""``magcilia readout`` of 1e6 samples end to end (read, estimate, write) against pandas (issue 13).

Writes a recording of 1e6 samples (``time_s,voltage_V``: 1 kHz, the bundled force sensor
``examples/force-sensor.toml`` under a force that rests at 0 for 0.1 s, then ramps and steps over
0..0.2 mN, plus the sensor's noise; 10 significant digits of a volt, as a DAQ exports) to a
temporary folder, then times, interleaved in this process (min and median of the runs):

* **ours**: ``magcilia.cli.main(["readout", "--setup", SETUP, REC, "--quantity", "force", "--span",
  "0:0.2", "--csv", OUT, "--quiet"])``: loading the setup and building the read-out table (the
  model solved at 513 forces plus the edges), reading the CSV, value + 1-σ + flags for every
  reading, and writing the six-column CSV (``time_s, voltage_V, force_mN, sigma_force_mN, flags,
  flag_names``) atomically;
* **anchor** (the ordinary pandas route over the same, already built table):
  ``pd.read_csv(engine="c")``, ``np.interp`` over ``Readout.table`` (value only), and
  ``DataFrame.to_csv(float_format="%.10g")`` of ``time_s, voltage_V, force_mN``.

Also printed: where our time goes (one run, by stage), and the command's cost from a shell: a
fresh interpreter running ``readout --help`` (imports and start-up) and the whole command.
Target: ours <= 3 s.

Run: python benchmarks/bench_readout.py [--quick] [--samples N]
"""

from __future__ import annotations

import os

for _var in ("OMP_NUM_THREADS", "OPENBLAS_NUM_THREADS", "MKL_NUM_THREADS", "NUMBA_NUM_THREADS"):
    os.environ[_var] = "1"  # single thread, before NumPy loads BLAS

import argparse
import contextlib
import io
import statistics
import subprocess
import sys
import tempfile
import time
from pathlib import Path

import numpy as np
import pandas as pd
from _timing import interleaved

import magcilia as mc
from magcilia.cli import main as cli_main
from magcilia.io.recordings import read_samples
from magcilia.report import csvtext
from magcilia.report.readout import write_readout_csv

SETUP = Path(__file__).resolve().parents[1] / "examples" / "force-sensor.toml"
SPAN = (0.0, 2e-4)  # N
RATE = 1000.0  # Hz (one raw sample at 1 kHz: the default noise band)
TARGET = 3.0  # s


def recording(path: Path, samples: int, readout: mc.Readout) -> None:
    """The test recording: rest, a ramp to full scale and steps, the sensor's noise."""
    t = np.arange(samples) / RATE
    phase = (t % 100.0) / 100.0
    force = np.where(phase < 0.01, 0.0, np.where(phase < 0.5, SPAN[1] * (phase - 0.01) / 0.49,
                                                   SPAN[1] * np.round(8 * phase) / 8))
    table = readout.table
    clean = np.interp(force, table.quantity, table.output)  # the model at each force
    noise = readout.setup.sensor.noise(samples, RATE, rng=0)
    path.write_bytes(b"time_s,voltage_V\n" + csvtext.rows(
        [csvtext.shortest(t), csvtext.significant(clean + noise, 10)]))


def ours(setup: Path, rec: Path, out: Path) -> None:
    with contextlib.redirect_stdout(io.StringIO()):
        code = cli_main(["readout", "--setup", str(setup), str(rec), "--quantity", "force",
                         "--span", "0:0.2", "--csv", str(out), "--quiet"])
    assert code == 0


def anchor(readout: mc.Readout, rec: Path, out: Path) -> None:
    frame = pd.read_csv(rec, engine="c")
    table = readout.table
    frame["force_mN"] = np.interp(frame["voltage_V"].to_numpy(), table.volts, table.values) * 1e3
    frame.to_csv(out, index=False, float_format="%.10g")


def stages(setup: Path, rec: Path, out: Path) -> dict[str, float]:
    """One run of what the command does, stage by stage (s)."""
    t: dict[str, float] = {}
    t0 = time.perf_counter()
    s = mc.load_setup(setup)
    r = mc.Readout(s, quantity="force", span=SPAN)
    t["setup + table"] = time.perf_counter() - t0
    t0 = time.perf_counter()
    cols = read_samples(rec, required=("voltage_V",))
    t["read CSV"] = time.perf_counter() - t0
    t0 = time.perf_counter()
    result = r.read(cols["voltage_V"])
    t["estimate (value, 1-σ, flags)"] = time.perf_counter() - t0
    t0 = time.perf_counter()
    write_readout_csv(out, result, cols["voltage_V"], cols["time_s"])
    t["write CSV"] = time.perf_counter() - t0
    return t


def shell(args: list[str]) -> float:
    t0 = time.perf_counter()
    code = "import sys; from magcilia.cli import main; sys.exit(main(sys.argv[1:]))"
    subprocess.run([sys.executable, "-c", code, *args], check=True, capture_output=True)
    return time.perf_counter() - t0


def check(readout: mc.Readout, ours_out: Path, anchor_out: Path) -> None:
    """Our estimates agree with np.interp over the same table where both estimate (to the
    table's stated error: ours interpolates its uniform-output resampling)."""
    a = pd.read_csv(anchor_out)
    o = pd.read_csv(ours_out, keep_default_na=False, na_values=[""])
    inside = o["flags"].to_numpy() == 0
    assert inside.mean() > 0.95
    np.testing.assert_allclose(o["force_mN"].to_numpy()[inside],
                               a["force_mN"].to_numpy()[inside], rtol=0,
                               atol=2e3 * readout.table_error)
    assert o["force_mN"].notna().all()  # the noisy rest below 0 is extrapolated, not blank


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--quick", action="store_true", help="3 runs instead of 5")
    parser.add_argument("--samples", type=int, default=1_000_000)
    args = parser.parse_args()
    runs = 3 if args.quick else 5
    readout = mc.Readout(mc.load_setup(SETUP), quantity="force", span=SPAN)
    with tempfile.TemporaryDirectory() as tmp:
        rec = Path(tmp) / "rec.csv"
        recording(rec, args.samples, readout)
        out_ours, out_anchor = Path(tmp) / "ours.csv", Path(tmp) / "anchor.csv"
        ours(SETUP, rec, out_ours)  # warm: first-use compilation and caches
        anchor(readout, rec, out_anchor)
        check(readout, out_ours, out_anchor)
        times = interleaved({"ours": lambda: ours(SETUP, rec, out_ours),
                             "anchor": lambda: anchor(readout, rec, out_anchor)}, runs)
        parts = stages(SETUP, rec, out_ours)
        help_s = shell(["readout", "--help"])
        whole_s = shell(["readout", "--setup", str(SETUP), str(rec), "--quantity", "force",
                         "--span", "0:0.2", "--csv", str(out_ours), "--quiet"])
        size = (rec.stat().st_size / 1e6, out_ours.stat().st_size / 1e6,
                out_anchor.stat().st_size / 1e6)
    o, a = times["ours"], times["anchor"]
    print(f"readout of {args.samples:.0e} samples end to end (min, median of {runs} interleaved "
          f"runs; recording {size[0]:.1f} MB, our CSV {size[1]:.1f} MB, the anchor's "
          f"{size[2]:.1f} MB)")
    print(f"  magcilia readout (in-process main)  {min(o):7.3f} {statistics.median(o):7.3f} s "
          f"  target <= {TARGET:g} s: {'met' if statistics.median(o) <= TARGET else 'NOT met'}")
    print(f"  anchor: pandas read_csv + np.interp + to_csv  {min(a):7.3f} "
          f"{statistics.median(a):7.3f} s")
    print(f"  ratio anchor/ours  {min(a) / min(o):7.2f} "
          f"{statistics.median(a) / statistics.median(o):7.2f}")
    print("  ours by stage (one run): " + ", ".join(f"{k} {v:.3f} s" for k, v in parts.items()))
    print(f"  from a shell (fresh interpreter): `readout --help` {help_s:.2f} s (start-up), the "
          f"whole command {whole_s:.2f} s")


if __name__ == "__main__":
    main()
