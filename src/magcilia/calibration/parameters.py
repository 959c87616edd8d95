"""A calibration's parameters as objects (lmfit's ``Parameter`` is the model).

:class:`ParameterKey` names a parameter structurally: the registry name
(:data:`~magcilia.device.parameters.PARAMETERS`) and, for the linear parameters each experiment
has of its own (its constant offset, one per field axis), the experiment's index and the axis.
Its :attr:`~ParameterKey.label` (``offset_x[2]``) is for people and files; code compares keys,
never parses labels.

:class:`FitParameter` is one parameter of a fit: its key, fitted value, bounds, fixed or free,
Gaussian prior, standard error and SI unit (:meth:`CalibrationResult.parameters
<magcilia.calibration.result.CalibrationResult.parameters>` lists them).
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Any

from magcilia._display import Display, Item, number
from magcilia.device.parameters import PARAMETERS as REGISTRY
from magcilia.device.parameters import Parameter

#: the field axes of a 3-axis experiment's offsets, in order
AXES = "xyz"


@dataclass(frozen=True, order=True)
class ParameterKey:
    """The structural name of a calibration parameter.

    Attributes
    ----------
    name : str
        The registry name (``"height"``, ``"offset"``, ``"magnetization_scale"``, …) or
        ``"bias"`` for a polynomial bias term.
    experiment : int or None
        The experiment it belongs to (index into the fit's experiments); None for a parameter
        shared by all (the geometry, the scale).
    axis : int or None
        The field axis (0, 1, 2: x, y, z) of a 3-axis experiment's offset; None otherwise.
    degree : int
        The power of the angle of a polynomial bias term (``"bias"``; 0 for everything else).

    Examples
    --------
    >>> ParameterKey("offset", 2, 0).label(many=True), ParameterKey("height").label()
    ('offset_x[2]', 'height')
    """

    name: str
    experiment: int | None = None
    axis: int | None = None
    degree: int = 0

    def label(self, many: bool = False) -> str:
        """The display name: ``offset_x`` for an axis' offset, ``bias_2`` for a bias term, with
        ``[i]`` (the experiment) when ``many`` experiments are fitted together."""
        base = self.name
        if self.axis is not None:
            base = f"{base}_{AXES[self.axis]}"
        if self.name == "bias":
            base = f"bias_{self.degree}"
        return f"{base}[{self.experiment}]" if many and self.experiment is not None else base

    @property
    def registry(self) -> Parameter | None:
        """The registry entry (unit, display unit, limits) of this parameter, None for a bias
        term of degree ≥ 1 (V/rad^d: no entry)."""
        return REGISTRY.get(self.name)

    @property
    def unit(self) -> str:
        """Its SI unit ("" where dimensionless or unknown); a field experiment's offset is in T."""
        if self.name == "offset" and self.axis is not None:
            return "T"
        entry = self.registry
        return entry.unit if entry is not None else ""

    def display(self) -> tuple[float, str]:
        """SI value of one display unit and its symbol (``(1e-3, "mm")`` for a length,
        ``(1e-6, "µT")`` for a field offset, ``(1.0, "")`` without one)."""
        if self.name == "offset" and self.axis is not None:
            return 1e-6, "µT"
        entry = self.registry
        return (entry.display_factor, entry.display) if entry is not None and entry.display else (
            1.0, "")


@dataclass(frozen=True, eq=False, repr=False)
class FitParameter(Display):
    """One parameter of a calibration (immutable).

    Attributes
    ----------
    key : ParameterKey
        Its structural name.
    label : str
        Its display name (``offset_x[2]``; the key of ``values`` and ``stderr``).
    value : float
        The fitted (or held) value, SI.
    bounds : (float, float)
        The search bounds, SI ((nan, nan) for a linear parameter solved in closed form).
    fixed : bool
        Held at ``value`` instead of fitted.
    prior : (float, float) or None
        Gaussian prior (value, σ), SI.
    stderr : float
        1-σ standard error, SI (inf: undetermined; NaN: not estimated, e.g. held).
    unit : str
        The SI unit.
    """

    key: ParameterKey
    label: str
    value: float
    bounds: tuple[float, float]
    fixed: bool
    prior: tuple[float, float] | None
    stderr: float
    unit: str

    @property
    def name(self) -> str:
        """The registry name (``key.name``)."""
        return self.key.name

    @property
    def vary(self) -> bool:
        """Whether the fit varied it (lmfit's ``vary``): not :attr:`fixed`."""
        return not self.fixed

    def to_dict(self) -> dict[str, Any]:
        """JSON-ready content (SI)."""
        return {"name": self.key.name, "experiment": self.key.experiment, "axis": self.key.axis,
                "degree": self.key.degree, "label": self.label, "value": self.value,
                "bounds": list(self.bounds), "fixed": self.fixed,
                "prior": None if self.prior is None else list(self.prior),
                "stderr": self.stderr, "unit": self.unit}

    def report(self) -> str:
        """One line: label, value ± standard error (display units), held or prior."""
        factor, unit = self.key.display()
        se = ("fixed" if self.fixed else "undetermined" if self.stderr == math.inf
              else "-" if not math.isfinite(self.stderr) else f"± {number(self.stderr / factor)}")
        parts = [f"{self.label} = {number(self.value / factor)}", unit, se]
        if self.prior is not None:
            parts.append(f"(prior {number(self.prior[0] / factor)} ± "
                         f"{number(self.prior[1] / factor)})")
        return " ".join(p for p in parts if p)

    def _display_items(self) -> list[Item]:
        return [("", self.report())]
