"""Figures drawn by a helper process that readies matplotlib while the command computes.

A command that ends in figures (``magcilia calibrate``) spends a third of a second importing
matplotlib and loading its fonts before it draws anything. :func:`figure_writer` forks a child
at the command's start that does that work while the parent reads and fits, on the other core;
the figures are then sent to it as tasks (a module-level function and its arguments, pickled)
and it draws and saves them while the parent writes its other files. Where two or more CPUs are
available, each task runs in a worker forked from the ready child, side by side (the parent only
waits then): ``calibrate``'s two figures take as long as ``fit.png`` alone, not its 0.23 s and
``residuals.png``'s 0.07 s one after the other (drawn by a ready process on the quiet 2-core VM).
Tasks must therefore not depend on each other.

Errors end as before: a task that fails in the child comes back as its one-line message and the
parent raises it (:class:`~magcilia.MagciliaError`); a child or a worker that dies is an error
too, and the workers end with the child (killed when it ends, on Linux). The files
are written atomically into the command's staging folder, which is published only after
:meth:`FigureWriter.wait` returned: no half-written file, no partial folder. On an error the
child is stopped before the staging folder is removed (open the writer inside the folder's
block).

The child is used only where forking is safe and its work overlaps: a POSIX system other than
macOS, one Python thread in the process, matplotlib not yet imported (a notebook or a test
process that already has it draws in-process as fast), and two or more CPUs available to the
process (whatever their load: on the 2-core VM the child saved 0.33 s of a first calibrate's
1.37 s when the machine was quiet and still 0.05 s under a load of 3.4, where a gate on the load
average turned it off when the command itself was the load). ``MAGCILIA_FIGURE_PROCESS=0``
always draws in-process; ``=1`` uses the child whenever forking is safe, even on one CPU.
"""

from __future__ import annotations

import contextlib
import logging
import os
import sys
import threading
from collections.abc import Callable, Iterator
from typing import Any

from magcilia._errors import MagciliaError

_log = logging.getLogger(__name__)

#: environment switch: "0" draws in the command's own process, "1" in the child where forking is
#: safe (even on one CPU), unset: in the child where forking is safe and two CPUs are available
ENVIRONMENT = "MAGCILIA_FIGURE_PROCESS"


class FigureWriter:
    """Runs figure tasks: in a forked child (:func:`figure_writer` decides) or right here.

    ``submit(task, *args)`` runs ``task(*args)`` (``task`` a module-level function, so that it
    pickles by name; tasks may run at the same time, in any order); :meth:`wait` returns when
    every task is done and raises the first failure (in the order of the tasks) as a one-line
    :class:`~magcilia.MagciliaError`."""

    def __init__(self, connection: Any = None, process: Any = None) -> None:
        self._connection = connection
        self._process = process
        self._pending = 0

    @property
    def forked(self) -> bool:
        """Whether the tasks run in the helper process."""
        return self._process is not None

    def submit(self, task: Callable[..., object], *args: Any) -> None:
        """Run ``task(*args)`` (in the child, or now: also where the task does not pickle or
        the child is gone)."""
        if self._connection is not None:
            try:
                self._connection.send((task, args))
            except Exception as exc:  # noqa: BLE001 (not picklable, or a broken pipe: draw here)
                _log.debug("figure task run in-process: %s", exc)
            else:
                self._pending += 1
                return
        task(*args)

    def wait(self) -> None:
        """Wait for the submitted tasks; the first failure is raised here, as one line."""
        failure = None
        while self._pending:
            try:
                reply = self._connection.recv()
            except (EOFError, OSError):
                code = self._process.exitcode if self._process is not None else None
                self._pending = 0
                raise MagciliaError(
                    f"the figure process ended before writing the figures (exit code {code}); "
                    f"rerun, or set {ENVIRONMENT}=0 to draw them in the command's own process"
                ) from None
            self._pending -= 1
            if reply is not None and failure is None:
                failure = reply
        if failure is not None:
            raise MagciliaError(failure)

    def close(self, abandon: bool = False) -> None:
        """Stop the child: it leaves when its tasks are done, or at once with ``abandon`` (a
        task in progress is then cut short: the caller discards the files)."""
        if self._connection is not None:
            with contextlib.suppress(OSError, ValueError):
                self._connection.send(None)
            self._connection.close()
            self._connection = None
        if self._process is not None:
            if abandon:
                self._process.terminate()
            self._process.join(timeout=5.0)
            if self._process.is_alive():
                self._process.kill()
                self._process.join()
            self._process = None


def _cpus() -> int:
    """The CPUs this process may run on."""
    try:
        return len(os.sched_getaffinity(0))
    except AttributeError:  # (not on every POSIX system)
        return os.cpu_count() or 1


def _can_fork() -> bool:
    switch = os.environ.get(ENVIRONMENT, "")
    if switch == "0" or "matplotlib" in sys.modules:
        return False
    if os.name != "posix" or sys.platform == "darwin":  # (fork is unsafe on macOS)
        return False
    if threading.active_count() != 1:
        return False
    if switch == "1":
        return True
    return _cpus() >= 2


@contextlib.contextmanager
def figure_writer(style: str = "screen") -> Iterator[FigureWriter]:
    """A :class:`FigureWriter` for the block: a child that readies matplotlib (for figures in
    ``style``, :mod:`magcilia.report.style`) from now on where that can overlap with the block's
    work (see the module docstring), else in-process. The child is stopped when the block ends,
    whether it ends well or not."""
    if not _can_fork():
        yield FigureWriter()
        return
    import multiprocessing

    context = multiprocessing.get_context("fork")
    parent, child = context.Pipe()
    process = context.Process(target=_serve, args=(child, style, parent, _cpus()), daemon=True,
                              name="magcilia-figures")
    try:
        process.start()
    except OSError:  # (no process to spare: draw here)
        parent.close()
        child.close()
        yield FigureWriter()
        return
    child.close()
    writer = FigureWriter(parent, process)
    try:
        yield writer
    except BaseException:
        writer.close(abandon=True)  # (before the caller's staging folder goes)
        raise
    writer.close()


def _serve(connection: Any, style: str, parents_end: Any, workers: int = 1) -> None:
    """The child: ready matplotlib, then run tasks until told to stop (or the parent is gone);
    each task's reply is None or its error as one line. Nothing is printed. The parent's end of
    the pipe, which the fork copied, is closed first: otherwise the child itself would keep the
    pipe open and never see it end when the parent is killed (an orphan holding the parent's
    stderr open). With ``workers`` > 1 (the CPUs available) the tasks run side by side, each in
    a process forked from this ready one (:func:`_serve_side_by_side`)."""
    import signal

    parents_end.close()

    from magcilia.model import compiled

    signal.signal(signal.SIGINT, signal.SIG_IGN)  # (Ctrl-C is the parent's to handle)
    # the figures' few model curves by the NumPy reference (equal to 1e-12): importing numba here
    # would come after the fit, on the figures' path
    compiled.ENABLED = False
    with contextlib.suppress(Exception):
        _warm(style)
    if workers > 1:
        _serve_side_by_side(connection, workers)
        return
    while True:
        try:
            message = connection.recv()
        except (EOFError, OSError):
            return
        if message is None:
            return
        task, args = message
        try:
            connection.send(_run_task(task, args))
        except (OSError, ValueError):
            return


def _run_task(task: Callable[..., object], args: tuple[Any, ...]) -> str | None:
    """Run one task: None, or its error as one line."""
    try:
        task(*args)
    except Exception as exc:  # noqa: BLE001 (every failure goes back as one line)
        return " ".join(str(exc).split()) or type(exc).__name__
    return None


def _serve_side_by_side(connection: Any, workers: int) -> None:
    """Run each task in a process forked from this one (matplotlib ready in it), at most
    ``workers`` at a time, and send the replies in the order the tasks came: the command waits
    for its two figures as long as for the slower one, not for both one after the other (on
    two CPUs, while the command itself waits). A worker that dies is a failed task. Told to
    stop, the tasks started are finished first; when the parent is gone (the pipe ends), the
    workers are killed."""
    import signal
    from collections import deque
    from multiprocessing.connection import wait

    from magcilia.execution import _parent_death_signal  # (imported here, not in each worker)

    queued: deque[tuple[int, Callable[..., object], tuple[Any, ...]]] = deque()
    running: dict[int, tuple[int, int, bytearray]] = {}  # read end -> (task number, pid, bytes)
    replies: dict[int, str | None] = {}
    sent = received = 0
    stopping = False
    try:
        while True:
            while queued and len(running) < workers:
                number, task, args = queued.popleft()
                fd, pid = _fork_worker(task, args, connection, _parent_death_signal)
                running[fd] = (number, pid, bytearray())
            while sent in replies:
                connection.send(replies.pop(sent))
                sent += 1
            if stopping and not running and not queued:
                return
            watched: list[Any] = list(running) + ([] if stopping else [connection])
            for ready in wait(watched):
                if not isinstance(ready, int):  # (the pipe from the command; a worker's is a fd)
                    message = connection.recv()
                    if message is None:
                        stopping = True
                    else:
                        queued.append((received, *message))
                        received += 1
                    continue
                number, pid, data = running[ready]
                chunk = os.read(ready, 65536)
                if chunk:
                    data += chunk
                    continue
                del running[ready]
                os.close(ready)
                _, status = os.waitpid(pid, 0)
                replies[number] = _worker_reply(bytes(data), status)
    except (EOFError, OSError, ValueError):  # the parent is gone: so are the workers
        return
    finally:
        for fd, (_, pid, _) in running.items():
            with contextlib.suppress(OSError):
                os.kill(pid, signal.SIGKILL)
                os.waitpid(pid, 0)
            with contextlib.suppress(OSError):
                os.close(fd)


def _fork_worker(task: Callable[..., object], args: tuple[Any, ...], connection: Any,
                 die_with_parent: Callable[[], object]) -> tuple[int, int]:
    """Fork a worker that runs ``task(*args)`` and writes its reply (``b"ok"``, or ``b"!"`` and
    the one-line error) into a pipe of its own; the pipe's read end and the worker's pid. The
    worker first calls ``die_with_parent`` (killed when the helper ends, on Linux; elsewhere it
    finishes its one task and exits)."""
    helper = os.getpid()
    read, write = os.pipe()
    pid = os.fork()
    if pid == 0:  # the worker: never back into the caller's loop
        code = 1
        try:
            os.close(read)
            connection.close()  # (its copy: the parent sees the helper's end alone)
            die_with_parent()
            if os.getppid() != helper:  # (the helper ended before the signal was set)
                os._exit(1)
            reply = _run_task(task, args)
            data = b"ok" if reply is None else b"!" + reply.encode("utf-8", "replace")
            while data:
                data = data[os.write(write, data):]
            code = 0
        finally:
            os._exit(code)
    os.close(write)
    return read, pid


def _worker_reply(data: bytes, status: int) -> str | None:
    """A worker's reply from what it wrote and its wait status."""
    if data == b"ok":
        return None
    if data.startswith(b"!"):
        return data[1:].decode("utf-8", "replace")
    return (f"a figure worker ended without a reply (wait status {status}); rerun, or set "
            f"{ENVIRONMENT}=0 to draw the figures in the command's own process")


def _warm(style: str) -> None:
    """Import matplotlib's Agg path and load the fonts and the mathtext parser that figures in
    ``style`` use (drawn on a throwaway canvas), and the model's path for their curves."""
    import numpy as np
    from matplotlib.backends.backend_agg import FigureCanvasAgg
    from matplotlib.figure import Figure

    from magcilia.io import presets
    from magcilia.report import style as st

    presets.setup("paper").field(np.radians([0.0, 10.0]))
    with st.use(style):
        fig = Figure(figsize=(1.0, 1.0), layout="constrained")
        ax = fig.add_subplot()
        ax.set_ylabel("$B_x$ (µV)")
        ax.set_title("θ −1", loc="left")
        FigureCanvasAgg(fig).draw()
