"""``xarray.Dataset`` views of recordings, measurements and read-out results (NetCDF's model).

One builder, :func:`dataset`: named 1-D variables along one dimension (``sample`` for raw
samples and readings, ``condition`` for a reduced :class:`~magcilia.io.measurement.Measurement`),
the coordinates among them (``time_s``, the angle, load or applied field, as they apply), a
``units`` attribute on every variable (SI, the unit the name carries), and the metadata as the
dataset's attributes (text, numbers or booleans; anything else as JSON text, so that the dataset
writes to NetCDF as it is). xarray is imported here, where it is used: without it, one
:class:`~magcilia.MissingDependencyError` line naming the ``export`` extra.
"""

from __future__ import annotations

import json
from collections.abc import Mapping, Sequence
from typing import Any

import numpy as np
from numpy.typing import ArrayLike

from magcilia._atomic import jsonable
from magcilia._errors import require


def xarray_module(purpose: str = "An xarray view") -> Any:
    """The ``xarray`` module, or one :class:`~magcilia.MissingDependencyError` line naming the
    ``export`` extra."""
    return require("xarray", package="xarray", extra="export", purpose=purpose)


def attribute(value: Any) -> str | int | float | bool:
    """A value as a NetCDF attribute: text, a number or a boolean as it is (booleans as 0/1),
    None as "", anything else as JSON text."""
    if isinstance(value, bool | np.bool_):
        return int(value)
    if isinstance(value, str | int | float | np.integer | np.floating):
        return value.item() if isinstance(value, np.generic) else value
    if value is None:
        return ""
    return json.dumps(jsonable(value))


def dataset(variables: Mapping[str, ArrayLike], units: Mapping[str, str], *,
            dim: str | tuple[str, ...],
            coords: Sequence[str] = (), attrs: Mapping[str, Any] | None = None,
            descriptions: Mapping[str, str] | None = None) -> Any:
    """An ``xarray.Dataset`` of 1-D variables along ``dim``.

    Parameters
    ----------
    variables : mapping of str to array-like, each shape (n,) (or the shape of ``dim``)
        The values by name (SI).
    units : mapping of str to str
        The unit of each variable (``units`` attribute; "" or missing: none written).
    dim : str or tuple of str
        The dimension's name (``"sample"``, ``"condition"``), or the names of several.
    coords : sequence of str
        The names among ``variables`` that are coordinates along ``dim``.
    attrs : mapping, optional
        The dataset's attributes (:func:`attribute` of each).
    descriptions : mapping of str to str, optional
        A ``long_name`` attribute per variable.
    """
    xr = xarray_module()
    made: dict[str, Any] = {}
    for name, values in variables.items():
        var_attrs = {}
        if units.get(name):
            var_attrs["units"] = units[name]
        if descriptions and descriptions.get(name):
            var_attrs["long_name"] = descriptions[name]
        made[name] = xr.Variable((dim,) if isinstance(dim, str) else dim, np.asarray(values),
                                 attrs=var_attrs)
    return xr.Dataset({k: x for k, x in made.items() if k not in coords},
                      coords={k: made[k] for k in coords if k in made},
                      attrs={k: attribute(x) for k, x in (attrs or {}).items()})

