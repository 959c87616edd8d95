"""``magcilia live``: the live read-out in the terminal, as status lines, or as JSON lines."""

from __future__ import annotations

import sys
from typing import Any

import click

from magcilia._errors import MagciliaError, require
from magcilia._validate import fail
from magcilia.cli._common import Physical
from magcilia.cli._live import LIVE_KEYS, build_live, live_options
from magcilia.cli._outputs import writes_files
from magcilia.cli._signals import stop_signals
from magcilia.live.pipeline import LiveStatus


@click.command()
@writes_files
@live_options
@click.option("--json-lines", "json_lines", is_flag=True,
              help="Stream one JSON object per read-out sample to stdout instead of the view, "
                   'in SI units: {"t": s, "value", "sigma", "flags", "unit", "raw_V": V}; a '
                   "force vector's value and sigma are [fx, fy], an array's one [fx, fy] per "
                   "cilium in the file's order (flags: one per cilium); "
                   'events as {"event": kind, "text", "t"}.')
@click.option("--duration", type=Physical.of("time", "10s"), default=None,
              help="Stop after this long (for scripts): s, or with a unit; default: until q or "
                   "Ctrl-C.")
@click.option("--every", default=1, show_default=True, type=int,
              help="With --json-lines: write every N-th read-out sample.")
@click.option("--lsl", "lsl_name", default=None, is_flag=False, flag_value="magcilia",
              metavar="[NAME]",
              help="Also publish every read-out sample as a Lab Streaming Layer stream named "
                   "NAME (default magcilia; needs pylsl, the lsl extra): the values, their "
                   "sigma and the flags as channels, SI units in the stream's description, "
                   "nominal rate = --rate (docs/streams.md; examples/lsl_consumer.py).")
def command(json_lines: bool, duration: float | None, every: int, lsl_name: str | None,
            **kwargs: Any) -> None:
    """Watch a sensor live: the force, angle or flow speed ± σ, a sparkline of the last 10 s,
    the flags (outside the span, fold, saturated), the state and the drop counters. With
    --sensor (a 3-axis magnetometer at the element) the force vector: magnitude, direction and
    each component ± σ; with an array setup file every cilium's (a map of the cilia and a chosen
    one's traces: n/p choose it).

    Keys: t tare, r start/stop recording (into --record-dir), q quit. Works over SSH. When
    stdout is not a terminal, a plain status line is printed every second instead;
    --json-lines streams every value for other programs. A source that is unplugged is retried
    every second (the view says so); acquisition and recording go on when it comes back. q,
    --duration, Ctrl-C, SIGTERM and a closed SSH session (SIGHUP) all end it the same way: the
    recording is closed complete (and named), exit status 0.
    """
    with stop_signals() as stop:
        if duration is not None and not duration > 0:
            raise fail("--duration", duration, "a positive number of seconds")
        if every < 1:
            raise fail("--every", every, "a whole number ≥ 1")
        terminal_view = not json_lines and sys.stdout.isatty()
        if terminal_view:  # the rich view: check for it before starting
            require("rich", package="rich", extra="live", purpose="The terminal view")
        if lsl_name is not None:
            from magcilia.live.lsl import LslPublisher, check_name, pylsl_module

            pylsl_module()  # before anything opens
            check_name(lsl_name)
        live = build_live(**{k: kwargs[k] for k in LIVE_KEYS}, duration=duration)
        from magcilia.live import terminal

        if stop.requested:  # during the setup: nothing was opened
            return
        status: LiveStatus | None = None
        recording = None
        outlet = None
        try:
            live.start()
            if lsl_name is not None:
                outlet = LslPublisher(live, lsl_name).start()
                click.echo(f"magcilia live: publishing the LSL stream {outlet.describe()}",
                           err=True)
            if json_lines:
                status = terminal.stream_json_lines(live, sys.stdout, seconds=duration,
                                                    every=every, stop=stop)
            elif terminal_view:
                status = terminal.run_terminal(live, record_dir=kwargs["record_dir"],
                                               seconds=duration, stop=stop)
            else:
                status = terminal.run_lines(live, sys.stdout, seconds=duration, stop=stop)
        finally:  # the one way out (signals after the first are ignored: none cuts it short)
            if outlet is not None:
                outlet.stop()
            recording = live.recording
            live.stop()
    if recording is not None:
        click.echo(f"recording closed: {recording}")
    if outlet is not None and outlet.error is not None:
        click.echo(f"magcilia: warning: the LSL stream stopped early: {outlet.error}", err=True)
    if status is not None and status.state == "failed":
        raise MagciliaError(f"live read-out failed: {status.message}")
