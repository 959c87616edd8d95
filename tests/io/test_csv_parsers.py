"""The fast CSV reader with each of its parsers (``csvparsers.PARSER``): pyarrow's and pandas'
give the careful reader's columns on every plain file of ``test_recordings_fast`` (its tests,
run again here with the parser fixed), and the default picks pyarrow only while pandas is not
imported and the file is small."""

from __future__ import annotations

import importlib.util
import sys
from collections.abc import Iterator
from pathlib import Path

import numpy as np
import pytest

from magcilia.io import csvfile, csvparsers

pytest.importorskip("pyarrow")

_spec = importlib.util.spec_from_file_location(
    "_recordings_fast_tests", Path(__file__).with_name("test_recordings_fast.py"))
assert _spec is not None and _spec.loader is not None
base = importlib.util.module_from_spec(_spec)
_spec.loader.exec_module(base)


@pytest.fixture(autouse=True, scope="module", params=["arrow", "pandas"])
def parser(request: pytest.FixtureRequest) -> Iterator[str]:
    before = csvparsers.PARSER
    csvparsers.PARSER = request.param
    yield request.param
    csvparsers.PARSER = before


test_plain_files_are_read_fast = base.test_plain_files_are_read_fast
test_other_files_go_to_the_careful_reader = base.test_other_files_go_to_the_careful_reader
test_blocks_cut_anywhere = base.test_blocks_cut_anywhere
test_a_header_without_rows = base.test_a_header_without_rows
test_giving_up_after_some_blocks_starts_afresh = base.test_giving_up_after_some_blocks_starts_afresh
test_the_row_limit_of_the_fast_reader = base.test_the_row_limit_of_the_fast_reader
test_the_fast_reader_agrees_with_the_careful_one = (
    base.test_the_fast_reader_agrees_with_the_careful_one)
test_whole_columns_are_the_blocks_joined = base.test_whole_columns_are_the_blocks_joined


def test_blank_lines_of_spaces_between_rows(tmp_path: Path, parser: str) -> None:
    path = tmp_path / "r.csv"
    path.write_bytes(b"angle_deg,voltage_V\n1,2\n \t \n3, 4\r\n\t\r\n5,6\n   ")
    blocks = list(csvfile.plain_csv_blocks(path, ("angle_deg", "voltage_V"),
                                           ("angle_deg", "voltage_V"), max_samples=10,
                                           max_line_chars=100))
    np.testing.assert_array_equal(np.concatenate([b["voltage_V"] for b in blocks]), [2, 4, 6])


def test_the_default_parser(monkeypatch: pytest.MonkeyPatch, parser: str) -> None:
    monkeypatch.setattr(csvparsers, "PARSER", None)
    monkeypatch.delitem(sys.modules, "pandas", raising=False)
    assert csvparsers.arrow_parses(",", 1 << 20)
    assert not csvparsers.arrow_parses(",", csvparsers.ARROW_BYTES + 1)
    assert not csvparsers.arrow_parses(" ", 1 << 20)
    monkeypatch.setitem(sys.modules, "pandas", sys.modules.get("pandas") or object())
    assert not csvparsers.arrow_parses(",", 1 << 20)
