"""The house's plan, checked from the import graph (docs/ARCHITECTURE.md draws it).

Every module of ``src/magcilia`` is parsed (imports inside functions and ``TYPE_CHECKING`` blocks
count too); each import of a magcilia module is an arrow. A room (subpackage) may import only
rooms of lower layers, a room never imports another room of its own layer, and the module graph
has no cycle.
"""

from __future__ import annotations

import ast
from pathlib import Path

import pytest

SRC = Path(__file__).resolve().parents[1] / "src" / "magcilia"

#: layers from the bottom up; a room may import rooms of lower layers only
LAYERS: tuple[tuple[str, ...], ...] = (
    ("foundation",),  # constants, units, _errors, _validate, _atomic, _display: no physics
    ("fitting",),  # the one least-squares core (batched LM, multistart, polish): no physics
    ("model",),  # the field model: plain values in, arrays out
    ("device",),  # the checked device objects and the parameter registry
    ("mechanics", "approximation"),
    ("io",),  # files: setup files, recordings, firmware headers
    ("calibration",),
    ("analysis", "readout", "acquire"),
    ("design",),  # design metrics and optimisation: read ranges, sweeps, the search
    ("report",),  # figures and written reports
    ("batch",),  # many recordings through the execution layer (magcilia.execution)
    ("live",),  # the streaming read-out and its views (terminal, browser)
    ("api",),  # magcilia/__init__.py: the public names
    ("cli",),
)
RANK = {room: i for i, rooms in enumerate(LAYERS) for room in rooms}
#: top-level modules of the public face beside magcilia/__init__ (``magcilia.plot`` imports report)
API_MODULES = frozenset({"magcilia.plot"})


def _module_name(path: Path) -> str:
    parts = list(path.relative_to(SRC.parent).with_suffix("").parts)
    if parts[-1] == "__init__":
        parts.pop()
    return ".".join(parts)


MODULES = {_module_name(p): p for p in SRC.rglob("*.py")}


def room_of(module: str) -> str:
    parts = module.split(".")
    if len(parts) == 1 or module in API_MODULES:
        return "api"
    if module == "magcilia.__main__":  # ``python -m magcilia`` runs the CLI
        return "cli"
    if f"magcilia.{parts[1]}" in MODULES and MODULES[f"magcilia.{parts[1]}"].name == "__init__.py":
        return parts[1]
    return "foundation"


def _resolve(module: str, name: str | None) -> str:
    """The magcilia module an import refers to: ``from module import name`` is the submodule
    ``module.name`` when there is one, else ``module`` itself."""
    if name is not None and f"{module}.{name}" in MODULES:
        return f"{module}.{name}"
    return module


def imports_of(module: str) -> set[str]:
    path = MODULES[module]
    package = module if path.name == "__init__.py" else module.rpartition(".")[0]
    found: set[str] = set()
    for node in ast.walk(ast.parse(path.read_text(encoding="utf-8"))):
        if isinstance(node, ast.Import):
            found |= {a.name for a in node.names if a.name.split(".")[0] == "magcilia"}
        elif isinstance(node, ast.ImportFrom):
            if node.level:
                base = package.split(".")[: len(package.split(".")) - node.level + 1]
                target = ".".join([*base, *([node.module] if node.module else [])])
            else:
                target = node.module or ""
            if target.split(".")[0] == "magcilia":
                found |= {_resolve(target, a.name) for a in node.names}
    return {m for m in found if m in MODULES}


GRAPH = {module: imports_of(module) for module in MODULES}


def test_every_room_has_a_layer() -> None:
    rooms = {room_of(m) for m in MODULES}
    assert rooms <= set(RANK), f"rooms without a layer: {rooms - set(RANK)}"


#: deprecated forwards kept for one release: a room's face that lazily hands out names which
#: moved up a layer (in its module ``__getattr__``, behind a DeprecationWarning). Issue 26 moved
#: the design metrics from readout/ to design/; remove the entry with the alias.
DEPRECATED_FORWARDS = {("magcilia.readout", "magcilia.design")}


@pytest.mark.parametrize("module", sorted(MODULES))
def test_imports_point_down(module: str) -> None:
    room = room_of(module)
    for target in sorted(GRAPH[module]):
        other = room_of(target)
        if other == room or (module, target) in DEPRECATED_FORWARDS:
            continue
        assert RANK[other] < RANK[room], (
            f"{module} ({room}, layer {RANK[room]}) imports {target} ({other}, layer "
            f"{RANK[other]}): rooms may import lower layers only"
        )


@pytest.mark.parametrize("module", sorted(MODULES))
def test_no_module_imports_its_own_package_face(module: str) -> None:
    """Inside a room, modules import each other directly, never through the room's __init__
    (which imports them all: a hidden circle)."""
    package = module.rpartition(".")[0]
    if MODULES[module].name == "__init__.py" or package == "magcilia":
        return
    assert package not in GRAPH[module], f"{module} imports its own package {package}"


def test_the_module_graph_has_no_cycle() -> None:
    state: dict[str, int] = {}
    stack: list[str] = []

    def visit(module: str) -> None:
        state[module] = 1
        stack.append(module)
        for target in sorted(GRAPH[module]):
            if state.get(target) == 1:
                cycle = [*stack[stack.index(target):], target]
                pytest.fail("import cycle: " + " -> ".join(cycle))
            if target not in state:
                visit(target)
        stack.pop()
        state[module] = 2

    for module in sorted(MODULES):
        if module not in state:
            visit(module)


def test_the_layer_test_sees_real_arrows() -> None:
    """The graph is not empty: the known arrows of the house are found."""
    assert "magcilia.model.kernels" in GRAPH["magcilia.model.pose"]
    assert any(room_of(t) == "model" for t in GRAPH["magcilia.device.setup"])
    assert {room_of(m) for m in MODULES} == set(RANK)  # every layer's rooms exist
    assert room_of("magcilia._display") == "foundation"
    assert room_of("magcilia.__main__") == "cli"
    assert room_of("magcilia.plot") == "api" and "magcilia.report.calibration" in GRAPH[
        "magcilia.plot"]


def test_a_deprecated_forward_warns_and_gives_the_moved_name() -> None:
    import magcilia
    import magcilia.readout

    for name in ("design_metrics", "DesignMetrics", "Metric"):
        with pytest.warns(DeprecationWarning, match=f"magcilia.readout.{name} moved"):
            assert getattr(magcilia.readout, name) is getattr(magcilia.design, name)
    with pytest.raises(AttributeError, match="no attribute 'nothing'"):
        magcilia.readout.nothing  # noqa: B018
