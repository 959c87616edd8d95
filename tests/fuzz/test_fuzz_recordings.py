"""Fuzzing the recording readers: every mutated recording is read or refused in one line.

Short mode (the default suite): a few hundred cases of the seeded corpus (``corpus.py``) across
CSV, MATLAB v4/v5/v7.3 and TDMS, and Hypothesis examples for the CSV reader. Each read must
succeed or raise :class:`~magcilia.MagciliaError` whose message is one line naming the file;
any other exception, a warning (the suite turns warnings into errors) or a crash of this
process fails the run. MATLAB files go through the public reader, so the child process that
isolates SciPy and h5py is exercised (several corpus cases kill it with SIGSEGV).

Long mode, for CI nights: ``MAGCILIA_FUZZ=long`` (at least 10,000 cases; ``MAGCILIA_FUZZ_SEED``
picks another corpus, ``MAGCILIA_FUZZ_CASES`` another count). ``scripts/fuzz_recordings.py``
runs the same corpus in worker processes and counts the outcomes.
"""

from __future__ import annotations

import concurrent.futures
import importlib.util
import os
import sys
import tempfile
from collections import Counter
from pathlib import Path
from types import ModuleType

import pytest
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

import magcilia as mc

LONG = os.environ.get("MAGCILIA_FUZZ", "").lower() == "long"
SEED = int(os.environ.get("MAGCILIA_FUZZ_SEED", "0"))
SHORT = {".csv": 800, ".tdms": 800, ".mat": 64, ".h5": 48}  # cases per format, default suite


def _corpus() -> ModuleType:
    """``corpus.py`` beside this file (the tests folder is not a package)."""
    name = "magcilia_fuzz_corpus"
    if name in sys.modules:
        return sys.modules[name]
    spec = importlib.util.spec_from_file_location(name, Path(__file__).with_name("corpus.py"))
    if spec is None or spec.loader is None:
        raise ImportError("cannot load tests/fuzz/corpus.py")
    module = importlib.util.module_from_spec(spec)
    sys.modules[name] = module
    spec.loader.exec_module(module)
    return module


corpus = _corpus()


def _read(case: object, directory: Path) -> str:
    """Read one case: "ok" or "refused"; anything but a one-line MagciliaError fails."""
    path = case.write(directory)  # type: ignore[attr-defined]
    try:
        corpus.read_case(path, case.index)  # type: ignore[attr-defined]
    except mc.MagciliaError as exc:
        text = str(exc)
        assert "\n" not in text and "\r" not in text, (case, text)
        assert str(path) in text, (case, text)
        return "refused"
    finally:
        path.unlink()
    return "ok"


def _run(cases: list[object], tmp_path: Path) -> Counter[str]:
    """Read the cases: MATLAB and HDF5 files in threads (each read waits on its child process),
    the rest in this thread."""
    mat = [c for c in cases if c.suffix in (".mat", ".h5")]  # type: ignore[attr-defined]
    rest = [c for c in cases if c.suffix not in (".mat", ".h5")]  # type: ignore[attr-defined]
    outcomes = Counter(_read(c, tmp_path) for c in rest)
    with concurrent.futures.ThreadPoolExecutor(max_workers=2 * (os.cpu_count() or 1)) as pool:
        outcomes.update(pool.map(lambda c: _read(c, tmp_path), mat))
    return outcomes


def test_the_seed_recordings_are_read(tmp_path: Path) -> None:
    """Unmutated, every seed recording reads (so mutations start from valid files)."""
    for name, (suffix, data) in corpus.seeds().items():
        path = tmp_path / f"{name}{suffix}"
        path.write_bytes(data)
        corpus.read_case(path, 2)
    assert {".csv", ".mat"} <= {s for s, _ in corpus.seeds().values()}
    assert corpus.seeds()["csv_eu"][1].count(b",") > 25  # decimal commas


def test_the_corpus_is_deterministic() -> None:
    a = [c.data for c in corpus.cases(30, seed=7)]
    b = [c.data for c in corpus.cases(30, seed=7)]
    assert a == b
    assert a != [c.data for c in corpus.cases(30, seed=8)]


@pytest.mark.parametrize("suffix", sorted(SHORT))
def test_mutated_recordings_short(tmp_path: Path, suffix: str) -> None:
    if suffix not in {s for s, _ in corpus.seeds().values()}:
        pytest.skip(f"no {suffix} seed recordings (optional package missing)")
    cases = list(corpus.cases(SHORT[suffix], SEED, (suffix,)))
    outcomes = _run(cases, tmp_path)
    assert sum(outcomes.values()) == SHORT[suffix]
    assert outcomes["refused"] > 0  # the mutations reach the readers' checks


@pytest.mark.skipif(not LONG, reason="long fuzz run for CI nights: set MAGCILIA_FUZZ=long")
def test_mutated_recordings_long(tmp_path: Path) -> None:
    n = int(os.environ.get("MAGCILIA_FUZZ_CASES", "10000"))
    outcomes: Counter[str] = Counter()
    for start in range(0, n, 500):
        outcomes += _run(list(corpus.cases(min(500, n - start), SEED, start=start)), tmp_path)
    assert sum(outcomes.values()) == n
    print(f"fuzz seed {SEED}: {dict(outcomes)}")


# -- no value change without a note (TDMS) ------------------------------------------------------
VALUE_CASES = 5000 if LONG else 400


def _values_outcomes(n: int, seed: int, tmp_path: Path) -> Counter[str]:
    """Read ``n`` mutated TDMS recordings and compare each with its seed: refused, same,
    noted, or silent (split by whether the damage reached the file's structure)."""
    outcomes: Counter[str] = Counter()
    for case in corpus.cases(n, seed, (".tdms",)):
        path = case.write(tmp_path)
        kind, detail = corpus.check_case(path, case.index, case.seed_name)
        if kind == "silent":
            kind += ":structure" if corpus.touches_structure(case, tmp_path) else ":data"
            assert kind == "silent:data", (case.index, case.seed_name, case.mutations, detail)
        path.unlink()
        outcomes[kind] += 1
    return outcomes


def test_damage_to_a_tdms_structure_never_changes_values_silently(tmp_path: Path) -> None:
    """Every mutated TDMS recording is refused, read as written, or read with other values and a
    note; values changed without a word come only from raw-data bytes changed in place (a format
    without checksums reads them as a measurement). Long mode: 5,000 cases of another corpus."""
    if ".tdms" not in {s for s, _ in corpus.seeds().values()}:
        pytest.skip("no TDMS seed recordings (npTDMS missing)")
    outcomes = _values_outcomes(VALUE_CASES, SEED + 25 if LONG else SEED, tmp_path)
    assert sum(outcomes.values()) == VALUE_CASES
    assert outcomes["noted"] > 0 and outcomes["refused"] > 0
    if LONG:
        print(f"TDMS values, {VALUE_CASES} cases: {dict(outcomes)}")


# -- Hypothesis: the CSV reader -----------------------------------------------------------------
def _read_csv_bytes(data: bytes) -> None:
    with tempfile.TemporaryDirectory() as tmp:
        path = Path(tmp) / "h.csv"
        path.write_bytes(data)
        text = ""
        try:
            mc.read_measurements(path, nan_policy="omit", saturation="keep")
        except mc.MagciliaError as exc:
            text = str(exc)
        assert not text or ("\n" not in text and str(path) in text), text


@settings(max_examples=60, suppress_health_check=[HealthCheck.too_slow])
@given(st.binary(max_size=600))
def test_csv_reader_on_arbitrary_bytes(data: bytes) -> None:
    _read_csv_bytes(b"angle_deg,voltage_V\n" + data if data[:1] == b"0" else data)


@settings(max_examples=60, suppress_health_check=[HealthCheck.too_slow])
@given(st.text(max_size=400))
def test_csv_reader_on_arbitrary_text(text: str) -> None:
    _read_csv_bytes(text.encode("utf-8", "surrogatepass"))


NUMBERS = st.one_of(st.floats(allow_nan=True, allow_infinity=True).map(repr),
                    st.integers(-400, 400).map(str), st.sampled_from(["", "nan", "1e309", "x"]))


@settings(max_examples=60, suppress_health_check=[HealthCheck.too_slow])
@given(st.permutations(["angle_deg", "voltage_V", "time_s", "setreset", "note"]),
       st.lists(st.tuples(NUMBERS, NUMBERS, NUMBERS, st.sampled_from(["set", "reset", "1", "0"]),
                          st.text(alphabet=st.characters(blacklist_characters=",\r\n\"",
                                                         blacklist_categories=("Cs",)),
                                  max_size=5)),
                max_size=30))
def test_csv_reader_on_well_formed_tables(header: list[str], rows: list[tuple[str, ...]]) -> None:
    order = [["angle_deg", "voltage_V", "time_s", "setreset", "note"].index(h) for h in header]
    lines = [",".join(header)] + [",".join(row[i] for i in order) for row in rows]
    _read_csv_bytes(("\n".join(lines) + "\n").encode("utf-8", "surrogatepass"))


@settings(max_examples=60, suppress_health_check=[HealthCheck.too_slow])
@given(st.binary(max_size=400), st.sampled_from([None, ";", "tab", "whitespace"]),
       st.sampled_from(".,"))
def test_csv_reader_with_delimiters_and_decimal_commas_on_arbitrary_bytes(
        data: bytes, delimiter: str | None, decimal: str) -> None:
    with tempfile.TemporaryDirectory() as tmp:
        path = Path(tmp) / "h.csv"
        path.write_bytes(b"Winkel [deg];Spannung (mV)\n" + data)
        text = ""
        try:
            mc.read_measurements(path, nan_policy="omit", saturation="keep", decimal=decimal,
                                 delimiter=delimiter, columns="angle=Winkel,voltage=Spannung")
        except mc.MagciliaError as exc:
            text = str(exc)
        assert not text or ("\n" not in text and str(path) in text), text
