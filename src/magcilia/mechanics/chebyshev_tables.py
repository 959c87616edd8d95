"""Shipped Chebyshev references for the node counts a first bend most often needs, read instead of
computed (pure arrays; :mod:`magcilia.mechanics.elastica` uses them).

A bend's collocation grid scales the references on [-1, 1] of its node count n
(:func:`magcilia.mechanics.elastica._reference`, :func:`~magcilia.mechanics.elastica.
_uniform_reference`); building them in closed form costs a first bend in a fresh process
~0.15 ms of its ~0.7 ms (their own arithmetic and the first use of the NumPy operations in it).
For the counts in :data:`SHIPPED` they are read from ``magcilia/data/chebyshev/`` instead: one
file ``n{n}-m{m}.f64`` each, raw little-endian float64 in this order:

* the n nodes t (ascending), shape (n,);
* ∫_{-1}^{t} of the nodal interpolant at the nodes, shape (n, n), row-major;
* the weights of ∫_{-1}^{1}, shape (n,);
* ∫_{-1}^{x} at m uniform x from −1 to 1, shape (m, n), row-major (m = the bend's
  :data:`~magcilia.mechanics.planar.OUTPUT_POINTS`).

They are the closed forms' own output, written by ``scripts/chebyshev_tables.py``
(``tests/mechanics/test_chebyshev_tables.py`` recomputes and compares them). Only the counts of
the issue's tapered cilium (34 nodes: L = 3 mm, r 0.2 → 0.05 mm) and of the bundled
force-sensor setup (32) are shipped, 45 kB each; every other count is computed on first use
as before.
"""

from __future__ import annotations

import os
import sys
from functools import lru_cache

import numpy as np
from numpy.typing import NDArray

F64 = NDArray[np.float64]

#: node counts n whose references are shipped, each with the output points m of its uniform table
SHIPPED = {32: 129, 34: 129}

#: where the tables are: a plain str path (pathlib's first use would cost a first bend ~30 µs)
FOLDER = os.path.join(  # noqa: PTH118 (a str path, above)
    os.path.dirname(os.path.dirname(os.path.abspath(__file__))),  # noqa: PTH100, PTH120
    "data", "chebyshev")


def path(n: int, m: int) -> str:
    """The file of the references for n nodes and m uniform output points."""
    return f"{FOLDER}{os.sep}n{n}-m{m}.f64"


@lru_cache(maxsize=8)
def read(n: int) -> tuple[F64, F64, F64, F64] | None:
    """The shipped references of n nodes, read-only: nodes (n,), the integration matrix at the
    nodes (n, n), the weights (n,) and the uniform output matrix (m, n) (the module notes);
    None if n is not shipped or its file is missing or of the wrong size."""
    m = SHIPPED.get(n)
    if m is None:
        return None
    size = 8 * n * (n + m + 2)
    try:  # one system call to read (no file object, no pathlib: ~20 µs less on a first bend)
        fd = os.open(path(n, m), os.O_RDONLY | getattr(os, "O_BINARY", 0))
        try:
            raw = os.read(fd, size + 1)  # one byte more: a longer file is found out
        finally:
            os.close(fd)
    except OSError:
        return None
    if len(raw) != size:
        return None
    values = np.frombuffer(raw, dtype=np.float64)  # read-only: a view of the bytes
    if sys.byteorder != "little":  # the files are little-endian
        values = values.byteswap()
        values.setflags(write=False)
    nn = n * n
    return (values[:n], values[n:n + nn].reshape(n, n), values[n + nn:2 * n + nn],
            values[2 * n + nn:].reshape(m, n))


def encode(nodes: F64, at_nodes: F64, weights: F64, uniform: F64) -> bytes:
    """The file contents (raw little-endian float64, the module's layout) of the references."""
    return np.concatenate([np.ravel(a) for a in (nodes, at_nodes, weights, uniform)]).astype(
        "<f8").tobytes()
