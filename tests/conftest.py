"""Shared fixtures: every random draw in the suite comes from a seeded generator."""

from __future__ import annotations

import numpy as np
import pytest


@pytest.fixture
def rng() -> np.random.Generator:
    """A fresh, seeded generator per test (reproducible, independent of test order)."""
    return np.random.default_rng(0)
