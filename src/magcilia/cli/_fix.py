"""``--fix NAME=VALUE``: hold calibration parameters (``magcilia calibrate`` and ``demo``)."""

from __future__ import annotations

from magcilia._errors import MagciliaError
from magcilia._validate import fail
from magcilia.calibration import PARAMETERS
from magcilia.device.parameters import PARAMETERS as REGISTRY
from magcilia.units import parse_quantity

#: help text of ``--fix`` (calibrate and demo)
FIX_HELP = ("Hold a parameter instead of fitting it, NAME=VALUE with VALUE in mm or with a unit "
            "(height=3.1, height=3.1mm; n_loops=2); repeatable.")


def _fix_allowed(name: str) -> str:
    """What ``--fix NAME=...`` takes, in display units, for its one-line error."""
    p = REGISTRY[name]
    if p.domain == "integer":
        return f"NAME=VALUE with VALUE a whole number from 1 to {p.maximum:g}, e.g. {name}=2"
    lo = p.to_display(p.minimum) if p.domain == "positive" else (
        0.0 if p.domain == "non_negative" else -p.to_display(p.maximum))
    return (f"NAME=VALUE with VALUE in {p.display} or with a unit, within "
            f"[{lo:g}, {p.to_display(p.maximum):g}] {p.display}, e.g. {name}=3.1 or "
            f"{name}=3.1{p.display}")


def parse_fixed(items: tuple[str, ...]) -> dict[str, float]:
    """``NAME=VALUE`` items of ``--fix`` -> SI values; VALUE in the parameter's display unit (mm)
    or with a unit string (``3.1mm``, ``3100um``), whole numbers for n_loops and
    dipoles_per_loop. Errors echo the item as typed."""
    out: dict[str, float] = {}
    for item in items:
        name, sep, text = (part.strip() for part in item.partition("="))
        if name not in PARAMETERS or not sep:
            raise fail("--fix", item, "NAME=VALUE with NAME one of " + ", ".join(PARAMETERS))
        p = REGISTRY[name]
        try:
            value = p.from_display(float(text))
        except ValueError:
            try:
                if p.dimension is None:
                    raise MagciliaError(text) from None
                value = parse_quantity(text, p.dimension, f"--fix {name}")
            except MagciliaError:
                raise fail("--fix", item, _fix_allowed(name)) from None
        try:
            p.check(value, "--fix")
        except MagciliaError:
            raise fail("--fix", item, _fix_allowed(name)) from None
        if name in out:
            raise fail("--fix", item, f"one value per parameter ({name} is given twice)")
        out[name] = value
    return out
