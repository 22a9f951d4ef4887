"""Fixtures of the learned tests.

``frames``: the counting tests' frames (:func:`tests.learned._synthetic.count_frames`); a test module that
needs other frames defines its own ``frames`` fixture, which takes precedence.
"""

from __future__ import annotations

import pytest


@pytest.fixture(scope="module")
def frames():
    pytest.importorskip("torch")
    from tests.learned._synthetic import count_frames

    return count_frames()
