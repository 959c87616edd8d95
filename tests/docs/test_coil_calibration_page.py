"""docs/coil-calibration.md holds the identifiability table the tool computes
(scripts/identifiability_table.py; about 30 s, so slow)."""

from __future__ import annotations

import importlib.util
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[2]


@pytest.mark.slow
def test_the_committed_table_is_current():
    spec = importlib.util.spec_from_file_location("identifiability_table",
                                                  ROOT / "scripts" / "identifiability_table.py")
    assert spec is not None and spec.loader is not None
    module = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(module)
    page = (ROOT / "docs" / "coil-calibration.md").read_text(encoding="utf-8")
    assert module.block() in page, "run python scripts/identifiability_table.py --write"


def test_the_page_is_in_the_nav_and_has_the_table():
    assert "coil-calibration.md" in (ROOT / "mkdocs.yml").read_text(encoding="utf-8")
    page = (ROOT / "docs" / "coil-calibration.md").read_text(encoding="utf-8")
    assert "**paper's tilt rig** (reference)" in page and "all lengths together" in page
