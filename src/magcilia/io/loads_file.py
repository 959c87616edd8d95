"""Tip loads on an array's cilia from a CSV file (``magcilia array --loads``): :func:`read_loads`.

Moved out of :mod:`magcilia.io.array_file` (which still exports its names) so that the array
file's reader and writer stay one module of ≤ 600 lines.
"""

from __future__ import annotations

import math
import os

import numpy as np

from magcilia import _validate as v
from magcilia.io.setup_files import _fail, _key
from magcilia.units import UNITS

__all__ = ["MAX_LOADS_BYTES", "MAX_LOAD_SETS", "read_loads"]


#: largest loads CSV read, bytes
MAX_LOADS_BYTES = 10_000_000
#: most load sets in a loads CSV
MAX_LOAD_SETS = 10_000


def read_loads(path: str | os.PathLike[str], names: tuple[str, ...]) -> np.ndarray:
    """Tip loads on an array's cilia from a CSV file, N, shape (sets, C, 2) (board frame).

    Columns: ``Fx_<unit>`` and ``Fy_<unit>`` with a force unit (``Fx_mN``, ``Fy_uN``, ``Fx_N``);
    optional ``cilium`` (a name of ``names``: cilia not listed carry no load) and ``set`` (a
    whole number: several load sets, each read on its own). Without ``cilium`` the rows of a set
    are the cilia in order, one each.

    Parameters
    ----------
    path : path
        The CSV file (at most :data:`MAX_LOADS_BYTES`).
    names : tuple of str
        The array's cilium names (C).
    """
    import csv
    import io
    from pathlib import Path

    p = Path(path)
    where = v.printable(str(p))
    with p.open("rb") as f:
        raw = f.read(MAX_LOADS_BYTES + 1)
    if len(raw) > MAX_LOADS_BYTES:
        raise v.MagciliaError(f"loads file {where} is larger than {MAX_LOADS_BYTES} bytes "
                              "(MAX_LOADS_BYTES)")
    try:
        text = raw.decode("utf-8-sig")
    except UnicodeDecodeError:
        raise v.MagciliaError(f"loads file {where} is not UTF-8 text") from None
    reader = csv.reader(io.StringIO(text))
    header = [h.strip() for h in next(reader, [])]
    allowed = ("a CSV with columns Fx_<unit> and Fy_<unit> (a force unit: N, mN, uN, nN), "
               "optional cilium and set")
    factors: dict[str, tuple[int, float]] = {}
    for i, h in enumerate(header):
        head, _, unit = h.partition("_")
        if head in ("Fx", "Fy"):
            factor = UNITS["force"].get(unit)
            if factor is None or head in factors:
                raise _fail(f"{where}: column {_key(h)}", h, allowed)
            factors[head] = (i, factor)
    if set(factors) != {"Fx", "Fy"}:
        raise _fail(f"loads file {where}", ",".join(header)[:80], allowed)
    col_c = header.index("cilium") if "cilium" in header else None
    col_s = header.index("set") if "set" in header else None
    sets: dict[int, list[tuple[int | None, float, float]]] = {}
    for line, row in enumerate(reader, start=2):
        if not row or all(not x.strip() for x in row):
            continue
        if len(row) != len(header):
            raise _fail(f"{where}: line {line}", ",".join(row)[:80],
                        f"{len(header)} fields like the header")
        try:
            fx, fy = (float(row[factors[k][0]]) * factors[k][1] for k in ("Fx", "Fy"))
            s = int(row[col_s]) if col_s is not None else 0
        except ValueError:
            raise _fail(f"{where}: line {line}", ",".join(row)[:80],
                        "numbers in Fx and Fy and a whole number in set") from None
        if not (math.isfinite(fx) and math.isfinite(fy)):
            raise _fail(f"{where}: line {line}", ",".join(row)[:80], "finite forces")
        c = None
        if col_c is not None:
            name = row[col_c].strip()
            if name not in names:
                raise _fail(f"{where}: line {line}: cilium", name,
                            "a cilium of the array: " + ", ".join(names[:8])
                            + (", …" if len(names) > 8 else ""))
            c = names.index(name)
        sets.setdefault(s, []).append((c, fx, fy))
        if len(sets) > MAX_LOAD_SETS:
            raise _fail(f"{where}: set", f"more than {MAX_LOAD_SETS} sets",
                        f"at most {MAX_LOAD_SETS} (MAX_LOAD_SETS)")
    if not sets:
        raise _fail(f"loads file {where}", "no rows", "at least one row of loads")
    out = np.zeros((len(sets), len(names), 2))
    for k, key in enumerate(sorted(sets)):
        rows = sets[key]
        if col_c is None:
            if len(rows) != len(names):
                raise _fail(f"{where}: set {key}", f"{len(rows)} rows",
                            f"{len(names)} rows (one per cilium, in order), or a cilium column")
            out[k] = [(fx, fy) for _, fx, fy in rows]
            continue
        seen: set[int] = set()
        for c, fx, fy in rows:
            assert c is not None
            if c in seen:
                raise _fail(f"{where}: set {key}", f"cilium {names[c]} twice",
                            "one row per cilium and set")
            seen.add(c)
            out[k, c] = (fx, fy)
    return out
