"""Export read-out approximations for firmware: JSON and a self-contained C header.

:func:`to_c_header` writes a piecewise-linear approximation (:class:`~magcilia.PiecewiseLinear`)
as C99 ``static inline`` functions, no libraries needed:

* float variant: ``float NAME_output(float tilt_rad)`` (V) and, where the curve is monotonic,
  ``float NAME_angle(float volts)`` (rad); single-precision arithmetic, a linear scan over the
  few segments, linear extrapolation beyond the end nodes (as in Python).
* fixed-point variant: the same functions on Q-format integers, ``int32_t NAME_output_q(int32_t
  tilt_q)`` and ``int32_t NAME_angle_q(int32_t volts_q)``. Angles are ``round(rad · 2^A)`` and
  outputs ``round(V · 2^B)`` with ``A = NAME_ANGLE_FRAC_BITS`` and ``B = NAME_VOLT_FRAC_BITS``
  (chosen from the data unless given; B may exceed 31 for millivolt-scale signals — it is a scale,
  not a storage width). Tables, inputs and outputs are int32; each call does one signed 32×32→64
  multiply (a single SMULL on Cortex-M3/M4) and an arithmetic right shift with rounding. Segment
  slopes are stored in Q``S`` with S chosen per direction so they use ~30 bits.

:func:`fixed_point_format` gives the scalings and the worst-case quantisation error bounds that a
caller (or a test) can compare the integer results with.
"""

from __future__ import annotations

import dataclasses
import math
import re
from dataclasses import dataclass
from typing import Any

import numpy as np

from magcilia import _validate as v
from magcilia._atomic import json_text
from magcilia._display import Display, Item, si
from magcilia.approximation import PiecewiseLinear

_NAME = re.compile(r"^[A-Za-z_][A-Za-z0-9_]*$")
_INT32_MAX = 2**31 - 1


@dataclass(frozen=True, repr=False)
class FixedPointFormat(Display):
    """Q-format scalings of a fixed-point export.

    Attributes
    ----------
    angle_bits : int
        Fractional bits of angles: ``tilt_q = round(tilt_rad · 2^angle_bits)``.
    volt_bits : int
        Fractional bits of outputs: ``volts_q = round(V · 2^volt_bits)``.
    slope_bits, inverse_slope_bits : int
        Fractional bits of the stored slopes (V/rad and rad/V).
    output_tolerance : float
        Bound on |fixed-point output − float approximation|, V, for inputs within the range
        (rounding of nodes, slopes and the result).
    angle_tolerance : float
        Same for the inverse, rad (NaN when there is no inverse).
    """

    angle_bits: int
    volt_bits: int
    slope_bits: int
    inverse_slope_bits: int
    output_tolerance: float
    angle_tolerance: float

    def to_dict(self) -> dict[str, Any]:
        """JSON-ready content (bits; tolerances in V and rad)."""
        return dataclasses.asdict(self)

    def report(self) -> str:
        """One line: the Q formats and the quantisation error bounds."""
        return (f"angles Q{self.angle_bits}, volts Q{self.volt_bits}, slopes Q{self.slope_bits} "
                f"(inverse Q{self.inverse_slope_bits}); quantisation error ≤ "
                f"{self.output_tolerance:.3g} V, {self.angle_tolerance:.3g} rad")

    # -- display --------------------------------------------------------------------------------
    def _display_items(self) -> list[Item]:
        return [("angle", f"Q{self.angle_bits}"), ("volt", f"Q{self.volt_bits}"),
                ("slope", f"Q{self.slope_bits}"), ("inverse slope", f"Q{self.inverse_slope_bits}"),
                ("output tolerance", si(self.output_tolerance, "V")),
                ("angle tolerance", f"{math.degrees(self.angle_tolerance):.3g} deg")]


def _frac_bits(max_abs: float, headroom: float = 4.0) -> int:
    """Fractional bits so that ``max_abs · headroom`` fits in an int32."""
    if max_abs <= 0 or not math.isfinite(max_abs):
        return 30
    return math.floor(math.log2(_INT32_MAX / (max_abs * headroom)))


def fixed_point_format(
    approx: PiecewiseLinear, angle_bits: int | None = None, volt_bits: int | None = None
) -> FixedPointFormat:
    """Choose (or check) the Q formats of a fixed-point export.

    Parameters
    ----------
    approx : PiecewiseLinear
        The approximation.
    angle_bits, volt_bits : int, optional
        Fractional bits of angles and volts; default: as many as leave 4× headroom over the
        largest node magnitude in an int32 (extrapolation up to twice the range stays in range).
    """
    if not isinstance(approx, PiecewiseLinear):
        raise v.fail("approx", type(approx).__name__, "a magcilia PiecewiseLinear")
    knots, values = approx.knots, approx.values
    qa = _frac_bits(float(np.abs(knots).max())) if angle_bits is None else v.integer(
        "angle_bits", angle_bits, 0)
    qv = _frac_bits(float(np.abs(values).max())) if volt_bits is None else v.integer(
        "volt_bits", volt_bits, 0)
    for name, q, mx in (("angle_bits", qa, np.abs(knots).max()),
                        ("volt_bits", qv, np.abs(values).max())):
        if mx * 2.0**q > _INT32_MAX / 2 or q > 60:
            raise v.fail(name, q, f"small enough that the nodes (max {mx:.6g}) fit an int32 with "
                         f"2x headroom (<= {_frac_bits(float(mx), 2.0)})")
    slopes = approx.slopes
    qs = max(_frac_bits(float(np.abs(slopes).max()), 2.0), qv - qa)
    if approx.invertible:
        inv = 1.0 / slopes
        qi = max(_frac_bits(float(np.abs(inv).max()), 2.0), qa - qv)
        # angle: node rounding + slope rounding over one segment + result rounding
        span_v = float(np.abs(np.diff(values)).max())
        ang_tol = (2.0 ** -(qa + 1) * 2 + 2.0 ** -(qi + 1) * span_v
                   + float(np.abs(inv).max()) * 2.0 ** -(qv + 1) * 2)
    else:
        qi, ang_tol = 0, math.nan
    span_t = float(np.diff(knots).max())
    out_tol = (2.0 ** -(qv + 1) * 2 + 2.0 ** -(qs + 1) * span_t
               + float(np.abs(slopes).max()) * 2.0 ** -(qa + 1) * 2)
    return FixedPointFormat(qa, qv, qs, qi, out_tol, ang_tol)


def to_json(approx: PiecewiseLinear) -> str:
    """The approximation as a JSON document (:meth:`PiecewiseLinear.to_dict`, SI units)."""
    return json_text(approx.to_dict())


def _flt(x: float) -> str:
    return f"{x:.9g}f" if "e" in f"{x:.9g}" or "." in f"{x:.9g}" else f"{x:.9g}.0f"


def _shift(expr: str, s: int) -> str:
    """``expr`` (int64) scaled by 2^-s with rounding (s may be <= 0)."""
    if s <= 0:
        return f"({expr} * ((int64_t)1 << {-s}))" if s < 0 else expr
    return f"(({expr} + ((int64_t)1 << {s - 1})) >> {s})"


def to_c_header(
    approx: PiecewiseLinear,
    name: str = "magcilia_approx",
    fixed_point: bool = False,
    *,
    angle_bits: int | None = None,
    volt_bits: int | None = None,
) -> str:
    """C99 header evaluating the approximation (and its inverse where the curve is monotonic).

    Parameters
    ----------
    approx : PiecewiseLinear
        The fitted approximation (:func:`magcilia.piecewise_linear`).
    name : str
        C identifier prefix of the functions, tables and macros.
    fixed_point : bool
        False: ``float`` functions of rad / V. True: Q-format ``int32_t`` functions (see the module
        docstring and :func:`fixed_point_format`).
    angle_bits, volt_bits : int, optional
        Fixed-point fractional bits (default: chosen from the data).

    Returns
    -------
    str
        The header text (include guard, ``<stdint.h>`` only).
    """
    if not isinstance(approx, PiecewiseLinear):
        raise v.fail("approx", type(approx).__name__, "a magcilia PiecewiseLinear")
    if not isinstance(name, str) or not _NAME.match(name):
        raise v.fail("name", name,
                     "a C identifier (letters, digits, underscore; not a digit first)")
    up = name.upper()
    m = approx.knots.size
    lo, hi = approx.angle_range
    lines = [
        f"/* {name}: piecewise-linear approximation of a magnetic-cilium sensor's output vs tilt.",
        " * Generated by magcilia; do not edit. Continuous, linear extrapolation beyond the ends.",
        (f" * Range {math.degrees(lo):.6g}..{math.degrees(hi):.6g} deg, {m - 2} corner(s); "
        f"fit error max {approx.max_error * 1e3:.4g} mV, RMS {approx.rms_error * 1e3:.4g} mV, "
        f"angle {math.degrees(approx.max_angle_error):.4g} deg. */"),
        f"#ifndef {up}_H",
        f"#define {up}_H",
        "",
        "#include <stdint.h>",
        "",
        f"#define {up}_NODES {m}",
        f"#define {up}_INVERTIBLE {int(approx.invertible)}",
    ]
    if fixed_point:
        lines += _fixed_body(approx, name, up, angle_bits, volt_bits)
    else:
        lines += _float_body(approx, name, up)
    lines += ["", f"#endif /* {up}_H */", ""]
    return "\n".join(lines)


def _float_body(approx: PiecewiseLinear, name: str, up: str) -> list[str]:
    knots = ", ".join(_flt(float(k)) for k in approx.knots)
    vals = ", ".join(_flt(float(x)) for x in approx.values)
    slopes = ", ".join(_flt(float(s)) for s in approx.slopes)
    out = [
        "",
        "/* nodes: tilt in rad, output in V, segment slopes in V/rad */",
        f"static const float {name}_knots[{up}_NODES] = {{{knots}}};",
        f"static const float {name}_values[{up}_NODES] = {{{vals}}};",
        f"static const float {name}_slopes[{up}_NODES - 1] = {{{slopes}}};",
        "",
        "/* sensor output (V) at tilt angle tilt_rad (rad) */",
        f"static inline float {name}_output(float tilt_rad)",
        "{",
        "    int i = 0;",
        f"    while (i < {up}_NODES - 2 && tilt_rad >= {name}_knots[i + 1]) ++i;",
        f"    return {name}_values[i] + {name}_slopes[i] * (tilt_rad - {name}_knots[i]);",
        "}",
    ]
    if approx.invertible:
        increasing = approx.values[-1] > approx.values[0]
        cmp = ">=" if increasing else "<="
        inv = ", ".join(_flt(float(1.0 / s)) for s in approx.slopes)
        out += [
            "",
            f"/* inverse slopes, rad/V; node outputs are {'in' if increasing else 'de'}creasing */",
            f"static const float {name}_inv_slopes[{up}_NODES - 1] = {{{inv}}};",
            "",
            "/* tilt angle (rad) from sensor output volts (V) */",
            f"static inline float {name}_angle(float volts)",
            "{",
            "    int i = 0;",
            f"    while (i < {up}_NODES - 2 && volts {cmp} {name}_values[i + 1]) ++i;",
            f"    return {name}_knots[i] + {name}_inv_slopes[i] * (volts - {name}_values[i]);",
            "}",
        ]
    else:
        out += ["", "/* no inverse: the curve is not monotonic over the range */"]
    return out


def _fixed_body(approx: PiecewiseLinear, name: str, up: str, angle_bits: int | None,
                volt_bits: int | None) -> list[str]:
    fmt = fixed_point_format(approx, angle_bits, volt_bits)
    qa, qv, qs, qi = fmt.angle_bits, fmt.volt_bits, fmt.slope_bits, fmt.inverse_slope_bits

    def ints(arr: np.ndarray, bits: int) -> str:
        q = np.rint(np.asarray(arr) * 2.0**bits)
        if np.abs(q).max() > _INT32_MAX:  # pragma: no cover - guarded by fixed_point_format
            raise v.fail("fixed-point table", float(np.abs(q).max()), "values that fit an int32")
        return ", ".join(f"{int(x)}" for x in q)

    out = [
        "",
        f"/* Q formats: tilt_q = round(rad * 2^{qa}), volts_q = round(V * 2^{qv});",
        f" * slopes in Q{qs} (V/rad), inverse slopes in Q{qi} (rad/V).",
        (f" * worst-case quantisation error vs the float approximation: "
        f"{fmt.output_tolerance:.3g} V, {fmt.angle_tolerance:.3g} rad. */"),
        f"#define {up}_ANGLE_FRAC_BITS {qa}",
        f"#define {up}_VOLT_FRAC_BITS {qv}",
        f"#define {up}_SLOPE_FRAC_BITS {qs}",
        f"static const int32_t {name}_knots_q[{up}_NODES] = {{{ints(approx.knots, qa)}}};",
        f"static const int32_t {name}_values_q[{up}_NODES] = {{{ints(approx.values, qv)}}};",
        f"static const int32_t {name}_slopes_q[{up}_NODES - 1] = {{{ints(approx.slopes, qs)}}};",
        "",
        "/* sensor output (volts_q) at tilt angle tilt_q (both Q-format int32) */",
        f"static inline int32_t {name}_output_q(int32_t tilt_q)",
        "{",
        "    int i = 0;",
        "    int64_t p;",
        f"    while (i < {up}_NODES - 2 && tilt_q >= {name}_knots_q[i + 1]) ++i;",
        f"    p = (int64_t){name}_slopes_q[i] * (int64_t)(tilt_q - {name}_knots_q[i]);",
        f"    return {name}_values_q[i] + (int32_t){_shift('p', qs + qa - qv)};",
        "}",
    ]
    if approx.invertible:
        increasing = approx.values[-1] > approx.values[0]
        cmp = ">=" if increasing else "<="
        out += [
            "",
            f"#define {up}_INV_SLOPE_FRAC_BITS {qi}",
            (f"static const int32_t {name}_inv_slopes_q[{up}_NODES - 1] = "
            f"{{{ints(1.0 / approx.slopes, qi)}}};"),
            "",
            "/* tilt angle (tilt_q) from sensor output volts_q (both Q-format int32) */",
            f"static inline int32_t {name}_angle_q(int32_t volts_q)",
            "{",
            "    int i = 0;",
            "    int64_t p;",
            f"    while (i < {up}_NODES - 2 && volts_q {cmp} {name}_values_q[i + 1]) ++i;",
            f"    p = (int64_t){name}_inv_slopes_q[i] * (int64_t)(volts_q - {name}_values_q[i]);",
            f"    return {name}_knots_q[i] + (int32_t){_shift('p', qi + qv - qa)};",
            "}",
        ]
    else:
        out += ["", "/* no inverse: the curve is not monotonic over the range */"]
    return out
