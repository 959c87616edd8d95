"""Hostile setup files (issue 12): deep nesting, huge numbers and files, invalid UTF-8, control
characters, long profiles — each refused with one short line naming the file; and a setup that
cannot be read back is never written."""

from __future__ import annotations

import re
from pathlib import Path

import numpy as np
import pytest

import magcilia as mc
from magcilia.device.cilium import MAX_PROFILE_POINTS
from magcilia.io.setup_files import MAX_NESTING, MAX_SETUP_BYTES, setup_from_dict

PAPER = (Path(__file__).resolve().parents[2] / "examples" / "paper.toml").read_text()


def _refused(tmp_path: Path, content: str | bytes) -> str:
    path = tmp_path / "hostile.toml"
    if isinstance(content, str):
        path.write_text(content, encoding="utf-8")
    else:
        path.write_bytes(content)
    with pytest.raises(mc.MagciliaError) as err:
        mc.load_setup(path)
    text = str(err.value)
    assert str(path) in text and "\n" not in text and text.isprintable() and len(text) < 600
    return text


@pytest.mark.parametrize("depth", [MAX_NESTING + 1, 100, 500, 5000])
@pytest.mark.parametrize("kind", ["array", "inline-table", "header", "dotted-key"])
def test_deep_nesting_is_refused(tmp_path: Path, depth: int, kind: str) -> None:
    """Shallow enough for tomllib: the depth check; deeper: tomllib's RecursionError, caught."""
    content = {
        "array": "[amplifier]\ngain = " + "[" * depth + "1" + "]" * depth,
        "inline-table": "v = " + "{a = " * depth + "1" + "}" * depth,
        "header": "[" + ".".join(["t"] * depth) + "]\nx = 1",
        "dotted-key": ".".join(["k"] * depth) + " = 1",
    }[kind]
    assert "nested" in _refused(tmp_path, content)


def test_nesting_within_the_limit_reaches_the_schema(tmp_path: Path) -> None:
    text = _refused(tmp_path, "[amplifier]\ngain = [[[1]]]")
    assert "amplifier.gain must be a number" in text and "[[[1]]]" in text


@pytest.mark.parametrize(
    ("line", "match"),
    [
        ("gain = " + "9" * 400,
         r"amplifier\.gain must be .* within \[1e-09, 1e\+09\]; got 9+… \(400 characters\)"),
        ("gain = 1e308", r"amplifier\.gain must be .*; got 1e\+308"),
        ("gain = nan", r"amplifier\.gain must be a finite number"),
        ("gain = inf", r"amplifier\.gain must be a finite number"),
        ('offset = "1e300 V"', r"amplifier\.offset must be a finite number in V, within"),
        ('offset = "' + "1" * 500 + ' V"',
         r"amplifier\.offset must be a voltage with a unit.*\(502 characters\)"),
    ],
    ids=["400-digits", "1e308", "nan", "inf", "1e300-V", "500-digit-string"],
)
def test_huge_and_nonfinite_numbers(tmp_path: Path, line: str, match: str) -> None:
    text = _refused(tmp_path, PAPER.replace("gain = 1.0\noffset = \"0 V\"", line))
    assert re.search(match, text), text


@pytest.mark.parametrize(
    ("key", "value", "match"),
    [
        ("[model]\nn_loops", "1000000000", r"model\.n_loops must be an integer >= 1, at most 1000"),
        ("[model]\nn_loops", "9223372036854775807", "at most 1000"),
        ("[model]\nn_loops", "1" * 5000, "not valid TOML"),  # beyond Python's int parsing
        ("[cilium]\nbase_radius", '"1e300 mm"',
         r"cilium\.base_radius must be a positive length in m, within \[1e-09, 1\] m; got 1e\+297"),
        ("[cilium]\nheight", '"1e-400 mm"', r"cilium\.height must be a positive length"),
        ("[placement]\nz", '"1e306 mm"', r"placement\.z must be a finite number in m"),
        ("[material]\nmagnetization_scale", "1e5", "within \\[0, 100\\]"),
    ],
)
def test_values_beyond_the_registry_limits(tmp_path: Path, key: str, value: str,
                                           match: str) -> None:
    table, name = key.split("\n")
    body = "\n".join(line for line in PAPER.splitlines() if not line.startswith(name + " ="))
    text = _refused(tmp_path, body.replace(table, f"{table}\n{name} = {value}", 1))
    assert re.search(match, text), text


def test_a_file_over_the_size_limit(tmp_path: Path) -> None:
    text = _refused(tmp_path, PAPER + "#" + "x" * MAX_SETUP_BYTES)
    assert f"larger than {MAX_SETUP_BYTES} bytes" in text
    path = tmp_path / "just-under.toml"
    path.write_text(PAPER + "#" + "x" * (MAX_SETUP_BYTES - len(PAPER) - 2) + "\n")
    assert mc.load_setup(path).n_loops == 2


@pytest.mark.parametrize(
    "data",
    [b"\xff\xfe[cilium]", b"[cilium]\nheight = \"3 mm\xc3\x28\"", b"\xed\xa0\x80", b"\x00" * 10],
    ids=["utf16-bom", "bad-continuation", "surrogate", "nul"],
)
def test_binary_data(tmp_path: Path, data: bytes) -> None:
    text = _refused(tmp_path, data)
    assert "not UTF-8 text" in text or "not valid TOML" in text


@pytest.mark.parametrize(
    "content",
    ['"\\u001b[2Jx" = 1', '["\\u001b[31mred"]\nx = 1', '[cilium]\n"height\\r\\nfake: ok" = 1',
     '[amplifier]\ngain = "\\u001b]0;title\\u0007"', '[model]\nring = "\\u009b1m"'],
    ids=["key", "table", "crlf-key", "osc-value", "c1-value"],
)
def test_control_characters_are_escaped(tmp_path: Path, content: str) -> None:
    text = _refused(tmp_path, content)
    assert "\x1b" not in text and "\x9b" not in text and "\r" not in text


def test_long_keys_and_values_are_cut_short(tmp_path: Path) -> None:
    text = _refused(tmp_path, f'[cilium]\n{"k" * 5000} = 1')
    assert "(5002 characters)" in text and "k" * 100 not in text
    text = _refused(tmp_path, '[cilium]\nheight = [' + ", ".join(["1"] * 20000) + "]")
    assert "characters)" in text


def test_profiles_are_bounded(tmp_path: Path) -> None:
    n = MAX_PROFILE_POINTS + 1
    s = ", ".join(f'"{x:.6g} mm"' for x in np.linspace(0, 3, n))
    r = ", ".join(['"0.1 mm"'] * n)
    text = _refused(tmp_path, f"[cilium]\nprofile_s = [{s}]\nprofile_r = [{r}]")
    assert f"at most {MAX_PROFILE_POINTS} points" in text
    text = _refused(tmp_path, '[cilium]\nprofile_s = ["0 mm", "3 mm"]\n'
                              'profile_r = ["0.2 mm", "5 m"]')
    assert "profile radius must be radii within [1e-09, 1] m" in text


def test_a_document_that_is_not_a_table() -> None:
    with pytest.raises(mc.MagciliaError, match="doc must be a document of"):
        setup_from_dict([1, 2], source="doc")  # type: ignore[arg-type]


# -- saving: never write what cannot be read back -------------------------------------------------
def test_a_setup_beyond_the_limits_cannot_be_built() -> None:
    with pytest.raises(mc.MagciliaError, match="z must be"):
        mc.Setup.paper(z=1e306)


def test_save_refuses_a_setup_that_load_would_refuse(tmp_path: Path) -> None:
    setup = mc.Setup.paper(sensor=mc.Sensor(name="HMC1001"))
    path = tmp_path / "s.toml"
    with pytest.raises(mc.MagciliaError, match=r"not written, because the file could not be read "
                                                r"back: setup: sensor\.preset must be one of"):
        mc.save_setup(setup, path)
    assert not path.exists()


def test_save_and_load_round_trip_at_the_limits(tmp_path: Path) -> None:
    setup = mc.Setup.paper(gain=1e9, offset=-1e6, n_loops=1000, dipoles_per_loop=100,
                           bridge_voltage=1e4, sensitivity=1e9, magnetization_scale=100.0)
    mc.save_setup(setup, tmp_path / "s.toml")
    back = mc.load_setup(tmp_path / "s.toml")
    np.testing.assert_allclose(back.output([0.0, 0.5]), setup.output([0.0, 0.5]), rtol=1e-10)
    assert np.isfinite(back.output([0.0, 0.5])).all()
