"""The fast CSV reader with each of its parsers (``csvparsers.PARSER``): NumPy's and pandas'
give the careful reader's columns on every plain file of ``test_recordings_fast`` (its tests,
run again here with the parser fixed), and the default picks NumPy only where it can parse the
file and the file is small enough to hold at once."""

from __future__ import annotations

import importlib.util
from collections.abc import Iterator
from pathlib import Path

import numpy as np
import pytest

from magcilia.io import csvfile, csvparsers

_spec = importlib.util.spec_from_file_location(
    "_recordings_fast_tests", Path(__file__).with_name("test_recordings_fast.py"))
assert _spec is not None and _spec.loader is not None
base = importlib.util.module_from_spec(_spec)
_spec.loader.exec_module(base)


@pytest.fixture(autouse=True, scope="module", params=["numpy", "pandas"])
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


@pytest.mark.parametrize(("body", "expected"), [
    (b"1\n \n2\n\t\n3\n", [1, 2, 3]),  # one column: a line of blanks is no empty field
    (b" \n\t\r\n  ", []),  # only lines of blanks: no rows
    (b"\n\r\n\n", []),  # only line ends
])
def test_lines_of_blanks_in_one_column_files(tmp_path: Path, parser: str, body: bytes,
                                             expected: list[float]) -> None:
    """NumPy's reader meets a line of blanks as a bad row; it is taken out and the file read
    again (the scan for such lines costs only those files)."""
    path = tmp_path / "r.csv"
    path.write_bytes(b"voltage_V\n" + body)
    blocks = list(csvfile.plain_csv_blocks(path, ("voltage_V",), ("voltage_V",), max_samples=10,
                                           max_line_chars=100))
    got = np.concatenate([b["voltage_V"] for b in blocks]) if blocks else np.zeros(0)
    np.testing.assert_array_equal(got, expected)


def test_the_default_parser(monkeypatch: pytest.MonkeyPatch, parser: str) -> None:
    monkeypatch.setattr(csvparsers, "PARSER", None)
    assert csvparsers.numpy_parses(",", ".", 1 << 20, None)
    assert csvparsers.numpy_parses("\t", ".", csvparsers.NUMPY_BYTES, None)
    assert not csvparsers.numpy_parses(",", ".", csvparsers.NUMPY_BYTES + 1, None)
    assert not csvparsers.numpy_parses(" ", ".", 1 << 20, None)  # runs of white space
    assert not csvparsers.numpy_parses(";", ",", 1 << 20, None)  # the decimal comma
    assert not csvparsers.numpy_parses(",", ".", 1 << 20, 2)  # a setreset column
    monkeypatch.setattr(csvparsers, "PARSER", "pandas")
    assert not csvparsers.numpy_parses(",", ".", 1 << 20, None)
