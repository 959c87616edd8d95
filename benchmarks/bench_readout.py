"""The single-output read-out at memory speed (issue 27, item 4): ``Readout.read`` and
``Readout.estimate`` per second, and ``magcilia readout`` of 1e6 samples from a shell.

1. **read / estimate** (the bundled force sensor ``examples/force-sensor.toml``, 0..0.2 mN, its
   257-point table, readings uniform over the span's outputs) at 1e3, 1e5, 1e6 and 1e7 readings,
   interleaved in this process, one thread (min and median): ``read`` (value, σ, its noise part
   and flags written by the call into one fresh allocation; the calibration and edge parts zeroed
   (``np.zeros``), written only where a reading has no estimate; the force-scale part, exactly
   |value| · σ_E/E for this tip force, formed by the result when asked: "+ σ_scale" times the
   call and that ask) and ``estimate`` (value), against **a plain numba fused loop** over the
   same uniform
   output cells (value, σ = |slope| · noise and the span/saturation flags into three fresh
   arrays; value alone for ``estimate``): what one would write by hand. Targets: read ≥ 2e8/s,
   estimate ≥ 4e8/s (at 1e6).
2. **magcilia readout** of a 1e6-sample recording (``time_s,voltage_V``: 1 kHz, rest, a ramp and
   steps over 0..0.2 mN, the sensor's noise; 10 significant digits of a volt, as a DAQ exports)
   from a shell: a fresh interpreter per run, median of the runs, interleaved with **the pyarrow
   route** in a fresh interpreter (``pyarrow.csv.read_csv`` → ``np.interp`` over the same table
   for the value and its slope's σ, the flags by comparison → ``pyarrow.csv.write_csv`` of
   ``time_s, voltage_V, force_mN, sigma_force_mN, flags``, the estimates rounded to 10 and 4
   digits first). Also: our part, in process and stage by stage (setup + table, reading the CSV,
   ``read``, writing the CSV), and the start-up (``readout --help`` from a shell). Target:
   ≤ 1 s from a shell.

The machine (CPU, cores) and its load (``os.getloadavg``) are printed: the machine may be shared,
so compare the ratios, measured in one run.

Run: python benchmarks/bench_readout.py [--quick] [--samples N]
"""

from __future__ import annotations

import os

for _var in ("OMP_NUM_THREADS", "OPENBLAS_NUM_THREADS", "MKL_NUM_THREADS", "NUMBA_NUM_THREADS"):
    os.environ[_var] = "1"  # single thread, before NumPy loads BLAS

import argparse
import contextlib
import io
import platform
import resource
import statistics
import subprocess
import sys
import tempfile
import time
from collections.abc import Callable
from pathlib import Path

import numba
import numpy as np
from _timing import interleaved

import magcilia as mc
from magcilia.cli import main as cli_main
from magcilia.io.recordings import read_samples
from magcilia.readout import compiled as compiled_read
from magcilia.report import csvtext
from magcilia.report.readout import write_readout_csv

ROOT = Path(__file__).resolve().parents[1]
SETUP = ROOT / "examples" / "force-sensor.toml"
SPAN = (0.0, 2e-4)  # N
RATE = 1000.0  # Hz (one raw sample at 1 kHz: the default noise band)
SIZES = (1_000, 100_000, 1_000_000, 10_000_000)
TARGETS = {"read": 2e8, "estimate": 4e8, "shell": 1.0}
COMMAND = ["readout", "--setup", str(SETUP), "{rec}", "--quantity", "force", "--span", "0:0.2",
           "--csv", "{out}", "--quiet"]

#: the pyarrow route, run in a fresh interpreter: argv = recording, table .npz, output CSV
ARROW_ROUTE = """
import sys
import numpy as np
import pyarrow as pa
import pyarrow.csv as pc
rec, tab, out = sys.argv[1:4]
t = np.load(tab)
data = pc.read_csv(rec, read_options=pc.ReadOptions(use_threads=False))
v = data.column("voltage_V").to_numpy()
lo, hi = t["volts"][0], t["volts"][-1]
inside = (v >= lo) & (v <= hi)
sat = ~(np.abs((v - t["offset"]) / t["scale"]) <= t["field_range"])
flags = (~inside).astype(np.uint16) | sat.astype(np.uint16) * 4
value = np.interp(v, t["volts"], t["values"])
sigma = np.abs(np.interp(v, t["volts"], t["slope"])) * t["noise"]
bad = flags != 0
def digits(x, p):
    a = np.abs(x)
    with np.errstate(divide="ignore", invalid="ignore"):
        e = np.floor(np.log10(np.where(a > 0, a, 1.0)))
    s = 10.0 ** (p - 1 - e)
    return np.rint(x * s) / s
table = pa.table({"time_s": data.column("time_s"), "voltage_V": data.column("voltage_V"),
                  "force_mN": pa.array(digits(value * 1e3, 10), mask=bad),
                  "sigma_force_mN": pa.array(digits(sigma * 1e3, 4), mask=bad),
                  "flags": flags})
pc.write_csv(table, out, write_options=pc.WriteOptions(quoting_style="none"))
"""


def machine() -> str:
    """CPU model, cores and the load averages."""
    cpu = platform.processor() or platform.machine()
    with contextlib.suppress(OSError):
        for line in Path("/proc/cpuinfo").read_text().splitlines():
            if line.startswith("model name"):
                cpu = line.split(":", 1)[1].strip()
                break
    load = ", ".join(f"{x:.2f}" for x in os.getloadavg())
    return (f"{cpu}, {os.cpu_count()} cores; load {load} (1, 5, 15 min); Python "
            f"{platform.python_version()}, NumPy {np.__version__}, numba {numba.__version__}")


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


# -- 1. read and estimate against a plain fused loop --------------------------------------------
@numba.njit(cache=True, error_model="numpy")
def plain_read(x: np.ndarray, v0: float, v_end: float, per_volt: float, start: np.ndarray,
               step: np.ndarray, slope: np.ndarray, noise: float, sat_lo: float,
               sat_hi: float) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """The hand-written reference: value, σ = |slope| · noise and flags, one loop."""
    n = x.size
    value = np.empty(n)
    sigma = np.empty(n)
    flags = np.empty(n, np.uint16)
    last = start.size - 1
    for r in range(n):
        xi = x[r]
        inside = xi >= v0 and xi <= v_end
        f = (0 if inside else 1) | (0 if sat_lo <= xi <= sat_hi else 4)
        u = ((xi if inside else v0) - v0) * per_volt
        i = min(int(u), last)
        flags[r] = f
        value[r] = step[i] * (u - i) + start[i] if f == 0 else np.nan
        sigma[r] = abs(slope[i]) * noise if f == 0 else np.nan
    return value, sigma, flags


@numba.njit(cache=True, error_model="numpy")
def plain_estimate(x: np.ndarray, v0: float, per_volt: float, start: np.ndarray,
                   step: np.ndarray) -> np.ndarray:
    """The hand-written reference of the value alone."""
    value = np.empty(x.size)
    last = start.size - 1
    for r in range(x.size):
        u = (x[r] - v0) * per_volt
        i = max(min(int(u), last), 0)
        value[r] = step[i] * (u - i) + start[i]
    return value


def speeds(readout: mc.Readout, quick: bool) -> None:
    t = readout.table
    sensor = readout.setup.sensor
    noise = sensor.output_noise_rms(0.5, 500.0)
    slope_cells = np.interp(t.volts[0] + np.arange(t.cell_start.size) / t.cells_per_volt,
                            t.volts, t.slope)
    sat = (sensor.offset - sensor.field_range * abs(sensor.scale),
           sensor.offset + sensor.field_range * abs(sensor.scale))
    rng = np.random.default_rng(1)
    packed, read_pass = readout._packed, compiled_read.kernels()[0]  # type: ignore[index]
    print("read / estimate, readings per second (min, median; one thread, interleaved; the "
          "result's arrays allocated by each call; + σ_scale: read and the force-scale part it "
          "leaves to the result to form; pass alone: read's compiled pass into arrays allocated "
          "once, what the allocation leaves)")
    print(f"  {'readings':>10}  {'read':>9} {'median':>9}  {'plain loop':>10} {'ratio':>6}   "
          f"{'estimate':>9} {'median':>9}  {'plain loop':>10} {'ratio':>6}   {'pass alone':>10}"
          f"  {'+ σ_scale':>9}")
    for n in SIZES:
        x = rng.uniform(t.volts[0], t.volts[-1], n)
        runs: dict[str, Callable[[], object]] = {
            "read": lambda x=x: readout.read(x),
            "plain read": lambda x=x: plain_read(x, t.volts[0], t.volts[-1], t.cells_per_volt,
                                                 t.cell_start, t.cell_step, slope_cells, noise,
                                                 *sat),
            "estimate": lambda x=x: readout.estimate(x),
            "plain estimate": lambda x=x: plain_estimate(x, t.volts[0], t.cells_per_volt,
                                                         t.cell_start, t.cell_step)}
        outs = (*(np.empty(n) for _ in range(6)), np.empty(n, np.uint16))
        runs["pass alone"] = lambda x=x, outs=outs: read_pass(x, 0.0, noise, 0.0, *packed, *outs)
        runs["+ scale"] = lambda x=x: readout.read(x).sigma_scale
        for run in runs.values():
            run()  # compile, warm
        repeat = max(3 if quick else 5, min(200 if quick else 1000, int(3e6 / n)))
        times = interleaved(runs, repeat)
        best = {k: n / min(v) for k, v in times.items()}
        med = {k: n / statistics.median(v) for k, v in times.items()}
        print(f"  {n:>10.0e}  {best['read']:9.3g} {med['read']:9.3g}  {best['plain read']:10.3g} "
              f"{best['read'] / best['plain read']:5.2f}×   {best['estimate']:9.3g} "
              f"{med['estimate']:9.3g}  {best['plain estimate']:10.3g} "
              f"{best['estimate'] / best['plain estimate']:5.2f}×   {best['pass alone']:10.3g}"
              f"  {best['+ scale']:9.3g}")
        if n == 1_000_000:
            summary = (best["read"], best["estimate"])
            alone = [time.perf_counter()]
            for _ in range(repeat):  # read in a loop of its own: the allocator's memory reused
                readout.read(x)
                alone.append(time.perf_counter())
            own = n / min(np.diff(alone))
    print(f"  at 1e6: read {summary[0]:.3g}/s (target ≥ {TARGETS['read']:.0e}: "
          f"{'met' if summary[0] >= TARGETS['read'] else 'NOT met'}), estimate "
          f"{summary[1]:.3g}/s (target ≥ {TARGETS['estimate']:.0e}: "
          f"{'met' if summary[1] >= TARGETS['estimate'] else 'NOT met'}); read in a loop of "
          f"its own (no other allocation between calls: the pages of the last call's result "
          f"reused, not faulted in afresh) {own:.3g}/s")
    for n in (1, 10, 100):  # a live read-out's call
        x = rng.uniform(t.volts[0], t.volts[-1], n)
        readout.read(x)
        per = min(_per_call(lambda x=x: readout.read(x)) for _ in range(5))
        est = min(_per_call(lambda x=x: readout.estimate(x)) for _ in range(5))
        print(f"  a call of {n:>3} readings: read {per * 1e6:.2f} µs, estimate {est * 1e6:.2f} µs")


def _per_call(fn: Callable[[], object], calls: int = 2000) -> float:
    t0 = time.perf_counter()
    for _ in range(calls):
        fn()
    return (time.perf_counter() - t0) / calls


# -- 2. magcilia readout from a shell against the pyarrow route ---------------------------------
def stages(rec: Path, out: Path) -> dict[str, float]:
    """One run of what the command does, stage by stage, in this process (s)."""
    t: dict[str, float] = {}
    t0 = time.perf_counter()
    r = mc.Readout(mc.load_setup(SETUP), quantity="force", span=SPAN)
    t["setup + table"] = time.perf_counter() - t0
    t0 = time.perf_counter()
    cols = read_samples(rec, required=("voltage_V",))
    t["read CSV"] = time.perf_counter() - t0
    t0 = time.perf_counter()
    result = r.read(cols["voltage_V"])
    t["read (value, σ, flags)"] = time.perf_counter() - t0
    t0 = time.perf_counter()
    write_readout_csv(out, result, cols["voltage_V"], cols["time_s"])
    t["write CSV"] = time.perf_counter() - t0
    return t


def ours_in_process(rec: Path, out: Path) -> None:
    args = [a.format(rec=rec, out=out) for a in COMMAND]
    with contextlib.redirect_stdout(io.StringIO()):
        assert cli_main(args) == 0


#: CPU seconds (user + system) of each fresh interpreter, by name: what a busy machine's
#: wall times hide
CPU: dict[str, list[float]] = {}


def shell(args: list[str], name: str = "") -> Callable[[], None]:
    def run() -> None:
        before = resource.getrusage(resource.RUSAGE_CHILDREN)
        subprocess.run([sys.executable, *args], check=True, capture_output=True, cwd=ROOT)
        after = resource.getrusage(resource.RUSAGE_CHILDREN)
        CPU.setdefault(name, []).append(after.ru_utime - before.ru_utime
                                        + after.ru_stime - before.ru_stime)
    return run


def check(ours: Path, arrow: Path, readout: mc.Readout) -> None:
    """Both routes' estimates agree where both estimate (to the table's stated error: ours
    interpolates its uniform-output resampling, the route the table's nodes)."""
    import pyarrow.csv as pc

    o = pc.read_csv(ours)
    a = pc.read_csv(arrow)
    flags = o.column("flags").to_numpy()
    both = (flags == 0) & (a.column("flags").to_numpy() == 0)
    assert both.mean() > 0.9
    np.testing.assert_allclose(o.column("force_mN").to_numpy()[both],
                               a.column("force_mN").to_numpy()[both], rtol=0,
                               atol=2e3 * readout.table_error + 1e-9)


def commands(readout: mc.Readout, samples: int, runs: int) -> None:
    try:
        import pyarrow as pa  # noqa: F401
    except ImportError:
        print("magcilia readout from a shell: pyarrow is not installed (the anchor); skipped")
        return
    with tempfile.TemporaryDirectory() as tmp:
        rec, out, arrow = Path(tmp) / "rec.csv", Path(tmp) / "ours.csv", Path(tmp) / "arrow.csv"
        tab = Path(tmp) / "table.npz"
        recording(rec, samples, readout)
        s = readout.setup.sensor
        np.savez(tab, volts=readout.table.volts, values=readout.table.values,
                 slope=readout.table.slope, offset=s.offset, scale=s.scale,
                 field_range=s.field_range, noise=s.output_noise_rms(0.5, 500.0))
        ours_args = ["-m", "magcilia", *(a.format(rec=rec, out=out) for a in COMMAND)]
        arrow_args = ["-c", ARROW_ROUTE, str(rec), str(tab), str(arrow)]
        shell(ours_args)()  # warm the disk caches and numba's cache
        shell(arrow_args)()
        check(out, arrow, readout)
        ours_in_process(rec, out)
        CPU.clear()
        times = interleaved({"ours": shell(ours_args, "ours"), "arrow": shell(arrow_args, "arrow"),
                             "help": shell(["-m", "magcilia", "readout", "--help"], "help"),
                             "in process": lambda: ours_in_process(rec, out)}, runs)
        parts = stages(rec, out)
        sizes = rec.stat().st_size / 1e6, out.stat().st_size / 1e6, arrow.stat().st_size / 1e6
    med = {k: statistics.median(v) for k, v in times.items()}
    low = {k: min(v) for k, v in times.items()}
    print(f"magcilia readout of {samples:.0e} samples (recording {sizes[0]:.1f} MB; our CSV "
          f"{sizes[1]:.1f} MB, six columns; the route's {sizes[2]:.1f} MB, five), fresh "
          f"interpreters, interleaved, median (min) of {runs}:")
    print(f"  from a shell: magcilia readout {med['ours']:.3f} s ({low['ours']:.3f})   target "
          f"≤ {TARGETS['shell']:g} s: {'met' if med['ours'] <= TARGETS['shell'] else 'NOT met'}")
    print(f"  the pyarrow route (read_csv, np.interp, write_csv) {med['arrow']:.3f} s "
          f"({low['arrow']:.3f})   ratio route/ours {med['arrow'] / med['ours']:.2f}")
    print(f"  start-up: `magcilia readout --help` {med['help']:.3f} s ({low['help']:.3f}); "
          f"our part (the command in a warm process) {med['in process']:.3f} s "
          f"({low['in process']:.3f})")
    cpu = {k: statistics.median(v) for k, v in CPU.items()}
    print(f"  CPU seconds (user + system, median): magcilia readout {cpu['ours']:.3f}, the "
          f"pyarrow route {cpu['arrow']:.3f}, `readout --help` {cpu['help']:.3f}")
    print("  our part by stage (one run): " + ", ".join(f"{k} {v:.3f} s"
                                                        for k, v in parts.items()))


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--quick", action="store_true",
                        help="fewer repetitions, 3 shell runs instead of 7")
    parser.add_argument("--samples", type=int, default=1_000_000,
                        help="readings in the recording of `magcilia readout`")
    args = parser.parse_args()
    print(machine())
    readout = mc.Readout(mc.load_setup(SETUP), quantity="force", span=SPAN)
    speeds(readout, args.quick)
    commands(readout, args.samples, 3 if args.quick else 7)
    print(f"load after: {', '.join(f'{x:.2f}' for x in os.getloadavg())}")


if __name__ == "__main__":
    main()
