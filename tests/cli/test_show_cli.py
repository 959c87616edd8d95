"""``magcilia show`` and ``Setup.show()``: the 3-D scene (bodies, sensors, field slice), the files
it writes, and its one-line errors."""

from __future__ import annotations

import sys
from pathlib import Path

import numpy as np
import pytest

import magcilia as mc
from magcilia.cli import main
from magcilia.device.scene import FIELD_LABEL, scene

PNG = b"\x89PNG\r\n\x1a\n"


def _run(capsys: pytest.CaptureFixture[str], argv: list[str]) -> tuple[int, str, str]:
    code = main(argv)
    captured = capsys.readouterr()
    return code, captured.out, captured.err


def test_the_scene_is_the_exact_body_in_its_pose() -> None:
    """The drawn body is exact_field's stack: its field at the sensing element is the exact
    field of the same pose (rigid tilt and a bent shape); the sensor sits at the origin."""
    setup = mc.Setup.paper(tip_radius=5e-5)
    bent = mc.bend(setup, force=2e-5)
    for pose, as_many in ((0.4, [0.4]), (bent, bent)):
        collection = scene(setup, pose, n_slices=30)
        body, sensor, field = collection.children
        assert len(body.sources) == 30
        assert np.allclose(body.getB((0.0, 0.0, 0.0)),
                           mc.exact_field(setup, as_many, 30)[0], rtol=1e-9, atol=0.0)
        assert np.allclose(sensor.position, 0.0)
        assert field.style.label == FIELD_LABEL and field.pixel.shape == (13, 13, 3)
        # the slice runs through the base along x, from the board up past the tip
        assert np.allclose(field.pixel[..., 1], setup.spec.base_centre[1])
        assert field.pixel[..., 2].max() > setup.spec.base_centre[2] + setup.cilium.height
    assert len(scene(setup, field=False).children) == 2


def test_the_array_scene_has_every_cilium_and_sensor() -> None:
    part = mc.Magnetometer(field_range=5e-3, resolution=1.5e-7, noise=3e-7, rate=100.0)
    array = mc.CiliaArray.grid(mc.Setup.paper(tip_radius=5e-5, position=(0, 0, 0)), 2, 2,
                               pitch=4e-3, sensor=part)
    collection = scene(array, n_slices=8, field=False)
    assert len(collection.children) == len(array) + array.n_sensors
    assert [c.style.label for c in collection.children[:4]] == [f"cilium {n}"
                                                                for n in array.names]
    with pytest.raises(mc.MagciliaError, match="poses"):
        scene(array, [0.1])


def test_setup_show_draws_on_a_canvas() -> None:
    import matplotlib.pyplot as plt

    fig = plt.figure()
    try:
        ax = fig.add_subplot(projection="3d")
        mc.Setup.paper().show(0.3, canvas=ax, backend="matplotlib")
        assert ax.collections  # the body's faces and the sensor
    finally:
        plt.close(fig)


def test_png_and_html_are_written(capsys: pytest.CaptureFixture[str], tmp_path: Path) -> None:
    pytest.importorskip("plotly", reason="the show extra: pip install 'magcilia[show]'")
    png, html = tmp_path / "paper.png", tmp_path / "paper.html"
    code, out, err = _run(capsys, ["show", "--setup", "paper", "--out", str(png), "--tilt", "30"])
    assert code == 0 and not err and out.strip() == f"wrote {png}"
    assert png.read_bytes()[:8] == PNG and png.stat().st_size > 10_000
    code, _, err = _run(capsys, ["show", "--setup", "force-sensor", "--out", str(html)])
    assert code == 0 and not err
    page = html.read_text(encoding="utf-8")
    assert page.count('"type":"mesh3d"') >= 2  # the body and the sensor
    assert '"name":"cilium (exact body)' in page and '"name":"HMC1021Z' in page
    assert "field B on the x" in page
    assert 'src="https://cdn.plot.ly' not in page and len(page) > 1e6  # plotly.js inline
    assert not [p for p in tmp_path.iterdir() if p.name not in ("paper.png", "paper.html")]


def test_an_array_is_drawn(capsys: pytest.CaptureFixture[str], tmp_path: Path) -> None:
    out = tmp_path / "array.png"
    code, _, err = _run(capsys, ["show", "--setup", "array", "--out", str(out), "--no-field"])
    assert code == 0 and not err and out.read_bytes()[:8] == PNG


def test_bad_input_is_one_line_and_writes_nothing(capsys: pytest.CaptureFixture[str],
                                                  tmp_path: Path) -> None:
    bad = tmp_path / "paper.txt"
    code, out, err = _run(capsys, ["show", "--setup", "paper", "--out", str(bad)])
    assert code == 2 and not out and not bad.exists()
    assert err.startswith("magcilia: error: --out must end in .png") and err.count("\n") == 1
    # an existing file is left byte-identical without --force, replaced with it
    old = tmp_path / "old.png"
    old.write_bytes(b"keep me")
    code, _, err = _run(capsys, ["show", "--setup", "paper", "--out", str(old)])
    assert code == 2 and old.read_bytes() == b"keep me"
    assert err == f"magcilia: error: {old} exists; pass --force to replace it, or choose " \
                  "another --out\n"
    code, _, _ = _run(capsys, ["show", "--setup", "paper", "--out", str(old), "--force",
                               "--no-field"])
    assert code == 0 and old.read_bytes()[:8] == PNG
    code, _, err = _run(capsys, ["show", "--setup", "array", "--out", str(tmp_path / "a.png"),
                                 "--tilt", "10"])
    assert code == 2 and "--tilt applies to one cilium" in err
    code, _, err = _run(capsys, ["show", "--setup", "papr", "--out", str(tmp_path / "b.png")])
    assert code == 2 and "unknown preset 'papr'" in err and "paper" in err
    code, _, err = _run(capsys, ["show", "--setup", "paper", "--out", str(tmp_path / "c.png"),
                                 "--tilt", "inf"])
    assert code == 2 and "--tilt" in err and err.count("\n") == 1
    assert sorted(p.name for p in tmp_path.iterdir()) == ["old.png"]


def test_the_positional_setup_of_the_issue_works(capsys: pytest.CaptureFixture[str],
                                                 tmp_path: Path) -> None:
    """`magcilia show SETUP --out FILE` (issue 30's spelling) draws, with the one line that
    names --setup, as every command's positional SETUP does; --tilt takes units."""
    out = tmp_path / "p.png"
    code, _, err = _run(capsys, ["show", "paper", "--out", str(out), "--tilt", "0.5rad",
                                 "--no-field"])
    assert code == 0 and out.read_bytes()[:8] == PNG
    assert "--setup" in err and err.count("\n") == 1


def test_html_without_plotly_names_the_extra(capsys: pytest.CaptureFixture[str],
                                             tmp_path: Path,
                                             monkeypatch: pytest.MonkeyPatch) -> None:
    monkeypatch.setitem(sys.modules, "plotly", None)  # import plotly raises ImportError
    out = tmp_path / "view.html"
    code, _, err = _run(capsys, ["show", "--setup", "paper", "--out", str(out)])
    assert code == 2 and not out.exists()
    assert "pip install 'magcilia[show]'" in err and "plotly" in err and err.count("\n") == 1
