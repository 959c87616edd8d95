"""``live --recalibrate``: coil pulses in the live pipeline are flagged and never shown as a
force; the others are read; the status says when it last re-calibrated."""

from __future__ import annotations

import numpy as np
import pytest

import magcilia as mc
from magcilia.acquire.simulated_coil import CoilPulses, Drifts, SimulatedCoilSource
from magcilia.cli import main
from magcilia.live import LiveReadout
from magcilia.live.recalibrating import LiveRecalibration
from magcilia.readout.protocol import Flag
from magcilia.readout.recalibration import Recalibrator
from magcilia.readout.recalibration_stream import PulseTracker

SETUP = mc.presets.load("force-sensor")
SPAN = (-2e-5, 2e-5)


def test_pulse_readings_are_flagged_and_have_no_value() -> None:
    source = SimulatedCoilSource(SETUP, 1e-6, rng=1, readout_noise=2e-5, set_reset=10,
                                 pulses=CoilPulses(every=0.5, duration=0.05, start=0.75),
                                 drifts=Drifts(sensitivity=-1e-3))
    readout = mc.Readout(SETUP, "force", span=SPAN)
    recal = LiveRecalibration(PulseTracker(Recalibrator(SETUP, span=SPAN, points=5)))
    with LiveReadout(source, readout, rate=100, recalibration=recal) as live:
        live.wait(300, timeout=60)
        samples = live.history.since(0)[0].first(300)  # from the source's first window on
        status = live.status
    pulse = (samples.flags & Flag.COIL_PULSE) != 0
    t = samples.time - samples.time[0] + 0.0045  # each window's centre, in source time
    inside = np.zeros(t.size, bool)
    for k in range(6):  # pulses at 0.75 + 0.5 k s for 50 ms: the windows wholly inside them
        start = 0.75 + 0.5 * k
        inside |= (t - 0.005 >= start - 1e-9) & (t + 0.005 <= start + 0.05 + 1e-9)
    assert pulse[inside].all() and pulse.sum() < 2 * inside.sum()
    assert np.isnan(samples.value[pulse]).all()
    assert np.isfinite(samples.value[1:][~pulse[1:]]).all()  # (the first window: set only)
    assert np.nanmedian(samples.value[~pulse]) == pytest.approx(1e-6, abs=0.3e-6)
    assert status.recalibration.startswith("recal ") and "S −" in status.recalibration
    assert status.to_dict()["recalibration"] == status.recalibration
    assert status.recalibration in status.report()


def test_recalibrate_needs_the_simulated_coil_and_a_force(capsys: pytest.CaptureFixture[str]
                                                          ) -> None:
    for args, words in ((["--quantity", "angle"], "--quantity"),
                        (["--source", "serial:/dev/null"], "--source"),
                        (["--dynamic"], "--dynamic")):
        assert main(["live", "--recalibrate", "2s", "--duration", "1s", *args]) == 2
        err = capsys.readouterr().err
        assert err.count("\n") == 1 and words in err and "--recalibrate" in err
