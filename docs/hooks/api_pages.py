"""MkDocs hook: the API reference pages, and Sphinx roles in docstrings shown as plain code.

A nav entry ``api/<dotted.module>.md`` that has no file of that name becomes a page rendering the
module's docstring and its public members (``__all__``) with mkdocstrings; a file of that name in
docs/api/ replaces the generated page. The package's own page (``api/magcilia.md``) is an index:
each top-level name, its summary line and a link to the subpackage page that documents it (names
that no subpackage exports are rendered there in full).

The docstrings cross-reference in Sphinx's syntax (``:func:`calibrate```), which Markdown shows
as ``:func:`` before the code; :func:`on_page_content` drops the role (and Sphinx's ``~``).
"""

from __future__ import annotations

import importlib
import importlib.util
import inspect
import re
from typing import Any

from mkdocs.structure.files import File, Files

PREFIX = "api/"
PACKAGE = "magcilia"
_ROLE = re.compile(r":(?:py:)?(?:func|class|meth|mod|data|attr|exc|obj|const|ref):<code>~?")


def _nav_paths(item: Any) -> list[str]:
    """Every page path in a (nested) MkDocs nav."""
    if isinstance(item, str):
        return [item]
    if isinstance(item, dict):
        return [p for value in item.values() for p in _nav_paths(value)]
    if isinstance(item, list):
        return [p for value in item for p in _nav_paths(value)]
    return []


def _shadowed(module: str, name: str) -> str | None:
    """The defining path of a public name that a submodule of the same name hides from griffe
    (``magcilia.mechanics.bend``, the function, is also a module), else None."""
    parent = importlib.import_module(module)
    obj = getattr(parent, name)
    if not (inspect.isclass(obj) or inspect.isroutine(obj)) or not hasattr(parent, "__path__"):
        return None  # a plain module (magcilia.plot) has no submodules to hide a name
    if importlib.util.find_spec(f"{module}.{name}") is None:
        return None
    return f"{obj.__module__}.{obj.__qualname__}"


def _target(module: str, name: str) -> str:
    """The identifier under which ``module.name`` is rendered (for cross-references)."""
    return _shadowed(module, name) or f"{module}.{name}"


def _module_page(module: str) -> str:
    """The module's docstring and members, plus the members a submodule hides."""
    lines = [f"# `{module}`", "", f"::: {module}", "    options:", "      show_root_heading: false"]
    for name in getattr(importlib.import_module(module), "__all__", ()):
        path = _shadowed(module, name)
        if path is not None:
            lines += ["", f"::: {path}"]
    return "\n".join([*lines, ""])


def _summary(obj: Any) -> str:
    """First paragraph of an object's own docstring (a constant: its type)."""
    if inspect.isclass(obj) or inspect.isroutine(obj):
        return (inspect.getdoc(obj) or "").strip().split("\n\n")[0].replace("\n", " ")
    return f"a `{type(obj).__name__}`"


def _package_page(modules: list[str]) -> str:
    """The index of the package's top-level names, each linked to the page documenting it."""
    package = importlib.import_module(PACKAGE)
    exported = {m: set(getattr(importlib.import_module(m), "__all__", ())) for m in modules}
    rows, elsewhere = [], []
    for name in package.__all__:
        home = next((m for m in modules if name in exported[m]), None)
        if home is None:
            if not name.startswith("_"):
                elsewhere.append(name)
            continue
        obj = getattr(package, name)
        summary = _summary(obj).replace("|", "\\|")
        # constants have no docstring, so no entry of their own: name them, link the page
        link = (f"[`{name}`][{_target(home, name)}]"
                if inspect.isclass(obj) or inspect.isroutine(obj) else f"`{name}`")
        rows.append(f"| {link} | {summary} | [`{home}`]({home}.md) |")
    members = ", ".join(elsewhere)
    return "\n".join([
        f"# `{PACKAGE}`", "",
        f"::: {PACKAGE}", "    options:", "      show_root_heading: false",
        f"      members: [{members}]", "",
        "## Top-level names", "",
        (f"`import {PACKAGE} as mc` gives these names; each is documented on the page of the "
         "subpackage that holds it."), "",
        "| name | summary | documented in |", "|---|---|---|", *rows, "",
    ])


def on_files(files: Files, config: Any) -> Files:
    paths = [p for p in _nav_paths(config["nav"]) if p.startswith(PREFIX) and p.endswith(".md")]
    modules = [p.removeprefix(PREFIX).removesuffix(".md") for p in paths]
    for path, module in zip(paths, modules, strict=True):
        if files.get_file_from_path(path):
            continue
        content = (_package_page([m for m in modules if m != PACKAGE]) if module == PACKAGE
                   else _module_page(module))
        files.append(File.generated(config, path, content=content))
    return files


def on_page_content(html: str, **_: Any) -> str:
    return _ROLE.sub("<code>", html)
