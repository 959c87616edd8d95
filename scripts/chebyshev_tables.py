"""The shipped Chebyshev references (``src/magcilia/data/chebyshev/``), from their closed forms.

:mod:`magcilia.mechanics.chebyshev_tables` reads them so that a first bend in a fresh process
does not build them (issue 27 item 6); ``tests/mechanics/test_chebyshev_tables.py`` recomputes
them and compares. Rerun after changing the closed forms or ``SHIPPED``.

Run: python scripts/chebyshev_tables.py            (say which files differ)
     python scripts/chebyshev_tables.py --write    (write them)
"""

from __future__ import annotations

import argparse
from pathlib import Path

from magcilia.mechanics import chebyshev_tables as tables
from magcilia.mechanics.elastica import _closed_reference, _closed_uniform_reference


def contents(n: int, m: int) -> bytes:
    """The file of n nodes and m uniform output points, from the closed forms."""
    return tables.encode(*_closed_reference(n), _closed_uniform_reference(n, m))


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--write", action="store_true", help="write the files")
    args = parser.parse_args()
    for n, m in tables.SHIPPED.items():
        path = Path(tables.path(n, m))
        data = contents(n, m)
        same = path.is_file() and path.read_bytes() == data
        if args.write and not same:
            path.parent.mkdir(parents=True, exist_ok=True)
            path.write_bytes(data)
        state = "unchanged" if same else "written" if args.write else "differs"
        print(f"{path.name}: {len(data)} bytes, {state}")


if __name__ == "__main__":
    main()
