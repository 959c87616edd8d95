"""Lazy public names: a package's face that imports each name's module on its first use.

Every room's ``__init__`` (and ``magcilia`` itself) writes its public names once, as ordinary
imports inside an ``if TYPE_CHECKING:`` block (so mypy, IDEs and ``tests/test_architecture.py``
see every name and every arrow), and ends with::

    __getattr__, __dir__ = attach(__name__)

:func:`attach` reads that block from the package's own source and hands out module-level
``__getattr__`` and ``__dir__`` (PEP 562): ``magcilia.calibrate`` (or ``from magcilia import
calibrate``) imports :mod:`magcilia.calibration.search` on first access and keeps the value, so
``import magcilia`` costs almost nothing and SciPy, pandas, numba or matplotlib load only where a
name that needs them is used. ``dir()``, ``help()``, tab completion and ``from magcilia import *``
list the lazy names as if they were there.

One subtlety is handled here: a public name that is also a submodule's name (``mechanics.bend``
the function, ``mechanics/bend.py`` the module; ``fitting.multistart``, ``fitting.polish``). An
eager ``__init__`` rebound the name to the function after the import; lazily, whoever imports the
submodule first would bind the module over the name. The package's module object therefore
refuses that binding (:class:`_LazyModule`), and the name resolves to the function, as before.
"""

from __future__ import annotations

import ast
import importlib
import sys
import types
from collections.abc import Callable
from typing import Any

#: ``name -> (module to import, attribute of it or None for the module itself)``
Table = dict[str, tuple[str, str | None]]


def attach(package: str, fallback: Callable[[str], Any] | None = None
           ) -> tuple[Callable[[str], Any], Callable[[], list[str]]]:
    """The ``__getattr__`` and ``__dir__`` of a package whose public names are the imports of its
    ``if TYPE_CHECKING:`` block.

    Parameters
    ----------
    package : str
        The package's ``__name__`` (it must be in ``sys.modules``: call at the end of its
        ``__init__``).
    fallback : callable, optional
        Called with names the block does not hold (e.g. deprecated forwards that warn); it
        raises ``AttributeError`` for unknown names. Without one, unknown names raise it here.

    Returns
    -------
    (__getattr__, __dir__)
        To assign at module level.
    """
    module = sys.modules[package]
    table = lazy_table(package)
    module.__class__ = _LazyModule
    module.__dict__["_lazy_table"] = table

    def __getattr__(name: str) -> Any:  # noqa: N807 (the PEP 562 name)
        try:
            source, attribute = table[name]
        except KeyError:
            if fallback is not None:
                return fallback(name)
            raise AttributeError(f"module {package!r} has no attribute {name!r}") from None
        if source == package and attribute is not None:  # ``from magcilia.io import presets``
            source, attribute = f"{package}.{attribute}", None
        value: Any = importlib.import_module(source)
        if attribute is not None:
            value = getattr(value, attribute)
        module.__dict__[name] = value  # found once; later lookups never reach __getattr__
        return value

    def __dir__() -> list[str]:  # noqa: N807 (the PEP 562 name)
        return sorted(set(module.__dict__) | set(table))

    return __getattr__, __dir__


def lazy_table(package: str) -> Table:
    """Each name imported in the ``if TYPE_CHECKING:`` block(s) of ``package``'s ``__init__``, with
    the module it comes from and the attribute of it (``None``: the module itself)."""
    module = sys.modules[package]
    spec = module.__spec__
    source = spec.loader.get_source(package) if spec is not None and spec.loader is not None \
        and hasattr(spec.loader, "get_source") else None
    if source is None:
        raise ImportError(f"magcilia cannot read the source of {package} to find its public "
                          "names (installed without .py files?); reinstall magcilia from its wheel")
    table: Table = {}
    for node in ast.parse(source).body:
        if isinstance(node, ast.If) and _is_type_checking(node.test):
            for statement in node.body:
                if isinstance(statement, ast.ImportFrom) and statement.module and \
                        not statement.level:
                    for alias in statement.names:
                        table[alias.asname or alias.name] = (statement.module, alias.name)
                elif isinstance(statement, ast.Import):
                    for alias in statement.names:
                        if alias.asname:
                            table[alias.asname] = (alias.name, None)
    return table


def _is_type_checking(test: ast.expr) -> bool:
    return (isinstance(test, ast.Name) and test.id == "TYPE_CHECKING") or (
        isinstance(test, ast.Attribute) and test.attr == "TYPE_CHECKING")


class _LazyModule(types.ModuleType):
    """A package face with lazy names: a submodule never binds over a public name of the same
    spelling that is something else (``mechanics.bend``, the function), which keeps the eager
    ``__init__``'s meaning whichever module was imported first."""

    def __setattr__(self, name: str, value: Any) -> None:
        table: Table = self.__dict__.get("_lazy_table", {})
        if (isinstance(value, types.ModuleType) and name in table
                and value.__name__ == f"{self.__name__}.{name}"
                and table[name] != (value.__name__, None)
                and table[name] != (self.__name__, name)):
            return  # the public name (resolved by __getattr__) wins over the submodule
        super().__setattr__(name, value)
