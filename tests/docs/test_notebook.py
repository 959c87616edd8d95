"""The tutorial notebook (docs/tutorial.ipynb) runs green, start to end, in a fresh kernel, and
its committed outputs (what the docs site shows) are those of the run.

scripts/execute_tutorial.py runs it (and, with --write, stores its outputs): the kernel is this
interpreter (a kernelspec written into tmp_path, so no `jupyter kernelspec install` is needed and
no other environment's `python3` kernel can be picked up), importing the same magcilia as the
tests, with warnings turned into errors and its working directory in tmp_path. Figures render with
matplotlib's inline backend (Agg underneath) as PNG outputs.
"""

from __future__ import annotations

import importlib.util
import sys
from pathlib import Path
from types import ModuleType

import pytest

nbformat = pytest.importorskip("nbformat", reason="the docs extra: pip install -e '.[docs]'")
nbclient = pytest.importorskip("nbclient", reason="the docs extra: pip install -e '.[docs]'")
pytest.importorskip("ipykernel", reason="the docs extra: pip install -e '.[docs]'")

ROOT = Path(__file__).resolve().parents[2]
NOTEBOOK = ROOT / "docs" / "tutorial.ipynb"
#: injected before the notebook's first cell: a warning in the tutorial fails the test, and the
#: kernel says which interpreter it runs
STRICT = "import sys, warnings\nwarnings.simplefilter('error')\nprint(sys.executable)"


def _script() -> ModuleType:
    spec = importlib.util.spec_from_file_location("execute_tutorial",
                                                  ROOT / "scripts" / "execute_tutorial.py")
    assert spec is not None and spec.loader is not None
    module = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(module)
    return module


def test_notebook_is_committed_with_its_outputs() -> None:
    """Every code cell ran, in order, and shows what it printed; four figures; no machine's
    paths (scripts/execute_tutorial.py --write stores them)."""
    nb = nbformat.read(NOTEBOOK, as_version=4)
    nbformat.validate(nb)
    script = _script()
    code = [c for c in nb.cells if c.cell_type == "code"]
    assert [c.execution_count for c in code] == list(range(1, len(code) + 1))
    for i, cell in enumerate(code, start=1):
        assert cell.outputs, f"code cell {i}: run scripts/execute_tutorial.py --write"
        assert not any(o.output_type == "error" for o in cell.outputs), i
        assert "timing" not in cell.metadata.get("execution", {}), i
    assert sum(script.figures(c) for c in code) == 4
    text = "".join(script.printed(c) for c in code)
    assert "height 3.2613 mm, base radius 0.1801 mm" in text
    assert "magcilia/data/example_recording.csv" in text
    assert str(ROOT) not in NOTEBOOK.read_text(encoding="utf-8")
    assert nb.metadata.kernelspec.name == "python3"


def test_the_comparison_fails_on_a_stale_value() -> None:
    """The currency check sees a changed printed number, a lost figure and a changed word."""
    script = _script()
    committed = nbformat.read(NOTEBOOK, as_version=4)
    assert script.differences(committed, nbformat.read(NOTEBOOK, as_version=4)) == []
    for change in ("number", "figure", "word"):
        stale = nbformat.read(NOTEBOOK, as_version=4)
        cell = next(c for c in stale.cells if c.cell_type == "code"
                    and "height 3.2613 mm" in script.printed(c))
        out = next(o for o in cell.outputs if o.output_type == "stream")
        if change == "number":
            out.text = out.text.replace("3.2613 mm", "3.2713 mm")
        elif change == "word":
            out.text = out.text.replace("height", "length")
        else:
            fig = next(c for c in stale.cells if c.cell_type == "code" and script.figures(c))
            fig.outputs = [o for o in fig.outputs if "image/png" not in o.get("data", {})]
        assert script.differences(committed, stale), change


def test_notebook_uses_only_the_public_api() -> None:
    nb = nbformat.read(NOTEBOOK, as_version=4)
    source = "\n".join(c.source for c in nb.cells if c.cell_type == "code")
    assert "import magcilia as mc" in source
    private = [line for line in source.splitlines()
               if "magcilia." in line and "._" in line.split("magcilia.", 1)[1].split()[0]]
    assert not private, private


def test_tutorial_notebook_runs(tmp_path: Path) -> None:
    script = _script()
    committed = nbformat.read(NOTEBOOK, as_version=4)
    nb = script.execute(nbformat.read(NOTEBOOK, as_version=4), tmp_path, first=STRICT)

    assert nb.cells[0].outputs[0].text.strip() == sys.executable  # this interpreter's kernel
    problems = []
    figures = 0
    for i, cell in enumerate(nb.cells[1:], start=1):
        if cell.cell_type != "code":
            continue
        for out in cell.outputs:
            if out.output_type == "error":
                problems.append(f"cell {i}: {out.ename}: {out.evalue}")
            elif out.output_type == "stream" and out.name == "stderr":
                problems.append(f"cell {i} wrote to stderr: {out.text.strip()}")
            elif out.output_type == "display_data" and "image/png" in out.data:
                figures += 1
    assert not problems, "\n".join(problems)
    assert figures == 4, f"{figures} figures rendered"
    # the live cell ran: the status line says it read out at 1 kHz and took the tare
    live = next(c for c in nb.cells if c.get("id") == "live")
    text = "".join(o.get("text", "") for o in live.outputs)
    assert "tared" in text and "0 overruns" in text, text
    # the live estimate follows the simulated force: plateau means within 2 µN of it (steps of
    # 0.02-0.04 mN: the presets' 0.669 MPa modulus bends the hair as 0.1-0.2 mN did at 3.39 MPa)
    plot = next(c for c in nb.cells if c.get("id") == "live-plot")
    rows = [line.split() for line in "".join(o.get("text", "") for o in plot.outputs).splitlines()
            if line.strip() and line.split()[0][0] in "+-"]
    assert len(rows) == 5, rows
    for applied, mean, *_ in rows:
        assert abs(float(mean) - float(applied)) < 0.002, rows
    # nothing was written beside the notebook
    assert not list(NOTEBOOK.parent.glob("*.tdms"))
    # the committed outputs are this run's: printed values within tolerances, the same figures
    problems = script.differences(committed, script.tidied(nb))
    assert not problems, "run scripts/execute_tutorial.py --write:\n" + "\n".join(problems)
