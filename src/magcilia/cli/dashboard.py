"""``magcilia dashboard``: the live read-out in a browser (plots, value, flags, tare, record)."""

from __future__ import annotations

import webbrowser
from typing import Any

import click

from magcilia._errors import MagciliaError
from magcilia._validate import fail
from magcilia.cli._common import Physical
from magcilia.cli._live import LIVE_KEYS, build_live, live_options
from magcilia.cli._outputs import writes_files
from magcilia.cli._signals import stop_signals


@click.command()
@writes_files
@live_options
@click.option("--host", default="127.0.0.1", show_default=True,
              help="Address to listen on. Anything but 127.0.0.1/localhost/::1 lets anyone on "
                   "the network see the page and press its tare and record buttons (there is "
                   "no authentication). Whatever the address, requests naming another host "
                   "(DNS rebinding) or coming from another web page are refused, and commands "
                   "need the token of the page this server served.")
@click.option("--port", default=8050, show_default=True, type=click.IntRange(0, 65535),
              help="TCP port (0: any free one).")
@click.option("--window", default="10", show_default=True, type=Physical.of("time", "10s"),
              help="Time shown on the plots: s, or with a unit (e.g. 30s, 500ms).")
@click.option("--open", "open_browser", is_flag=True, help="Open the page in a browser tab.")
def command(host: str, port: int, window: float, open_browser: bool, **kwargs: Any) -> None:
    """Serve a browser dashboard of the live read-out: the value with its σ, flags, plots of
    the estimate (σ band, range, minimum detectable) and of the raw output, tare and record
    buttons, the setup and calibration in use. With --sensor (a 3-axis magnetometer at the
    element): |F|, its direction, a polar view of the force vector and Fx, Fy with σ bands; with
    an array setup file: a map of the cilia (click one to follow its traces). Ctrl-C, SIGTERM
    and a closed SSH session (SIGHUP) stop it the same way, at any moment: the recording is
    closed complete (and named), exit status 0. The server obeys only its own page: a foreign
    Host or Origin is refused, and tare and record carry a token that only the served page
    holds."""
    with stop_signals() as stop:
        from magcilia.live.dashboard import (
            DashboardServer,
            bind_socket,
            exposure_warning,
            require_server,
        )

        if not window > 0:
            raise fail("--window", f"{window:g} s", "a positive duration")
        warning = exposure_warning(host)
        if warning:
            click.echo(f"magcilia: warning: {warning}", err=True)
        require_server()  # before anything opens
        bind_socket(host, port).close()  # a port in use fails before the source is opened
        live = build_live(**{k: kwargs[k] for k in LIVE_KEYS}, replay_realtime=True)
        server = DashboardServer(live, host, port, window=window,
                                 record_dir=kwargs["record_dir"])
        recording = None
        try:
            if not stop.requested:
                live.start()
                server.start()
                click.echo(f"magcilia dashboard: {server.url}  (Ctrl-C to stop)")
                if open_browser:
                    webbrowser.open(server.url, new=2)
                stop.wait(until=lambda: not server.serving)
        finally:  # the one way out (signals after the first are ignored: none cuts it short)
            server.stop()
            recording = live.recording
            live.stop()
    if recording is not None:
        click.echo(f"recording closed: {recording}")
    if not stop.requested:
        raise MagciliaError(f"the dashboard server stopped: {server.failure or 'by itself'}")
    click.echo("magcilia dashboard: stopped")
