"""Three-axis magnetometers: a sensing point with three axes, a range, an LSB and noise per axis.

A :class:`Magnetometer` sits at ``position`` (m, in the frame of the README's "Coordinate frame":
+z up, out of the board) with its axes turned by ``rotation`` (a 3 × 3 matrix whose columns are
the sensor's x, y, z axes in that frame). A field ``B`` (T, frame coordinates) reads as
``rotation.T @ B`` on the sensor's axes; :meth:`Magnetometer.measure` adds white noise, clips
each axis at its full-scale range and rounds to the LSB, as the part's digital output does.

Presets (classmethods, and by name through :meth:`Magnetometer.preset` and
:data:`MAGNETOMETERS`) carry datasheet figures for common parts: :meth:`~Magnetometer.mlx90393`,
:meth:`~Magnetometer.tlv493d`, :meth:`~Magnetometer.mmc5983ma`, :meth:`~Magnetometer.lis3mdl`.
Each preset's docstring names its sources and says which figures could not be checked against
the manufacturer's datasheet; where the noise of a setting is not known, the preset asks for it
(``noise=``) rather than guessing.

All SI: T, T per LSB, T RMS, Hz, m.

Examples
--------
>>> m = Magnetometer.preset("LIS3MDL", full_scale=8e-4)
>>> round(m.resolution[0] * 1e9, 2)  # T per LSB at ±8 gauss: 1/3421 gauss
29.23
>>> sorted(MAGNETOMETERS)
['LIS3MDL', 'MLX90393', 'MMC5983MA', 'TLV493D-A1B6']
"""

from __future__ import annotations

from collections.abc import Callable, Mapping
from dataclasses import dataclass, replace
from typing import Any

import numpy as np
from numpy.typing import ArrayLike, NDArray

from magcilia import _validate as v
from magcilia._display import Display, Item, number
from magcilia.constants import GAUSS
from magcilia.device.sensor import beyond_range

F64 = NDArray[np.float64]

#: tolerance of :func:`rotation_matrix`'s orthonormality test (max |RᵀR − I|)
ROTATION_TOLERANCE = 1e-9


def _axes(name: str, value: ArrayLike, unit: str) -> tuple[float, float, float]:
    """A positive per-axis figure: one number for all three axes, or three."""
    arr = np.broadcast_to(np.asarray(value, dtype=np.float64), (3,)) if np.ndim(value) == 0 \
        else v.finite_array(name, value, ndim=1, unit=unit)
    if arr.shape != (3,) or not np.all(np.isfinite(arr)) or np.any(arr <= 0.0):
        raise v.fail(name, value, f"a positive number or three of them (x, y, z), {unit}")
    return (float(arr[0]), float(arr[1]), float(arr[2]))


def rotation_matrix(rotation: ArrayLike | None) -> F64:
    """A checked rotation: None (identity), a 3 × 3 proper orthogonal matrix, or anything with
    ``as_matrix()`` (a ``scipy.spatial.transform.Rotation``)."""
    if rotation is None:
        return np.eye(3)
    if hasattr(rotation, "as_matrix"):
        rotation = rotation.as_matrix()
    mat = v.finite_array("rotation", rotation)
    allowed = ("a 3 × 3 rotation matrix (orthonormal columns = the sensor's axes in the board "
               "frame, determinant +1) or a scipy Rotation")
    if mat.shape != (3, 3):
        raise v.fail("rotation", f"a {mat.shape} array", allowed)
    error = float(np.max(np.abs(mat.T @ mat - np.eye(3))))
    if error > ROTATION_TOLERANCE:
        raise v.fail("rotation", f"a matrix with max |RᵀR − I| = {error:.3g}",
                     allowed + "; orthonormalise it, e.g. with scipy's Rotation.from_matrix")
    if np.linalg.det(mat) < 0.0:
        raise v.fail("rotation", "a reflection (determinant −1)",
                     allowed + "; flip the sign of one column")
    return np.array(mat, dtype=np.float64)


def _field(field: ArrayLike) -> F64:
    """A finite board-frame field, T, shape (..., 3)."""
    arr = v.finite_array("field", field, unit="T")
    if arr.ndim == 0 or arr.shape[-1] != 3:
        raise v.fail("field", f"an array of shape {arr.shape}", "an array of shape (..., 3), T "
                                                                 "(Bx, By, Bz in the board frame)")
    return arr


def _prefix(value: float) -> tuple[float, str]:
    """The factor and prefix that show a field in gauss as 1 … 999 (G, mG, µG or nG)."""
    g = abs(value) / GAUSS
    for factor, prefix in ((1.0, ""), (1e-3, "m"), (1e-6, "µ")):
        if g >= factor:
            return factor, prefix
    return 1e-9, "n"


def _per_axis(values: tuple[float, float, float]) -> str:
    """Per-axis fields (T) in gauss: ``"8 G"``, or ``"3.2/3.2/4.1 mG"`` (x/y/z) where they
    differ."""
    factor, prefix = _prefix(max(values))
    shown = [number(x / GAUSS / factor, 4) for x in values]
    text = shown[0] if len(set(shown)) == 1 else "/".join(shown)
    return f"{text} {prefix}G"


@dataclass(frozen=True, eq=False, repr=False)
class Magnetometer(Display):
    """A three-axis magnetometer (all SI).

    Parameters
    ----------
    field_range : float or (3,) floats
        Full-scale range ±field_range per axis, T; readings beyond it saturate (clip).
    resolution : float or (3,) floats
        One LSB per axis, T.
    noise : float or (3,) floats
        RMS noise per axis at ``rate`` in the part's stated mode, T.
    rate : float
        Output data rate, Hz, at which ``noise`` holds.
    position : (3,) floats
        Sensing point, m, in the board frame (the single-axis sensor's element is the origin).
    rotation : (3, 3) array or scipy Rotation, optional
        The sensor's axes in the board frame (columns); default aligned with the board.
    name : str
        Part name, for reports.

    Examples
    --------
    >>> m = Magnetometer(field_range=8e-4, resolution=6.25e-9, noise=4e-8, rate=100.0)
    >>> (m.measure([[1e-3, 0.0, 2e-5]], noisy=False) * 1e6).round(3).tolist()  # µT: x clips
    [[800.0, 0.0, 20.0]]
    >>> m.saturated([[1e-3, 0.0, 2e-5]]).tolist()
    [[True, False, False]]
    """

    field_range: Any
    resolution: Any
    noise: Any
    rate: float
    position: Any = (0.0, 0.0, 0.0)
    rotation: Any = None
    name: str = "magnetometer"

    def __post_init__(self) -> None:
        object.__setattr__(self, "field_range", _axes("field_range", self.field_range, "T"))
        object.__setattr__(self, "resolution", _axes("resolution", self.resolution, "T"))
        object.__setattr__(self, "noise", _axes("noise", self.noise, "T"))
        object.__setattr__(self, "rate", v.positive("rate", self.rate, "Hz", "frequency"))
        pos = v.vector3("position", self.position)
        object.__setattr__(self, "position", tuple(float(p) for p in pos))
        mat = rotation_matrix(self.rotation)
        mat.setflags(write=False)
        object.__setattr__(self, "rotation", mat)
        if not isinstance(self.name, str) or not self.name:
            raise v.fail("name", self.name, "a non-empty string (the part's name)")

    # -- construction ---------------------------------------------------------------------------
    def replace(self, **changes: Any) -> Magnetometer:
        """A copy with some fields changed (e.g. ``position=``, ``rotation=``)."""
        return replace(self, **changes)

    @classmethod
    def preset(cls, part: str, /, **overrides: Any) -> Magnetometer:
        """A preset part by name (a key of :data:`MAGNETOMETERS`, case-insensitive; ``"TLV493D"``
        is the TLV493D-A1B6), with its settings and any field (``position=``, ``rotation=``,
        ``noise=``, ``name=``, …) given as keywords."""
        key = _preset_key(part)
        return MAGNETOMETERS[key](**overrides)

    @classmethod
    def mlx90393(cls, gain_sel: int = 7, res: int = 0, dig_filt: int = 7, osr: int = 3,
                 **overrides: Any) -> Magnetometer:
        """Melexis MLX90393 (Hall, programmable gain and resolution), HALLCONF = 0xC (default).

        LSB per axis from the datasheet's sensitivity table for HALLCONF = 0xC (Melexis
        MLX90393 datasheet, 3901090393 rev. 006, Jan 2020; the table as tabulated in Adafruit's
        MLX90393 driver, ``mlx90393_lsb_lookup``): x and y share one LSB, **z's is about 1.61
        times larger** (the vertical Hall plates are less sensitive). ``gain_sel`` 7 (gain 1×)
        and ``res`` 0 give 0.150 µT/LSB (x, y) and 0.242 µT/LSB (z); each step of ``res``
        doubles the LSB; ``gain_sel`` 0 (5×) is the coarsest.

        Range: the 16-bit output word (±2¹⁵ LSB for ``res`` 0–2, ±2¹⁴ LSB for ``res`` 3, whose
        output is offset-binary) times the LSB, capped at 50 mT, the upper end of the part's
        "wide dynamic range (5–50 mT)" (datasheet rev. 006, Features).

        Rate: 1 / t_conv, the XYZ conversion time for ``dig_filt`` and ``osr`` (datasheet
        Table 18 as tabulated in Adafruit's driver, ``mlx90393_tconv``: 200.37 ms at
        dig_filt 7, osr 3, i.e. 5 Hz; 1.27 ms at 0, 0, i.e. 787 Hz), the fastest a burst can run.

        Noise: the datasheet's noise figures (they depend on ``dig_filt`` and ``osr``) were not
        available to check here, so the preset takes ``noise=`` (T RMS per axis, one number or
        three) and refuses to guess.

        Parameters
        ----------
        gain_sel : int
            GAIN_SEL register field, 0 (5×) … 7 (1×).
        res : int
            RES_XYZ for all three axes, 0 … 3 (the LSB doubles per step).
        dig_filt : int
            DIG_FILT, 0 … 7.
        osr : int
            OSR, 0 … 3.
        **overrides
            ``noise`` (required) and any other field.
        """
        g = _setting("gain_sel", gain_sel, range(8))
        r = _setting("res", res, range(4))
        f = _setting("dig_filt", dig_filt, range(8))
        o = _setting("osr", osr, range(4))
        if "noise" not in overrides:
            raise v.MagciliaError(
                "noise must be given for the MLX90393 preset (T RMS per axis at your DIG_FILT and "
                "OSR, from the datasheet's noise table); magcilia could not verify those figures "
                "and does not guess them: e.g. Magnetometer.mlx90393(noise=(0.5e-6, 0.5e-6, "
                "0.8e-6))")
        xy, z = _MLX90393_LSB_UT[g][r]
        lsb = np.array([xy, xy, z]) * 1e-6
        counts = 2.0**14 if r == 3 else 2.0**15
        rng = np.minimum(lsb * counts, _MLX90393_MAX_RANGE)
        rate = 1e3 / _MLX90393_TCONV_MS[f][o]
        return _build(cls, overrides, field_range=tuple(rng), resolution=tuple(lsb), rate=rate,
                      name=f"MLX90393 G{g} R{r} F{f} O{o}")

    @classmethod
    def tlv493d(cls, mode: str = "fast", **overrides: Any) -> Magnetometer:
        """Infineon TLV493D-A1B6 (Hall, fixed range).

        Range ±130 mT of linear field measurement on each axis, 12-bit data, 98 µT per LSB
        (Infineon TLV493D-A1B6 datasheet v01_10 and user manual v01_03, as summarised in
        Infineon's Arduino library README and used there as ``TLV493D_B_MULT = 0.098`` mT/LSB).
        Rates by ``mode`` (Infineon's library, access-mode table): ``"fast"`` 3.3 kHz,
        ``"low_power"`` 100 Hz, ``"ultra_low_power"`` 10 Hz.

        Noise: not available to verify here; the preset takes ``noise=`` (T RMS per axis).
        The TLE493D-W2B6 is not preset: its figures could not be checked.
        """
        m = v.choice("mode", mode, tuple(_TLV493D_RATES))
        if "noise" not in overrides:
            raise v.MagciliaError(
                "noise must be given for the TLV493D-A1B6 preset (T RMS per axis in your mode); "
                "magcilia could not verify the datasheet's figure and does not guess it: e.g. "
                "Magnetometer.tlv493d(noise=1e-4)")
        return _build(cls, overrides, field_range=0.130, resolution=98e-6,
                      rate=_TLV493D_RATES[m], name=f"TLV493D-A1B6 ({m})")

    @classmethod
    def mmc5983ma(cls, rate: float = 100.0, bits: int = 18, **overrides: Any) -> Magnetometer:
        """MEMSIC MMC5983MA (AMR with set/reset, ±8 gauss).

        Range ±8 gauss; 18-bit output at 0.0625 mG/LSB (16384 counts per gauss; 16-bit output
        0.25 mG/LSB); total RMS noise 0.4 mG (MEMSIC MMC5983MA datasheet, as quoted by the
        SparkFun MMC5983MA library and board documentation and the mmc5983 drivers; the noise's
        filter-bandwidth condition was not confirmed here, so give ``noise=`` for a faster
        filter). Continuous-mode output data rates 1, 10, 20, 50, 100, 200 and 1000 Hz
        (SparkFun library, ``setContinuousModeFrequency``).

        Parameters
        ----------
        rate : float
            Continuous-mode output data rate, Hz.
        bits : {18, 16}
            Output word width.
        """
        r = _rate("rate", rate, _MMC5983MA_RATES)
        b = _setting("bits", bits, (16, 18))
        lsb = (0.0625e-3 if b == 18 else 0.25e-3) * GAUSS
        return _build(cls, overrides, field_range=8.0 * GAUSS, resolution=lsb,
                      noise=0.4e-3 * GAUSS, rate=r, name=f"MMC5983MA ({b}-bit)")

    @classmethod
    def lis3mdl(cls, full_scale: float = 4.0 * GAUSS, rate: float = 155.0,
                **overrides: Any) -> Magnetometer:
        """ST LIS3MDL (AMR, four full scales).

        Full scales ±4, ±8, ±12, ±16 gauss with 6842, 3421, 2281, 1711 LSB/gauss (16-bit;
        ST AN4602 rev. 1, Table 2, as quoted by the ``lis3mdl`` Rust driver docs; the same gains
        in the Zephyr driver). RMS noise in ultra-high-performance mode 3.2 mgauss (x, y) and
        4.1 mgauss (z) (LIS3MDL datasheet DocID024204 rev. 6, Table 3, as quoted in several
        sensor models; the full scale at which ST states it was not confirmed here). Output data
        rates 0.625 … 80 Hz in any mode, and with FAST_ODR 155 Hz (ultra-high performance),
        300 Hz (high), 560 Hz (medium) and 1000 Hz (low power) (Zephyr LIS3MDL driver's ODR
        table, ST's register description).

        The noise holds in ultra-high-performance mode, i.e. up to 155 Hz; at 300, 560 and
        1000 Hz the part runs in a lower-performance mode whose noise was not available: give
        ``noise=`` there.

        Parameters
        ----------
        full_scale : float
            ±full scale, T: 4e-4, 8e-4, 1.2e-3 or 1.6e-3 (4, 8, 12, 16 gauss).
        rate : float
            Output data rate, Hz.
        """
        fs = _full_scale(full_scale)
        r = _rate("rate", rate, _LIS3MDL_RATES)
        if r > 155.0 and "noise" not in overrides:
            raise v.MagciliaError(
                f"noise must be given for the LIS3MDL at rate {r:g} Hz (a lower-performance mode "
                "whose noise magcilia could not verify); the preset's 3.2/3.2/4.1 mgauss hold in "
                "ultra-high-performance mode, at most 155 Hz")
        lsb = GAUSS / _LIS3MDL_GAIN[fs]
        return _build(cls, overrides, field_range=fs * GAUSS, resolution=lsb,
                      noise=(3.2e-3 * GAUSS, 3.2e-3 * GAUSS, 4.1e-3 * GAUSS), rate=r,
                      name=f"LIS3MDL (±{fs:g} G)")

    # -- the reading ----------------------------------------------------------------------------
    @property
    def sigma(self) -> F64:
        """RMS noise per sensor axis, T, shape (3,)."""
        return np.array(self.noise)

    def to_sensor(self, field: ArrayLike) -> F64:
        """Field on the sensor's axes, T, shape (..., 3), from a board-frame field (..., 3)."""
        return _field(field) @ self.rotation

    def to_board(self, reading: ArrayLike) -> F64:
        """Board-frame field, T, shape (..., 3), from a reading on the sensor's axes (..., 3)."""
        arr = v.finite_array("reading", reading, unit="T")
        if arr.ndim == 0 or arr.shape[-1] != 3:
            raise v.fail("reading", f"an array of shape {arr.shape}", "an array of shape (..., 3), "
                                                                       "T (the sensor's x, y, z)")
        return arr @ self.rotation.T

    def in_range(self, field: ArrayLike) -> NDArray[np.bool_]:
        """True where a board-frame field (..., 3), T, lies within range on all three axes,
        shape (...)."""
        return ~np.any(self.saturated(field), axis=-1)

    def saturated(self, field: ArrayLike) -> NDArray[np.bool_]:
        """True per sensor axis where a board-frame field (..., 3), T, lies beyond that axis's
        range (the reading clips there), shape (..., 3): :func:`~magcilia.device.sensor.
        beyond_range` of the field on the sensor's axes."""
        return beyond_range(self.to_sensor(field), self.field_range)

    def saturated_reading(self, reading: ArrayLike) -> NDArray[np.bool_]:
        """True per axis where a reading (..., 3), T on the sensor's axes (what the part
        reports: clipped at its range, rounded to its LSB), is saturated, shape (..., 3)
        (:func:`~magcilia.device.sensor.beyond_range` with the LSB)."""
        return beyond_range(reading, self.field_range, self.resolution)

    def measure(self, field: ArrayLike, rng: int | np.random.Generator | None = None,
                noisy: bool = True) -> F64:
        """What the part reports for a board-frame field (..., 3), T: on the sensor's axes, plus
        white noise (if ``noisy``), clipped at ±field_range and rounded to the LSB, T,
        shape (..., 3)."""
        reading = self.to_sensor(field)
        if noisy:
            reading = reading + np.random.default_rng(rng).standard_normal(reading.shape) \
                * self.sigma
        rng_ = np.array(self.field_range)
        lsb = np.array(self.resolution)
        return np.asarray(np.round(np.clip(reading, -rng_, rng_) / lsb) * lsb, dtype=np.float64)

    # -- files and reports ----------------------------------------------------------------------
    def to_dict(self) -> dict[str, Any]:
        """JSON-ready content (SI): every field, per-axis figures as lists of three."""
        return {"name": self.name, "field_range_T": list(self.field_range),
                "resolution_T": list(self.resolution), "noise_T": list(self.noise),
                "rate_Hz": self.rate, "position_m": list(self.position),
                "rotation": self.rotation.tolist()}

    @classmethod
    def from_dict(cls, doc: Mapping[str, Any]) -> Magnetometer:
        """Rebuild from :meth:`to_dict`'s content (every value checked again)."""
        if not isinstance(doc, Mapping):
            raise v.fail("magnetometer", type(doc).__name__, "a mapping from to_dict()")
        keys = {"name": "name", "field_range_T": "field_range", "resolution_T": "resolution",
                "noise_T": "noise", "rate_Hz": "rate", "position_m": "position",
                "rotation": "rotation"}
        unknown = sorted(set(doc) - set(keys))
        if unknown:
            raise v.fail("magnetometer key", unknown[0], "one of " + ", ".join(keys))
        missing = [k for k in ("field_range_T", "resolution_T", "noise_T", "rate_Hz")
                   if k not in doc]
        if missing:
            raise v.fail("magnetometer", f"no {missing[0]!r}", "a mapping with field_range_T, "
                                                               "resolution_T, noise_T and rate_Hz")
        return cls(**{keys[k]: val for k, val in doc.items()})

    def report(self) -> str:
        """A few lines for people: the part, range, LSB, noise, rate and placement (gauss, mm,
        degrees of the axes' turn; per-axis figures that differ as x/y/z)."""
        pos = ", ".join(f"{p * 1e3:.4g}" for p in self.position)
        angle = float(np.degrees(np.arccos(np.clip((np.trace(self.rotation) - 1.0) / 2.0,
                                                   -1.0, 1.0))))
        lines = [f"{self.name}",
                 f"  range      ±{_per_axis(self.field_range)}",
                 f"  LSB        {_per_axis(self.resolution)}",
                 f"  noise      {_per_axis(self.noise)} RMS at {number(self.rate, 4)} Hz",
                 f"  position   ({pos}) mm",
                 f"  axes       turned {angle:.4g} deg from the board's"]
        return "\n".join(lines)

    def _display_items(self) -> list[Item]:
        items = [("", self.name), ("range", "±" + _per_axis(self.field_range)),
                 ("LSB", _per_axis(self.resolution)), ("noise", _per_axis(self.noise)),
                 ("rate", f"{number(self.rate, 4)} Hz"),
                 ("position", "(" + ", ".join(f"{p * 1e3:.4g}" for p in self.position) + ") mm")]
        if not np.allclose(self.rotation, np.eye(3)):
            items.append(("rotated", "yes"))
        return items


# -- datasheet tables ---------------------------------------------------------------------------
#: MLX90393, HALLCONF = 0xC: µT per LSB (xy, z) by [GAIN_SEL][RES] (see Magnetometer.mlx90393)
_MLX90393_LSB_UT: tuple[tuple[tuple[float, float], ...], ...] = (
    ((0.751, 1.210), (1.502, 2.420), (3.004, 4.840), (6.009, 9.680)),
    ((0.601, 0.968), (1.202, 1.936), (2.403, 3.872), (4.840, 7.744)),
    ((0.451, 0.726), (0.901, 1.452), (1.803, 2.904), (3.605, 5.808)),
    ((0.376, 0.605), (0.751, 1.210), (1.502, 2.420), (3.004, 4.840)),
    ((0.300, 0.484), (0.601, 0.968), (1.202, 1.936), (2.403, 3.872)),
    ((0.250, 0.403), (0.501, 0.807), (1.001, 1.613), (2.003, 3.227)),
    ((0.200, 0.323), (0.401, 0.645), (0.801, 1.291), (1.602, 2.581)),
    ((0.150, 0.242), (0.300, 0.484), (0.601, 0.968), (1.202, 1.936)),
)
#: MLX90393 XYZ conversion time, ms, by [DIG_FILT][OSR] (datasheet Table 18)
_MLX90393_TCONV_MS: tuple[tuple[float, ...], ...] = (
    (1.27, 1.84, 3.00, 5.30), (1.46, 2.23, 3.76, 6.84), (1.84, 3.00, 5.30, 9.91),
    (2.61, 4.53, 8.37, 16.05), (4.15, 7.60, 14.52, 28.34), (7.22, 13.75, 26.80, 52.92),
    (13.36, 26.04, 51.38, 102.07), (25.65, 50.61, 100.53, 200.37),
)
#: the MLX90393's widest range, T ("wide dynamic range (5–50 mT)")
_MLX90393_MAX_RANGE = 50e-3
_TLV493D_RATES = {"fast": 3300.0, "low_power": 100.0, "ultra_low_power": 10.0}
_MMC5983MA_RATES = (1.0, 10.0, 20.0, 50.0, 100.0, 200.0, 1000.0)
#: LIS3MDL LSB per gauss by full scale (gauss)
_LIS3MDL_GAIN = {4.0: 6842.0, 8.0: 3421.0, 12.0: 2281.0, 16.0: 1711.0}
_LIS3MDL_RATES = (0.625, 1.25, 2.5, 5.0, 10.0, 20.0, 40.0, 80.0, 155.0, 300.0, 560.0, 1000.0)


def _setting(name: str, value: object, allowed: Any) -> int:
    """A register setting: one of ``allowed`` whole numbers."""
    options = tuple(allowed)
    if isinstance(value, bool) or not isinstance(value, int | np.integer) or value not in options:
        raise v.fail(name, value, "one of " + ", ".join(str(o) for o in options))
    return int(value)


def _rate(name: str, value: object, allowed: tuple[float, ...]) -> float:
    """An output data rate, Hz: one of the part's ``allowed`` rates."""
    r = v.positive(name, value, "Hz", "frequency")
    for a in allowed:
        if abs(r - a) <= 1e-9 * a:
            return a
    raise v.fail(name, r, "one of the part's output data rates " +
                 ", ".join(f"{a:g}" for a in allowed) + " Hz")


def _full_scale(value: object) -> float:
    """The LIS3MDL's full scale in gauss, from an SI value (T)."""
    fs = v.positive("full_scale", value, "T", "field")
    for g in _LIS3MDL_GAIN:
        if abs(fs / GAUSS - g) <= 1e-9 * g:
            return g
    raise v.fail("full_scale", fs, "one of 4e-4, 8e-4, 1.2e-3, 1.6e-3 T (±4, 8, 12, 16 gauss)")


_FIELDS = frozenset({"field_range", "resolution", "noise", "rate", "position", "rotation", "name"})


def _build(cls: type[Magnetometer], overrides: dict[str, Any], **values: Any) -> Magnetometer:
    """A preset's figures under the caller's overrides (fields of Magnetometer only)."""
    unknown = sorted(set(overrides) - _FIELDS)
    if unknown:
        raise v.fail("keyword", unknown[0], "a setting of the preset or a Magnetometer field ("
                     + ", ".join(sorted(_FIELDS)) + ")")
    return cls(**{**values, **overrides})


#: preset parts by name: each a factory taking the part's settings and field overrides as keywords
MAGNETOMETERS: dict[str, Callable[..., Magnetometer]] = {
    "MLX90393": Magnetometer.mlx90393,
    "TLV493D-A1B6": Magnetometer.tlv493d,
    "MMC5983MA": Magnetometer.mmc5983ma,
    "LIS3MDL": Magnetometer.lis3mdl,
}
_ALIASES = {"TLV493D": "TLV493D-A1B6"}


def _preset_key(name: object) -> str:
    """The registry key of a preset name (case-insensitive, with aliases)."""
    if isinstance(name, str):
        key = _ALIASES.get(name.upper(), name.upper())
        if key in MAGNETOMETERS:
            return key
    raise v.fail("magnetometer preset", name, "one of " + ", ".join(repr(k) for k in MAGNETOMETERS)
                 + " (or build a Magnetometer from your part's datasheet figures)")

