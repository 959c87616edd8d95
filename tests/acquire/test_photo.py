"""Tilt angles from photos: rendered photos of a holder with a known tilt, the camera's artefacts
(blur, noise, JPEG, uneven light, a flash reflection), EXIF orientation, manual points, the CLI."""

from __future__ import annotations

import io
import json
import math
import struct
import subprocess
import sys
import zlib
from pathlib import Path
from typing import Any

import numpy as np
import pytest
from PIL import Image
from scipy import ndimage

from magcilia._errors import MagciliaError, MissingDependencyError
from magcilia.acquire.photo import (
    DECODE_SIDE,
    MAX_PIXELS,
    TiltMeasurement,
    load_photo,
    measure_tilt,
    pick_points,
    read_photo,
)
from magcilia.cli import main

SIZE = (480, 640)  # h, w


def scene(angle_deg: float, *, case_deg: float | None = None, flash: float | None = -1.0,
          seed: int = 0, blur: float = 1.5, noise: float = 0.02, tape: float = 12.0,
          holder: float = 36.0, length: float = 330.0) -> np.ndarray:
    """An 8-bit grey photo (h, w) of a dark holder with a bright tape, tilted by ``angle_deg``
    about its base (top to the right > 0): textured background, light gradient and vignetting,
    optionally the case (below an edge turned by ``case_deg``, its normal leaning right > 0) and a
    flash reflection (a bright round blob; ``flash`` is its place along the tape as a fraction of
    the holder's length, or < 0 for beside the holder, None for none); blur and noise."""
    rng = np.random.default_rng(seed)
    h, w = SIZE
    y, x = np.mgrid[0:h, 0:w].astype(np.float64)
    texture = ndimage.gaussian_filter(rng.normal(0.0, 1.0, SIZE), 6.0)
    texture /= texture.std()
    img = 0.55 + 0.08 * texture
    base = np.array([w / 2 + rng.uniform(-20.0, 20.0), 0.86 * h])
    if case_deg is not None:
        phi = math.radians(case_deg)
        below = -(x - base[0]) * math.sin(phi) + (y - base[1]) * math.cos(phi)
        img = np.where(below > 0, 0.25 + 0.03 * texture, img)
    th = math.radians(angle_deg)
    up, across = np.array([math.sin(th), -math.cos(th)]), np.array([math.cos(th), math.sin(th)])
    u = (x - base[0]) * up[0] + (y - base[1]) * up[1]
    v = (x - base[0]) * across[0] + (y - base[1]) * across[1]

    def cover(half_width: float, u0: float, u1: float) -> np.ndarray:  # anti-aliased bar
        outside = np.maximum(np.abs(v) - half_width, np.maximum(u0 - u, u - u1))
        return np.clip(0.5 - outside, 0.0, 1.0)

    a = cover(holder / 2, -10.0, length)
    img = img * (1 - a) + 0.12 * a
    a = cover(tape / 2, 10.0, length - 15.0)
    img = img * (1 - a) + (0.85 + 0.05 * np.sin(u / 23.0)) * a
    r2 = ((x - w / 2) ** 2 + (y - h / 2) ** 2) / (0.5 * w) ** 2
    img *= (0.75 + 0.4 * x / w) * (1 - 0.35 * r2)  # light gradient and vignetting
    if flash is not None:
        side = -1.0 if angle_deg > 0 else 1.0
        spot = (base + flash * length * up if flash >= 0
                else base + np.array([side * 0.25 * w, -0.45 * h]))
        img += 0.9 * np.exp(-((x - spot[0]) ** 2 + (y - spot[1]) ** 2) / (2 * 14.0**2))
    img = ndimage.gaussian_filter(img, blur) + rng.normal(0.0, noise, SIZE)
    return np.asarray(np.clip(img, 0.0, 1.0) * 255 + 0.5, dtype=np.uint8)


def jpeg_bytes(u8: np.ndarray, quality: int = 85, orientation: int | None = None) -> bytes:
    buf = io.BytesIO()
    exif = Image.Exif()
    if orientation is not None:
        exif[0x0112] = orientation
    Image.fromarray(u8).save(buf, format="JPEG", quality=quality, exif=exif)
    return buf.getvalue()


def photo(angle_deg: float, **kw: Any) -> np.ndarray:
    """``scene`` through a JPEG round trip at quality 85, as grey levels in [0, 1]."""
    data = jpeg_bytes(scene(angle_deg, **kw))
    return np.asarray(Image.open(io.BytesIO(data)).convert("L"), dtype=np.float64) / 255.0


def write_photo(path: Path, angle_deg: float, **kw: Any) -> Path:
    path.write_bytes(jpeg_bytes(scene(angle_deg, **kw)))
    return path


def test_accuracy_over_angles_with_camera_artefacts() -> None:
    angles = np.linspace(-45.0, 45.0, 31)
    flashes = (-1.0, 0.3, 0.6, 0.95, None)  # beside the holder, on the tape, at its end, none
    errors = np.array([
        math.degrees(measure_tilt(photo(a, seed=i, flash=flashes[i % 5])).angle) - a
        for i, a in enumerate(angles)
    ])
    rms, worst = float(np.sqrt(np.mean(errors**2))), int(np.argmax(np.abs(errors)))
    message = (f"RMS {rms:.3f} deg over {angles.size} angles; worst {errors[worst]:+.3f} deg "
               f"at {angles[worst]:+.1f} deg")
    assert rms <= 0.2, message
    assert abs(errors[worst]) <= 0.5, message


def test_sign_convention_leaning_right_is_positive() -> None:
    # a plain bright bar whose top end (y = 0) is to the right of its lower end
    y, x = np.mgrid[0:200, 0:200].astype(np.float64)
    bar = np.where((np.abs((x - 100) + 0.3 * (y - 100)) < 4) & (np.abs(y - 100) < 80), 0.9, 0.2)
    m = measure_tilt(bar)
    assert m.angle == pytest.approx(math.atan(0.3), abs=math.radians(0.2))
    assert m.line[0][1] > m.line[1][1] and m.line[1][0] > m.line[0][0]  # lower end first
    assert measure_tilt(bar[:, ::-1]).angle == pytest.approx(-m.angle, abs=1e-9)
    assert measure_tilt(photo(20.0)).angle > 0 > measure_tilt(photo(-20.0)).angle


@pytest.mark.parametrize(("tilt", "case"), [(12.0, 3.0), (-30.0, -2.0), (40.0, -4.5)])
def test_reference_detect_measures_from_the_case_edge(tilt: float, case: float) -> None:
    m = measure_tilt(photo(tilt, case_deg=case, seed=3), reference="detect")
    assert m.reference == "detected" and m.reference_line is not None
    assert math.degrees(m.reference_angle) == pytest.approx(case, abs=0.2)
    assert m.angle_deg == pytest.approx(tilt - case, abs=0.2)


def test_exif_orientation_is_respected(tmp_path: Path) -> None:
    upright = scene(25.0, seed=4)
    # stored turned a quarter turn counter-clockwise; orientation 6 says "turn clockwise to show"
    path = tmp_path / "turned.jpg"
    path.write_bytes(jpeg_bytes(np.ascontiguousarray(np.rot90(upright)), orientation=6))
    image = read_photo(path)
    assert image.shape == upright.shape and 0.0 <= image.min() <= image.max() <= 1.0
    m = measure_tilt(path)
    assert m.path == str(path) and m.angle_deg == pytest.approx(25.0, abs=0.2)


def test_manual_points_and_a_given_reference() -> None:
    img = photo(10.0)
    m = measure_tilt(img, line_points=[(300.0, 100.0), (200.0, 400.0)])
    assert m.method == "manual" and math.isnan(m.residual_rms)
    assert m.angle == pytest.approx(math.atan2(100.0, 300.0))
    assert m.line == ((200.0, 400.0), (300.0, 100.0))
    g = measure_tilt(img, line_points=[(300.0, 100.0), (200.0, 400.0)],
                     reference_points=[(100.0, 400.0), (110.0, 100.0)])
    assert g.reference == "given"
    assert g.angle == pytest.approx(math.atan2(100.0, 300.0) - math.atan2(10.0, 300.0))
    auto = measure_tilt(img, reference_points=[(100.0, 400.0), (110.0, 100.0)])
    assert auto.angle_deg == pytest.approx(10.0 - math.degrees(math.atan2(10.0, 300.0)), abs=0.2)


@pytest.mark.parametrize(
    ("kwargs", "match"),
    [
        ({"line_points": [(1.0, 2.0), (1.0, 2.0)]}, "two distinct"),
        ({"line_points": [(1.0, 2.0, 3.0)]}, "two distinct"),
        ({"line_points": [(10.0, 20.0), (900.0, 20.0)]}, "inside the 640 x 480"),
        ({"reference": "case"}, "reference must be one of"),
        ({"reference": "detect", "reference_points": [(1.0, 2.0), (3.0, 4.0)]}, "'vertical'"),
    ],
)
def test_bad_arguments_are_one_line_errors(kwargs: dict, match: str) -> None:
    with pytest.raises(MagciliaError, match=match) as info:
        measure_tilt(np.zeros(SIZE), **kwargs)
    assert "\n" not in str(info.value)


def test_result_round_trip_and_report() -> None:
    m = measure_tilt(photo(-7.5, case_deg=1.0), reference="detect")
    doc = json.loads(json.dumps(m.to_dict()))
    assert doc["angle_deg"] == pytest.approx(math.degrees(doc["angle_rad"]))
    assert TiltMeasurement.from_dict(doc) == m
    assert "\n" not in m.report() and "deg" in m.report()
    with pytest.raises(MagciliaError, match=r"TiltMeasurement\.to_dict"):
        TiltMeasurement.from_dict({"path": "x"})


def test_cli_json_text_and_annotate(tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    a = write_photo(tmp_path / "a.jpg", 15.0, seed=1)
    b = write_photo(tmp_path / "b.jpg", -22.0, seed=2, case_deg=2.0)
    assert main(["angle", str(a), str(b), "--json"]) == 0
    doc = json.loads(capsys.readouterr().out)
    assert [d["path"] for d in doc] == [str(a), str(b)]
    assert [d["angle_deg"] for d in doc] == pytest.approx([15.0, -22.0], abs=0.2)
    figs = tmp_path / "figs"
    assert main(["angle", str(b), "--reference", "detect", "--annotate", str(figs)]) == 0
    out = capsys.readouterr().out.strip()
    assert out.startswith(f"{b}: tilt ") and "case edge" in out
    assert float(out.split("tilt ")[1].split()[0]) == pytest.approx(-24.0, abs=0.2)
    assert (figs / "b_angle.png").read_bytes()[:8] == b"\x89PNG\r\n\x1a\n"
    assert main(["angle", str(a), "--line", "320,400,420,100", "--json"]) == 0
    manual = json.loads(capsys.readouterr().out)[0]
    assert manual["method"] == "manual"
    assert manual["angle_deg"] == pytest.approx(math.degrees(math.atan2(100, 300)))
    assert not list(tmp_path.glob(".*")) and not list(figs.glob(".*"))


def _bad_inputs(tmp: Path) -> list[tuple[list[str], str]]:
    text = tmp / "notes.jpg"
    text.write_text("not a photo\n")
    cut = tmp / "cut.jpg"
    cut.write_bytes(jpeg_bytes(scene(10.0))[:3000])
    blank = tmp / "blank.jpg"
    blank.write_bytes(jpeg_bytes(scene(0.0, length=0.0, case_deg=2.0)))
    return [
        ([str(tmp / "missing.jpg")], "does not exist"),
        ([str(text)], "is not an image"),
        ([str(cut)], "truncated"),
        ([str(blank)], "no tape line found"),
        ([str(blank), str(text), "--line", "1,2,3,4"], "one PHOTO"),
        ([str(blank), "--line", "1,2,3"], "--line must be X0,Y0,X1,Y1"),
        ([str(blank), "--manual"], "needs a display"),
    ]


def test_cli_bad_input_is_a_one_line_error(tmp_path: Path,
                                           capsys: pytest.CaptureFixture[str]) -> None:
    for args, match in _bad_inputs(tmp_path):
        assert main(["angle", *args]) == 2, args
        err = capsys.readouterr().err
        assert err.startswith("magcilia: error: ") and match in err, err
        assert err.count("\n") == 1, err
    with pytest.raises(MagciliaError, match="--manual"):
        measure_tilt(np.full(SIZE, 0.5))


def test_a_missing_scikit_image_names_the_extra(monkeypatch: pytest.MonkeyPatch) -> None:
    monkeypatch.setitem(sys.modules, "skimage.measure", None)
    with pytest.raises(MissingDependencyError, match=r"pip install 'magcilia\[photo\]'"):
        measure_tilt(np.zeros(SIZE))


def test_pick_points_needs_a_display() -> None:
    with pytest.raises(MagciliaError, match="--line X0,Y0,X1,Y1"):
        pick_points(np.zeros((20, 20)), 2, "click")


# -- large photos: decoded downscaled, capped --------------------------------------------------

def png_chunk(kind: bytes, data: bytes) -> bytes:
    return struct.pack(">I", len(data)) + kind + data + struct.pack(">I", zlib.crc32(kind + data))


def tape_png(path: Path, w: int, h: int, angle_deg: float) -> Path:
    """An 8-bit grey PNG of w x h px, streamed row by row (no w x h array): background 70, a
    bright tape (230, w/150 px wide) through the centre over 80 % of the height, its top leaning
    right by ``angle_deg``."""
    width = max(8, w // 150)
    slope = math.tan(math.radians(angle_deg))
    comp = zlib.compressobj(1)
    blank = b"\x00" + bytes([70]) * w
    bright = bytes([230]) * width
    parts = []
    for y in range(h):
        row = blank
        if abs(y - h / 2) < 0.4 * h:
            x0 = round(w / 2 + (h / 2 - y) * slope - width / 2)
            row = blank[:1 + x0] + bright + blank[1 + x0 + width:]
        parts.append(comp.compress(row))
    parts.append(comp.flush())
    path.write_bytes(b"\x89PNG\r\n\x1a\n"
                     + png_chunk(b"IHDR", struct.pack(">IIBBBBB", w, h, 8, 0, 0, 0, 0))
                     + png_chunk(b"IDAT", b"".join(parts)) + png_chunk(b"IEND", b""))
    return path


def header_only_png(path: Path, w: int, h: int) -> Path:
    """A PNG that claims w x h px and holds almost nothing (never decoded if refused first)."""
    path.write_bytes(b"\x89PNG\r\n\x1a\n"
                     + png_chunk(b"IHDR", struct.pack(">IIBBBBB", w, h, 8, 0, 0, 0, 0))
                     + png_chunk(b"IDAT", zlib.compress(b"\x00" * 64)) + png_chunk(b"IEND", b""))
    return path


@pytest.mark.parametrize("kind", ["jpeg", "png", "jpeg-turned"])
def test_a_large_photo_is_measured_downscaled_in_its_own_pixels(tmp_path: Path,
                                                                kind: str) -> None:
    u8 = scene(17.0, case_deg=2.0, seed=5)
    path = tmp_path / ("p.png" if kind == "png" else "p.jpg")
    if kind == "png":
        Image.fromarray(u8).save(path)
    elif kind == "jpeg":
        path.write_bytes(jpeg_bytes(u8))
    else:  # stored a quarter turn counter-clockwise, EXIF 6 turns it back
        path.write_bytes(jpeg_bytes(np.ascontiguousarray(np.rot90(u8)), orientation=6))
    full = measure_tilt(load_photo(path, max_side=None), reference="detect")
    small = load_photo(path, max_side=320)
    assert small.scale == 2 and small.size == (640, 480) == full.image_size
    assert small.image.shape == (240, 320)
    m = measure_tilt(small, reference="detect")
    assert m.image_size == (640, 480)
    assert m.angle_deg == pytest.approx(17.0 - 2.0, abs=0.2)
    assert m.angle_deg == pytest.approx(full.angle_deg, abs=0.2)
    # the line and the case edge in px of the photo, where the full-size measurement has them
    assert np.allclose(m.line, full.line, atol=4.0)
    assert m.reference_line is not None and full.reference_line is not None
    assert np.allclose(m.reference_line, full.reference_line, atol=12.0)
    manual = measure_tilt(small, line_points=[(300.0, 100.0), (200.0, 400.0)])
    assert manual.angle == pytest.approx(math.atan2(100.0, 300.0))  # points: the photo's px


def test_decoding_is_bounded_by_decode_side(tmp_path: Path) -> None:
    path = tape_png(tmp_path / "wide.png", 9000, 300, 0.0)
    decoded = load_photo(path)
    assert decoded.scale == 3 and decoded.image.shape == (100, 3000)
    assert max(decoded.image.shape) <= DECODE_SIDE and decoded.size == (9000, 300)


@pytest.mark.parametrize(("w", "h", "shown"), [(13000, 12800, "13000 x 12800 = 166,400,000"),
                                               (20000, 10000, "200,000,000")])
def test_a_photo_beyond_max_pixels_is_a_one_line_error(tmp_path: Path, w: int, h: int,
                                                       shown: str,
                                                       capsys: pytest.CaptureFixture[str]) -> None:
    path = header_only_png(tmp_path / "huge.png", w, h)
    assert w * h > MAX_PIXELS
    assert main(["angle", str(path)]) == 2
    err = capsys.readouterr().err
    assert err.count("\n") == 1
    assert err.startswith(f"magcilia: error: photo '{path}' has {shown} pixels, more than the "
                          f"{MAX_PIXELS:,} that magcilia measures (MAX_PIXELS")
    assert err.rstrip().endswith("scale it down or crop it to the holder")


AT_THE_LIMIT = """
import resource, sys
from magcilia.acquire.photo import load_photo, measure_tilt
base = resource.getrusage(resource.RUSAGE_SELF).ru_maxrss
decoded = load_photo(sys.argv[1])
m = measure_tilt(decoded)
peak = resource.getrusage(resource.RUSAGE_SELF).ru_maxrss
print(m.angle_deg, decoded.image.size, (peak - base) * (1 if sys.platform == "darwin" else 1024))
"""


@pytest.mark.skipif(sys.platform == "win32", reason="resource.getrusage")
def test_a_photo_at_max_pixels_costs_what_its_decoding_does(tmp_path: Path) -> None:
    """At the limit (a 16000 x 10000 grey PNG, 160 MP) the tape is measured on at most
    DECODE_SIDE² pixels and the process grows by about two bytes per pixel of the photo (Pillow's
    decoded image, freed once downscaled), not the ~18 of a float64 copy and its work arrays
    (2.8 GB before the limit existed)."""
    w, h = 16000, 10000
    assert w * h == MAX_PIXELS
    path = tape_png(tmp_path / "limit.png", w, h, 12.5)
    child = subprocess.run([sys.executable, "-c", AT_THE_LIMIT, str(path)], capture_output=True,
                           text=True, timeout=300, check=False)
    assert child.returncode == 0, child.stderr
    angle, pixels, grown = child.stdout.split()
    assert float(angle) == pytest.approx(12.5, abs=0.01)
    assert int(pixels) <= DECODE_SIDE**2
    assert int(grown) < 2.5 * MAX_PIXELS  # bytes; measured ~2.0 per pixel
