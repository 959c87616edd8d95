"""The plain summary line (stdout not a terminal) of force vectors: a 3-axis sensor's and an
array's — the line had only a scalar form and broke on (n, 2) values — in the unit of their
magnitude."""

from __future__ import annotations

import re

import pytest

from magcilia.cli import main


@pytest.mark.parametrize("args", [["--sensor", "mmc5983ma"], ["--setup", "examples/array.toml"]])
def test_vector_summary_lines(args: list[str], capsys: pytest.CaptureFixture[str]) -> None:
    assert main(["live", *args, "--duration", "1.2"]) == 0
    out = capsys.readouterr().out
    lines = [line for line in out.splitlines() if "tip force |F|" in line]
    assert lines, out
    for line in lines:
        assert re.search(r"\|F\| (—|[+-]\d+(\.\d+)? ± \d+(\.\d+)? [mµn]N)", line), line
        shares = [int(p) for p in re.findall(r"(\d+)%", line.split("|", 2)[-1].split("| ")[0])]
        assert all(p <= 100 for p in shares), line  # a share of every estimate, never > 100 %
