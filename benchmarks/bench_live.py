"""Live read-out + browser dashboard with 3 headless Chromium tabs, one server core.

The server process (pinned to CPU 0 where the OS allows: the simulated source, the reader, the
read-out thread and uvicorn all share it) runs a realtime 10 kHz simulated sensor, the read-out at
1 kHz and the dashboard on a free port. A second process (not pinned, nor are the browser
processes it starts) opens 3 pages of it in a headless Chromium. Every 0.5 s the main thread
steps the simulated force between 0 and half the span; one page notes, at each animation frame,
when its shown value (``window.magcilia.lastValue``) crosses half the step.

Reported: samples delivered, dropped and overrun; pipeline latency (sample in -> value out);
screen latency (sample in -> drawn, the browsers' acknowledgements over the last 1000 frames);
step response (``set_value`` -> the page's value past half the step, wall clock); the server
process's CPU time per second of wall time, without browsers and with them.
Targets: 0 overruns, screen latency median <= 100 ms and p99 <= 250 ms, step response
median <= 100 ms and max <= 250 ms (the tests only guard against a hang; speed is checked here).

Run: python benchmarks/bench_live.py [--seconds 20] [--quick]
"""

from __future__ import annotations

import os

for _var in ("OMP_NUM_THREADS", "OPENBLAS_NUM_THREADS", "MKL_NUM_THREADS"):
    os.environ[_var] = "1"

import argparse
import contextlib
import json
import math
import subprocess
import sys
import threading
import time
from pathlib import Path
from typing import Any

import numpy as np

import magcilia as mc
from magcilia.acquire import Script, SimulatedSource
from magcilia.live import LiveReadout
from magcilia.live.chromium import CHROMIUM_ARGS, find_chromium
from magcilia.live.dashboard import DashboardServer

SPAN = (-3e-4, 3e-4)  # N
STEP = 1.5e-4  # N, half the span
PERIOD = 0.5  # s between steps
#: the page's observer: the wall time (ms) of each crossing of the threshold, at each frame
OBSERVER = """threshold => {
  window.__crossings = []; let above = null;
  const poll = () => {
    const v = window.magcilia.lastValue;
    if (v !== null) {
      const now = v > threshold;
      if (now !== above) {
        window.__crossings.push([performance.timeOrigin + performance.now(), now]);
        above = now;
      }
    }
    requestAnimationFrame(poll);
  };
  requestAnimationFrame(poll);
}"""


def drive(url: str, pages: int, seconds: float, threshold: float) -> None:
    """The browser side (a separate process): open ``pages`` tabs, say "ready", watch for
    ``seconds``, print what one page saw as JSON."""
    if hasattr(os, "sched_setaffinity"):
        os.sched_setaffinity(0, range(os.cpu_count() or 1))  # the browsers are not pinned
    from playwright.sync_api import sync_playwright

    errors: list[str] = []
    with sync_playwright() as p:
        browser = p.chromium.launch(executable_path=find_chromium(), headless=True,
                                    args=CHROMIUM_ARGS)
        tabs = [browser.new_page(viewport={"width": 1280, "height": 800})
                for _ in range(pages)]
        for tab in tabs:
            tab.on("console", lambda m: errors.append(m.text) if m.type == "error" else None)
            tab.goto(url)
        for tab in tabs:
            tab.wait_for_function("() => window.magcilia.lastValue !== null", timeout=20000)
        tabs[0].evaluate(OBSERVER, threshold)
        print("ready", flush=True)
        time.sleep(seconds)
        crossings = tabs[0].evaluate("window.__crossings")
        frames = [tab.evaluate("window.magcilia.drawn") for tab in tabs]
        browser.close()
    print(json.dumps({"crossings": crossings, "errors": errors, "drawn": frames}), flush=True)


def thread_cpu() -> dict[str, float]:
    """CPU time of each named thread of this process so far, s (Linux; else only "process")."""
    out = {"process": time.process_time()}
    tick = os.sysconf("SC_CLK_TCK") if hasattr(os, "sysconf") else 100
    for thread in threading.enumerate():
        stat = Path(f"/proc/self/task/{thread.native_id}/stat")
        with contextlib.suppress(OSError):
            fields = stat.read_text().rsplit(")", 1)[1].split()
            out[thread.name] = (int(fields[11]) + int(fields[12])) / tick  # utime + stime
    return out


def stepping(source: SimulatedSource,
             seconds: float) -> tuple[list[tuple[float, bool]], dict[str, float]]:
    """Step the force 0 <-> STEP every PERIOD for ``seconds``: the steps (wall time, up) and
    the CPU time per second of wall time meanwhile of the process and of its threads."""
    c0, t0 = thread_cpu(), time.monotonic()
    steps: list[tuple[float, bool]] = []
    while time.monotonic() - t0 < seconds:
        up = len(steps) % 2 == 0
        steps.append((time.time(), up))
        source.set_value(STEP if up else 0.0)
        time.sleep(max(0.0, t0 + len(steps) * PERIOD - time.monotonic()))
    source.set_value(0.0)
    c1, wall = thread_cpu(), time.monotonic() - t0
    return steps, {k: (c1[k] - c0[k]) / wall for k in c1.keys() & c0.keys()}


def step_responses(steps: list[tuple[float, bool]], crossings: list[list[Any]]) -> np.ndarray:
    """Seconds from each step to the page's first crossing in its direction after it."""
    out = []
    seen = [(t / 1e3, bool(up)) for t, up in crossings]
    for at, up in steps:
        later = [t for t, u in seen if u == up and t >= at]
        if later:
            out.append(later[0] - at)
    return np.array(out)


def stats(x: np.ndarray) -> str:
    if not x.size:
        return "none"
    return f"median {np.median(x) * 1e3:6.1f} ms   p99 {np.quantile(x, 0.99) * 1e3:6.1f} ms"


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--seconds", type=float, default=20.0, help="run with browsers, s")
    parser.add_argument("--baseline", type=float, default=5.0, help="run without, s")
    parser.add_argument("--pages", type=int, default=3, help="browser tabs")
    parser.add_argument("--quick", action="store_true", help="short smoke run")
    parser.add_argument("--drive", help=argparse.SUPPRESS)  # the browser process
    args = parser.parse_args()
    if args.quick:
        args.seconds, args.baseline = 6.0, 2.0
    if args.drive:
        drive(args.drive, args.pages, args.seconds, STEP * 1e3 / 2)
        return
    if find_chromium() is None:
        sys.exit("bench_live: no Chromium found (Debian: apt-get install chromium)")

    pinned = "not pinned (no sched_setaffinity here)"
    if hasattr(os, "sched_setaffinity"):  # before any thread starts: they all inherit it
        os.sched_setaffinity(0, {0})
        pinned = "pinned to CPU 0"
    setup = mc.Setup.paper(tip_radius=5e-5)
    source = SimulatedSource(setup, Script.constant(0.0, "force"), rate=10000.0, realtime=True,
                             rng=0, readout_noise=2e-5)
    live = LiveReadout(source, mc.Readout(setup, "force", span=SPAN), rate=1000.0,
                       tare_at_start=True)
    print(f"live read-out + dashboard, {args.pages} headless Chromium tabs; server process "
          f"{pinned}, browsers not pinned ({os.cpu_count()} CPUs)")
    print(f"  sim source 10 kHz (realtime) -> read-out 1 kHz; force steps 0 <-> "
          f"{STEP * 1e3:g} mN every {PERIOD:g} s; {args.seconds:g} s with browsers")
    with live, DashboardServer(live, port=0) as server:
        live.wait(1000)
        _, idle = stepping(source, args.baseline)
        driver = subprocess.Popen(
            [sys.executable, __file__, "--drive", server.url, "--pages", str(args.pages),
             "--seconds", str(args.seconds)], stdout=subprocess.PIPE, text=True)
        assert driver.stdout is not None
        line = driver.stdout.readline()
        if line.strip() != "ready":
            driver.kill()
            sys.exit(f"bench_live: the browser process did not start ({line.strip()!r})")
        start_total, start_status, t0 = live.history.total, live.status, time.monotonic()
        steps, busy = stepping(source, args.seconds - 1.0)
        out, _ = driver.communicate(timeout=60)
        status, wall = live.status, time.monotonic() - t0
        samples = live.history.since(start_total)[0]
        screen = server.screen_latency()
    seen = json.loads(out.strip().splitlines()[-1])
    response = step_responses(steps, seen["crossings"])
    pipeline = samples.latency
    delivered = status.counters.samples - start_status.counters.samples
    dropped = status.counters.dropped
    print(f"  source samples delivered {delivered} ({delivered / wall:.0f}/s), "
          f"dropped {dropped}, overruns {status.overruns}")
    print(f"  pipeline latency  (sample in -> value out)        {stats(pipeline)}")
    print(f"  screen latency    (sample in -> drawn, {screen.size} acks)  {stats(screen)}")
    print(f"  step response     (set_value -> page, {response.size} steps)    "
          f"{stats(response)}")
    print(f"  frames drawn per tab: {', '.join(str(d) for d in seen['drawn'])} "
          f"({np.mean(seen['drawn']) / args.seconds:.0f}/s); console errors: "
          f"{len(seen['errors'])}")
    print(f"  server process CPU (% of a core): {idle['process'] * 100:.1f} without browsers, "
          f"{busy['process'] * 100:.1f} with {args.pages}")
    for name, what in (("magcilia-dashboard", "dashboard thread (uvicorn, all browsers)"),
                       ("magcilia-live", "read-out thread"), ("magcilia-reader", "reader thread")):
        if name in busy:
            print(f"    {what:42s} {idle.get(name, math.nan) * 100:5.1f} -> "
                  f"{busy[name] * 100:5.1f}")
    checks = {"0 overruns": status.overruns == 0,
              "screen latency median <= 100 ms": bool(screen.size)
              and np.median(screen) <= 0.100,
              "screen latency p99 <= 250 ms": bool(screen.size)
              and np.quantile(screen, 0.99) <= 0.250,
              "step response median <= 100 ms": bool(response.size)
              and np.median(response) <= 0.100,
              "step response max <= 250 ms": bool(response.size)
              and np.max(response) <= 0.250}
    for name, ok in checks.items():
        print(f"  {'PASS' if ok else 'FAIL'}  {name}")
    print("all targets met" if all(checks.values()) else "SOME TARGETS MISSED")


if __name__ == "__main__":
    main()
