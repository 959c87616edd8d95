"""Numba compilation of plain-Python kernels with the house's options (no switch, no physics).

:func:`compile_kernel` compiles a kernel once per process (single-threaded,
``error_model="numpy"``, ``nogil``; optionally fastmath limited to ``reassoc`` and ``contract``,
as :mod:`magcilia.model.compiled` explains), caching the machine code on disk (``cache=True``;
without a writable cache folder, in memory), or gives None where numba cannot be imported. The
switch that turns compiled kernels off lives above it (:func:`magcilia.model.jit.jit`, or
the fitter's :data:`magcilia.fitting.compiled.ENABLED`).
"""

from __future__ import annotations

from collections.abc import Callable
from functools import cache
from typing import Any


@cache
def compile_kernel(kernel: Callable[..., Any], fastmath: bool = False
                   ) -> Callable[..., Any] | None:
    """``kernel`` compiled by numba (once per process; from the disk cache after the first
    process), or None where numba cannot be imported."""
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
