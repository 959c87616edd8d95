"""A seeded corpus of mutated setup files (TOML) for the fuzz tests.

The seed files are ``examples/*.toml``, the :func:`magcilia.save_setup` output of a few setups
made here (the presets, a measured profile, a converged model) and a file whose sensing element
sits exactly on a dipole of the model (:data:`ON_DIPOLE`); nothing binary is stored in the
repository. Case ``i`` of seed ``s`` takes seed file ``i mod n`` and applies one to four
mutations (mostly one) drawn with ``numpy.random.default_rng([s, i])``:

* numbers: huge, tiny, negative, zero, NaN and inf, 400-digit integers, ``2**63 - 1``, values at
  and just past the registry's limits, written in quotes or bare; and random numbers over 24
  decades, so that many files stay valid and the model runs on odd values;
* units: swapped for another dimension's, left out, misspelt, doubled;
* keys: renamed, duplicated, dropped, moved to another table, unknown keys and tables added;
* types: a value replaced by a string, integer, float, boolean, date, array or inline table;
* nesting: arrays, inline tables, table headers and dotted keys nested 2 to 1500 deep;
* profiles: ``profile_s``/``profile_r`` lists of 1 to 10 001 points, unequal, decreasing;
* bytes: invalid UTF-8, NUL and control characters, truncation, bit flips, chunks deleted or
  duplicated, CRLF line ends, a byte-order mark, a file just over the 1 MB limit.

The same seed, index and library versions give the same bytes. Used by
``tests/fuzz/test_fuzz_setup.py`` and ``scripts/fuzz_setups.py``; :func:`check_file` is the one
property both check.
"""

from __future__ import annotations

import functools
import math
import re
import tempfile
from collections.abc import Callable, Iterator
from dataclasses import dataclass
from pathlib import Path

import numpy as np

import magcilia as mc
from magcilia.device.parameters import PARAMETERS
from magcilia.io.setup_files import MAX_SETUP_BYTES
from magcilia.units import UNITS

EXAMPLES = Path(__file__).resolve().parents[2] / "examples"

#: numbers written over a value: float extremes, integers that overflow, the registry's limits
NUMBERS = (
    "0", "-0", "1", "-1", "0.5", "-3.2613", "1e-9", "1e-12", "4e-324", "5e-324", "1e-400",
    "1e308", "1.7976931348623157e308", "1e309", "-1e308", "1e300", "1e306", "1e6", "1e9",
    "1e12", "1e30", "nan", "-nan", "inf", "-inf", "+inf", "9" * 400, "-" + "9" * 400,
    "9223372036854775807", "-9223372036854775808", "18446744073709551616", "1000", "1001",
    "100000", "1000000", "1e5", "0.999999999999", "1.000000000001", "2.5", "0x10", "0o17",
    "0b101", "1_000", "1e", ".", "--1", "1..2",
    *(f"{p.maximum * f:.17g}" for p in PARAMETERS.values() if np.isfinite(p.maximum)
      for f in (1.0, 1.0000001, -1.0)),
)
ALL_UNITS = tuple(sorted({u for table in UNITS.values() for u in table}))
BAD_UNITS = ("", " ", "mm mm", "MM", "m m", "\u00b5", "mm\x00", "\x1b[2J", "mm\n", "1", "mm;",
             "meter", "%", "m^2", "\ud7ff")
KEYS = ("height", "base_radius", "tip_radius", "youngs_modulus", "x", "y", "z", "gain",
        "offset", "n_loops", "dipoles_per_loop", "ring", "preset", "depth", "profile_s",
        "profile_r", "magnetization_scale", "sensitivity", "range", "heigth", "",
        "\x1b[31mred", "a.b", '"quoted key"', "k" * 300)
TABLES = ("cilium", "material", "placement", "sensor", "amplifier", "model", "wiring",
          "cilium.extra", "model.model", "\x07bell")
VALUES = ('"3 mm"', "3", "3.0", "true", "false", "1979-05-27T07:32:00Z", "1979-05-27",
          "07:32:00", "[]", "[1, 2]", '["1 mm", "2 mm"]', "{}", "{a = 1}", '""', "'literal'",
          '"""multi\nline"""', '"nan mm"', '"inf V"', '"1e999 mm"', '"-3 mm"', '"mean"',
          '"rms"', '"median"', '"HMC1021Z"', '"HMC1001"', "-0.0", "nan", "inf")
BYTES = (b"\xff", b"\xfe\xff", b"\xc3\x28", b"\xe2\x82", b"\xed\xa0\x80", b"\x00", b"\x1b[2J",
         b"\r", b"\x7f", b"\xef\xbb\xbf", b"\xf4\x90\x80\x80", b"\x80")
_NUMBER = re.compile(r"[-+]?(?:\d+\.?\d*|\.\d+)(?:[eE][-+]?\d+)?")
_UNIT = re.compile(r'(?<=\d) ([^"\d][^"]*)"')
_LINE = re.compile(r"^[ \t]*([A-Za-z0-9_\-]+)[ \t]*=[ \t]*(.*)$", re.MULTILINE)


@dataclass(frozen=True)
class Case:
    """One mutated setup file: its index, seed file, bytes and the mutations applied."""

    index: int
    seed_name: str
    data: bytes
    mutations: tuple[str, ...]

    def write(self, directory: Path) -> Path:
        """Write the file as ``case<index>-<seed>.toml`` in ``directory``."""
        path = directory / f"case{self.index}-{self.seed_name}.toml"
        path.write_bytes(self.data)
        return path


def _profile_setup() -> mc.Setup:
    s = np.array([0.0, 0.5e-3, 1.5e-3, 2.5e-3, 3.2e-3])
    r = np.array([0.2e-3, 0.22e-3, 0.15e-3, 0.08e-3, 0.03e-3])
    return mc.Setup.paper(cilium=mc.Cilium.from_profile(s, r), n_loops=8, dipoles_per_loop=4,
                          ring="rms")


#: a valid file whose model has the sensing element exactly on its one dipole (a waisted profile
#: puts the ring outside the body; the values are exact in binary): its output must be an error
ON_DIPOLE = """[cilium]
profile_s = ["0 mm", "1 mm", "2 mm"]
profile_r = ["0.2 mm", "0.02 mm", "0.2 mm"]

[placement]
x = "-0.2 mm"
y = "0 mm"
z = "-1 mm"

[sensor]
depth = "0 mm"

[model]
n_loops = 1
dipoles_per_loop = 1
"""


@functools.cache
def seeds() -> dict[str, bytes]:
    """The valid setup files the mutations start from: name -> bytes."""
    out = {p.stem: p.read_bytes() for p in sorted(EXAMPLES.glob("*.toml"))}
    out["on_dipole"] = ON_DIPOLE.encode()
    made = {
        "saved_paper": mc.Setup.paper(),
        "saved_initial": mc.Setup.paper_initial(),
        "saved_profile": _profile_setup(),
        "saved_options": mc.Setup.paper(tip_radius=3e-5, youngs_modulus=2.2e6, ring="rms",
                                        magnetization_scale=0.3, offset=-1.5e-3, gain=-20.0,
                                        n_loops=40, dipoles_per_loop=6),
    }
    with tempfile.TemporaryDirectory() as tmp:
        for name, setup in made.items():
            path = Path(tmp) / f"{name}.toml"
            mc.save_setup(setup, path)
            out[name] = path.read_bytes()
    return out


# -- text mutations (on the decoded text) ---------------------------------------------------------
TextMutation = Callable[[str, np.random.Generator], str]


def _pick(rng: np.random.Generator, options: tuple[str, ...] | list[str]) -> str:
    return options[int(rng.integers(0, len(options)))]


def _lines(text: str) -> list[str]:
    return text.split("\n")


def _numbers(text: str, rng: np.random.Generator) -> list[re.Match[str]]:
    """The numbers of the file: values, mostly; now and then also those in units (m^-3)."""
    found = list(_NUMBER.finditer(text))
    if rng.random() < 0.9:
        found = [m for m in found if text[m.start() - 1:m.start()] not in ("^", "-", "_")]
    return found


def number(text: str, rng: np.random.Generator) -> str:
    """A number in the file (quoted or bare) replaced by an extreme one."""
    found = _numbers(text, rng)
    if not found:
        return text
    m = found[int(rng.integers(0, len(found)))]
    return text[:m.start()] + _pick(rng, NUMBERS) + text[m.end():]


def scale(text: str, rng: np.random.Generator) -> str:
    """A number multiplied by a power of ten (stays a valid number, crosses the limits)."""
    found = [m for m in _numbers(text, rng) if "e" not in m.group().lower()]
    if not found:
        return text
    m = found[int(rng.integers(0, len(found)))]
    exp = int(rng.choice([-400, -320, -300, -30, -12, -9, -3, 3, 6, 9, 12, 30, 300, 310]))
    return text[:m.start()] + f"{m.group()}e{exp}" + text[m.end():]


def jitter(text: str, rng: np.random.Generator) -> str:
    """A number replaced by a random one of either sign over 24 decades: mostly a valid file with
    odd values, so that the model runs on them (positions near the element, tiny radii, …)."""
    found = _numbers(text, rng)
    if not found:
        return text
    m = found[int(rng.integers(0, len(found)))]
    value = float(rng.choice([-1.0, 1.0])) * 10.0 ** float(rng.uniform(-12.0, 12.0))
    if rng.random() < 0.3:
        value = float(rng.choice([0.0, 1.0, 2.0, 0.71, -0.71, -0.3804, 0.1801, 3.2613]))
    return text[:m.start()] + repr(value) + text[m.end():]


def unit(text: str, rng: np.random.Generator) -> str:
    """A unit swapped for another dimension's, left out or garbled."""
    spans = [m.span(1) for m in _UNIT.finditer(text)]
    if not spans:
        return text
    a, b = spans[int(rng.integers(0, len(spans)))]
    new = _pick(rng, ALL_UNITS) if rng.random() < 0.6 else _pick(rng, BAD_UNITS)
    return text[:a] + new + text[b:]


def _keyed_line(lines: list[str], rng: np.random.Generator) -> tuple[int, re.Match[str]] | None:
    """A random ``key = value`` line of ``lines``: its index and match (None if there is none)."""
    keyed = [i for i, line in enumerate(lines) if _LINE.match(line)]
    if not keyed:
        return None
    i = keyed[int(rng.integers(0, len(keyed)))]
    m = _LINE.match(lines[i])
    assert m is not None
    return i, m


def key(text: str, rng: np.random.Generator) -> str:
    """A key renamed, a line dropped, duplicated, or moved to another table."""
    lines = _lines(text)
    picked = _keyed_line(lines, rng)
    if picked is None:
        return text
    i, m = picked
    kind = int(rng.integers(0, 4))
    if kind == 0:
        lines[i] = f"{_pick(rng, KEYS)} = {m.group(2)}"
    elif kind == 1:
        del lines[i]
    elif kind == 2:
        lines.insert(i, lines[i])
    else:
        del lines[i]
        lines.append(f"[{_pick(rng, TABLES)}]\n{m.group(1)} = {m.group(2)}")
    return "\n".join(lines)


def table(text: str, rng: np.random.Generator) -> str:
    """A table header renamed, duplicated or dropped, or a new table added."""
    lines = _lines(text)
    headers = [i for i, line in enumerate(lines) if line.startswith("[")]
    kind = int(rng.integers(0, 3))
    if kind == 0 and headers:
        lines[headers[int(rng.integers(0, len(headers)))]] = f"[{_pick(rng, TABLES)}]"
    elif kind == 1 and headers:
        lines.append(lines[headers[int(rng.integers(0, len(headers)))]])
    else:
        lines.append(f"[{_pick(rng, TABLES)}]\n{_pick(rng, KEYS)} = {_pick(rng, VALUES)}")
    return "\n".join(lines)


def value_type(text: str, rng: np.random.Generator) -> str:
    """A value replaced by one of another type (string, number, bool, date, array, table)."""
    lines = _lines(text)
    picked = _keyed_line(lines, rng)
    if picked is None:
        return text
    i, m = picked
    lines[i] = f"{m.group(1)} = {_pick(rng, VALUES)}"
    return "\n".join(lines)


def nesting(text: str, rng: np.random.Generator) -> str:
    """A value, header or key nested 2 to 1500 levels deep."""
    depth = int(rng.choice([2, 3, 5, 31, 32, 33, 34, 64, 100, 200, 300, 500, 1000, 1500]))
    kind = int(rng.integers(0, 4))
    if kind == 0:
        deep = "[" * depth + '"1 mm"' + "]" * depth
    elif kind == 1:
        deep = "{a = " * depth + "1" + "}" * depth
    elif kind == 2:
        return text + "\n[" + ".".join(["t"] * depth) + "]\nx = 1\n"
    else:
        return text + "\n" + ".".join(["k"] * depth) + " = 1\n"
    lines = _lines(text)
    keyed = [i for i, line in enumerate(lines) if _LINE.match(line)]
    if not keyed:
        return text + f"\nv = {deep}\n"
    i = keyed[int(rng.integers(0, len(keyed)))]
    m = _LINE.match(lines[i])
    assert m is not None
    lines[i] = f"{m.group(1)} = {deep}"
    return "\n".join(lines)


def profile(text: str, rng: np.random.Generator) -> str:
    """Measured-profile lists: long, short, unequal, decreasing or with extreme values."""
    n = int(rng.choice([0, 1, 2, 3, 10, 100, 1000, 10_000, 10_001]))
    m = n if rng.random() < 0.7 else int(rng.integers(0, max(2, n + 2)))
    height = float(rng.choice([3.0, 1e-7, 1e3, 1e300, 0.0]))
    s = np.linspace(0.0, height, n)
    if rng.random() < 0.2:
        s = s[::-1]
    r = np.linspace(0.2, float(rng.choice([0.0, 0.03, 0.5, 1e-12, 1e9])), m)
    u = _pick(rng, ("mm", "mm", "um", "m", "kg", ""))
    lists = (f"profile_s = [{', '.join(f'{chr(34)}{x:.6g} mm{chr(34)}' for x in s)}]\n"
             f"profile_r = [{', '.join(f'{chr(34)}{x:.6g} {u}{chr(34)}' for x in r)}]\n")
    lines = [line for line in _lines(text)
             if not re.match(r"\s*(height|base_radius|tip_radius)\s*=", line)
             or rng.random() < 0.2]
    body = "\n".join(lines)
    if "[cilium]" in body:
        return body.replace("[cilium]", "[cilium]\n" + lists, 1)
    return body + "\n[cilium]\n" + lists


# -- byte mutations (on the encoded file) ---------------------------------------------------------
ByteMutation = Callable[[bytearray, np.random.Generator], bytearray]


def _at(data: bytearray, rng: np.random.Generator) -> int:
    return int(rng.integers(0, len(data) + 1))


def insert_bytes(data: bytearray, rng: np.random.Generator) -> bytearray:
    """Invalid UTF-8, NUL, escape sequences or a byte-order mark inserted."""
    i = _at(data, rng)
    data[i:i] = BYTES[int(rng.integers(0, len(BYTES)))]
    return data


def flip_bits(data: bytearray, rng: np.random.Generator) -> bytearray:
    for _ in range(int(rng.choice([1, 1, 1, 1, 2, 2, 3, 4]))):
        if data:
            data[int(rng.integers(0, len(data)))] ^= 1 << int(rng.integers(0, 8))
    return data


def truncate(data: bytearray, rng: np.random.Generator) -> bytearray:
    return data[:_at(data, rng)]


def chunk(data: bytearray, rng: np.random.Generator) -> bytearray:
    """A chunk deleted or duplicated."""
    a = _at(data, rng)
    b = min(len(data), a + int(rng.integers(1, 64)))
    if rng.random() < 0.5:
        del data[a:b]
    else:
        data[b:b] = data[a:b]
    return data


def line_ends(data: bytearray, rng: np.random.Generator) -> bytearray:
    """CRLF, lone CR or a byte-order mark."""
    kind = int(rng.integers(0, 3))
    if kind == 0:
        return bytearray(bytes(data).replace(b"\n", b"\r\n"))
    if kind == 1:
        return bytearray(bytes(data).replace(b"\n", b"\r", 1))
    return bytearray(b"\xef\xbb\xbf" + bytes(data))


def oversize(data: bytearray, rng: np.random.Generator) -> bytearray:
    """A comment that takes the file just over (or just under) the size limit."""
    target = MAX_SETUP_BYTES + int(rng.choice([-1, 0, 1, 1000]))
    pad = max(0, target - len(data) - 3)
    return data + b"\n#" + b"x" * pad + b"\n"


TEXT: tuple[TextMutation, ...] = (number, number, number, scale, scale, jitter, jitter, jitter,
                                  jitter, unit, unit, key, table, value_type, value_type, nesting,
                                  profile)
BYTE: tuple[ByteMutation, ...] = (insert_bytes, flip_bits, truncate, chunk, line_ends)


def case(index: int, seed: int = 0) -> Case:
    """Case ``index`` of the corpus of ``seed``."""
    names = sorted(seeds())
    name = names[index % len(names)]
    rng = np.random.default_rng([seed, index])
    text = seeds()[name].decode("utf-8")
    applied = []
    for _ in range(int(rng.choice([1, 1, 1, 1, 2, 2, 3, 4]))):
        if rng.random() < 0.8:
            op = TEXT[int(rng.integers(0, len(TEXT)))]
            text = op(text, rng)
            applied.append(op.__name__)
    data = bytearray(text.encode("utf-8", "surrogatepass"))
    if rng.random() < 0.25 or not applied:
        op_b = BYTE[int(rng.integers(0, len(BYTE)))]
        data = op_b(data, rng)
        applied.append(op_b.__name__)
    if rng.random() < 0.004:
        data = oversize(data, rng)
        applied.append("oversize")
    return Case(index, name, bytes(data), tuple(applied))


def cases(n: int, seed: int = 0, start: int = 0) -> Iterator[Case]:
    """Cases ``start`` … ``start + n - 1`` of the corpus of ``seed``."""
    for i in range(start, start + n):
        yield case(i, seed)


# -- the property ----------------------------------------------------------------------------------
def check_file(path: Path) -> str:
    """Load one setup file and use it; return the outcome.

    ``"refused"``: :func:`magcilia.load_setup` raised a one-line MagciliaError naming the file.
    ``"model refused"``: it loaded, and ``output([0, 0.5])`` raised a one-line MagciliaError (the
    element on a dipole). ``"loaded"``: the output is finite, and the setup saves and loads back
    with the same parameters; ``"save refused"``: :func:`magcilia.save_setup` refused it in one
    line (what it would write could not be read back). Anything
    else raises: an exception other than MagciliaError, a message of several lines or without the
    file name, NaN output.
    """
    try:
        setup = mc.load_setup(path)
    except mc.MagciliaError as exc:
        _one_line(exc, str(path))
        return "refused"
    try:
        out = setup.output([0.0, 0.5])
    except mc.MagciliaError as exc:
        _one_line(exc)
        return "model refused"
    if out.shape != (2,) or not np.isfinite(out).all():
        raise AssertionError(f"{path}: output {out!r} is not two finite volts")
    again = path.with_name(path.stem + "-saved.toml")
    try:
        mc.save_setup(setup, again)
    except mc.MagciliaError as exc:  # e.g. 12-digit rounding would move the element inside
        _one_line(exc)
        return "save refused"
    try:
        back = mc.load_setup(again)  # what save_setup writes, load_setup reads
    finally:
        again.unlink(missing_ok=True)
    for name, value in setup.params().items():  # to the 12 digits written
        if not math.isclose(back.params()[name], value, rel_tol=1e-11, abs_tol=1e-300):
            raise AssertionError(f"{path}: {name} {value!r} saved and read back as "
                                 f"{back.params()[name]!r}")
    if not np.isfinite(back.output([0.0, 0.5])).all():
        raise AssertionError(f"{path}: the saved setup's output is not finite")
    return "loaded"


def _one_line(exc: Exception, name: str = "") -> None:
    text = str(exc)
    if "\n" in text or "\r" in text or not text.isprintable():
        raise AssertionError(f"message is not one printable line: {text!r}")
    if name and name not in text:
        raise AssertionError(f"message does not name the file {name}: {text!r}")
    if len(text) > 2000:
        raise AssertionError(f"message of {len(text)} characters: {text[:200]!r}…")
