"""Quality checked before fitting (issue 25): one bad value no longer moves a fit silently.

The single-value corruptions the issue measured on the bundled example (an angle's dropped digit,
one sample ×10, 500 duplicated rows) are each flagged, named and, with ``suspect="omit"``, left
out so that the measurement is the clean one again; ``"raise"`` refuses them. The checks are pure
functions, tested against independent constructions: seeded Gaussian noise (no false flags at
the sizes of real recordings), quantised data, noise-free set/reset data, steps and spikes.
"""

from __future__ import annotations

import json
import math
from pathlib import Path

import numpy as np
import pytest

import magcilia as mc
from magcilia.io import example_path
from magcilia.io.quality import (
    OUTLIER_MIN_SAMPLES,
    TINY,
    RecordingQuality,
    check_samples,
    duplicated_rows,
    robust_outliers,
    sparse_conditions,
    spikes,
)
from magcilia.io.recordings import check_quality, measurement_from_samples, read_samples


@pytest.fixture(scope="module")
def example() -> dict[str, np.ndarray]:
    return read_samples(example_path())


def _write(path: Path, cols: dict[str, np.ndarray]) -> Path:
    from magcilia.io.csvfile import write_samples_csv

    return write_samples_csv(path, cols)


def _same(a: mc.Measurement, b: mc.Measurement) -> None:
    np.testing.assert_array_equal(a.angles, b.angles)
    np.testing.assert_array_equal(a.counts, b.counts)
    np.testing.assert_allclose(a.volts, b.volts, rtol=1e-12)


# -- the three corruptions of the bundled example ----------------------------------------
Corrupted = tuple[dict[str, np.ndarray], list[int]]


def _dropped_digit(cols: dict[str, np.ndarray]) -> Corrupted:
    """One angle's dropped digit; the row it damaged."""
    out = {k: a.copy() for k, a in cols.items()}
    i = int(np.flatnonzero(np.isclose(out["angle_deg"], 39.84375))[0])
    out["angle_deg"][i] = 3.984375  # 39.8438 -> 3.8438 (a digit dropped)
    return out, [i]


def _times_ten(cols: dict[str, np.ndarray]) -> Corrupted:
    out = {k: a.copy() for k, a in cols.items()}
    i = int(np.flatnonzero(np.isclose(out["angle_deg"], 85.0))[100])
    out["voltage_V"][i] *= 10.0
    assert abs(out["voltage_V"][i]) < 0.045  # still within the sensor's linear range (±6 gauss)
    return out, [i]


def _duplicated(cols: dict[str, np.ndarray]) -> Corrupted:
    return {k: np.concatenate([a[:20000], a[19500:20000], a[20000:]])
            for k, a in cols.items()}, []


@pytest.mark.parametrize(("corrupt", "finding", "flagged"), [
    (_dropped_digit, (r"1 condition with far fewer samples than the others \(median 2000\): "
                     r"3.98438 deg \(1 sample\)"), 1),
    (_times_ten, (r"1 sample beyond 8 robust standard deviations from their condition's median: "
                 r"1 at 85 deg"), 1),
    (_duplicated, (r"500 rows repeating earlier rows bit for bit \(rows 20001–20500 repeat rows "
                  r"19501–20000\)"), 500)],
    ids=["dropped-digit", "times-ten", "500-duplicated-rows"])
def test_one_bad_value_is_named_and_can_be_left_out(
        tmp_path: Path, example: dict[str, np.ndarray], corrupt: object, finding: str,
        flagged: int) -> None:
    cols, damaged = corrupt(example)  # type: ignore[operator]
    keep = np.ones(example["angle_deg"].size, dtype=bool)
    keep[damaged] = False  # the clean recording less the rows the corruption damaged
    clean = measurement_from_samples(example["angle_deg"][keep], example["voltage_V"][keep])
    path = _write(tmp_path / "bad.csv", cols)
    kept = mc.read_measurements(path)
    (note,) = kept.notes()
    assert note.startswith("quality: ") and note.endswith("(omit them: --suspect omit)")
    assert __import__("re").search(finding, note), note
    assert kept.metadata["quality"]["flagged"] == flagged
    omitted = mc.read_measurements(path, suspect="omit")
    _same(omitted, clean)  # the clean recording's measurement (less the damaged rows)
    assert omitted.notes()[0].endswith("left out")
    with pytest.raises(mc.MagciliaError, match="clean the recording, or pass suspect='omit'"
                       ) as info:
        mc.read_measurements(path, suspect="raise")
    assert "\n" not in str(info.value) and str(path) in str(info.value)


def test_the_clean_example_is_not_flagged(example: dict[str, np.ndarray]) -> None:
    q = check_quality(example)
    assert not q.found and q.report() == "quality: 66000 samples checked, nothing flagged"
    assert q.median_count == 2000 and q.condition == "angle"


def test_suspect_is_checked() -> None:
    with pytest.raises(mc.MagciliaError, match="suspect"):
        measurement_from_samples([0, 10], [1e-3, 2e-3], suspect="drop")


# -- the checks on their own ---------------------------------------------------------------------
def test_sparse_conditions() -> None:
    assert sparse_conditions([2000, 1999, 1, 2000]).tolist() == [False, False, True, False]
    assert sparse_conditions([2, 1, 2]).tolist() == [False] * 3  # (half is not far fewer)
    assert sparse_conditions([5]).tolist() == [False]


def test_gaussian_noise_is_not_flagged() -> None:
    """33 conditions of 2,000 samples and 2,000 conditions of OUTLIER_MIN_SAMPLES samples of
    seeded Gaussian noise: no outlier (the threshold's odds per sample are 1e-15; the scale's
    uncertainty from 30 samples makes a false flag about 1e-4 per group, seeded to none here)."""
    rng = np.random.default_rng(2024)
    for n, groups in ((2000, 33), (OUTLIER_MIN_SAMPLES, 2000)):
        x = rng.normal(size=n * groups)
        assert not robust_outliers(np.repeat(np.arange(groups), n), x).any()


def test_an_outlier_among_noise_and_quantised_data() -> None:
    rng = np.random.default_rng(3)
    x = rng.normal(0.0, 1.0, 200)
    x[17] = 12.0
    assert np.flatnonzero(robust_outliers(np.zeros(200, int), x)).tolist() == [17]
    counts = np.round(rng.normal(0.0, 0.3, 200))  # quantised: most samples equal, MAD 0
    assert not robust_outliers(np.zeros(200, int), counts).any()
    counts[50] = 40.0
    assert np.flatnonzero(robust_outliers(np.zeros(200, int), counts)).tolist() == [50]
    few = np.r_[np.zeros(OUTLIER_MIN_SAMPLES - 2), 1e3]  # too few to judge
    assert not robust_outliers(np.zeros(few.size, int), few).any()


def test_spikes_but_not_steps() -> None:
    t = np.arange(2000)
    x = np.where(t < 1000, 0.0, 5.0) + 0.01 * np.sin(t / 7.0)  # a load step
    assert not spikes(x).any()
    x[500] += 3.0
    assert np.flatnonzero(spikes(x)).tolist() == [500]
    sr = np.tile([1.0, -1.0], 1000)  # set/reset alternate: each polarity a series
    assert not spikes(x * sr, sr)[:499].any()


def test_duplicated_blocks_and_what_is_not_one() -> None:
    rng = np.random.default_rng(4)
    rows = rng.normal(size=(300, 2))
    dup, blocks = duplicated_rows(np.concatenate([rows[:200], rows[50:90], rows[200:]]))
    assert int(dup.sum()) == 40 and blocks.tolist() == [[200, 40, 50]]
    constant = np.ones((300, 2))
    assert not duplicated_rows(constant)[0].any()  # a quiet sensor without time stamps
    alternating = np.tile([[10.0, 1e-3], [10.0, -1e-3]], (150, 1))  # noise-free set/reset
    assert not duplicated_rows(alternating)[0].any()
    short = np.concatenate([rows[:100], rows[20:30], rows[100:]])  # 10 rows: below the run
    assert not duplicated_rows(short)[0].any()


def test_garbled_values_are_flagged() -> None:
    angle = np.repeat([0.0, 10.0, 20.0], 40)
    volts = np.repeat([1e-3, 2e-3, 3e-3], 40) + np.random.default_rng(5).normal(0, 1e-6, 120)
    volts[7] = 7.3e-304  # a damaged exponent
    q = check_samples(angle, volts)
    assert q.garbled == 1 and q.flagged.tolist() == [7]
    assert "a value too small to be measured" in q.report()


def test_field_data_and_loads_are_checked() -> None:
    rng = np.random.default_rng(6)
    angle = np.repeat([0.0, 20.0, 40.0], 60)
    field = np.stack([1e-5 + 1e-7 * angle, np.full(180, 2e-5), np.full(180, 3e-6)], axis=1)
    field = field + rng.normal(0.0, 1e-9, field.shape)
    field[70, 1] += 1e-6  # one component of one sample
    m = measurement_from_samples(angle, field=field)
    assert m.metadata["quality"]["outliers"] == 1
    assert m.metadata["quality"]["outlier_values"] == [pytest.approx(np.radians(20.0))]
    forces = np.repeat([0.0, 1e-5, 2e-5], 50)
    cols = {"force_N": np.r_[forces, 3e-5], "voltage_V": np.r_[forces * 40.0, 1.2e-3]}
    q = check_quality(cols)
    assert q.condition == "force" and q.sparse_values.tolist() == [pytest.approx(3e-5)]
    assert "30 uN (1 sample)" in q.report()


def test_quality_round_trips_and_reports() -> None:
    angle = np.r_[np.repeat([0.0, 10.0], 100), 5.0]
    q = check_samples(angle, np.r_[np.repeat([1e-3, 2e-3], 100), 1.5e-3])
    back = RecordingQuality.from_dict(json.loads(json.dumps(q.to_dict())))
    assert back.report() == q.report() and back.to_dict() == q.to_dict()
    assert "5 deg (1 sample)" in q.report()
    assert repr(q).startswith("RecordingQuality(samples=201, flagged=1")


# -- how the checks are computed (magcilia.io.sample_checks) -------------------------------------
def test_large_conditions_take_median_and_mad_from_a_subsample() -> None:
    """Conditions of more than OUTLIER_SUBSAMPLE samples: the subsample's median and scale are
    the whole condition's within three of their standard errors, seeded noise is not flagged,
    12σ samples are."""
    from magcilia.io.sample_checks import OUTLIER_SUBSAMPLE, centre_and_scale

    n = 24 * OUTLIER_SUBSAMPLE + 5
    rng = np.random.default_rng(11)
    x = rng.normal(3.0, 0.5, 2 * n)
    group = np.repeat([0, 1], n)
    exact = centre_and_scale(x[:n])
    picked = centre_and_scale(x[:n][::math.ceil(n / OUTLIER_SUBSAMPLE)])
    assert picked[0] == pytest.approx(exact[0], abs=0.06 * exact[1])  # 3 standard errors
    assert picked[1] == pytest.approx(exact[1], rel=0.05)
    assert not robust_outliers(group, x).any()
    x[[17, n + 40_000, 2 * n - 1]] += np.array([6.0, -6.0, 6.0])  # 12 σ
    assert np.flatnonzero(robust_outliers(group, x)).tolist() == [17, n + 40_000, 2 * n - 1]


def test_interleaved_conditions_give_the_same_flags() -> None:
    """Conditions in runs and the same rows interleaved (sorted by condition once) are judged
    alike, with set/reset polarity and two columns."""
    rng = np.random.default_rng(12)
    group = np.repeat(np.arange(40), 60)
    sr = np.tile([1.0, -1.0], group.size // 2)
    x = np.column_stack([rng.normal(size=group.size) * sr, rng.normal(size=group.size)])
    x[rng.choice(group.size, 25, replace=False), rng.integers(0, 2, 25)] += 30.0
    together = robust_outliers(group, x, sr)
    assert together.sum() == 25
    order = rng.permutation(group.size)
    mixed = robust_outliers(group[order], x[order], sr[order])
    np.testing.assert_array_equal(mixed, together[order])


@pytest.mark.parametrize("length", [1, 2, 3, 5, 8, 13, 16, 17])
def test_window_hashes_are_the_polynomial_of_their_rows(length: int) -> None:
    from magcilia.io.sample_checks import window_hashes

    h = np.random.default_rng(length).integers(0, 2**63, 40, dtype=np.uint64)
    base, mod = 0x100000001B3, 1 << 64
    direct = [sum(int(h[i + k]) * pow(base, length - 1 - k, mod) for k in range(length)) % mod
              for i in range(h.size - length + 1)]
    assert window_hashes(h, length).tolist() == direct


def test_garbled_values_by_their_bits() -> None:
    from magcilia.io.sample_checks import PIECE, garbled

    special = np.array([0.0, -0.0, 5e-324, -5e-324, 2.2e-308, 1e-101, -1e-101, 1e-100,
                        np.nextafter(1e-100, 0.0), 1.0, -3.0, np.inf, -np.inf, np.nan, 1e308])
    x = np.tile(special, PIECE // 7)  # several pieces
    with np.errstate(invalid="ignore"):
        direct = (np.abs(x) < TINY) & (x != 0.0)
    found = garbled(x, TINY)
    assert found is not None and found.tolist() == direct.tolist()
    assert garbled(np.linspace(-1.0, 1.0, 11), TINY) is None


def test_a_strictly_monotone_column_rules_out_duplicates() -> None:
    """Rows with distinct time stamps never repeat (no hashing needed); the same rows without
    the time stamps repeat."""
    rng = np.random.default_rng(13)
    volts = rng.normal(size=300)
    volts[200:240] = volts[50:90]
    angle = np.zeros(300)
    assert not duplicated_rows([angle, volts, np.arange(300.0)])[0].any()
    assert not duplicated_rows([angle, volts, -np.arange(300.0)])[0].any()
    dup, blocks = duplicated_rows([angle, volts])
    assert blocks.tolist() == [[200, 40, 50]] and dup.sum() == 40
