"""Firmware export: the C header compiled with the machine's `cc` reproduces the Python evaluation
(float and fixed-point, forward and inverse); JSON; bad input."""

from __future__ import annotations

import json
import math
import shutil
import subprocess
from pathlib import Path

import numpy as np
import pytest

import magcilia as mc
from magcilia.approximation import PiecewiseLinear
from magcilia.io.firmware import fixed_point_format, to_json

CC = shutil.which("cc") or shutil.which("gcc") or shutil.which("clang")
needs_cc = pytest.mark.skipif(CC is None, reason="no C compiler (cc, gcc or clang) on this machine")


def _curves() -> dict[str, PiecewiseLinear]:
    return {
        "paper": mc.piecewise_linear(mc.Setup.paper(), corners=2),  # decreasing
        "rising": mc.piecewise_linear(lambda t: 1e-3 * np.tanh(t) + 5e-4, 3, (0.0, 1.3)),
        "folded": mc.piecewise_linear(np.sin, 2, (0.0, math.pi)),  # no inverse
    }


def _run_c(tmp_path: Path, header: str, body: str) -> np.ndarray:
    (tmp_path / "approx.h").write_text(header)
    src = tmp_path / "main.c"
    src.write_text('#include <stdio.h>\n#include <stdint.h>\n#include "approx.h"\n'
                   f"int main(void)\n{{\n{body}\n    return 0;\n}}\n")
    exe = tmp_path / "main"
    assert CC is not None
    subprocess.run([CC, "-std=c99", "-O2", "-Wall", "-Wextra", "-Werror", "-pedantic",
                    "-o", str(exe), str(src)], check=True, capture_output=True, text=True)
    out = subprocess.run([str(exe)], check=True, capture_output=True, text=True).stdout
    return np.array([float(x) for x in out.split()])


def _loop(n: int, fmt: str, expr: str) -> str:
    """C loop printing ``expr`` (of i) for i < n with printf format ``fmt``."""
    return f'    for (int i = 0; i < {n}; ++i) printf("{fmt}\\n", {expr});\n'


def _array(name: str, ctype: str, values: np.ndarray, fmt: str) -> str:
    items = ", ".join(fmt.format(x) for x in values)
    return f"    static const {ctype} {name}[{values.size}] = {{{items}}};\n"


@needs_cc
@pytest.mark.parametrize("which", ["paper", "rising", "folded"])
def test_float_header_reproduces_python(which: str, tmp_path: Path) -> None:
    approx = _curves()[which]
    lo, hi = approx.angle_range
    t = np.linspace(lo - 0.05, hi + 0.05, 97)
    header = mc.to_c_header(approx, name="pl")
    body = _array("t", "float", t, "{:.9e}f")
    body += _loop(t.size, "%.9g", "(double)pl_output(t[i])")
    volts = approx(t)
    if approx.invertible:
        body += _array("v", "float", volts, "{:.9e}f")
        body += _loop(t.size, "%.9g", "(double)pl_angle(v[i])")
    else:
        assert "pl_angle" not in header and "#define PL_INVERTIBLE 0" in header
    got = _run_c(tmp_path, header, body)
    scale = np.abs(approx.values).max()
    np.testing.assert_allclose(got[: t.size], volts, rtol=0, atol=4e-7 * scale)
    if approx.invertible:
        np.testing.assert_allclose(got[t.size:], t, rtol=0, atol=2e-6)


@needs_cc
@pytest.mark.parametrize("which", ["paper", "rising", "folded"])
def test_fixed_point_header_reproduces_python(which: str, tmp_path: Path) -> None:
    approx = _curves()[which]
    fmt = fixed_point_format(approx)
    lo, hi = approx.angle_range
    t = np.linspace(lo, hi, 101)
    t_q = np.rint(t * 2.0**fmt.angle_bits)
    header = mc.to_c_header(approx, name="plq", fixed_point=True)
    assert f"#define PLQ_ANGLE_FRAC_BITS {fmt.angle_bits}" in header
    body = _array("t", "int32_t", t_q, "{:.0f}")
    body += _loop(t.size, "%ld", "(long)plq_output_q(t[i])")
    volts = approx(t)
    if approx.invertible:
        body += _array("v", "int32_t", np.rint(volts * 2.0**fmt.volt_bits), "{:.0f}")
        body += _loop(t.size, "%ld", "(long)plq_angle_q(v[i])")
    got = _run_c(tmp_path, header, body)
    assert np.all(got == np.rint(got))  # integers
    out_v = got[: t.size] * 2.0**-fmt.volt_bits
    err = np.abs(out_v - volts).max()
    assert err <= fmt.output_tolerance
    # the Q format keeps ~30 significant bits: far below any sensor's resolution
    assert fmt.output_tolerance < 1e-6 * np.abs(approx.values).max()
    if approx.invertible:
        ang = got[t.size:] * 2.0**-fmt.angle_bits
        assert np.abs(ang - t).max() <= fmt.angle_tolerance
        assert fmt.angle_tolerance < 1e-6


def test_fixed_point_format_choices_and_limits() -> None:
    approx = _curves()["paper"]
    fmt = fixed_point_format(approx)
    # 4x headroom: the largest node uses 28..29 bits of the int32
    assert 2**28 <= np.abs(approx.values).max() * 2.0**fmt.volt_bits < 2**29
    assert 2**28 <= np.abs(approx.knots).max() * 2.0**fmt.angle_bits < 2**29
    assert fixed_point_format(approx, angle_bits=20, volt_bits=30).volt_bits == 30
    with pytest.raises(mc.MagciliaError, match="volt_bits must be small enough"):
        fixed_point_format(approx, volt_bits=fmt.volt_bits + 3)
    assert math.isnan(fixed_point_format(_curves()["folded"]).angle_tolerance)


def test_header_text_and_bad_input() -> None:
    approx = _curves()["paper"]
    header = mc.to_c_header(approx, name="cilium_read")
    assert ("#ifndef CILIUM_READ_H" in header
            and header.rstrip().endswith("#endif /* CILIUM_READ_H */"))
    assert "static inline float cilium_read_output(float tilt_rad)" in header
    assert "static inline float cilium_read_angle(float volts)" in header
    assert "2 corner(s)" in header
    with pytest.raises(mc.MagciliaError, match="name must be a C identifier"):
        mc.to_c_header(approx, name="9lives")
    with pytest.raises(mc.MagciliaError, match="approx must be a magcilia PiecewiseLinear"):
        mc.to_c_header({"knots_rad": [0, 1]})  # type: ignore[arg-type]


def test_json_export_round_trip() -> None:
    approx = _curves()["paper"]
    doc = json.loads(to_json(approx))
    again = PiecewiseLinear.from_dict(doc)
    np.testing.assert_array_equal(again(np.array([0.3, 1.0])), approx(np.array([0.3, 1.0])))
    # non-finite numbers become null, never invalid JSON
    flat = mc.piecewise_linear(lambda t: np.minimum(t, 0.5), 0, (0.0, 1.0))
    assert math.isinf(flat.max_angle_error)  # flat output: no angle can be read
    assert json.loads(to_json(flat))["max_angle_error_rad"] is None
