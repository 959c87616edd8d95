"""Numba compilation on first use for the kernels that live beside their NumPy twins.

:func:`jit` compiles a plain-Python kernel with the house's options (single-threaded,
``error_model="numpy"``, ``nogil``; optionally fastmath limited to ``reassoc`` and ``contract``,
as :mod:`magcilia.model.compiled` explains) the first time it is asked for, caching the machine
code on disk (``cache=True``; without a writable cache folder, in memory). It returns None where
numba cannot be imported or :data:`magcilia.model.compiled.ENABLED` is False, and the caller runs
its NumPy reference instead.
"""

from __future__ import annotations

from collections.abc import Callable
from functools import cache
from typing import Any

from magcilia.model import compiled


@cache
def _compiled(kernel: Callable[..., Any], fastmath: bool) -> Callable[..., Any] | None:
    try:
        import numba
    except ImportError:  # e.g. a Python that numba does not support yet
        return None
    options: dict[str, Any] = {"error_model": "numpy", "nogil": True}
    if fastmath:
        options["fastmath"] = {"reassoc", "contract"}
    try:
        return numba.njit(kernel, cache=True, **options)
    except RuntimeError:  # no writable cache folder (numba's own or NUMBA_CACHE_DIR)
        return numba.njit(kernel, cache=False, **options)


def jit(kernel: Callable[..., Any], fastmath: bool = False) -> Callable[..., Any] | None:
    """``kernel`` compiled by numba (once per process; from the disk cache after the first
    process), or None where numba cannot be imported or the compiled kernels are switched off
    (:data:`magcilia.model.compiled.ENABLED`)."""
    return _compiled(kernel, fastmath) if compiled.ENABLED else None
