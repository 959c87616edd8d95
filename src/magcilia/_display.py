"""How magcilia's objects show themselves in a console and a notebook (no physics).

Every setup and result class mixes in :class:`Display` and writes one method,
``_display_items()``: a short list of ``(label, text)`` pairs, most telling first, with the numbers
already in display units (``"3.26 mm"``). From it come

- ``repr(obj)``: one line of at most :data:`REPR_WIDTH` characters,
  ``Name(label=text, label=text, …)`` (items that do not fit are dropped, an ellipsis says so);
- ``obj._repr_html_()``: a small HTML table (Jupyter shows it), every text escaped with
  :func:`html.escape`, plus an optional row table from ``_display_table()`` (a header and rows,
  cut to :data:`HTML_ROWS` rows).

:func:`dataframe` builds a ``pandas.DataFrame`` from named columns (pandas imported lazily), the
body of every ``to_dataframe()``.

Examples
--------
>>> si(4.1e-6, "V")
'4.1 µV'
>>> si(5.49e-10, "V²")
'5.49e-10 V²'
>>> scaled(3.2613e-3, 1e-3, "mm")
'3.26 mm'
>>> one_line("Thing", [("a", "1 mm"), ("", "2 warnings")])
'Thing(a=1 mm, 2 warnings)'
"""

from __future__ import annotations

import html
import math
from collections.abc import Mapping, Sequence
from typing import Any

#: longest ``repr`` of a magcilia object, characters
REPR_WIDTH = 120
#: longest text of one item in a ``repr`` (longer ones keep their end: file names)
ITEM_WIDTH = 40
#: most rows of the row table in ``_repr_html_`` (the rest is counted in a last row)
HTML_ROWS = 20

#: an item of a display: (label, text); an empty label shows the text alone
Item = tuple[str, str]
#: a row table: (header, rows of texts)
Table = tuple[Sequence[str], Sequence[Sequence[str]]]

_PREFIXES = ((1e9, "G"), (1e6, "M"), (1e3, "k"), (1.0, ""), (1e-3, "m"), (1e-6, "µ"),
             (1e-9, "n"), (1e-12, "p"), (1e-15, "f"))
_STYLE = ("border-collapse:collapse;font-size:0.9em;text-align:left")
_CELL = "padding:1px 8px;text-align:left"


def number(value: float, digits: int = 3) -> str:
    """``value`` with ``digits`` significant digits (``"nan"``, ``"inf"`` as such)."""
    value = float(value)
    if not math.isfinite(value):
        return "nan" if math.isnan(value) else "inf" if value > 0 else "-inf"
    return f"{value:.{digits}g}"


def si(value: float, unit: str, digits: int = 3) -> str:
    """An SI ``value`` in ``unit`` with an engineering prefix (µV, mN, kPa); units with a power
    (``V²``) or a slash keep the bare unit and an exponent."""
    value = float(value)
    if not math.isfinite(value) or value == 0.0 or any(c in unit for c in "²³^/·*"):
        return f"{number(value, digits)} {unit}".rstrip()
    magnitude = abs(value) * (1.0 + 0.5 * 10.0 ** (1 - digits))  # 999.7 µV rounds to 1 mV
    for factor, prefix in _PREFIXES:
        if magnitude >= factor:
            return f"{number(value / factor, digits)} {prefix}{unit}"
    return f"{number(value, digits)} {unit}"


def scaled(value: float, factor: float, unit: str, digits: int = 3) -> str:
    """An SI ``value`` shown in ``unit``, one of which is ``factor`` in SI (``1e-3`` for mm)."""
    return f"{number(float(value) / factor, digits)} {unit}".rstrip()


def count(n: int, noun: str) -> str:
    """``"1 angle"``, ``"33 angles"``."""
    return f"{n} {noun}" if n == 1 else f"{n} {noun}s"


def one_line(name: str, items: Sequence[Item], width: int = REPR_WIDTH) -> str:
    """``Name(label=text, …)`` in at most ``width`` characters: the items that fit, in order, and
    ``…`` where some were dropped; a text over :data:`ITEM_WIDTH` characters keeps its end."""
    texts = [" ".join(text.split()) for _, text in items]  # one line, whatever the texts held
    texts = [t if len(t) <= ITEM_WIDTH else "…" + t[1 - ITEM_WIDTH:] for t in texts]
    parts = [f"{label}={t}" if label else t for (label, _), t in zip(items, texts, strict=True)]
    for kept in range(len(parts), -1, -1):
        shown = parts[:kept] + (["…"] if kept < len(parts) else [])
        line = f"{name}({', '.join(shown)})"
        if len(line) <= width:
            return line
    return f"{name}(…)"


def html_table(name: str, items: Sequence[Item], table: Table | None = None,
               rows: int = HTML_ROWS) -> str:
    """A small HTML block: ``name`` as caption, one row per item, and an optional row table
    (header and at most ``rows`` rows; a last row counts the others). Every text is escaped."""
    e = html.escape
    out = [f'<div class="magcilia"><table style="{_STYLE}">',
           f"<caption style=\"text-align:left\"><b>{e(name)}</b></caption>", "<tbody>"]
    for label, text in items:
        out.append(f'<tr><th style="{_CELL}">{e(label)}</th><td style="{_CELL}">{e(text)}</td>'
                   "</tr>")
    out.append("</tbody></table>")
    if table is not None:
        header, body = table
        out.append(f'<table style="{_STYLE}"><thead><tr>'
                   + "".join(f'<th style="{_CELL}">{e(h)}</th>' for h in header)
                   + "</tr></thead><tbody>")
        for row in body[:rows]:
            out.append("<tr>" + "".join(f'<td style="{_CELL}">{e(c)}</td>' for c in row)
                       + "</tr>")
        if len(body) > rows:
            out.append(f'<tr><td colspan="{len(header)}" style="{_CELL}">… '
                       f"{len(body) - rows} more rows</td></tr>")
        out.append("</tbody></table>")
    out.append("</div>")
    return "\n".join(out)


class Display:
    """Mixin: a one-line ``repr`` and a notebook ``_repr_html_`` from ``_display_items()``.

    A class sets ``repr=False`` on its dataclass (else the dataclass writes its own ``__repr__``)
    and defines ``_display_items()``; ``_display_table()`` may add a row table to the HTML.
    """

    __slots__ = ()

    def _display_items(self) -> list[Item]:
        raise NotImplementedError

    def _display_table(self) -> Table | None:
        return None

    def __repr__(self) -> str:
        return one_line(type(self).__name__, self._display_items())

    def _repr_html_(self) -> str:
        """HTML for Jupyter: the items as a table (display units), escaped."""
        return html_table(type(self).__name__, self._display_items(), self._display_table())


def dataframe(columns: Mapping[str, Any]) -> Any:
    """A ``pandas.DataFrame`` of the named columns (arrays or lists of equal length), pandas
    imported here, not at ``import magcilia``."""
    import pandas as pd

    return pd.DataFrame(dict(columns))


def rows_table(records: Sequence[Mapping[str, Any]], digits: int = 4) -> Table | None:
    """A row table from a list of dicts (``table()`` of a result): numbers with ``digits``
    significant digits. None for no rows."""
    if not records:
        return None
    header = list(records[0])
    body = [[number(v, digits) if isinstance(v, (int, float)) and not isinstance(v, bool)
             else str(v) for v in (r[h] for h in header)] for r in records]
    return header, body


def column(name: str, unit: str) -> str:
    """A column name with its unit as an ASCII suffix: ``column("force", "N")`` is
    ``"force_N"``, ``column("flow", "m/s")`` is ``"flow_m_per_s"``; no suffix without a unit."""
    if not unit:
        return name
    ascii_unit = (unit.replace("µ", "u").replace("²", "2").replace("^", "").replace("*", "")
                  .replace("/", "_per_").replace("·", ""))
    return f"{name}_{ascii_unit}"
