"""The thin checking layer: turn user input into clean arrays or raise one-line errors.

The physics kernels do no checking; the public functions call these helpers first.
"""

from __future__ import annotations

import contextlib
import math
import numbers
from collections.abc import Iterator, Mapping, Sequence

import numpy as np
from numpy.typing import ArrayLike, NDArray

from magcilia._errors import MagciliaError


def printable(text: str) -> str:
    r"""``text`` with every non-printable character (control characters, line breaks, escape
    sequences that would clear or recolour a terminal) written as a Python escape, so that a
    message built from a file's bytes stays one harmless line.

    >>> printable("volt\x1b[2J\nage")
    'volt\\x1b[2J\\nage'
    """
    if text.isprintable():
        return text
    return "".join(c if c.isprintable() else repr(c)[1:-1] for c in text)


def short(value: object, limit: int = 60) -> str:
    """``value`` for a message: a string as it is, anything else as its ``str``, non-printable
    characters escaped and cut to ``limit`` characters (a value read from a file may be huge:
    a 400-digit number, a megabyte of text).

    >>> short(10**400, 12)
    '100000000000… (401 characters)'
    """
    try:
        text = value if isinstance(value, str) else str(value)
    except (RecursionError, ValueError):  # e.g. an int beyond Python's digit limit
        text = f"a {type(value).__name__}"
    text = printable(text)
    return text if len(text) <= limit else f"{text[:limit]}… ({len(text)} characters)"


def _fmt(value: object) -> str:
    if isinstance(value, float):
        return f"{value:.6g}"
    return repr(short(value)) if isinstance(value, str) else short(value)


def fail(name: str, value: object, allowed: str) -> MagciliaError:
    """The package's single error template: ``NAME must be ALLOWED; got VALUE``."""
    return MagciliaError(f"{name} must be {allowed}; got {_fmt(value)}")


def real(name: str, value: object, unit: str = "") -> float:
    """A finite real number (``unit`` is only used in the message)."""
    what = f"a finite number in {unit}" if unit else "a finite number"
    if type(value) is not float and (isinstance(value, bool)
                                     or not isinstance(value, numbers.Real)):
        raise fail(name, value, what)
    out = float(value)
    if not math.isfinite(out):
        raise fail(name, value, what)
    return out


def positive(name: str, value: object, unit: str = "m", what: str = "length") -> float:
    """A finite number > 0."""
    allowed = f"a positive {what} in {unit}" if unit else f"a positive {what}"
    if type(value) is not float and (isinstance(value, bool)
                                     or not isinstance(value, numbers.Real)):
        raise fail(name, value, allowed)
    out = float(value)
    if not (math.isfinite(out) and out > 0.0):
        raise fail(name, value, allowed)
    return out


def non_negative(name: str, value: object, unit: str = "m", what: str = "length") -> float:
    """A finite number >= 0."""
    allowed = f"a non-negative {what} in {unit}" if unit else f"a non-negative {what}"
    if type(value) is not float and (isinstance(value, bool)
                                     or not isinstance(value, numbers.Real)):
        raise fail(name, value, allowed)
    out = float(value)
    if not (math.isfinite(out) and out >= 0.0):
        raise fail(name, value, allowed)
    return out


def integer(name: str, value: object, minimum: int = 1) -> int:
    """An integer >= ``minimum`` (floats with an integral value, like 3.0, are accepted)."""
    allowed = f"an integer >= {minimum}"
    if isinstance(value, bool):
        raise fail(name, value, allowed)
    if isinstance(value, numbers.Integral):
        out = int(value)
    elif isinstance(value, numbers.Real) and float(value).is_integer():
        out = int(float(value))
    else:
        raise fail(name, value, allowed)
    if out < minimum:
        raise fail(name, value, allowed)
    return out


def finite_array(
    name: str, value: ArrayLike, ndim: int | None = None, unit: str = ""
) -> NDArray[np.float64]:
    """A float64 array with only finite entries (and, if given, exactly ``ndim`` dimensions)."""
    try:
        arr = np.asarray(value, dtype=np.float64)
    except (TypeError, ValueError):
        raise fail(name, value, f"numeric{' in ' + unit if unit else ''}") from None
    if ndim is not None and arr.ndim != ndim:
        raise fail(name, f"an array of shape {arr.shape}", f"an array with {ndim} dimension(s)")
    if not np.all(np.isfinite(arr)):
        bad = arr[~np.isfinite(arr)].ravel()[0]
        raise fail(name, f"an array containing {bad}", "finite (no NaN or inf)")
    return arr


def vector3(name: str, value: Sequence[float] | ArrayLike, unit: str = "m") -> NDArray[np.float64]:
    """A finite 3-vector."""
    arr = finite_array(name, value, unit=unit)
    if arr.shape != (3,):
        raise fail(name, f"an array of shape {arr.shape}", f"three numbers (x, y, z) in {unit}")
    return arr


def choice(name: str, value: object, options: Sequence[str]) -> str:
    """One of a fixed set of strings."""
    if value not in options:
        raise fail(name, value, "one of " + ", ".join(repr(o) for o in options))
    return str(value)


def intervals(
    name: str,
    given: Mapping[str, Sequence[float]] | None,
    defaults: Mapping[str, tuple[float, float]],
) -> dict[str, tuple[float, float]]:
    """``defaults`` updated with ``given`` (low, high) pairs; each key known, each pair finite with
    low <= high. ``name`` ("bounds", "spans") is used in the messages."""
    merged = dict(defaults)
    for key, pair in (given or {}).items():
        if key not in defaults:
            raise fail(f"{name} key", key, "one of " + ", ".join(defaults))
        try:
            lo, hi = (float(b) for b in pair)
        except (TypeError, ValueError):
            raise fail(f"{name}[{key!r}]", pair, "a (low, high) pair of numbers") from None
        if not (math.isfinite(lo) and math.isfinite(hi)) or lo > hi:
            raise fail(f"{name}[{key!r}]", (lo, hi), "a finite (low, high) pair with low <= high")
        merged[key] = (lo, hi)
    return merged


@contextlib.contextmanager
def rebuilding(what: str, cls_name: str) -> Iterator[None]:
    """Turn a missing or bad entry met while rebuilding a result from its ``to_dict()`` output
    into one line: ``WHAT must be a dict from CLS.to_dict(); got missing or bad …``."""
    try:
        yield
    except (KeyError, TypeError, ValueError) as exc:
        raise fail(what, f"missing or bad {exc}", f"a dict from {cls_name}.to_dict() (SI; "
                   "a command's JSON in display units is not one: write it with --si)") from None
