"""What the live tests share: a simulated sensor whose cable can be pulled."""

from __future__ import annotations

import math
import time
from typing import Any

import pytest

from magcilia._errors import AcquisitionError
from magcilia.acquire import SimulatedSource
from magcilia.acquire.source import Block


class Unplugged(SimulatedSource):
    """A simulated sensor whose cable is pulled by :meth:`unplug` or after ``good`` reads, and
    put back by :meth:`plug` or ``down`` s later: reads fail ("sim: device vanished") and so
    do reopenings ("sim: no such device") meanwhile."""

    def __init__(self, *args: Any, good: int | None = None, down: float = math.inf,
                 **kw: Any) -> None:
        super().__init__(*args, **kw)
        self.good, self.down, self.reads = good, down, 0
        self.unplugged_at: float | None = None

    def unplug(self) -> None:
        self.unplugged_at = time.monotonic()

    def plug(self) -> None:
        self.unplugged_at = None

    @property
    def unplugged(self) -> bool:
        return self.unplugged_at is not None and time.monotonic() - self.unplugged_at < self.down

    def _open(self) -> None:
        if self.unplugged:
            raise AcquisitionError("sim: no such device (unplugged)")
        super()._open()

    def _read(self, n: int) -> Block:
        self.reads += 1
        if self.reads == self.good:
            self.unplug()
        if self.unplugged:
            raise AcquisitionError("sim: device vanished")
        return super()._read(n)


@pytest.fixture
def unplugged() -> type[Unplugged]:
    """The class :class:`Unplugged` (a fixture: test modules are not importable here)."""
    return Unplugged
