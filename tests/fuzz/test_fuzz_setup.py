"""Fuzzing setup files and the checked model: every mutated file loads or is refused in one line.

Short mode (the default suite): a few hundred cases of the seeded corpus (``setup_corpus.py``),
and Hypothesis examples for the unit parser, the setup document, raw bytes and the model on
arbitrary placements. Each case must load (and then give a finite output at 0 and 0.5 rad, and
save and load back) or raise :class:`~magcilia.MagciliaError` with a one-line message naming the
file; any other exception, a warning (the suite turns warnings into errors), a NaN or a crash of
this process fails the run.

Long mode, for CI nights: ``MAGCILIA_FUZZ=long`` (at least 5,000 cases; ``MAGCILIA_FUZZ_SEED``
picks another corpus, ``MAGCILIA_FUZZ_CASES`` another count). ``scripts/fuzz_setups.py`` runs
the same corpus in worker processes and counts the outcomes.
"""

from __future__ import annotations

import importlib.util
import math
import os
import sys
import tempfile
from collections import Counter
from pathlib import Path
from types import ModuleType
from typing import Any

import numpy as np
import pytest
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

import magcilia as mc
from magcilia.io.setup_files import SCHEMA, setup_from_dict
from magcilia.units import UNITS, parse_quantity

LONG = os.environ.get("MAGCILIA_FUZZ", "").lower() == "long"
SEED = int(os.environ.get("MAGCILIA_FUZZ_SEED", "0"))
SHORT = 600  # cases in the default suite (about 2 s)


def _corpus() -> ModuleType:
    """``setup_corpus.py`` beside this file (the tests folder is not a package)."""
    name = "magcilia_fuzz_setup_corpus"
    if name in sys.modules:
        return sys.modules[name]
    spec = importlib.util.spec_from_file_location(name,
                                                  Path(__file__).with_name("setup_corpus.py"))
    if spec is None or spec.loader is None:
        raise ImportError("cannot load tests/fuzz/setup_corpus.py")
    module = importlib.util.module_from_spec(spec)
    sys.modules[name] = module
    spec.loader.exec_module(module)
    return module


corpus = _corpus()


def _run(cases: list[Any], directory: Path) -> Counter[str]:
    outcomes: Counter[str] = Counter()
    for case in cases:
        path = case.write(directory)
        try:
            outcomes[corpus.check_file(path)] += 1
        except Exception as exc:
            raise AssertionError(f"case {case.index} ({case.seed_name}, {case.mutations}): "
                                 f"{type(exc).__name__}: {exc}") from exc
        finally:
            path.unlink()
    return outcomes


def test_the_seed_files_load(tmp_path: Path) -> None:
    """Unmutated, every seed file loads and runs (so mutations start from valid files); the
    element-on-a-dipole seed loads and its output is refused."""
    for name, data in corpus.seeds().items():
        path = tmp_path / f"{name}.toml"
        path.write_bytes(data)
        assert corpus.check_file(path) == ("model refused" if name == "on_dipole" else "loaded")
    assert {"paper", "paper-initial", "force-sensor", "saved_profile"} <= set(corpus.seeds())


def test_the_corpus_is_deterministic() -> None:
    a = [c.data for c in corpus.cases(40, seed=7)]
    assert a == [c.data for c in corpus.cases(40, seed=7)]
    assert a != [c.data for c in corpus.cases(40, seed=8)]


def test_mutated_setup_files_short(tmp_path: Path) -> None:
    outcomes = _run(list(corpus.cases(SHORT, SEED)), tmp_path)
    assert sum(outcomes.values()) == SHORT
    assert outcomes["refused"] > 0 and outcomes["loaded"] > 0  # both paths are exercised


@pytest.mark.skipif(not LONG, reason="long fuzz run for CI nights: set MAGCILIA_FUZZ=long")
def test_mutated_setup_files_long(tmp_path: Path) -> None:
    n = int(os.environ.get("MAGCILIA_FUZZ_CASES", "5000"))
    outcomes: Counter[str] = Counter()
    for start in range(0, n, 500):
        outcomes += _run(list(corpus.cases(min(500, n - start), SEED, start=start)), tmp_path)
    assert sum(outcomes.values()) == n
    print(f"setup fuzz seed {SEED}: {dict(outcomes)}")


# -- Hypothesis ---------------------------------------------------------------------------------
DIMENSIONS = sorted(UNITS)


@given(st.text(max_size=300), st.sampled_from(DIMENSIONS))
def test_parse_quantity_on_arbitrary_text(text: str, dimension: str) -> None:
    try:
        value = parse_quantity(text, dimension, "key")
    except mc.MagciliaError as exc:
        message = str(exc)
    else:
        assert math.isfinite(value)
        return
    assert "\n" not in message and message.startswith("key must be a ")


@given(st.one_of(st.floats(), st.integers(), st.text(max_size=20)).map(str),
       st.sampled_from(DIMENSIONS), st.data())
def test_parse_quantity_on_numbers_with_units(number: str, dimension: str,
                                              data: st.DataObject) -> None:
    unit = data.draw(st.sampled_from(sorted(UNITS[dimension])))
    try:
        value = parse_quantity(f"{number} {unit}", dimension, "key")
    except mc.MagciliaError:
        return
    assert math.isfinite(value)


TOML_SCALARS = st.one_of(
    st.floats(), st.integers(min_value=-(2**80), max_value=2**80), st.booleans(),
    st.text(max_size=12), st.sampled_from(["3 mm", "1e300 mm", "nan V", "mean", "HMC1021Z"]),
    st.datetimes(),
)
TOML_VALUES = st.recursive(TOML_SCALARS, lambda inner: st.one_of(
    st.lists(inner, max_size=4), st.dictionaries(st.text(max_size=8), inner, max_size=4)),
    max_leaves=12)
KNOWN = {table: sorted(keys) for table, keys in SCHEMA.items()}


@st.composite
def documents(draw: st.DrawFn) -> dict[str, Any]:
    """Setup documents with known tables and keys (mostly) and arbitrary values."""
    doc: dict[str, Any] = {}
    for table in draw(st.lists(st.sampled_from([*KNOWN, "other"]), max_size=4, unique=True)):
        keys = KNOWN.get(table, ["k"])
        doc[table] = draw(st.dictionaries(st.sampled_from([*keys, "unknown"]), TOML_VALUES,
                                          max_size=4))
    return doc


@settings(suppress_health_check=[HealthCheck.too_slow])
@given(documents())
def test_setup_documents_with_arbitrary_values(doc: dict[str, Any]) -> None:
    message = ""
    try:
        setup = setup_from_dict(doc, source="doc")
        out = setup.output([0.0, 0.5])
    except mc.MagciliaError as exc:
        message = str(exc)
    else:
        assert np.isfinite(out).all()
    assert "\n" not in message


@settings(suppress_health_check=[HealthCheck.too_slow])
@given(st.binary(max_size=400))
def test_setup_files_of_arbitrary_bytes(data: bytes) -> None:
    with tempfile.TemporaryDirectory() as tmp:
        path = Path(tmp) / "h.toml"
        path.write_bytes(b"[cilium]\n" + data if data[:1] == b"h" else data)
        assert corpus.check_file(path) in ("loaded", "refused", "model refused", "save refused")


LENGTH = st.floats(min_value=-2e-2, max_value=2e-2, allow_subnormal=True)


@settings(suppress_health_check=[HealthCheck.too_slow])
@given(x=LENGTH, y=LENGTH, z=LENGTH, depth=st.floats(0.0, 2e-3),
       n=st.integers(1, 12), k=st.integers(1, 12), ring=st.sampled_from(["mean", "rms"]),
       tip=st.floats(0.0, 1.0), angles=st.lists(st.floats(-4.0, 4.0), min_size=1, max_size=5))
def test_the_checked_model_never_returns_nan(x: float, y: float, z: float, depth: float, n: int,
                                             k: int, ring: str, tip: float,
                                             angles: list[float]) -> None:
    """Any placement, including the element on the body or on a dipole: a finite output or a
    one-line MagciliaError, never NaN."""
    message = ""
    try:
        setup = mc.Setup.paper(position=(x, y, z), depth=depth, n_loops=n, dipoles_per_loop=k,
                               ring=ring, tip_radius=tip * 1.801e-4)
        out = setup.output(angles)
        field = setup.field(angles)
    except mc.MagciliaError as exc:
        message = str(exc)
    else:
        assert np.isfinite(out).all() and np.isfinite(field).all()
    assert "\n" not in message
