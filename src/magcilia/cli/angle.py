"""``magcilia angle``: the holder's tilt angle measured in photos (the tape along the holder)."""

from __future__ import annotations

import math
from pathlib import Path
from typing import Any

import click

from magcilia._validate import fail
from magcilia.acquire.photo import TiltMeasurement, load_photo, measure_tilt, pick_points
from magcilia.cli._common import echo_json, si_option, style_option
from magcilia.cli._outputs import writes_files
from magcilia.report.photo import annotate
from magcilia.report.units import output_units
from magcilia.units import OutputUnits


def _parse_line(text: str) -> tuple[tuple[float, float], tuple[float, float]]:
    """``X0,Y0,X1,Y1`` in px -> two points."""
    allowed = ("X0,Y0,X1,Y1: two points on the tape in px of the upright photo, "
               "e.g. 812,2950,1040,610")
    try:
        x0, y0, x1, y1 = (float(p) for p in text.split(","))
    except ValueError:
        raise fail("--line", text, allowed) from None
    if not all(math.isfinite(c) for c in (x0, y0, x1, y1)):
        raise fail("--line", text, allowed)
    return (x0, y0), (x1, y1)


def tilt_text(m: TiltMeasurement, units: OutputUnits) -> str:
    """One line: the photo, the tilt and what it is measured from (as ``TiltMeasurement.report``,
    in ``units``)."""
    deg = units.unit("angle")
    if m.reference == "vertical":
        ref = "the image vertical"
    else:
        what = "case edge normal" if m.reference == "detected" else "given reference"
        ref = f"the {what} (at {units.value(m.reference_angle, 'angle'):+.4g} {deg})"
    fit = "" if math.isnan(m.residual_rms) else f", rms {m.residual_rms:.2g} px"
    return (f"{m.path}: tilt {units.value(m.angle, 'angle'):+.5g} {deg} from {ref} ({m.method}, "
            f"line {m.length:.0f} px{fit})")


def annotated_files(params: dict[str, Any]) -> list[tuple[str, str]]:
    """The figures ``--annotate DIR`` writes: DIR/PHOTO-STEM_angle.png for each PHOTO."""
    folder = params.get("annotate_dir")
    if folder is None:
        return []
    return [("--annotate", str(Path(folder) / f"{Path(p).stem}_angle.png"))
            for p in params.get("photos", ())]


@click.command()
@writes_files(extra=annotated_files)
@click.argument("photos", metavar="PHOTO...", nargs=-1, required=True,
                type=click.Path(dir_okay=False))
@click.option("--reference", type=click.Choice(["vertical", "detect"]), default="vertical",
              show_default=True,
              help="Measure from the image vertical, or from the normal of the sensor case's top "
                   "edge found in the photo.")
@click.option("--manual", is_flag=True,
              help="Click two points on the tape in a window instead of finding it.")
@click.option("--line", "line_text", metavar="X0,Y0,X1,Y1",
              help="Two points on the tape, px of the upright photo (one PHOTO only).")
@click.option("--annotate", "annotate_dir", type=click.Path(file_okay=False),
              help="Write PHOTO-STEM_angle.png figures of what was measured into this folder "
                   "(an existing one replaced only with --force).")
@click.option("--json", "as_json", is_flag=True,
              help="Print a JSON list, one object per photo (path, angle_deg, ...; angle_rad "
                   "with --si).")
@si_option
@style_option
def command(photos: tuple[str, ...], reference: str, manual: bool, line_text: str | None,
            annotate_dir: str | None, as_json: bool, si: bool, style: str) -> None:
    """Measure the holder's tilt in each PHOTO (JPEG, PNG, TIFF) from the reflective tape on it.

    Angles in degrees (rad with --si), positive when the top of the holder leans to the photo's
    right; EXIF orientation is applied and points are pixels (x right, y down) of the upright photo.
    Without --manual or --line the tape (a bright, long, straight stripe) is found and fitted.
    """
    line = _parse_line(line_text) if line_text is not None else None
    if line is not None and len(photos) > 1:
        raise fail("--line", line_text, "used with one PHOTO (the points belong to one photo)")
    units = output_units(si)
    results = []
    for photo in photos:
        decoded = load_photo(photo)  # a large photo downscaled; points stay in the photo's px
        points = line
        if points is None and manual:
            clicked = decoded.to_photo(pick_points(
                decoded.image, 2, f"{Path(photo).name}: click two points on the tape"))
            points = ((float(clicked[0, 0]), float(clicked[0, 1])),
                      (float(clicked[1, 0]), float(clicked[1, 1])))
        m = measure_tilt(decoded, reference=reference, line_points=points)  # path: the photo's
        if annotate_dir is not None:
            annotate(m, decoded.image, Path(annotate_dir) / f"{Path(photo).stem}_angle.png",
                     style)
        results.append(m)
        if not as_json:
            click.echo(tilt_text(m, units))
    if as_json:
        echo_json([units.convert(m.to_dict()) for m in results])
