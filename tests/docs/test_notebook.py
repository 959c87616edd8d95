"""The tutorial notebook (docs/tutorial.ipynb) runs green, start to end, in a fresh kernel.

The kernel is this interpreter (a kernelspec written into tmp_path, so no `jupyter kernelspec
install` is needed and no other environment's `python3` kernel can be picked up), importing the
same magcilia as the tests, with warnings turned into errors and its working directory in
tmp_path. Figures render with matplotlib's inline backend (Agg underneath) as PNG outputs.
"""

from __future__ import annotations

import json
import os
import sys
from pathlib import Path

import pytest

import magcilia

nbformat = pytest.importorskip("nbformat", reason="the docs extra: pip install -e '.[docs]'")
nbclient = pytest.importorskip("nbclient", reason="the docs extra: pip install -e '.[docs]'")
pytest.importorskip("ipykernel", reason="the docs extra: pip install -e '.[docs]'")

NOTEBOOK = Path(__file__).resolve().parents[2] / "docs" / "tutorial.ipynb"
#: seconds one cell may take (the live cell runs ~3 s of clock-paced samples; the first one
#: may compile numba's kernels on a cold cache)
CELL_TIMEOUT = 180
#: injected before the notebook's first cell: a warning in the tutorial fails the test, and the
#: kernel says which interpreter it runs
STRICT = "import sys, warnings\nwarnings.simplefilter('error')\nprint(sys.executable)"


def kernel_manager_class(tmp_path: Path) -> type:
    """An (async) KernelManager whose only kernelspec runs ipykernel on this interpreter."""
    from jupyter_client.kernelspec import KernelSpecManager
    from jupyter_client.manager import AsyncKernelManager
    from traitlets import default

    spec = tmp_path / "kernels" / "python3"
    spec.mkdir(parents=True)
    (spec / "kernel.json").write_text(json.dumps({
        "argv": [sys.executable, "-m", "ipykernel_launcher", "-f", "{connection_file}"],
        "display_name": "Python 3 (magcilia tests)",
        "language": "python",
    }), encoding="utf-8")

    class Manager(AsyncKernelManager):
        @default("kernel_spec_manager")
        def _kernel_spec_manager_default(self) -> KernelSpecManager:
            return KernelSpecManager(kernel_dirs=[str(spec.parent)])

    return Manager


def test_notebook_is_committed_without_outputs() -> None:
    nb = nbformat.read(NOTEBOOK, as_version=4)
    nbformat.validate(nb)
    for i, cell in enumerate(nb.cells):
        if cell.cell_type == "code":
            assert cell.outputs == [], f"cell {i} has outputs: strip them before committing"
            assert cell.execution_count is None, f"cell {i} has an execution count"
    assert nb.metadata.kernelspec.name == "python3"


def test_notebook_uses_only_the_public_api() -> None:
    nb = nbformat.read(NOTEBOOK, as_version=4)
    source = "\n".join(c.source for c in nb.cells if c.cell_type == "code")
    assert "import magcilia as mc" in source
    private = [line for line in source.splitlines()
               if "magcilia." in line and "._" in line.split("magcilia.", 1)[1].split()[0]]
    assert not private, private


def test_tutorial_notebook_runs(tmp_path: Path, monkeypatch: pytest.MonkeyPatch) -> None:
    nb = nbformat.read(NOTEBOOK, as_version=4)
    nb.cells.insert(0, nbformat.v4.new_code_cell(STRICT, id="strict-warnings"))
    work = tmp_path / "work"
    work.mkdir()
    # the kernel imports the magcilia under test (an editable install, or PYTHONPATH=src)
    package_root = str(Path(magcilia.__file__).resolve().parents[1])
    monkeypatch.setenv("PYTHONPATH", os.pathsep.join(
        [package_root, *filter(None, [os.environ.get("PYTHONPATH")])]))
    monkeypatch.setenv("MPLBACKEND", "module://matplotlib_inline.backend_inline")
    monkeypatch.setenv("JUPYTER_PLATFORM_DIRS", "1")
    monkeypatch.setenv("PYDEVD_DISABLE_FILE_VALIDATION", "1")
    monkeypatch.setenv("MPLCONFIGDIR", str(tmp_path / "mpl"))
    client = nbclient.NotebookClient(
        nb, kernel_manager_class=kernel_manager_class(tmp_path), timeout=CELL_TIMEOUT,
        allow_errors=False, kernel_name="python3",
        resources={"metadata": {"path": str(work)}})
    client.execute()

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
