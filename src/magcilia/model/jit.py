"""Numba compilation on first use for the kernels that live beside their NumPy twins.

:func:`jit` compiles a plain-Python kernel with the house's options
(:func:`magcilia._jit.compile_kernel`, the project's one way to compile a kernel: single-threaded,
``error_model="numpy"``, ``nogil``; optionally fastmath limited to ``reassoc`` and ``contract``, as
:mod:`magcilia.model.compiled` explains) the first time it is asked for, caching the machine code on
disk. It returns None where numba cannot be imported or :data:`magcilia.model.compiled.ENABLED` is
False, and the caller runs its NumPy reference instead.
"""

from __future__ import annotations

from collections.abc import Callable
from typing import Any

from magcilia._jit import compile_kernel
from magcilia.model import compiled


def jit(kernel: Callable[..., Any], fastmath: bool = False) -> Callable[..., Any] | None:
    """``kernel`` compiled by numba (once per process; from the disk cache after the first
    process), or None where numba cannot be imported or the compiled kernels are switched off
    (:data:`magcilia.model.compiled.ENABLED`)."""
    return compile_kernel(kernel, fastmath) if compiled.ENABLED else None
