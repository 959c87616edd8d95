"""Execute docs/tutorial.ipynb in a fresh kernel and store its outputs in the notebook.

The docs site renders the notebook as committed (mkdocs-jupyter, ``execute: false``): executing at
build time would double the strict build's time in the default test run and make the site depend
on a working kernel. So the outputs are committed, and tests/docs/test_notebook.py re-executes the
notebook with :func:`execute` and checks that the committed printed values (within tolerances)
and figures are current.

The kernel is this interpreter (a kernelspec written into a temporary folder, so no ``jupyter
kernelspec install`` is needed and no other environment's ``python3`` kernel can be picked up),
importing the magcilia on ``PYTHONPATH`` (or installed), with its working directory in a
temporary folder; figures render with matplotlib's inline backend as PNG outputs.

Run: PYTHONPATH=src python scripts/execute_tutorial.py            (run, compare, write nothing)
     PYTHONPATH=src python scripts/execute_tutorial.py --write    (store the outputs)
"""

from __future__ import annotations

import argparse
import json
import os
import re
import sys
import tempfile
from collections.abc import Iterator
from contextlib import contextmanager
from pathlib import Path
from typing import Any

NOTEBOOK = Path(__file__).resolve().parents[1] / "docs" / "tutorial.ipynb"
#: seconds one cell may take (the live cell runs ~3 s of clock-paced samples; the first one
#: may compile numba's kernels on a cold cache)
CELL_TIMEOUT = 180
#: the inline backend's resolution (dots per inch): small PNGs in the committed notebook
DPI = 72
#: cells whose printed numbers depend on the clock (the live read-out paces real time)
CLOCKED = ("live", "live-plot")
#: cells whose fits end at a point along directions the data leave (nearly) open: where they
#: stop there depends on the floating-point path (another CPU, BLAS or numba), so only their
#: determined figures are compared (:data:`_DETERMINED` lines: cost, chi2, the data fitted)
SEARCHED = ("calibrate", "identify", "79591f6b")
_DETERMINED = re.compile(
    r"^(?:cost |chi2 |calibration of |joint calibration |- the fit reproduces the data)")
#: relative tolerance of the determined figures of :data:`SEARCHED` cells
SEARCHED_RTOL = 0.05
_NUMBER = re.compile(r"[-+]?(?:\d+\.\d*|\.\d+|\d+)(?:[eE][-+]?\d+)?")


def kernel_manager_class(folder: Path) -> type:
    """An (async) KernelManager whose only kernelspec runs ipykernel on this interpreter."""
    from jupyter_client.kernelspec import KernelSpecManager
    from jupyter_client.manager import AsyncKernelManager
    from traitlets import default

    spec = folder / "kernels" / "python3"
    spec.mkdir(parents=True)
    (spec / "kernel.json").write_text(json.dumps({
        "argv": [sys.executable, "-m", "ipykernel_launcher", "-f", "{connection_file}"],
        "display_name": "Python 3 (magcilia)",
        "language": "python",
    }), encoding="utf-8")

    class Manager(AsyncKernelManager):
        @default("kernel_spec_manager")
        def _kernel_spec_manager_default(self) -> KernelSpecManager:
            return KernelSpecManager(kernel_dirs=[str(spec.parent)])

    return Manager


@contextmanager
def _environment(folder: Path) -> Iterator[None]:
    """The kernel's environment: this magcilia first on the path, inline figures at :data:`DPI`."""
    import magcilia

    package_root = str(Path(magcilia.__file__).resolve().parents[1])
    (folder / "mpl").mkdir()
    (folder / "mpl" / "matplotlibrc").write_text(f"figure.dpi: {DPI}\n", encoding="utf-8")
    changes = {
        "PYTHONPATH": os.pathsep.join([package_root,
                                       *filter(None, [os.environ.get("PYTHONPATH")])]),
        "MPLBACKEND": "module://matplotlib_inline.backend_inline",
        "JUPYTER_PLATFORM_DIRS": "1",
        "PYDEVD_DISABLE_FILE_VALIDATION": "1",
        "MPLCONFIGDIR": str(folder / "mpl"),
    }
    saved = {k: os.environ.get(k) for k in changes}
    os.environ.update(changes)
    try:
        yield
    finally:
        for k, v in saved.items():
            if v is None:
                os.environ.pop(k, None)
            else:
                os.environ[k] = v


def execute(nb: Any, folder: Path, *, first: str | None = None) -> Any:
    """Run the notebook ``nb`` (nbformat v4, changed in place and returned) in a fresh kernel.

    ``folder``: an empty temporary folder (the kernelspec, matplotlib's config, the working
    directory). ``first``: code run in a cell inserted before the notebook's first (id
    ``magcilia-first``; removes it).
    """
    import nbclient
    import nbformat

    if first is not None:
        nb.cells.insert(0, nbformat.v4.new_code_cell(first, id="magcilia-first"))
    work = folder / "work"
    work.mkdir()
    with _environment(folder):
        client = nbclient.NotebookClient(
            nb, kernel_manager_class=kernel_manager_class(folder), timeout=CELL_TIMEOUT,
            allow_errors=False, kernel_name="python3", record_timing=False,
            resources={"metadata": {"path": str(work)}})
        client.execute()
    return nb


def _data_folder() -> str:
    """This machine's folder of magcilia's package data, as printed (recording paths)."""
    import magcilia

    return str(Path(magcilia.__file__).resolve().parent / "data") + os.sep


def tidied(nb: Any) -> Any:
    """``nb`` as committed: the injected first cell removed, execution counts from 1, and this
    machine's package folder in printed paths replaced by ``magcilia/data/`` (a reader's
    installation has its own)."""
    nb.cells = [c for c in nb.cells if c.get("id") != "magcilia-first"]
    folder = _data_folder()
    count = 0
    for cell in nb.cells:
        if cell.cell_type != "code":
            continue
        count += 1
        cell.execution_count = count
        for out in cell.outputs:
            if "execution_count" in out:
                out["execution_count"] = count
            if out.output_type == "stream":
                out.text = out.text.replace(folder, "magcilia/data/")
    nb.metadata.pop("widgets", None)
    return nb


def printed(cell: Any) -> str:
    """The text a code cell shows: its streams and the text of its results."""
    parts = []
    for out in cell.outputs:
        if out.output_type == "stream":
            parts.append(out.text)
        elif out.output_type in ("execute_result", "display_data") and "image/png" not in out.data:
            parts.append(out.data.get("text/plain", ""))
    return "".join(parts)


def figures(cell: Any) -> int:
    """The PNG figures a code cell shows."""
    return sum(1 for out in cell.outputs
               if out.output_type == "display_data" and "image/png" in out.get("data", {}))


def numbers(text: str) -> list[float]:
    """Every number in ``text``, in order."""
    return [float(m) for m in _NUMBER.findall(text)]


def determined(text: str) -> str:
    """The lines of a searched cell's text that the data determine (:data:`_DETERMINED`)."""
    return "\n".join(line for line in text.splitlines() if _DETERMINED.match(line))


def differences(committed: Any, fresh: Any, *, rtol: float = 2e-3, atol: float = 2e-6) -> list[str]:
    """Where the committed notebook's outputs are not those of a fresh run (empty: current).

    Per code cell: the same number of figures; the printed text with its numbers masked equal;
    every number within ``rtol`` (relative) or ``atol`` (absolute, in printed units; the last
    printed digit of a 4-digit value, another BLAS's rounding, passes). The clocked cells
    (:data:`CLOCKED`: a live read-out paced by the clock, whose events and counts vary with the
    machine's load) must show the same figures only; tests/docs/test_notebook.py checks their
    content against the script's forces instead. The searched cells (:data:`SEARCHED`) compare
    their determined lines within :data:`SEARCHED_RTOL`.
    """
    problems: list[str] = []
    old = [c for c in committed.cells if c.cell_type == "code"]
    new = [c for c in fresh.cells if c.cell_type == "code" and c.get("id") != "magcilia-first"]
    if len(old) != len(new):
        return [f"{len(old)} code cells committed, {len(new)} run"]
    for i, (a, b) in enumerate(zip(old, new, strict=True), start=1):
        if a.source != b.source:
            problems.append(f"code cell {i}: the source differs")
            continue
        if figures(a) != figures(b):
            problems.append(f"code cell {i}: {figures(a)} figures committed, {figures(b)} now")
        if a.get("id") in CLOCKED:
            continue
        ta, tb = printed(a), printed(b)
        tol = rtol
        if a.get("id") in SEARCHED:
            ta, tb = (determined(t) for t in (ta, tb))
            tol = SEARCHED_RTOL
        if _NUMBER.sub("#", ta) != _NUMBER.sub("#", tb):
            problems.append(f"code cell {i}: the printed text differs:\n{ta}\n---\n{tb}")
            continue
        for x, y in zip(numbers(ta), numbers(tb), strict=True):
            if abs(x - y) > atol + tol * max(abs(x), abs(y)):
                problems.append(f"code cell {i}: {x!r} committed, {y!r} now")
    return problems


def main() -> None:
    import nbformat

    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--write", action="store_true",
                        help="store the outputs in docs/tutorial.ipynb")
    args = parser.parse_args()
    committed = nbformat.read(NOTEBOOK, as_version=4)
    nb = nbformat.read(NOTEBOOK, as_version=4)
    with tempfile.TemporaryDirectory() as tmp:
        nb = tidied(execute(nb, Path(tmp)))
    nbformat.validate(nb)
    problems = differences(committed, nb)
    print("\n".join(problems) if problems else "the committed outputs are current")
    if args.write:
        from magcilia._atomic import write_text

        write_text(NOTEBOOK, nbformat.writes(nb) + "\n")
        print(f"wrote {NOTEBOOK}")


if __name__ == "__main__":
    main()
