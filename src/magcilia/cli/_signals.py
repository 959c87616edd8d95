"""How ``magcilia live`` and ``magcilia dashboard`` end: one path for Ctrl-C (SIGINT), SIGTERM,
a closed SSH session (SIGHUP), ``q`` and ``--duration``; and how ``magcilia record`` ends at any
of those signals (:func:`signals_interrupt`).

A signal raises nothing into what the main thread is doing: an exception thrown at a random
instant can leave things half started or half closed (a server thread without an owner, a
recording never closed; on Python ≤ 3.12 a ``Thread.join`` that Ctrl-C interrupts marks a running
thread as ended, CPython issue 90882; and a KeyboardInterrupt that passes through code run by
``exec`` makes the interpreter kill itself with SIGINT at exit even when it was caught). The first
signal is a **stop request**: the command checks it once its setup is done (building the read-out
takes about a second) and the views check it about ten times a second; the command then stops
as it does at the end of ``--duration``: the server, the read-out, the recording closed complete,
one line, exit status 0. Signals after the first are ignored, so that none cuts the closing short.
"""

from __future__ import annotations

import contextlib
import signal
import threading
import time
from collections.abc import Callable, Iterator
from types import FrameType

#: the signals that stop a live view (those this platform has)
STOP_SIGNALS = tuple(name for name in ("SIGINT", "SIGTERM", "SIGHUP", "SIGBREAK")
                     if hasattr(signal, name))
#: seconds between looks at the request while waiting (the delay of a stop, at most)
POLL = 0.1


class StopRequest:
    """Whether a stop was asked for, and by which signal (see the module's text).

    Calling it (``stop()``) says whether a stop was requested: the form the views take
    (:func:`magcilia.live.terminal.run_lines` and the others, ``stop=``).
    """

    def __init__(self) -> None:
        self.signal: str | None = None  # the name of the first stop signal

    @property
    def requested(self) -> bool:
        """Whether a stop signal came."""
        return self.signal is not None

    def __call__(self) -> bool:
        return self.requested

    def handle(self, signum: int, _frame: FrameType | None = None) -> None:
        """The signal handler: note the first signal, ignore the others."""
        if self.signal is None:
            self.signal = signal.Signals(signum).name

    def wait(self, until: Callable[[], bool] | None = None) -> None:
        """Sleep until a stop is requested or ``until()`` is true (checked every ``POLL`` s)."""
        while not self.requested and not (until is not None and until()):
            time.sleep(POLL)


@contextlib.contextmanager
def _installed(handler: Callable[[int, FrameType | None], None]) -> Iterator[None]:
    """``handler`` for every signal of :data:`STOP_SIGNALS` while inside, the handlers before put
    back on the way out; outside the main thread (where handlers cannot be set, and no signal
    arrives) nothing is installed."""
    if threading.current_thread() is not threading.main_thread():
        yield
        return
    saved = {name: signal.signal(getattr(signal, name), handler) for name in STOP_SIGNALS}
    try:
        yield
    finally:
        for name, before in saved.items():
            signal.signal(getattr(signal, name), before)


@contextlib.contextmanager
def stop_signals() -> Iterator[StopRequest]:
    """While inside, SIGINT, SIGTERM and SIGHUP (SIGBREAK on Windows) are stop requests
    (:class:`StopRequest`); the handlers before are put back on the way out. Outside the main
    thread (where handlers cannot be set, and no signal arrives) nothing is installed."""
    stop = StopRequest()
    with _installed(stop.handle):
        yield stop


@contextlib.contextmanager
def signals_interrupt() -> Iterator[StopRequest]:
    """While inside, the first SIGINT, SIGTERM or SIGHUP (SIGBREAK on Windows) interrupts the main
    thread as Ctrl-C does (a KeyboardInterrupt), and later ones are ignored, so that none cuts
    short the closing that the interrupt starts. For a command that is one piece of work whose
    writer closes its file at an interrupt, saying where it stopped (``magcilia record``:
    :meth:`magcilia.io.recording_file.RecordingWriter.keeping`); the request names the signal.
    The handlers before are put back on the way out; outside the main thread nothing is
    installed."""
    stop = StopRequest()

    def interrupt(signum: int, frame: FrameType | None) -> None:
        if stop.signal is None:
            stop.handle(signum, frame)
            raise KeyboardInterrupt

    with _installed(interrupt):
        yield stop
