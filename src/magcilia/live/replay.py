"""Replay: a live read-out's recording run again through the same pipeline.

:func:`replay` builds a :class:`~magcilia.live.pipeline.LiveReadout` on a
:class:`~magcilia.acquire.replay.ReplaySource` of the file with what the recording stores
(:mod:`magcilia.live.recorded`: the setup, span, calibration, the pipeline's settings, the state
of zero tracking when recording began, and where each tare's window began): the samples come in
the recorded chunks with their recorded times (:attr:`ReplaySource.recorded_clock
<magcilia.acquire.replay.ReplaySource.recorded_clock>`), so the windows, the tares and their
rest checks, zero tracking and the read-out are the live run's, number for number
(``tests/live/test_replay.py``: the values agree to 1e-3 σ and closer); the read-out ends when
the file does. What cannot come back: samples the live run lost (they were never recorded), and
set/reset windows of a recording started mid-run whose first window pairs with a half-window
before it.
"""

from __future__ import annotations

from pathlib import Path

from magcilia._errors import MagciliaError
from magcilia.acquire.replay import ReplaySource
from magcilia.live.pipeline import LiveReadout
from magcilia.live.recorded import REPLAY_VERSION, recorded_readout, stored
from magcilia.live.zero import Zero


# -- replay ---------------------------------------------------------------------------------------
def replay(path: str | Path, *, realtime: bool = False, speed: float = 1.0,
           history: float | None = None) -> LiveReadout:
    """A live read-out of a recording (not started; see the module docstring).

    Parameters
    ----------
    path : str or Path
        A live recording (``magcilia live --record``).
    realtime : bool
        At the recorded pace (a view watching), or as fast as it goes (False).
    speed : float
        With ``realtime``: how many times faster than recorded.
    history : float, optional
        Seconds of output kept for the views (default: the whole recording as fast as it goes,
        so that no view misses a value; 60 s in real time).

    Raises
    ------
    MagciliaError
        If the file is not a live recording that stores what a replay needs.
    """
    source = ReplaySource(path, realtime=realtime, speed=speed)
    props = source.properties
    p = Path(path)
    stored(props, p)
    doc = props.get("replay")
    if not isinstance(doc, dict) or doc.get("version") != REPLAY_VERSION:
        raise MagciliaError(f"{p}: the recording does not store the read-out's state (recorded "
                            "by an earlier magcilia); `magcilia readout FILE` reads its values")
    readout = recorded_readout(p, dynamic=True)
    factor = int(props.get("factor", 1))
    zero = Zero.from_state(doc["zero"])
    if history is None:
        history = 60.0 if realtime else max(1.0, source.length / source.rate + 1.0)
    live = LiveReadout(source, readout, rate=source.rate / factor, channel=source.channel,
                       history=history, batch=int(doc["batch_samples"]) / source.rate,
                       tare_seconds=float(doc["tare_seconds"]), tare_at_start=False,
                       tracking=zero.tau, band=zero.band, demodulate=doc["demodulate"])
    live.zero = zero
    return live
