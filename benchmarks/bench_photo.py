"""Tilt angles from photos: speed on a 20-megapixel photo and accuracy over many rendered angles.

Measures, in one run and on one thread:
  * ``measure_tilt`` on a rendered 5472 x 3648 (20 MP) JPEG photo of the holder (textured
    background, light gradient and vignetting, a flash reflection, the case's top edge, blur,
    noise, JPEG quality 85): median time with the image vertical and with the detected case edge
    as reference [target <= 0.5 s], its error, and ``read_photo``'s time for the file; and from
    the file itself (decoded downscaled to at most ``DECODE_SIDE`` px a side), time and error;
  * the anchor: the plain scikit-image recipe on the full-resolution image (Otsu's threshold,
    connected components, the orientation of the most elongated region's moments), time, error
    and the ratio;
  * accuracy over many rendered angles from -45 to +45 degrees at 1200 x 800 px with the same
    artefacts (and the flash on the tape in a third of them): RMS and worst error, in degrees,
    from the vertical and from the detected case edge.

Run: python benchmarks/bench_photo.py [--quick]
"""

from __future__ import annotations

import os

for _var in ("OMP_NUM_THREADS", "OPENBLAS_NUM_THREADS", "MKL_NUM_THREADS", "NUMBA_NUM_THREADS"):
    os.environ[_var] = "1"  # single thread, before NumPy loads BLAS

import argparse
import math
import tempfile
import time
from collections.abc import Callable
from pathlib import Path

import numpy as np
from PIL import Image
from scipy import ndimage

from magcilia.acquire.photo import load_photo, measure_tilt, read_photo


def render(angle_deg: float, case_deg: float, size: tuple[int, int], *, flash: float = -1.0,
           seed: int = 0, noise: float = 0.02) -> np.ndarray:
    """An 8-bit grey photo (h, w) of the holder tilted by ``angle_deg`` (top to the right > 0)
    standing on the case, whose top edge is turned by ``case_deg`` (its normal leaning right >
    0). Lengths scale with the width; blur comes from soft edges (no full-size filtering), the
    texture from smoothed noise on a coarse grid. ``flash``: place of the reflection along the
    holder (fraction of its length), or < 0 for beside it."""
    rng = np.random.default_rng(seed)
    h, w = size
    px = w / 640.0  # one pixel of the 640-px-wide design
    y = np.arange(h, dtype=np.float32)[:, None]
    x = np.arange(w, dtype=np.float32)[None, :]
    coarse = ndimage.gaussian_filter(rng.normal(0.0, 1.0, (h // 8 + 2, w // 8 + 2)), 6.0 * px / 8)
    texture = ndimage.zoom(coarse / coarse.std(), 8, order=1)[:h, :w].astype(np.float32)
    base = (w / 2 + rng.uniform(-20.0, 20.0) * px, 0.86 * h)
    phi, th = math.radians(case_deg), math.radians(angle_deg)
    soft = 1.5 * px  # edge blur, px

    def ramp(dist: np.ndarray) -> np.ndarray:  # 1 inside (dist < 0), 0 outside, soft edge
        return np.clip(0.5 - dist / (2 * soft), 0.0, 1.0)

    below = -(x - base[0]) * math.sin(phi) + (y - base[1]) * math.cos(phi)
    case = ramp(-below)
    img = (0.55 + 0.08 * texture) * (1 - case) + (0.25 + 0.03 * texture) * case
    u = (x - base[0]) * math.sin(th) - (y - base[1]) * math.cos(th)
    v = (x - base[0]) * math.cos(th) + (y - base[1]) * math.sin(th)
    length = 330.0 * px
    for half, u0, u1, level in ((18.0 * px, -10.0 * px, length, 0.12),
                                (6.0 * px, 10.0 * px, length - 15.0 * px, 0.85)):
        a = ramp(np.maximum(np.abs(v) - half, np.maximum(u0 - u, u - u1)))
        img = img * (1 - a) + level * a
    r2 = ((x - w / 2) ** 2 + (y - h / 2) ** 2) / (0.5 * w) ** 2
    img *= (0.75 + 0.4 * x / w) * (1 - 0.35 * r2)
    side = -1.0 if angle_deg > 0 else 1.0
    spot = ((base[0] + flash * length * math.sin(th), base[1] - flash * length * math.cos(th))
            if flash >= 0 else (base[0] + side * 0.25 * w, base[1] - 0.45 * h))
    img += 0.9 * np.exp(-((x - spot[0]) ** 2 + (y - spot[1]) ** 2) / (2 * (14.0 * px) ** 2))
    img += rng.normal(0.0, noise, size).astype(np.float32)
    return np.asarray(np.clip(img, 0.0, 1.0) * 255 + 0.5, dtype=np.uint8)


def save_jpeg(u8: np.ndarray, path: Path) -> Path:
    Image.fromarray(u8).save(path, quality=85)
    return path


def median_time(fn: Callable[[], object], repeat: int) -> float:
    times = []
    for _ in range(repeat):
        t0 = time.perf_counter()
        fn()
        times.append(time.perf_counter() - t0)
    return float(np.median(times))


def skimage_anchor(image: np.ndarray) -> tuple[float, float]:
    """Time and angle (deg from vertical) of the plain recipe on the full image."""
    from skimage import filters, measure

    t0 = time.perf_counter()
    labels = measure.label(image > filters.threshold_otsu(image))
    best = max(measure.regionprops(labels),
               key=lambda r: r.axis_major_length / max(r.axis_minor_length, 1.0)
               if r.area > 1000 else 0.0)
    # regionprops: orientation is the angle between the rows axis and the major axis
    angle = -math.degrees(best.orientation)
    return time.perf_counter() - t0, angle


def speed(repeat: int) -> None:
    tilt, case = 17.3, 1.5
    t0 = time.perf_counter()
    u8 = render(tilt, case, (3648, 5472), flash=0.5)
    with tempfile.TemporaryDirectory() as tmp:
        path = save_jpeg(u8, Path(tmp) / "holder.jpg")
        print(f"rendered a 5472 x 3648 (20 MP) JPEG in {time.perf_counter() - t0:.2f} s; "
              f"tilt {tilt} deg, case edge {case} deg, flash on the tape")
        t_read = median_time(lambda: read_photo(path), max(1, repeat // 3))
        image = read_photo(path)
        decoded = load_photo(path)
        for reference, expected in (("vertical", tilt), ("detect", tilt - case)):
            t = median_time(lambda ref=reference: measure_tilt(path, reference=ref), repeat)
            m = measure_tilt(path, reference=reference)
            print(f"measure_tilt(file) reference={reference:8s}: median {t:.3f} s with the "
                  f"decoding at 1/{decoded.scale} scale ({decoded.image.shape[1]} x "
                  f"{decoded.image.shape[0]} px), error {m.angle_deg - expected:+.4f} deg")
    times = {}
    for reference, expected in (("vertical", tilt), ("detect", tilt - case)):
        t = times[reference] = median_time(
            lambda ref=reference: measure_tilt(image, reference=ref), repeat)
        m = measure_tilt(image, reference=reference)
        print(f"measure_tilt reference={reference:8s}: median {t:.3f} s over {repeat} runs "
              f"[target <= 0.5 s], error {m.angle_deg - expected:+.4f} deg "
              f"(line {m.length:.0f} px, rms {m.residual_rms:.2f} px)")
    print(f"read_photo (JPEG decode, EXIF, grey float64): median {t_read:.3f} s")
    t_anchor, angle = skimage_anchor(image)
    print(f"anchor: skimage Otsu + label + regionprops on the full image: {t_anchor:.3f} s, "
          f"error {angle - tilt:+.3f} deg; ratio anchor / measure_tilt: "
          f"{t_anchor / times['vertical']:.3g}x")


def accuracy(n: int) -> None:
    rng = np.random.default_rng(2024)
    angles = np.linspace(-45.0, 45.0, n)
    cases = rng.uniform(-5.0, 5.0, n)
    errors: dict[str, list[float]] = {"vertical": [], "detect": []}
    for i, (a, c) in enumerate(zip(angles, cases, strict=True)):
        flash = float(rng.uniform(0.1, 0.9)) if i % 3 == 0 else -1.0
        with tempfile.TemporaryDirectory() as tmp:
            image = read_photo(save_jpeg(render(a, c, (800, 1200), flash=flash, seed=i),
                                         Path(tmp) / "p.jpg"))
        errors["vertical"].append(measure_tilt(image).angle_deg - a)
        errors["detect"].append(measure_tilt(image, reference="detect").angle_deg - (a - c))
    for reference, errs in errors.items():
        e = np.asarray(errs)
        worst = int(np.argmax(np.abs(e)))
        print(f"accuracy reference={reference:8s}: RMS {math.sqrt(float(np.mean(e**2))):.4f} "
              f"deg, worst {e[worst]:+.4f} deg (at {angles[worst]:+.1f} deg) over {n} angles "
              "-45..45 deg, 1200 x 800 px JPEG q85 [target RMS <= 0.2 deg]")


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--quick", action="store_true", help="fewer repeats and angles")
    args = parser.parse_args()
    speed(3 if args.quick else 9)
    accuracy(31 if args.quick else 181)


if __name__ == "__main__":
    main()
