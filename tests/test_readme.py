"""The README's Python examples run as written (in a scratch folder with a recording)."""

from __future__ import annotations

import re
import shutil
from pathlib import Path

import numpy as np
import pytest

from magcilia.io import example_path

README = Path(__file__).resolve().parents[1] / "README.md"


def python_blocks() -> list[str]:
    return re.findall(r"```python\n(.*?)```", README.read_text(encoding="utf-8"), flags=re.DOTALL)


def test_readme_has_python_examples() -> None:
    assert len(python_blocks()) >= 3


def test_readme_python_examples_run(tmp_path: Path, monkeypatch: pytest.MonkeyPatch) -> None:
    monkeypatch.chdir(tmp_path)
    shutil.copy(example_path(), tmp_path / "run.csv")
    namespace: dict[str, object] = {}
    for block in python_blocks():
        exec(compile(block, str(README), "exec"), namespace)  # noqa: S102
    forces = namespace["forces"]
    assert isinstance(forces, np.ndarray)
    np.testing.assert_allclose(forces, 1e-4, rtol=1e-4)
    assert (tmp_path / "my-sensor.toml").is_file()
