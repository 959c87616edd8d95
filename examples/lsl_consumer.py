"""Receive a magcilia live read-out over the Lab Streaming Layer (LSL), as any lab program would.

Start the read-out in one terminal, then this script in another (or on another computer on the
same network)::

    magcilia live --lsl cilium              # or: --source serial:/dev/ttyACM0 --lsl cilium
    python examples/lsl_consumer.py cilium --seconds 5

It needs only ``pylsl`` and ``numpy`` (no magcilia): the stream describes itself. Its channels
are the read-out's values, then their 1-sigma uncertainties, then the flag bits (0 = a good
reading), each with a label, a unit (SI: N, rad, m/s) and a type (value, sigma, flags) in the
stream's XML description; values are NaN where a flag means "no estimate". The script prints one
line per second (mean of the good readings ± their sigma), and with ``--json`` one JSON summary
at the end (what the test reads).
"""

from __future__ import annotations

import argparse
import json
import sys
import time
from typing import Any

import numpy as np


def channels(info: Any) -> list[dict[str, str]]:
    """Label, unit and type of each channel, from the XML description of a pylsl.StreamInfo."""
    out = []
    ch = info.desc().child("channels").child("channel")
    while not ch.empty():
        out.append({key: ch.child_value(key) for key in ("label", "unit", "type")})
        ch = ch.next_sibling()
    return out


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("name", nargs="?", default="magcilia", help="the stream's name")
    parser.add_argument("--seconds", type=float, default=5.0, help="how long to listen, s")
    parser.add_argument("--timeout", type=float, default=10.0,
                        help="how long to look for the stream, s")
    parser.add_argument("--json", action="store_true", help="print one JSON summary at the end")
    args = parser.parse_args(argv)
    import pylsl

    found = pylsl.resolve_byprop("name", args.name, timeout=args.timeout)
    if not found:
        print(f"lsl_consumer: no LSL stream named {args.name!r} within {args.timeout:g} s "
              "(is `magcilia live --lsl` running on this network?)", file=sys.stderr)
        return 1
    inlet = pylsl.StreamInlet(found[0])
    info = inlet.info(timeout=args.timeout)
    chans = channels(info)
    kinds = np.array([c["type"] for c in chans])
    values, sigmas, flags = (np.flatnonzero(kinds == k) for k in ("value", "sigma", "flags"))
    rows: list[list[float]] = []
    stamps: list[float] = []
    start = time.monotonic()
    next_line = start + 1.0
    while time.monotonic() - start < args.seconds:
        chunk, ts = inlet.pull_chunk(timeout=0.2)
        rows.extend(chunk)
        stamps.extend(ts)
        if not args.json and time.monotonic() >= next_line and rows:
            next_line += 1.0
            last = np.asarray(rows[-int(info.nominal_srate()) or -1:])
            good = last[np.all(last[:, flags] == 0, axis=1)]
            text = ", ".join(
                f"{chans[i]['label']} {np.nanmean(good[:, i]):+.4g} ± "
                f"{np.nanmean(good[:, j]):.2g} {chans[i]['unit']}"
                for i, j in zip(values, sigmas, strict=True)) if len(good) else "no good reading"
            print(f"{len(rows)} samples: {text}", flush=True)
    data = np.asarray(rows, dtype=np.float64).reshape(-1, len(chans))
    if args.json:
        steps = np.diff(stamps) if len(stamps) > 1 else np.zeros(0)
        print(json.dumps({
            "name": info.name(), "type": info.type(), "rate_Hz": info.nominal_srate(),
            "channels": chans, "samples": len(data),
            "good": int(np.sum(np.all(data[:, flags] == 0, axis=1))) if len(data) else 0,
            "median_step_s": float(np.median(steps)) if steps.size else None,
            "mean": [float(np.nanmean(data[:, i])) if len(data) else None for i in values]}))
    return 0


if __name__ == "__main__":
    sys.exit(main())
