"""Array setup files (io/array_file.py): [[cilia]], [[sensors]], [array]; round trips and
one-line errors naming the file and the entry."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest

import magcilia as mc
from magcilia.constants import GAUSS
from magcilia.device.magnetometer import Magnetometer
from magcilia.io.array_file import load_array_grid, read_loads

EXAMPLES = Path(__file__).resolve().parents[2] / "examples"

HEAD = """
[cilium]
height = "3.2613 mm"
base_radius = "0.1801 mm"
tip_radius = "0.05 mm"
youngs_modulus = "1 MPa"
"""

LISTS = HEAD + """
[[cilia]]
name = "a"
base = ["0 mm", "0 mm", "1 mm"]

[[cilia]]
name = "b"
base = ["2.5 mm", "0 mm", "1 mm"]
tip_radius = "40 um"
n_loops = 48
ring = "rms"

[[sensors]]
name = "s1"
preset = "MMC5983MA"
rate = "50 Hz"
position = ["0 mm", "0 mm", "0 mm"]
euler = "xyz 0 0 90 deg"

[[sensors]]
name = "s2"
range = "8 gauss"
lsb = "0.0625 mG"
noise = ["0.4 mG", "0.4 mG", "0.6 mG"]
rate = "100 Hz"
position = ["2.5 mm", "0 mm", "0 mm"]
rotation = [[1.0, 0.0, 0.0], [0.0, 0.0, -1.0], [0.0, 1.0, 0.0]]
"""


def _write(tmp_path: Path, text: str, name: str = "arr.toml") -> Path:
    path = tmp_path / name
    path.write_text(text)
    return path


def test_lists_of_cilia_and_sensors(tmp_path: Path) -> None:
    arr = mc.load_array(_write(tmp_path, LISTS))
    assert arr.names == ("a", "b") and [s.name for s in arr.sensors] == ["s1", "s2"]
    np.testing.assert_allclose(arr.bases, [[0, 0, 1e-3], [2.5e-3, 0, 1e-3]], atol=1e-15)
    # the per-cilium overrides, the rest from the file's tables
    a, b = arr.cilia
    assert a.cilium.tip_radius == pytest.approx(5e-5) and b.cilium.tip_radius == pytest.approx(4e-5)
    # no [model]: a converged layout (at the sensors); b's own keys: its layout as given
    assert a.layout == "converged" and a.ring == "rms"
    assert (b.layout, b.n_loops, b.ring) == ("given", 48, "rms")
    assert a.youngs_modulus == pytest.approx(1e6) == b.youngs_modulus
    # the preset with its setting, turned 90 deg about z: sensor x along the board's y
    s1, s2 = arr.sensors
    ref = Magnetometer.preset("MMC5983MA", rate=50.0)
    assert s1.rate == 50.0 and s1.resolution == ref.resolution and s1.noise == ref.noise
    np.testing.assert_allclose(s1.rotation[:, 0], [0.0, 1.0, 0.0], atol=1e-15)
    # figures by value, per axis, and a rotation matrix by columns
    assert s2.noise == pytest.approx((0.4e-3 * GAUSS, 0.4e-3 * GAUSS, 0.6e-3 * GAUSS))
    assert s2.field_range == pytest.approx((8 * GAUSS,) * 3)
    np.testing.assert_allclose(s2.rotation[:, 1], [0.0, 0.0, 1.0])
    np.testing.assert_allclose(s2.position, (2.5e-3, 0.0, 0.0))
    # load_setup still reads the file's single setup and ignores the array tables
    setup = mc.load_setup(tmp_path / "arr.toml")
    assert setup.cilium.tip_radius == pytest.approx(5e-5)
    # a coarse layout given for one cilium is warned about with its error at the sensors
    coarse = LISTS.replace('n_loops = 48\nring = "rms"\n', "n_loops = 4\n")
    with pytest.warns(mc.LayoutWarning, match=r"4×5 mean, \d+ % from the exact body at the "
                                              "array's sensors"):
        mc.load_array(_write(tmp_path, coarse, "coarse.toml"))


def test_example_grid_matches_cilia_array_grid() -> None:
    arr = mc.load_array(EXAMPLES / "array.toml")
    setup = mc.Setup.paper(tip_radius=5e-5, position=(0.0, 0.0, 1.5e-3 - 0.71e-3),
                           layout="converged")
    ref = mc.CiliaArray.grid(setup, 4, 4, 4e-3, sensor=Magnetometer.preset("MMC5983MA"),
                             depth=1.5e-3)
    assert len(arr) == 16 and arr.n_sensors == 16 and arr.names == ref.names
    np.testing.assert_allclose(arr.bases, ref.bases, rtol=0, atol=1e-15)
    np.testing.assert_allclose(arr.sensor_positions, ref.sensor_positions, rtol=0, atol=1e-15)
    assert {(c.n_loops, c.ring) for c in arr.cilia} == {(ref.cilia[0].n_loops, "rms")}
    # the presets' sourced modulus, assumed (docs/stiffness.md), not a modulus taken as exact
    assert {c.modulus for c in arr.cilia} == {mc.Setup.paper().modulus}
    assert arr.cilia[0].modulus.source == "assumed" and arr.cilia[0].modulus.relative > 0.2
    np.testing.assert_allclose(arr.field(), ref.field(), rtol=1e-12)
    grid = load_array_grid(EXAMPLES / "array.toml")
    assert grid is not None and (grid.rows, grid.cols) == (4, 4)
    assert grid.pitch == (4e-3, 4e-3) and grid.depth == pytest.approx(1.5e-3)
    # the example's promise: crosstalk ratio below 1, the rest field within half the parts'
    # range (the exact body's field: tests/device/test_layout_rule.py)
    readout = mc.ArrayReadout(arr, 2e-5, table_size=9)  # neighbours clear under the span
    assert readout.crosstalk().ratio.max() < 1.0
    assert np.abs(arr.field()).max() < 0.5 * 8 * GAUSS
    # under the span (scripts/array_example.py: the exact body): every cilium bent by it keeps
    # every reading within half the range, and moves its own sensor by > 100 noise sigma
    span = 2e-5 * np.array([np.cos(0.7), np.sin(0.7)])
    bent = mc.field_for_loads(arr, np.tile(span, (len(arr), 1)))
    assert np.abs(bent).max() < 0.5 * 8 * GAUSS
    assert not arr.saturated(arr.readings(bent, noisy=False)).any()
    alone = mc.field_for_loads(arr, np.array([span] + [[0.0, 0.0]] * 15)) - arr.field()
    assert np.linalg.norm(alone[0]) > 100 * float(np.max(arr.sigma))
    # every bundled single-setup example still loads, and this one's setup too
    for path in EXAMPLES.glob("*.toml"):
        mc.load_setup(path)


@pytest.mark.parametrize("source", ["lists", "grid"])
def test_save_then_load_gives_the_same_array(tmp_path: Path, source: str) -> None:
    arr = mc.load_array(_write(tmp_path, LISTS) if source == "lists"
                        else EXAMPLES / "array.toml")
    path = tmp_path / "saved.toml"
    mc.save_array(arr, path)
    back = mc.load_array(path)
    assert back.names == arr.names
    assert [s.name for s in back.sensors] == [s.name for s in arr.sensors]
    np.testing.assert_allclose(back.bases, arr.bases, rtol=1e-13, atol=1e-18)
    np.testing.assert_allclose(back.sensor_positions, arr.sensor_positions, rtol=1e-13,
                               atol=1e-18)
    np.testing.assert_allclose(back.rotations, arr.rotations, rtol=0, atol=1e-15)
    for one, two in zip(arr.sensors, back.sensors, strict=True):
        for key in ("field_range", "resolution", "noise"):
            np.testing.assert_allclose(getattr(two, key), getattr(one, key), rtol=1e-13)
        assert two.rate == pytest.approx(one.rate, rel=1e-13)
    for one, two in zip(arr.cilia, back.cilia, strict=True):
        for key, value in one.params().items():
            assert two.params()[key] == pytest.approx(value, rel=1e-11, abs=1e-15), key
        assert (one.n_loops, one.dipoles_per_loop, one.ring) == (two.n_loops,
                                                                 two.dipoles_per_loop, two.ring)
    np.testing.assert_allclose(back.field(), arr.field(), rtol=1e-10, atol=1e-16)
    # saved again, the file is the same text
    again = tmp_path / "again.toml"
    mc.save_array(back, again)
    assert again.read_text() == path.read_text()


def _one_line(exc: pytest.ExceptionInfo[mc.MagciliaError]) -> str:
    text = str(exc.value)
    assert "\n" not in text
    return text


@pytest.mark.parametrize(
    ("change", "match"),
    [
        # overlapping cilia, named by the file's names
        (('base = ["2.5 mm", "0 mm", "1 mm"]', 'base = ["0.2 mm", "0 mm", "1 mm"]'),
         r"arr\.toml: cilia must be cilia that do not overlap.*'a and b 0\.2 mm apart'"),
        # a sensor inside a cilium
        (('position = ["2.5 mm", "0 mm", "0 mm"]', 'position = ["2.5 mm", "0 mm", "2 mm"]'),
         (r"arr\.toml: sensors must be sensing points outside every cilium \(it is inside "
         r"cilium b at rest\).*sensor 2 \(s2\)")),
        # an unknown preset
        (('preset = "MMC5983MA"', 'preset = "HMC5883L"'),
         r"arr\.toml: sensors\[0\] 's1'\.preset: magnetometer preset must be one of 'MLX90393'"),
        # not a rotation
        (("[0.0, 1.0, 0.0]]", "[0.0, 1.0, 0.5]]"),
         r"arr\.toml: sensors\[1\] 's2'\.rotation must be a 3 × 3 rotation matrix"),
        (("[0.0, 0.0, -1.0], [0.0, 1.0, 0.0]]", "[0.0, 0.0, 1.0], [0.0, 1.0, 0.0]]"),
         r"sensors\[1\] 's2'\.rotation must be .*flip the sign of one column"),
        (('euler = "xyz 0 0 90 deg"', 'euler = "xyz 0 0 90"'),
         r"sensors\[0\] 's1'\.euler must be \"SEQ A B C UNIT\""),
        (('euler = "xyz 0 0 90 deg"', 'euler = "xqz 0 0 90 deg"'),
         r"sensors\[0\] 's1'\.euler must be"),
        # missing units
        (('base = ["2.5 mm", "0 mm", "1 mm"]', 'base = [2.5, 0, 1]'),
         r"arr\.toml: cilia\[1\] 'b'\.base\[0\] must be a length with a unit"),
        (('position = ["0 mm", "0 mm", "0 mm"]', 'position = ["0", "0 mm", "0 mm"]'),
         r"sensors\[0\] 's1'\.position\[0\] must be a length with a unit"),
        (('lsb = "0.0625 mG"', "lsb = 0.0625"), r"sensors\[1\] 's2'\.lsb must be a field"),
        (('rate = "50 Hz"', "rate = 50"), r"sensors\[0\] 's1'\.rate must be a frequency"),
        # duplicate names
        (('name = "b"', 'name = "a"'), r"cilia\[1\]\.name must be a name no other cilium has"),
        (('name = "s2"', 'name = "s1"'), r"sensors\[1\]\.name must be a name no other sensor"),
        # unknown keys, missing figures, bad overrides
        (('tip_radius = "40 um"', 'tip_raduis = "40 um"'),
         r"cilia\[1\] 'b'\.tip_raduis must be name, base or a key of \[cilium\]"),
        (('tip_radius = "40 um"', 'tip_radius = "-40 um"'),
         r"cilia\[1\] 'b'.*tip_radius must be"),
        (('lsb = "0.0625 mG"\n', ""), r"sensors\[1\] 's2': lsb must be given"),
        (('rate = "50 Hz"', 'bits = 12'), r"sensors\[0\] 's1': bits must be one of 16, 18"),
        (('rate = "50 Hz"', 'rate = "51 Hz"'), r"sensors\[0\] 's1': rate must be one of the"),
        (('position = ["0 mm", "0 mm", "0 mm"]\n', ""),
         r"sensors\[0\] 's1'\.position must be three lengths"),
        (('rotation = [[', 'euler = "xyz 0 0 0 deg"\nrotation = [['),
         r"sensors\[1\] 's2'\.euler must be left out when rotation is given"),
    ],
)
def test_bad_input_is_one_line_naming_file_and_entry(tmp_path: Path, change: tuple[str, str],
                                                     match: str) -> None:
    assert change[0] in LISTS
    path = _write(tmp_path, LISTS.replace(change[0], change[1], 1))
    with pytest.raises(mc.MagciliaError, match=match) as exc:
        mc.load_array(path)
    _one_line(exc)


@pytest.mark.parametrize(
    ("text", "match"),
    [
        (HEAD, (r"arr\.toml: \[\[cilia\]\] must be an array file with \[\[cilia\]\] and "
               r"\[\[sensors\]\]")),
        (HEAD + '[array]\nrows = 2\ncols = 2\npitch = "0.2 mm"\nsensor = "MMC5983MA"\n',
         r"arr\.toml: \[array\]: cilia must be cilia that do not overlap"),
        (HEAD + '[array]\nrows = 2\ncols = 2\npitch = "2.5 mm"\n',
         r"array\.sensor must be the part under each cilium"),
        (HEAD + '[array]\nrows = 2\ncols = 0\npitch = "2.5 mm"\nsensor = "MMC5983MA"\n',
         r"array\.cols must be a whole number from 1 to 4096"),
        (HEAD + '[array]\nrows = 2\ncols = 2\npitch = 2.5\nsensor = "MMC5983MA"\n',
         r"array\.pitch must be a length with a unit"),
        (HEAD + '[array]\nrows = 2\ncols = 2\npitch = "2.5 mm"\nsensor = "MLX90393"\n',
         r"array\.sensor: noise must be given for the MLX90393 preset"),
        (HEAD + '[array]\nrows = 2\ncols = 2\npitch = "2.5 mm"\nsensor = "MMC5983MA"\n'
                'spacing = 1\n', r"array\.spacing must be one of rows, cols"),
        (HEAD + '[array]\nrows = 100\ncols = 100\npitch = "2.5 mm"\nsensor = "MMC5983MA"\n',
         r"at most 4096 cilia \(MAX_ARRAY_ITEMS\)"),
        (LISTS + '[array]\nrows = 2\ncols = 2\npitch = "2.5 mm"\nsensor = "MMC5983MA"\n',
         r"either the \[array\] shorthand or \[\[cilia\]\] and \[\[sensors\]\] lists"),
        (HEAD + '[array]\nrows = 2\ncols = 2\npitch = "2.5 mm"\n'
                'sensor = { preset = "MMC5983MA", position = ["0 mm", "0 mm", "0 mm"] }\n',
         r"array\.sensor\.position must be left out"),
        ("[cilium]\nheight = 3\n[[cilia]]\nbase = []\n", r"cilium\.height must be a length"),
    ],
)
def test_bad_files(tmp_path: Path, text: str, match: str) -> None:
    with pytest.raises(mc.MagciliaError, match=match) as exc:
        mc.load_array(_write(tmp_path, text))
    _one_line(exc)


def test_mlx90393_with_noise_and_a_grid_sensor_table(tmp_path: Path) -> None:
    text = HEAD + ('[array]\nrows = 2\ncols = 3\npitch = ["2.5 mm", "3 mm"]\n'
                   'centre = ["1 mm", "2 mm", "1 mm"]\ndepth = "1.2 mm"\n'
                   'sensor = { preset = "MLX90393", gain_sel = 5, noise = ["0.5 uT", "0.5 uT", '
                   '"0.8 uT"] }\n')
    arr = mc.load_array(_write(tmp_path, text))
    assert len(arr) == 6 and arr.names[-1] == "r2c3"
    ref = Magnetometer.mlx90393(gain_sel=5, noise=(0.5e-6, 0.5e-6, 0.8e-6))
    assert arr.sensors[0].resolution == ref.resolution and arr.sensors[0].noise == ref.noise
    np.testing.assert_allclose(arr.bases.mean(axis=0), [1e-3, 2e-3, 1e-3], atol=1e-15)
    np.testing.assert_allclose(arr.sensor_positions[:, 2], -0.2e-3, atol=1e-15)
    np.testing.assert_allclose(np.ptp(arr.bases[:, :2], axis=0), [5e-3, 3e-3], atol=1e-15)


def test_load_setup_ignores_array_and_actuation_tables(tmp_path: Path) -> None:
    text = (EXAMPLES / "force-sensor.toml").read_text() + (
        '\n[actuation]\nfield = ["1 mT", "0 mT", "0 mT"]\n'
        '[array]\nrows = 2\ncols = 2\npitch = "2.5 mm"\nsensor = "MMC5983MA"\n')
    with_tables = mc.load_setup(_write(tmp_path, text))
    plain = mc.load_setup(EXAMPLES / "force-sensor.toml")
    assert with_tables.params() == plain.params()


def test_read_loads(tmp_path: Path) -> None:
    names = ("a", "b", "c")
    path = _write(tmp_path, "Fx_mN,Fy_uN\n0.01,5\n0,0\n-0.002,-1\n", "loads.csv")
    np.testing.assert_allclose(read_loads(path, names),
                               [[[1e-5, 5e-6], [0, 0], [-2e-6, -1e-6]]], rtol=1e-12)
    path = _write(tmp_path, "set,cilium,Fx_N,Fy_N\n1,b,1e-5,0\n2,c,0,-2e-5\n2,a,3e-6,0\n",
                  "named.csv")
    np.testing.assert_allclose(read_loads(path, names),
                               [[[0, 0], [1e-5, 0], [0, 0]], [[3e-6, 0], [0, 0], [0, -2e-5]]])
    for text, match in [("Fx,Fy\n1,2\n", r"must be a CSV with columns Fx_<unit>"),
                        ("Fx_mN,Fy_kg\n1,2\n", r"column Fy_kg must be"),
                        ("Fx_mN,Fy_mN\n1,2\n", r"set 0 must be 3 rows"),
                        ("cilium,Fx_mN,Fy_mN\nz,1,2\n", r"line 2: cilium must be a cilium of"),
                        ("cilium,Fx_mN,Fy_mN\na,1,2\na,1,2\n", r"one row per cilium and set"),
                        ("Fx_mN,Fy_mN\n1,x\n", r"line 2 must be numbers"),
                        ("Fx_mN,Fy_mN\n", r"must be at least one row")]:
        with pytest.raises(mc.MagciliaError, match=match) as exc:
            read_loads(_write(tmp_path, text, "bad.csv"), names)
        _one_line(exc)


def test_mixed_cilia_round_trip_with_a_measured_profile(tmp_path: Path) -> None:
    text = LISTS.replace('tip_radius = "40 um"\n', 'profile_s = ["0 mm", "1 mm", "3 mm"]\n'
                         'profile_r = ["0.18 mm", "0.12 mm", "0.05 mm"]\n')
    arr = mc.load_array(_write(tmp_path, text))
    assert arr.cilia[0].cilium.profile is None and arr.cilia[1].cilium.profile is not None
    assert arr.cilia[1].cilium.height == pytest.approx(3e-3)
    mc.save_array(arr, tmp_path / "saved.toml")
    back = mc.load_array(tmp_path / "saved.toml")
    assert back.cilia[0].cilium.profile is None
    np.testing.assert_allclose(back.cilia[1].spec.radii, arr.cilia[1].spec.radii, rtol=1e-11)
    np.testing.assert_allclose(back.field(), arr.field(), rtol=1e-10, atol=1e-16)


@pytest.mark.parametrize(
    ("change", "match"),
    [
        (('name = "a"', 'name = "a\\u001b[31m"'),
         r"cilia\[0\]\.name must be a name of 1 to 64 printable characters; got 'a\\x1b\[31m'"),
        (('name = "s1"', f'name = "{"s" * 65}"'), r"sensors\[0\]\.name must be a name of 1 to 64"),
        (('position = ["2.5 mm", "0 mm", "0 mm"]', 'position = ["1e300 mm", "0 mm", "0 mm"]'),
         r"sensors\[1\] 's2'\.position must be coordinates within ±1 m"),
        (('base = ["0 mm", "0 mm", "1 mm"]', 'base = ["0 mm", "0 mm", "2 m"]'),
         r"cilia\[0\] 'a'\.base must be coordinates within ±1 m"),
        (('euler = "xyz 0 0 90 deg"', 'euler = "xyz 0 0 1e400 deg"'), r"\.euler must be"),
        (('euler = "xyz 0 0 90 deg"', f'euler = "{"x" * 300}"'), r"\.euler must be"),
    ],
)
def test_hostile_values_are_refused_and_escaped(tmp_path: Path, change: tuple[str, str],
                                                match: str) -> None:
    assert change[0] in LISTS
    with pytest.raises(mc.MagciliaError, match=match) as exc:
        mc.load_array(_write(tmp_path, LISTS.replace(change[0], change[1], 1)))
    assert len(_one_line(exc)) < 600


def test_too_many_cilia_are_refused_before_building(tmp_path: Path) -> None:
    text = HEAD + '[[cilia]]\nbase = ["0 mm", "0 mm", "1 mm"]\n' * 5000
    with pytest.raises(mc.MagciliaError, match=r"\[\[cilia\]\] must be at most 4096 "
                                               r"\(MAX_ARRAY_ITEMS\); got '5000 entries'"):
        mc.load_array(_write(tmp_path, text))
