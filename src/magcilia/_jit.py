"""Numba compilation of plain-Python kernels with the house's options (no switch, no physics).

:func:`compile_kernel` is the one way the project compiles a kernel: once per process (per kernel
and options), single-threaded, ``error_model="numpy"``, ``nogil``, caching the machine code on
disk (``cache=True``; without a writable cache folder, in memory), or None where numba cannot be
imported. Its options, for the few kernels that need them:

* ``fastmath``: False (none), True (``reassoc`` and ``contract``: sums may be reordered and
  products fused, as :mod:`magcilia.model.compiled` explains), or a set of those two flags
  (e.g. ``{"contract"}``). The flags that would change NaN or infinity (``nnan``, ``ninf``, …)
  are refused: the read-out's flags are NaN and inf.
* ``calls``: compiled helpers (:func:`compile_kernel`'s results) that the kernel calls by their
  names; each is put into the kernel's module under its Python function's name before the
  kernel compiles. Keep a helper in its kernel's module: numba keys a kernel's disk cache on
  its own file only, so an edited helper from another module would leave the kernel's cached
  machine code stale (checked: the old helper's result came back after the edit).
* ``cache=False``: in memory only (a helper inlined into a cached kernel needs no file of its own).
* any other numba option as a keyword (``boundscheck=False``, ``forceinline=True``,
  ``_nrt=False``, or ``nogil=False`` to override the default).

The switch that turns compiled kernels off lives above it (:func:`magcilia.model.jit.jit` and
:data:`magcilia.model.compiled.ENABLED`, or the fitter's :data:`magcilia.fitting.compiled.ENABLED`).
"""

from __future__ import annotations

from collections.abc import Callable
from collections.abc import Set as AbstractSet
from functools import cache
from typing import Any

#: the fastmath flags a kernel may ask for (numba's LLVM flags that keep NaN and inf exact)
FASTMATH_FLAGS = frozenset({"reassoc", "contract"})


def compile_kernel(kernel: Callable[..., Any], fastmath: bool | AbstractSet[str] = False,
                   *, calls: tuple[Callable[..., Any] | None, ...] = (), cache: bool = True,
                   **options: Any) -> Callable[..., Any] | None:
    """``kernel`` compiled by numba (once per process for the same options; from the disk cache
    after the first process unless ``cache`` is False), or None where numba cannot be imported.

    ``fastmath``: False, True (``reassoc`` and ``contract``) or a subset of
    :data:`FASTMATH_FLAGS`; ``calls``: the compiled helpers the kernel calls by name (this
    function's results; a None among them gives None); ``options``: further numba options
    (they override ``error_model="numpy"`` and ``nogil``). Cheap to call again (a cache lookup,
    ~0.2 µs): callers may ask for their kernel at every call.
    """
    try:  # (before the cache: where numba cannot be imported, nothing compiled is handed out)
        import numba  # noqa: F401
    except ImportError:  # e.g. a Python that numba does not support yet
        return None
    if calls and any(helper is None for helper in calls):
        return None
    if isinstance(fastmath, (set, list, tuple)):  # (a frozenset, hashable, is taken as it is)
        fastmath = frozenset(fastmath)
    return _compiled(kernel, fastmath, calls, cache, **options)


@cache
def _compiled(kernel: Callable[..., Any], fastmath: bool | frozenset[str],
              calls: tuple[Callable[..., Any], ...], cache: bool,
              **extra: Any) -> Callable[..., Any]:
    import numba

    if fastmath is True:
        flags = FASTMATH_FLAGS
    else:
        flags = frozenset() if fastmath is False else fastmath
        if not flags <= FASTMATH_FLAGS:
            raise ValueError(f"fastmath flags {sorted(flags - FASTMATH_FLAGS)} are not allowed; "
                             f"use a subset of {sorted(FASTMATH_FLAGS)}, True or False")
    options: dict[str, Any] = {"error_model": "numpy", "nogil": True, **extra}
    if flags:
        options["fastmath"] = set(flags)
    for helper in calls:  # the kernel reads each helper as a global of its module
        kernel.__globals__[getattr(helper, "py_func", helper).__name__] = helper
    if cache:
        try:
            return numba.njit(kernel, cache=True, **options)
        except RuntimeError:  # no writable cache folder (numba's own or NUMBA_CACHE_DIR)
            pass
    return numba.njit(kernel, cache=False, **options)
