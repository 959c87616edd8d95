"""Live read-out: force, angle and flow speed — or the force vectors of a 3-axis sensor or an
array — as they happen, with σ, flags, tare and recording.

:class:`LiveReadout` is the streaming pipeline (a source in, a :class:`History` of estimates
out); the terminal view (:mod:`magcilia.live.terminal`, needs ``rich``) and the browser dashboard
(:mod:`magcilia.live.dashboard`, needs ``starlette`` and ``uvicorn``) read it; other programs
subscribe to it through the dashboard's WebSocket or a Lab Streaming Layer stream
(:mod:`magcilia.live.lsl`, needs ``pylsl``; docs/streams.md).
"""

from __future__ import annotations

from typing import TYPE_CHECKING

from magcilia._lazy import attach

if TYPE_CHECKING:
    from magcilia.live.history import History, LiveSamples
    from magcilia.live.lsl import LslPublisher
    from magcilia.live.pipeline import EVENTS, Event, Limits, LiveReadout, LiveStatus
    from magcilia.live.readouts import LiveSensor, live_sensor, protocol_view
    from magcilia.live.windows import Averager, Windows
    from magcilia.live.zero import Zero

__all__ = ["EVENTS", "Averager", "Event", "History", "Limits", "LiveReadout", "LiveSamples",
           "LiveSensor", "LiveStatus", "LslPublisher", "Windows", "Zero", "live_sensor",
           "protocol_view"]

__getattr__, __dir__ = attach(__name__)
