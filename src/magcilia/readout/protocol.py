"""The read-out protocol: one flag set and one shape of result for every read-out.

Every read-out — the single-axis :class:`~magcilia.Readout` (angle, force or flow from one
output), the force vector of a 3-axis sensor (:class:`~magcilia.BiaxialReadout`), all force
vectors of an array (:class:`~magcilia.ArrayReadout`), the read-out while actuating
(:class:`~magcilia.ActuatedReadout`) — offers the same few things (:class:`SensorReadout`):

* ``inputs``: what one sample holds, in order: the source channel names (``("output",)`` for one
  output, V; ``("NAME.x", "NAME.y", "NAME.z")`` for a 3-axis sensor NAME, T; every sensor's three
  for an array, in the array's sensor order);
* ``rest``: the model's reading of each channel at rest (no load), channel units, shape (c,);
* ``read(samples, noise=None)``: samples of shape (n, c) (or (n,) for one channel) in, a result
  (:class:`ReadoutValues`) out with ``value``, ``sigma`` (1-σ, SI, the shape of ``value``) and
  ``flags`` (:class:`Flag` bits, one per estimate; 0 is a good estimate);
* ``tare(baseline)``: a copy whose zero is the mean of unloaded samples (one
  :class:`~magcilia.readout.tare.Tare`), and ``baseline``, the tare it holds or None;
* ``report()`` and ``to_dict()``, as every result of the project.

Shapes of ``value`` (``sigma`` alike) for n samples:

=========================  ==========  =============  ==========
read-out                   ``value``   ``flags``      ``unit``
=========================  ==========  =============  ==========
angle, force or flow       (n,)        (n,)           rad, N, m/s
force vector (Fx, Fy)      (n, 2)      (n,)           N
array of C cilia           (n, C, 2)   (n, C)         N
=========================  ==========  =============  ==========

The views (``magcilia live``, the dashboard, ``--json-lines``) rely on nothing else, so any
read-out that follows the protocol can be watched, recorded and replayed.
"""

from __future__ import annotations

import enum
from typing import Any, Protocol, Self, runtime_checkable

import numpy as np
from numpy.typing import ArrayLike, NDArray

from magcilia.readout.tare import Tare

F64 = NDArray[np.float64]

#: dtype of every flags array
FLAG_DTYPE = np.uint16
#: the input of a single-output read-out: the source channel of the sensor output, V (the same
#: name as :data:`magcilia.acquire.source.OUTPUT`)
OUTPUT = "output"


class Flag(enum.IntFlag):
    """Bit flags of an estimate, one set for every read-out (combine with ``|``; 0 is good).

    A bit means the same in every read-out; the read-outs that cannot raise a bit never do (a
    single output is never AMBIGUOUS between mirror directions, an array has no FOLD).
    """

    OK = 0
    #: no estimate: beyond the span by more than its edge tolerance, beyond the model's reach,
    #: or nothing finite to read
    OUTSIDE_SPAN = 1
    #: the span extends past a fold of the output and this output also occurs beyond it
    FOLD = 2
    #: a reading beyond its sensor's range (``device.sensor.beyond_range``): left out of the
    #: estimate; with one channel no estimate remains
    SATURATED = 4
    #: beyond an end of the span but within the edge tolerance: the model continued past it
    EXTRAPOLATED = 8
    #: beyond an end of the span but within the edge tolerance: set to the end
    CLIPPED = 16
    #: the estimate lies beyond the span's low end
    BELOW_SPAN = 32
    #: the estimate lies beyond the span's high end (for a vector: its magnitude)
    ABOVE_SPAN = 64
    #: another, distinct minimum fits the readings about as well: the direction is undetermined
    AMBIGUOUS = 128
    #: the readings do not determine every component: no estimate
    UNDETERMINED = 256
    #: the fit stopped before converging (its last estimate is kept)
    NOT_CONVERGED = 512
    #: the force is within a few σ of zero: its direction is undefined
    NEAR_ZERO = 1024
    #: a reading is NaN: left out of the estimate
    MISSING = 2048
    #: the tare's window was not at rest (noise or trend beyond the rest noise)
    TARE_UNDER_LOAD = 4096
    #: the zero drifts faster than zero tracking follows; σ includes the drift not tracked
    ZERO_DRIFT = 8192
    #: the temperature lies outside the range seen at calibration and tare (the temperature
    #: compensation, :mod:`magcilia.readout.thermal`, extrapolates its coefficients there)
    TEMPERATURE_OUTSIDE = 16384
    #: a coil pulse of the in-use re-calibration: the reading is no force (no value)
    COIL_PULSE = 32768
    #: the array read-out's former name of ABOVE_SPAN
    BEYOND_SPAN = 64


def tare_flags(baseline: Any) -> int:
    """The flags every estimate of a read-out tared on ``baseline`` (a
    :class:`~magcilia.readout.tare.Tare` or None) carries: TARE_UNDER_LOAD where the tare's
    window was not at rest (:attr:`Tare.at_rest <magcilia.readout.tare.Tare.at_rest>`), else 0."""
    if baseline is None or baseline.check is None or baseline.at_rest:
        return 0
    return int(Flag.TARE_UNDER_LOAD)


def flag_names(bits: int) -> tuple[str, ...]:
    """The names of the :class:`Flag` bits set in ``bits`` (ascending), e.g. for a view.

    >>> flag_names(Flag.SATURATED | Flag.ABOVE_SPAN)
    ('SATURATED', 'ABOVE_SPAN')
    >>> flag_names(0)
    ()
    """
    value = int(bits)
    return tuple(str(f.name) for f in Flag if value & f.value)  # canonical bits only


def flag_counts(flags: ArrayLike, always: Any = ()) -> dict[str, int]:
    """How many of the estimates' ``flags`` (any shape) carry each :class:`Flag` bit, by lower-case
    name (as in the CSVs' ``flag_names``), in the enum's order: the bits in ``always`` (Flags, or
    one combined Flag) even where none carries them, any other only where some do.

    >>> flag_counts([0, int(Flag.FOLD), int(Flag.FOLD | Flag.SATURATED)], always=(Flag.MISSING,))
    {'fold': 2, 'saturated': 1, 'missing': 0}
    """
    flat = np.asarray(flags).reshape(-1)
    out: dict[str, int] = {}
    for f in Flag:
        hits = int(np.count_nonzero(flat & int(f)))
        if hits or f in always:
            out[str(f.name).lower()] = hits
    return out


@runtime_checkable
class ReadoutValues(Protocol):
    """What every read-out's result holds (SI; shapes in the module's table)."""

    @property
    def value(self) -> F64:
        """The estimates: (n,), (n, 2) or (n, C, 2); NaN where there is none."""
        ...

    @property
    def sigma(self) -> F64:
        """1-σ of each component of ``value`` (its shape), in its unit."""
        ...

    @property
    def flags(self) -> NDArray[Any]:
        """:class:`Flag` bits: (n,) or (n, C)."""
        ...

    @property
    def unit(self) -> str:
        """SI unit of ``value``: ``"rad"``, ``"N"`` or ``"m/s"``."""
        ...

    def to_dict(self) -> dict[str, Any]:
        """JSON-ready content (SI)."""
        ...

    def report(self) -> str:
        """Text for people."""
        ...


@runtime_checkable
class SensorReadout(Protocol):
    """What every read-out offers (see the module's docstring)."""

    @property
    def inputs(self) -> tuple[str, ...]:
        """What one sample holds, in order: source channel names."""
        ...

    @property
    def rest(self) -> F64:
        """The model's reading of each channel at rest, shape (c,), channel units."""
        ...

    @property
    def baseline(self) -> Tare | None:
        """The tare held, or None."""
        ...

    def read(self, samples: ArrayLike, /, *, noise: ArrayLike | None = None) -> ReadoutValues:
        """Estimates of ``samples`` ((n, c), or (n,) for one channel), a tare's correction
        added first; ``noise``: each channel's noise RMS per sample (default: the tare's, else
        the sensor model's)."""
        ...

    def tare(self, baseline: ArrayLike, /) -> Self:
        """A copy whose zero is the mean of unloaded samples ``baseline`` ((n, c))."""
        ...

    def to_dict(self) -> dict[str, Any]:
        """JSON-ready content (SI)."""
        ...

    def report(self) -> str:
        """Text for people."""
        ...
