"""Fixtures of the analysis tests."""

from __future__ import annotations

import numpy as np
import pytest


@pytest.fixture
def rng() -> np.random.Generator:
    """A seeded generator: every run draws the same noise."""
    return np.random.default_rng(12345)
