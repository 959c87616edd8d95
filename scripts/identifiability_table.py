"""The identifiability table of docs/coil-calibration.md, computed by the tool.

The page holds between its markers what ``python -m magcilia plan --identifiability --markdown``
prints (:func:`magcilia.analysis.identifiability_table.identifiability_table`);
tests/docs/test_coil_calibration_page.py checks that it still does (slow).

Run: python scripts/identifiability_table.py            (print the block)
     python scripts/identifiability_table.py --write    (replace the block in the page)
"""

from __future__ import annotations

import argparse
from pathlib import Path

from magcilia._atomic import write_text
from magcilia.analysis.identifiability_table import identifiability_table

PAGE = Path(__file__).resolve().parents[1] / "docs" / "coil-calibration.md"
START = ("<!-- identifiability-table: start (python -m magcilia plan --identifiability "
         "--markdown) -->")
END = "<!-- identifiability-table: end -->"


def block() -> str:
    """The table between the markers."""
    return f"{START}\n\n{identifiability_table().markdown()}\n{END}"


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--write", action="store_true", help="replace the block in the page")
    args = parser.parse_args()
    text = block()
    if not args.write:
        print(text)
        return
    page = PAGE.read_text(encoding="utf-8")
    head, _, rest = page.partition(START)
    _, _, tail = rest.partition(END)
    write_text(PAGE, head + text + tail)


if __name__ == "__main__":
    main()
