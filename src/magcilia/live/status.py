"""What a live read-out reports besides its samples: its events (:class:`Event`), where it stands
(:class:`LiveStatus`) and what it can measure (:class:`Limits`). Immutable values, SI.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Any

import numpy as np

from magcilia._display import Display, Item, scaled, si
from magcilia.acquire.source import Counters
from magcilia.device.parameters import MEASURANDS

#: event codes stored in a live recording's ``events`` group (channel ``event_code``)
EVENTS = {"start": 0, "tare": 1, "disconnected": 2, "reconnected": 3, "recording": 4}


@dataclass(frozen=True, repr=False)
class Event(Display):
    """Something that happened during a live read-out (immutable).

    Attributes
    ----------
    time : float
        s since the read-out started.
    kind : str
        One of :data:`EVENTS`.
    text : str
        What happened, one line.
    """

    time: float
    kind: str
    text: str

    def to_dict(self) -> dict[str, Any]:
        """JSON-ready content."""
        return {"time_s": self.time, "kind": self.kind, "text": self.text}

    def report(self) -> str:
        """One line."""
        return f"{self.time:8.2f} s  {self.kind}: {self.text}"

    # -- display --------------------------------------------------------------------------------
    def _display_items(self) -> list[Item]:
        return [("", self.kind), ("time", f"{self.time:.6g} s"), ("", self.text)]


@dataclass(frozen=True, repr=False)
class LiveStatus(Display):
    """Where a live read-out stands (immutable; :attr:`LiveReadout.status`).

    Attributes
    ----------
    state : str
        ``"starting"``, ``"running"``, ``"taring"``, ``"disconnected"``, ``"failed"`` or
        ``"stopped"``.
    message : str
        One line for people: the last fault, a hint, or "".
    counters : Counters
        Samples delivered by the source, dropped (by the device and by buffer overruns, summed
        over reconnections), corrupt frames and unverified samples (from a serial format
        without a checksum: the status says "unverified (no checksum)").
    overruns : int
        Samples the ring buffer overwrote because the read-out fell behind.
    samples : int
        Output samples so far.
    rate : float
        Output samples per second, Hz.
    tared : bool
        Whether a tare was taken.
    correction : float or ndarray, shape (c,)
        Current tare + zero-tracking correction per channel, ``unit`` (a float for one
        channel).
    drift : float or ndarray, shape (c,)
        Zero tracking's share of it since the last tare, ``unit``.
    noise : float or ndarray, shape (c,)
        Noise RMS of one reading used for σ, ``unit``: measured at the tare; before one, the
        larger of the sensor model's and the spread of the last second's readings.
    recording : str or None
        The file being recorded.
    latency_median, latency_p99 : float
        Sample in -> value out over the last second, s (NaN before any output).
    unit : str
        The channels' unit: ``"V"`` (a sensor output) or ``"T"`` (field channels).
    recalibration : str
        The in-use re-calibration's last change, e.g. ``recal 12 s ago: S −1.8±0.1 %, offset
        +0.30±0.01 mV`` ("" without one, :mod:`magcilia.live.recalibrating`).
    temperature : str
        A temperature-compensated read-out's temperature and calibrated range, e.g. ``301.20 K
        (calibrated 293.15…295.00 K, compensated) — OUTSIDE the calibrated range`` ("" without
        a temperature channel, :mod:`magcilia.live.thermal`).
    """

    state: str
    message: str
    counters: Counters
    overruns: int
    samples: int
    rate: float
    tared: bool
    correction: Any
    drift: Any
    noise: Any
    recording: str | None
    latency_median: float
    latency_p99: float
    unit: str = "V"
    recalibration: str = ""
    temperature: str = ""

    def to_dict(self) -> dict[str, Any]:
        """JSON-ready content (SI; the channel quantities keyed by their unit, e.g.
        ``correction_V``, lists for several channels)."""
        c = self.counters
        u = self.unit
        return {"state": self.state, "message": self.message, "delivered": c.samples,
                "dropped": c.dropped, "corrupt": c.corrupt, "unverified": c.unverified,
                "overruns": self.overruns,
                "samples": self.samples, "rate_Hz": self.rate, "tared": self.tared,
                f"correction_{u}": _plain(self.correction), f"drift_{u}": _plain(self.drift),
                f"noise_{u}": _plain(self.noise), "recording": self.recording,
                "latency_median_s": self.latency_median, "latency_p99_s": self.latency_p99,
                "recalibration": self.recalibration, "temperature": self.temperature}

    @property
    def unverified_text(self) -> str:
        """``"unverified (no checksum): N samples, M corrupt lines/frames skipped"``; "" when
        every sample was checked."""
        c = self.counters
        if not c.unverified:
            return ""
        return (f"unverified (no checksum): {c.unverified} samples, {c.corrupt} malformed "
                "skipped")

    def _channel(self, value: Any) -> str:
        """A channel quantity as text: mV/µV for one output, the largest |value| in G else."""
        if np.ndim(value) == 0 and self.unit == "V":
            return si(float(value), "V", 4)
        return "max |·| " + scaled(float(np.max(np.abs(value))), 1e-4, "G", 4)

    def report(self) -> str:
        """One line."""
        if np.ndim(self.correction) == 0 and self.unit == "V":
            tare = (f"tared (correction {self.correction * 1e3:+.4g} mV, drift "
                    f"{self.drift * 1e6:+.3g} µV)" if self.tared else "not tared")
        else:
            tare = (f"tared (correction {self._channel(self.correction)}, drift "
                    f"{self._channel(self.drift)})" if self.tared else "not tared")
        rec = f", recording {self.recording}" if self.recording else ""
        rec += f", {self.recalibration}" if self.recalibration else ""
        rec += f", {self.unverified_text}" if self.counters.unverified else ""
        rec += f", temperature {self.temperature}" if self.temperature else ""
        msg = f" — {self.message}" if self.message else ""
        return (f"{self.state}: {self.samples} samples at {self.rate:g} Hz, {tare}; "
                f"{self.counters.dropped} dropped, {self.overruns} overruns, latency "
                f"{self.latency_median * 1e3:.2g} ms (p99 {self.latency_p99 * 1e3:.2g} ms)"
                f"{rec}{msg}")

    # -- display --------------------------------------------------------------------------------
    def _display_items(self) -> list[Item]:
        items = [("", self.state), ("samples", str(self.samples)), ("rate", f"{self.rate:.4g} Hz"),
                 ("tared", "yes" if self.tared else "no"), ("noise", self._channel(self.noise)),
                 ("dropped", str(self.counters.dropped)), ("overruns", str(self.overruns))]
        if self.counters.unverified:
            items.append(("samples checked", self.unverified_text))
        if self.message:
            items.append(("message", self.message))
        if self.recording:
            items.append(("recording", self.recording))
        return items


@dataclass(frozen=True, repr=False)
class Limits(Display):
    """What the read-out can measure (immutable; SI, :meth:`LiveReadout.limits`).

    Attributes
    ----------
    quantity, unit : str
    span : (float, float)
        The read-out's span.
    range : (float, float)
        The part of the span inside the sensor's linear range and before any fold.
    minimum : float
        Minimum detectable change at rest: the noise of one reading through the slope there.
    limited_by : str
        What ends the range ("span", "sensor range", "fold").
    scale_note : str
        Where a force's or flow's scale comes from (:meth:`magcilia.Modulus.note`: its σ is in
        every reading's ± σ); "" for an angle.
    mode : str
        The dynamic read-out in use, in a few words (:meth:`magcilia.DynamicReadout.mode`); ""
        for the static read-out.
    """

    quantity: str
    unit: str
    span: tuple[float, float]
    range: tuple[float, float]
    minimum: float
    limited_by: str
    scale_note: str = ""
    mode: str = ""

    def to_dict(self) -> dict[str, Any]:
        """JSON-ready content (SI)."""
        return {"quantity": self.quantity, "unit": self.unit, "span": list(self.span),
                "range": list(self.range), "minimum": self.minimum,
                "limited_by": self.limited_by, "scale_note": self.scale_note,
                "mode": self.mode or "static"}

    def report(self) -> str:
        """One line in display units (and the force scale's note for a force or flow)."""
        q = MEASURANDS[self.quantity]
        lo, hi = (q.to_display(x) for x in self.range)
        note = f"; ± σ includes the {self.scale_note}" if self.scale_note else ""
        mode = f"; {self.mode}" if self.mode else ""
        return (f"{q.label} range {lo:.4g}…{hi:.4g} {q.display} ({self.limited_by}), minimum "
                f"detectable {q.to_display(self.minimum):.3g} {q.display}{note}{mode}")

    # -- display --------------------------------------------------------------------------------
    def _display_items(self) -> list[Item]:
        q = MEASURANDS[self.quantity]
        return [("", self.quantity), ("span", f"{q.text(self.span[0])}…{q.text(self.span[1])}"),
                ("range", f"{q.text(self.range[0])}…{q.text(self.range[1])}"),
                ("minimum", q.text(self.minimum)), ("limited by", self.limited_by)]


def _plain(value: Any) -> Any:
    """A float, or a list for several channels (JSON-ready)."""
    return float(value) if np.ndim(value) == 0 else np.asarray(value, dtype=np.float64).tolist()


def tare_text(zero: Any, readings: Any) -> str:
    """The event text of a tare taken by ``zero`` (a :class:`~magcilia.live.zero.Zero`) on
    ``readings`` ((m,) V, or (m, c) T)."""
    if zero.scalar:
        text = (f"zero at {np.mean(readings) * 1e3:.6g} mV (correction "
                f"{zero.correction * 1e3:+.4g} mV, noise {(zero.noise or 0.0) * 1e6:.3g} µV "
                "per reading)")
    else:
        text = (f"zero of {zero.channels} channels (largest correction "
                f"{np.max(np.abs(zero.correction)) * 1e4:.4g} G, noise up to "
                f"{np.max(zero.noise) * 1e7:.3g} mG per reading)")
    return text + (" — NOT AT REST" if zero.under_load else "")
