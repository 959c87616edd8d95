"""The docs' gallery (docs/gallery.md): every figure the command line writes, with the command.

Each entry of :data:`ENTRIES` is a real ``magcilia`` command line; ``--write`` runs each one
(``python -m magcilia``, this interpreter) in a temporary folder, copies the PNGs it wrote into
docs/images/gallery/ (shrunk to :data:`WIDTH` pixels and a 256-colour palette, so the repository
stays small) and writes the page. The page's text depends on :data:`ENTRIES` only, so
tests/docs/test_gallery.py checks it is current without running anything, that each command parses
with the CLI, and that every figure the CLI can write is in it.

Run: PYTHONPATH=src python scripts/gallery.py            (print the page)
     PYTHONPATH=src python scripts/gallery.py --write    (run the commands; images and page)
"""

from __future__ import annotations

import argparse
import math
import shlex
import shutil
import subprocess
import sys
import tempfile
from dataclasses import dataclass
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
PAGE = ROOT / "docs" / "gallery.md"
IMAGES = ROOT / "docs" / "images" / "gallery"
#: the width of a gallery image, pixels (smaller figures are kept as they are)
WIDTH = 680
#: the bundled synthetic recording, copied into the run folder under this name
RECORDING = "example_recording.csv"
#: a synthetic photo of the tilted holder, drawn into the run folder under this name
PHOTO = "holder.png"


@dataclass(frozen=True)
class Entry:
    """One command of the gallery: its arguments (after ``magcilia``), the PNGs it writes
    (paths relative to the run folder) and what they show."""

    title: str
    args: str
    figures: tuple[str, ...]
    caption: str

    @property
    def command(self) -> str:
        return self.args.split()[0]

    def image(self, figure: str) -> str:
        """The figure's file name in docs/images/gallery/."""
        return f"{self.command}-{figure.replace('/', '-')}"


ENTRIES: tuple[Entry, ...] = (
    Entry("Field and output against tilt", "field --setup paper --plot field.png",
          ("field.png",),
          "The field at the sensing element and the sensor output over the paper's tilt path."),
    Entry("Calibration (the paper's Fig. 8)", f"calibrate {RECORDING} --out cal",
          ("cal/fit.png", "cal/residuals.png"),
          "The data in field units with 1 s.e. error bars and the fitted model; the residuals. "
          f"`{RECORDING}` is the bundled synthetic recording (`magcilia.io.example_path()`); "
          "`magcilia demo` and `magcilia batch --figures` write the same two figures."),
    Entry("Posterior of the physical model",
          f"calibrate {RECORDING} --model physical --prior height=3.26:0.05 "
          "--prior base_radius=0.18:0.01 --posterior --out post",
          ("post/fit.png", "post/pairs.png"),
          "The physical model's fit (lengths with priors from a microscope) and the pairs plot "
          "of the geometry's posterior (emcee; at most a minute of sampling)."),
    Entry("Sensitivity (the paper's Figs. 9-12)",
          "sensitivity --setup paper --points 9 --map-points 9 --sobol-base 64 --out sens",
          ("sens/fig09_xy.png", "sens/fig10_z.png", "sens/fig11_nk.png",
           "sens/fig12_geometry.png", "sens/xy_map.png", "sens/sobol.png"),
          "The output against placement, height above the sensor, layout and geometry; the "
          "x-y map of the output; Sobol indices of the parameters."),
    Entry("Bending under a tip force", "bend --setup force-sensor --tip-force 0.02 --plot bend.png",
          ("bend.png",), "The elastica shape of the hair under a 0.02 mN tip force."),
    Entry("Design metrics", "design --setup force-sensor --plot design.png", ("design.png",),
          "Output against force, flow speed and tilt angle, with the minimum detectable values."),
    Entry("Bending modes", "modes --setup force-sensor --fluid water --plot modes.png",
          ("modes.png",), "The first mode shapes of the clamped hair in water."),
    Entry("Design search (Pareto front)",
          "optimise --setup force-sensor --min-force 0.1uN --designs 512 --plot pareto.png",
          ("pareto.png",), "The designs searched and the front of range against minimum force."),
    Entry("Array of cilia", "array --setup array --random 1 --seed 0 --plot array.png "
                            "--crosstalk-plot crosstalk.png",
          ("array.png", "crosstalk.png"),
          "The array's cilia, sensors, loads and field change; the crosstalk image (sensor × "
          "cilium)."),
    Entry("Tilt angle from a photo", f"angle {PHOTO} --annotate figs", ("figs/holder_angle.png",),
          f"What was measured on a photo of the holder (`{PHOTO}`: a synthetic photo this script "
          "draws, the holder tilted 15°)."),
    Entry("3-D view", "show --setup paper --tilt 30 --out show.png", ("show.png",),
          "The cilium as its exact body, the sensor's sensitive axis and B on the x-z slice "
          "(`--out show.html`: the same, interactive)."),
)


def page() -> str:
    """The gallery page (markdown), from :data:`ENTRIES` alone."""
    lines = [
        "# Gallery",
        "",
        ("Every figure the command line writes, and the command that made it (run in an empty "
         "folder; generated by `scripts/gallery.py --write`, images shrunk for the site)."),
        "",
    ]
    for entry in ENTRIES:
        lines += [f"## {entry.title}", "", "```console", f"magcilia {entry.args}", "```", "",
                  entry.caption, ""]
        for figure in entry.figures:
            lines += [f"![{figure}](images/gallery/{entry.image(figure)})", "",
                      f"*`{figure}`*", ""]
    return "\n".join(lines)


def draw_photo(path: Path, angle_deg: float = 15.0) -> None:
    """A grey photo of the holder (a dark bar tilted ``angle_deg``, top to the right) with its
    bright tape, blurred a little, as an 8-bit PNG."""
    import numpy as np
    from PIL import Image, ImageFilter

    h, w = 480, 640
    y, x = np.mgrid[0:h, 0:w].astype(np.float64)
    th = math.radians(angle_deg)
    u = (x - w / 2) * math.sin(th) - (y - 0.86 * h) * math.cos(th)  # along the holder, up
    v = (x - w / 2) * math.cos(th) + (y - 0.86 * h) * math.sin(th)  # across it
    img = np.full((h, w), 0.55)
    img[(np.abs(v) < 30) & (u > -10) & (u < 330)] = 0.12
    img[(np.abs(v) < 9) & (u > 10) & (u < 315)] = 0.88
    picture = Image.fromarray(np.asarray(img * 255, dtype=np.uint8))
    picture.filter(ImageFilter.GaussianBlur(1.2)).save(path)


def _shrink(source: Path, target: Path) -> None:
    """``source`` at :data:`WIDTH` pixels wide at most, as a 256-colour PNG."""
    from PIL import Image

    with Image.open(source) as im:
        rgb = im.convert("RGB")
        if rgb.width > WIDTH:
            rgb = rgb.resize((WIDTH, round(rgb.height * WIDTH / rgb.width)), Image.LANCZOS)
        rgb.quantize(256, dither=Image.Dither.NONE).save(target, optimize=True)


def run(folder: Path) -> dict[str, Path]:
    """Run every entry in ``folder``; the written figures by their gallery image name."""
    from magcilia.io import example_path

    shutil.copy(example_path(), folder / RECORDING)
    draw_photo(folder / PHOTO)
    found: dict[str, Path] = {}
    for entry in ENTRIES:
        argv = [sys.executable, "-m", "magcilia", *shlex.split(entry.args)]
        print("$ magcilia", entry.args, flush=True)
        subprocess.run(argv, cwd=folder, check=True, stdout=subprocess.DEVNULL)
        for figure in entry.figures:
            path = folder / figure
            if not path.is_file():
                raise SystemExit(f"magcilia {entry.args} did not write {figure}")
            found[entry.image(figure)] = path
    return found


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--write", action="store_true",
                        help="run the commands, write docs/images/gallery/ and docs/gallery.md")
    args = parser.parse_args()
    if not args.write:
        print(page())
        return
    from magcilia._atomic import write_text

    with tempfile.TemporaryDirectory() as tmp:
        figures = run(Path(tmp))
        if IMAGES.exists():
            shutil.rmtree(IMAGES)
        IMAGES.mkdir(parents=True)
        for name, path in figures.items():
            _shrink(path, IMAGES / name)
    write_text(PAGE, page())
    total = sum(p.stat().st_size for p in IMAGES.iterdir())
    print(f"wrote {PAGE} and {len(figures)} images ({total / 1e3:.0f} kB) in {IMAGES}")


if __name__ == "__main__":
    main()
