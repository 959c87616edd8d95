"""The execution layer: run many independent tasks on this machine or on a Dask cluster.

One function, :func:`run_tasks`, runs ``fn(argument)`` for every task and returns one
:class:`TaskResult` per task, in the order given, whichever backend ran them:

- ``workers=1``: in this process, one task after the other (no pool; the reference);
- no ``scheduler`` (the default): a pool of worker processes on this machine
  (``concurrent.futures.ProcessPoolExecutor``), one per core unless ``workers`` says otherwise,
  with no scheduler between the tasks. It starts by :func:`start_method`: on Linux with Python
  3.11 the workers are forked from the caller and inherit its imports and loaded kernels (tens of
  ms; a spawned worker imports magcilia, SciPy and the kernels afresh: about a second, which is
  most of the 2-worker speed-up of a batch of a hundred fits); elsewhere ``forkserver`` with the
  task's module preloaded, or ``spawn``;
- ``scheduler="tcp://HOST:PORT"`` (or the environment variable ``MAGCILIA_SCHEDULER``): the tasks
  go to that running Dask cluster (``dask.distributed.Client``; the extra ``magcilia[cluster]``);
  the connection is given ``timeout`` seconds, then a one-line error;
- ``scheduler="local"``: a Dask ``LocalCluster`` of ``workers`` processes with one thread each,
  started for the call and closed after it (Dask's dashboard and worker restarts on one machine).

Every worker runs its tasks with BLAS/OpenMP limited to one thread (threadpoolctl, and
``OMP_NUM_THREADS=1`` and the like for libraries loaded later): the tasks are the parallelism,
and several workers each starting a thread per core only fight over the cores (measured on
2 cores: 4.4 s with the limit, 14.9 s without, slower than one process). The environment
variable ``MAGCILIA_WORKER_THREADS`` changes it (a number of threads, or ``none``).

Workers die with their parent (SIGKILL included): at once on Linux (the parent-death signal),
within :data:`WATCHDOG_INTERVAL` elsewhere (a watchdog thread: :func:`die_with_parent`).

Faults: an exception in a task is kept as that task's result (``error``, one line) and the task
is tried ``retries`` more times; a worker process that dies (killed, out of memory) takes none of
the results with it: Dask reruns its tasks on the other workers, the local pool is started afresh
once for the tasks not yet finished (a second loss reports them failed). Each task's result is
handed to ``on_result`` once, as it finishes, in the calling process (write it there, atomically:
workers never write the outputs, so a killed worker leaves nothing half-written and nothing twice).

Results are identical seed for seed on every backend: the seeds travel inside the task arguments,
and a task's value depends on its argument alone.

``fn`` must be picklable: a function defined at the top level of an importable module (or a
``functools.partial`` of one); with Dask, the workers must import the same magcilia.

Examples
--------
>>> import math
>>> [r.value for r in run_tasks(math.sqrt, [("a", 4.0), ("b", 9.0)], workers=1, progress=False)]
[2.0, 3.0]
>>> r = run_tasks(math.sqrt, {"bad": -1.0}, workers=1, progress=False)[0]
>>> r.value, r.error, r.attempts
(None, 'ValueError: math domain error', 2)
"""

from __future__ import annotations

import contextlib
import ctypes
import logging
import multiprocessing
import multiprocessing.connection
import os
import signal
import sys
import threading
import time
from collections.abc import Callable, Iterator, Mapping, Sequence
from concurrent.futures import FIRST_COMPLETED, Future, ProcessPoolExecutor, wait
from concurrent.futures.process import BrokenProcessPool
from dataclasses import dataclass
from typing import Any

from magcilia import _validate as v
from magcilia._atomic import pid_alive
from magcilia._errors import MagciliaError, require

__all__ = [
    "LOCAL_CLUSTER",
    "SCHEDULER_ENV",
    "START_ENV",
    "THREADS_ENV",
    "THREAD_VARIABLES",
    "WATCHDOG_INTERVAL",
    "TaskResult",
    "dask_client",
    "default_workers",
    "die_with_parent",
    "limit_threads",
    "one_line",
    "resolve_scheduler",
    "run_tasks",
    "start_method",
    "worker_threads",
]

logger = logging.getLogger(__name__)

#: environment variable naming the Dask scheduler when no ``scheduler`` is given
SCHEDULER_ENV = "MAGCILIA_SCHEDULER"
#: ``scheduler`` value that starts a Dask ``LocalCluster`` for the call
LOCAL_CLUSTER = "local"
#: thread-count variables set to 1 in every worker (libraries loaded after the start read them)
THREAD_VARIABLES = ("OMP_NUM_THREADS", "OPENBLAS_NUM_THREADS", "MKL_NUM_THREADS",
                    "BLIS_NUM_THREADS", "VECLIB_MAXIMUM_THREADS", "NUMEXPR_NUM_THREADS",
                    "NUMBA_NUM_THREADS")


@dataclass(frozen=True)
class TaskResult:
    """What one task gave (immutable).

    Attributes
    ----------
    key : str
        The task's key (unique within a call).
    value : object
        ``fn``'s return value, or None when the task failed.
    error : str
        ``""`` on success, else one line: ``"ExceptionType: message"`` (of the last attempt).
    attempts : int
        How many times the task ran: 1, or more after retries.
    worker : str
        Where it ran last: ``"local-PID"`` (a process of the local pool), ``"in-process"``
        (``workers=1``) or a Dask worker's address.
    seconds : float
        Wall time of the last attempt inside the worker, s.
    """

    key: str
    value: Any
    error: str
    attempts: int
    worker: str
    seconds: float

    @property
    def ok(self) -> bool:
        """True when the task succeeded (``error`` is empty)."""
        return not self.error


def one_line(exc: BaseException) -> str:
    """``"ExceptionType: message"`` on one line (whitespace runs collapsed, at most 500
    characters)."""
    text = " ".join(str(exc).split())
    line = f"{type(exc).__name__}: {text}" if text else type(exc).__name__
    return line if len(line) <= 500 else line[:497] + "..."


#: environment variable: BLAS/OpenMP threads per worker (default 1; ``none``: leave the
#: libraries' own choice, one thread per core in every worker)
THREADS_ENV = "MAGCILIA_WORKER_THREADS"
_LIMITED = False


def worker_threads() -> int | None:
    """BLAS/OpenMP threads per worker: :data:`THREADS_ENV` (a whole number, or ``none`` for no
    limit), default 1."""
    text = os.environ.get(THREADS_ENV, "1").strip().lower()
    if text in ("none", "0", ""):
        return None
    try:
        return max(1, int(text))
    except ValueError:
        raise v.fail(THREADS_ENV, text, "a whole number of threads per worker, or none") from None


def limit_threads() -> None:
    """Limit BLAS/OpenMP thread pools of this process to :func:`worker_threads` threads (1 by
    default; threadpoolctl, for the libraries already loaded) and set :data:`THREAD_VARIABLES`
    likewise (for those loaded later). Idempotent; the workers call it before their first
    task."""
    global _LIMITED  # noqa: PLW0603 (once per worker process)
    if _LIMITED:
        return
    _LIMITED = True
    threads = worker_threads()
    if threads is None:
        return
    for name in THREAD_VARIABLES:
        os.environ[name] = str(threads)
    try:
        from threadpoolctl import threadpool_limits
    except ImportError:  # pragma: no cover - threadpoolctl is a core dependency
        pass
    else:
        threadpool_limits(limits=threads)


#: seconds between a worker's checks that its parent lives (:func:`die_with_parent`)
WATCHDOG_INTERVAL = 0.5
_PR_SET_PDEATHSIG = 1  # linux/prctl.h


def _parent_death_signal() -> bool:
    """Ask Linux to SIGKILL this process when its parent (thread) ends; False elsewhere."""
    if not sys.platform.startswith("linux"):
        return False
    try:
        prctl = ctypes.CDLL(None, use_errno=True).prctl
        prctl.argtypes = [ctypes.c_int, ctypes.c_ulong, ctypes.c_ulong, ctypes.c_ulong,
                          ctypes.c_ulong]
        prctl.restype = ctypes.c_int
        return bool(prctl(_PR_SET_PDEATHSIG, int(signal.SIGKILL), 0, 0, 0) == 0)
    except (OSError, AttributeError):
        return False


def die_with_parent(parent: int, direct: bool = True) -> None:
    """End this process (``os._exit``) when the process ``parent`` ends, SIGKILL included.

    A local pool's workers call it first (the pool's initializer). On Linux the kernel's
    parent-death signal kills the worker the moment its parent ends (the pool's process, or the
    forkserver, which ends with it); everywhere a daemon thread checks every
    :data:`WATCHDOG_INTERVAL` s (and wakes at once when the parent's process sentinel closes)
    that the parent still runs: its own parent process id unchanged and ``parent`` alive.
    ``direct``: ``parent`` is this process's parent (fork, spawn), not a forkserver's client;
    then a parent already gone at the start is caught at once.
    """
    _parent_death_signal()
    ppid = os.getppid()
    if direct and ppid != parent:
        os._exit(1)  # the parent died before the signal was set: reparented already
    origin = multiprocessing.parent_process()
    sentinel = getattr(origin, "sentinel", None)

    def watch() -> None:
        while True:
            if sentinel is not None:
                with contextlib.suppress(OSError, ValueError):
                    multiprocessing.connection.wait([sentinel], timeout=WATCHDOG_INTERVAL)
            else:
                time.sleep(WATCHDOG_INTERVAL)
            if os.getppid() != ppid or not pid_alive(parent) or (
                    origin is not None and origin.pid == parent and not origin.is_alive()):
                os._exit(1)

    threading.Thread(target=watch, name="magcilia-parent-watchdog", daemon=True).start()


def _worker_start(parent: int, direct: bool) -> None:
    """The local pool's worker initializer: die with the parent, limit the threads."""
    try:
        die_with_parent(parent, direct)
    except Exception:  # an initializer must not raise: the pool would break
        logger.debug("no parent watchdog in worker %d", os.getpid(), exc_info=True)
    limit_threads()


def _call(fn: Callable[[Any], Any], argument: Any, where: str) -> tuple[bool, Any, float, str]:
    """Run one task in a worker: ``(ok, value or one-line error, seconds, worker)``; never
    raises (an exception becomes the error text, so nothing unpicklable travels back)."""
    if where != "in-process":
        limit_threads()
    if where == "dask":
        from distributed import get_worker

        where = get_worker().address
    else:
        where = where if where == "in-process" else f"local-{os.getpid()}"
    t0 = time.perf_counter()
    try:
        value = fn(argument)
    except Exception as exc:  # noqa: BLE001 (a task's failure is its result)
        return False, one_line(exc), time.perf_counter() - t0, where
    return True, value, time.perf_counter() - t0, where


def _task_list(tasks: Mapping[str, Any] | Sequence[tuple[str, Any]]) -> list[tuple[str, Any]]:
    items = list(tasks.items()) if isinstance(tasks, Mapping) else list(tasks)
    seen: set[str] = set()
    out = []
    for i, item in enumerate(items):
        try:
            key, argument = item
        except (TypeError, ValueError):
            raise v.fail(f"tasks[{i}]", type(item).__name__, "a (key, argument) pair") from None
        if not isinstance(key, str):
            raise v.fail(f"task key {i}", key, "a str")
        if key in seen:
            raise v.fail("task key", key, "unique (each task's key once)")
        seen.add(key)
        out.append((key, argument))
    return out


def default_workers() -> int:
    """Worker processes by default: the cores this process may use."""
    try:
        return max(1, len(os.sched_getaffinity(0)))
    except AttributeError:  # pragma: no cover - not Linux
        return max(1, os.cpu_count() or 1)


def resolve_scheduler(scheduler: str | None) -> str | None:
    """The scheduler to use: ``scheduler``, else :data:`SCHEDULER_ENV`, else None (local);
    checked: ``"local"`` or a ``tcp://``/``tls://``/``inproc://``/``ucx://`` address."""
    if scheduler is None:
        scheduler = os.environ.get(SCHEDULER_ENV) or None
    if scheduler is None:
        return None
    text = str(scheduler).strip()
    if text == LOCAL_CLUSTER:
        return text
    if "://" not in text or not text.split("://", 1)[1]:
        raise v.fail("scheduler", text, "a Dask scheduler address such as tcp://HOST:8786, or "
                                        "'local' for a LocalCluster on this machine")
    return text


class _Progress:
    """A tqdm bar on stderr (off unless ``show`` and stderr is a terminal)."""

    def __init__(self, total: int, show: bool, label: str) -> None:
        from tqdm import tqdm

        self.bar = tqdm(total=total, desc=label, unit="task", file=sys.stderr,
                        disable=not (show and sys.stderr.isatty()))
        self.failed = 0

    def done(self, result: TaskResult) -> None:
        self.failed += not result.ok
        if self.failed:
            self.bar.set_postfix(failed=self.failed, refresh=False)
        self.bar.update()

    def close(self) -> None:
        self.bar.close()


def run_tasks(
    fn: Callable[[Any], Any],
    tasks: Mapping[str, Any] | Sequence[tuple[str, Any]],
    *,
    workers: int | None = None,
    scheduler: str | None = None,
    progress: bool = True,
    retries: int = 1,
    timeout: float = 10.0,
    on_result: Callable[[TaskResult], None] | None = None,
    label: str = "tasks",
) -> list[TaskResult]:
    """Run ``fn(argument)`` for every task; one :class:`TaskResult` per task, in the order given.

    Parameters
    ----------
    fn : callable
        A picklable top-level function of one argument (or a ``functools.partial`` of one).
    tasks : mapping of str to object, or sequence of (str, object)
        The tasks by unique key; each argument is pickled to the worker (keep it small: paths,
        seeds, parameter arrays).
    workers : int, optional
        Worker processes: None (default) one per core, 1 in this process (no pool; a single
        task runs in this process too). With ``scheduler="local"`` the LocalCluster's workers;
        ignored with a scheduler address.
    scheduler : str, optional
        A Dask scheduler address (``tcp://HOST:PORT``) or ``"local"`` (a Dask LocalCluster for
        the call); default the environment variable ``MAGCILIA_SCHEDULER``, else the local pool.
    progress : bool
        Show a progress bar on stderr (only when it is a terminal).
    retries : int
        Further attempts of a task that raised (default 1: one retry).
    timeout : float
        Seconds to connect to a scheduler, and for its first worker, before a one-line error.
    on_result : callable(TaskResult), optional
        Called in this process with each task's final result as it finishes (any order); an
        exception raised by it stops the run.
    label : str
        The progress bar's description.

    Returns
    -------
    list of TaskResult
        In the order of ``tasks``.
    """
    items = _task_list(tasks)
    if workers is not None:
        workers = v.integer("workers", workers, 1)
    retries = v.integer("retries", retries, 0)
    timeout = v.positive("timeout", timeout, "s", "time")
    address = resolve_scheduler(scheduler)
    worker_threads()  # a bad MAGCILIA_WORKER_THREADS fails here, not in every worker
    results: dict[str, TaskResult] = {}
    bar = _Progress(len(items), progress, label)

    def finish(result: TaskResult) -> None:
        results[result.key] = result
        bar.done(result)
        if on_result is not None:
            on_result(result)

    try:
        if not items:
            return []
        if address is not None:
            _run_dask(fn, items, address, workers, retries, timeout, finish)
        elif (workers or default_workers()) == 1 or len(items) == 1:
            _run_serial(fn, items, retries, finish)
        else:
            _run_pool(fn, items, min(workers or default_workers(), len(items)), retries, finish)
    finally:
        bar.close()
    return [results[key] for key, _ in items]


def _result(key: str, outcome: tuple[bool, Any, float, str], attempts: int) -> TaskResult:
    ok, value, seconds, worker = outcome
    return TaskResult(key, value if ok else None, "" if ok else str(value), attempts, worker,
                      seconds)


def _run_serial(fn: Callable[[Any], Any], items: list[tuple[str, Any]], retries: int,
                finish: Callable[[TaskResult], None]) -> None:
    for key, argument in items:
        for attempt in range(1, retries + 2):
            outcome = _call(fn, argument, "in-process")
            if outcome[0] or attempt == retries + 1:
                finish(_result(key, outcome, attempt))
                break
            logger.info("task %s failed (%s); retrying", key, outcome[1])


#: environment variable naming the local pool's start method (fork, forkserver or spawn)
START_ENV = "MAGCILIA_START_METHOD"


def start_method() -> str:
    """How the local pool starts its workers: ``MAGCILIA_START_METHOD`` if set; else ``"fork"``
    on Linux with Python < 3.12 (the workers inherit the caller's imports and compiled kernels;
    Python 3.12 deprecates forking a process that runs threads, as BLAS does), else
    ``"forkserver"`` where the platform has it (not macOS, whose system libraries are unsafe to
    fork), else ``"spawn"``."""
    methods = multiprocessing.get_all_start_methods()
    chosen = os.environ.get(START_ENV, "").strip()
    if chosen:
        if chosen not in methods:
            raise v.fail(START_ENV, chosen, "one of " + ", ".join(methods))
        return chosen
    if sys.platform.startswith("linux") and sys.version_info < (3, 12):
        return "fork"
    return "forkserver" if "forkserver" in methods and sys.platform != "darwin" else "spawn"


def _run_pool(fn: Callable[[Any], Any], items: list[tuple[str, Any]], n: int, retries: int,
              finish: Callable[[TaskResult], None]) -> None:
    """The local process pool; a broken pool (a worker died) is started afresh once for the
    tasks not yet finished, a second loss reports them failed."""
    pending = dict(items)
    attempts = dict.fromkeys(pending, 0)
    context = multiprocessing.get_context(start_method())
    direct = context.get_start_method() != "forkserver"  # else the workers' parent is its server
    if context.get_start_method() == "forkserver":  # the server imports these once
        task = getattr(fn, "func", fn)  # a functools.partial: its function's module
        context.set_forkserver_preload(["magcilia.execution",
                                        getattr(task, "__module__", None) or "magcilia"])
    for life in (1, 2):
        broken: BaseException | None = None
        with ProcessPoolExecutor(max_workers=min(n, len(pending)), mp_context=context,
                                 initializer=_worker_start,
                                 initargs=(os.getpid(), direct)) as pool:
            running: dict[Future[Any], str] = {}

            def submit(key: str) -> None:
                attempts[key] += 1
                running[pool.submit(_call, fn, pending[key], "local")] = key  # noqa: B023

            try:
                for key in pending:
                    submit(key)
                broken = _drain(running, pending, attempts, retries, submit, finish)
            except BaseException:  # on_result raised, or Ctrl-C: drop the queue, then leave
                pool.shutdown(wait=False, cancel_futures=True)
                raise
        if broken is None or not pending:
            return
        logger.warning("a worker process died (%s); %s %d unfinished task(s)", one_line(broken),
                       "restarting the pool for" if life == 1 else "giving up on", len(pending))
    for key in list(pending):
        finish(TaskResult(key, None, "BrokenProcessPool: the worker process running it died "
                                     "twice (killed, or out of memory)",
                          max(attempts[key], 1), "local", 0.0))


def _drain(running: dict[Future[Any], str], pending: dict[str, Any], attempts: dict[str, int],
           retries: int, submit: Callable[[str], None],
           finish: Callable[[TaskResult], None]) -> BaseException | None:
    """Collect the pool's results as they finish (retrying failed tasks); returns the
    BrokenProcessPool when a worker died (the unfinished tasks stay in ``pending``)."""
    while running:
        done, _ = wait(running, return_when=FIRST_COMPLETED)
        broken: BaseException | None = None
        for future in done:
            key = running.pop(future)
            try:
                outcome = future.result()
            except BrokenProcessPool as exc:
                broken = exc
                attempts[key] -= 1  # lost with the pool, not failed by itself
                continue
            except Exception as exc:  # noqa: BLE001 (an unpicklable value, say)
                outcome = (False, one_line(exc), 0.0, "local")
            if not outcome[0] and attempts[key] <= retries:
                logger.info("task %s failed (%s); retrying", key, outcome[1])
                try:
                    submit(key)
                    continue
                except BrokenProcessPool as exc:
                    broken = exc
                    attempts[key] -= 1
                    continue
            finish(_result(key, outcome, attempts[key]))
            del pending[key]
        if broken is not None:
            for future in running:
                future.cancel()
            return broken
    return None


@contextlib.contextmanager
def dask_client(scheduler: str, workers: int | None = None,
                timeout: float = 10.0) -> Iterator[Any]:
    """A ``dask.distributed.Client`` connected to ``scheduler`` (an address, or ``"local"``: a
    ``LocalCluster`` of ``workers`` processes with one thread each, closed on leaving). A
    scheduler that does not answer within ``timeout`` s, or has no worker by then, is a one-line
    :class:`MagciliaError`."""
    distributed: Any = require("distributed", package="dask[distributed]", extra="cluster",
                               purpose="Running tasks on a Dask cluster")
    with contextlib.ExitStack() as stack:
        if scheduler == LOCAL_CLUSTER:
            n = workers or default_workers()
            threads = worker_threads()
            env = {THREADS_ENV: "none" if threads is None else str(threads),
                   **({} if threads is None else dict.fromkeys(THREAD_VARIABLES, str(threads)))}
            cluster = stack.enter_context(distributed.LocalCluster(
                # the HTTP server on a free port (None still binds 8787: "already in use")
                n_workers=n, threads_per_worker=1, processes=True, dashboard_address=":0",
                silence_logs=logging.ERROR,
                env=env))
            client = stack.enter_context(distributed.Client(cluster, timeout=timeout))
        else:
            try:
                client = distributed.Client(scheduler, timeout=timeout)
            except (OSError, TimeoutError) as exc:
                raise MagciliaError(
                    f"cannot reach the Dask scheduler at {v.printable(scheduler)} within "
                    f"{timeout:g} s ({one_line(exc)}); start it (dask scheduler), check the "
                    f"address, or leave out --scheduler (and {SCHEDULER_ENV}) to run on this "
                    "machine") from None
            stack.enter_context(client)
            try:
                client.wait_for_workers(1, timeout=timeout)
            except (OSError, TimeoutError) as exc:
                raise MagciliaError(
                    f"the Dask scheduler at {v.printable(scheduler)} has no workers (none joined "
                    f"within {timeout:g} s: {one_line(exc)}); start some (dask worker "
                    f"{v.printable(scheduler)}) or leave out --scheduler") from None
        yield client


def _run_dask(fn: Callable[[Any], Any], items: list[tuple[str, Any]], scheduler: str,
              workers: int | None, retries: int, timeout: float,
              finish: Callable[[TaskResult], None]) -> None:
    import uuid

    with dask_client(scheduler, workers, timeout) as client:
        distributed = sys.modules["distributed"]
        token = uuid.uuid4().hex[:12]
        arguments = dict(items)
        attempts = dict.fromkeys(arguments, 0)
        keys: dict[str, str] = {}

        def submit(key: str) -> Any:
            attempts[key] += 1
            future = client.submit(_call, fn, arguments[key], "dask", pure=False,
                                   key=f"magcilia-{token}-{key}-{attempts[key]}")
            keys[future.key] = key
            return future

        queue = distributed.as_completed([submit(key) for key in arguments])
        for future in queue:
            key = keys[future.key]
            try:
                outcome = future.result()
            except Exception as exc:  # noqa: BLE001 (KilledWorker: it killed workers repeatedly)
                outcome = (False, one_line(exc), 0.0, "dask")
            future.release()
            if not outcome[0] and attempts[key] <= retries:
                logger.info("task %s failed (%s); retrying", key, outcome[1])
                queue.add(submit(key))
                continue
            finish(_result(key, outcome, attempts[key]))
