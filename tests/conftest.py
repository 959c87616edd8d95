"""Shared test configuration: a headless matplotlib backend and a quick Hypothesis profile."""

from __future__ import annotations

import matplotlib
from hypothesis import settings

matplotlib.use("Agg")

settings.register_profile("magcilia", max_examples=40, deadline=None)
settings.load_profile("magcilia")
