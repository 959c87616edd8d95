"""Receive a magcilia dashboard's live values over its WebSocket, as another program would.

Start the dashboard, then this script with its address::

    magcilia dashboard --port 8050
    python examples/websocket_consumer.py http://127.0.0.1:8050/ --frames 20 [--tare]

It needs ``websockets`` and ``numpy`` (no magcilia). What it does, in order:

1. ``GET /api/info``: what is measured (quantity, display unit, SI unit) and the layout of the
   binary frames (``header`` and ``columns`` names);
2. reads the page's per-run token (``<meta name="magcilia-token" content="...">``); commands
   (``POST /api/tare``, ``POST /api/record``) carry it in the ``X-Magcilia-Token`` header —
   ``--tare`` sends one. Reading needs no token; a script sends no ``Origin``, so the server's
   cross-site check lets it through (docs/streams.md);
3. opens ``ws://HOST:PORT/ws``: binary messages are frames of little-endian float64, the header
   values then the columns (``time`` s, ``raw_mV``, ``value`` and ``sigma`` in the display unit,
   ``flags``; a force vector: ``time`` then ``fx, fy, sigma_x, sigma_y, flags`` per cilium),
   each ``points`` long; text messages are the status as JSON.

It prints one line per frame (or with ``--json`` one summary at the end).
"""

from __future__ import annotations

import argparse
import json
import re
import sys
import urllib.request
from urllib.parse import urlsplit

import numpy as np


def get(url: str, path: str) -> bytes:
    with urllib.request.urlopen(url.rstrip("/") + path, timeout=10) as answer:
        return bytes(answer.read())


def token(url: str) -> str:
    """The per-run token of the page at ``url``."""
    page = get(url, "/").decode("utf-8", "replace")
    match = re.search(r'<meta name="magcilia-token" content="([^"]+)"', page)
    if match is None:
        raise SystemExit("websocket_consumer: the page carries no token (not a magcilia "
                         "dashboard?)")
    return match.group(1)


def command(url: str, path: str, key: str, body: dict[str, str] | None = None) -> dict:
    """POST a command with the token; the server's JSON answer."""
    request = urllib.request.Request(url.rstrip("/") + path, method="POST",
                                     data=json.dumps(body or {}).encode(),
                                     headers={"X-Magcilia-Token": key,
                                              "Content-Type": "application/json"})
    with urllib.request.urlopen(request, timeout=10) as answer:
        return json.loads(answer.read())


def decode(data: bytes, header: list[str]) -> tuple[dict[str, float], np.ndarray]:
    """A binary frame: its header values by name and its columns, shape (rows, points)."""
    raw = np.frombuffer(data, dtype="<f8")
    head = dict(zip(header, raw[:len(header)].tolist(), strict=True))
    points = int(head["points"])
    return head, raw[len(header):].reshape(-1, points) if points else np.zeros((0, 0))


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("url", nargs="?", default="http://127.0.0.1:8050/")
    parser.add_argument("--frames", type=int, default=20, help="binary frames to read")
    parser.add_argument("--tare", action="store_true", help="tare first (a command: token)")
    parser.add_argument("--json", action="store_true", help="one JSON summary at the end")
    args = parser.parse_args(argv)
    from websockets.sync.client import connect

    info = json.loads(get(args.url, "/api/info"))
    header = info["header"]
    key = token(args.url)
    tared = command(args.url, "/api/tare", key) if args.tare else None
    parts = urlsplit(args.url)
    points = statuses = 0
    last_value = None
    with connect(f"ws://{parts.netloc}/ws", open_timeout=10) as ws:
        frames = 0
        while frames < args.frames:
            message = ws.recv(timeout=10)
            if isinstance(message, str):
                statuses += 1
                continue
            head, columns = decode(message, header)
            frames += 1
            points += int(head["points"])
            if columns.size:
                last_value = float(columns[2, -1]) if info["kind"] == "scalar" else \
                    float(np.hypot(columns[1, -1], columns[2, -1]))
            if not args.json:
                print(f"frame {int(head['frame'])}: {int(head['points'])} points, last "
                      f"{info['label']} {last_value} {info['unit']}", flush=True)
    if args.json:
        print(json.dumps({"quantity": info["quantity"], "unit": info["unit"],
                          "si_unit": info["si_unit"], "frames": args.frames, "points": points,
                          "statuses": statuses, "last_value": last_value,
                          "tare": tared}))
    return 0


if __name__ == "__main__":
    sys.exit(main())
