"""The paper's metrics against values computed by hand."""

from __future__ import annotations

import numpy as np

from learned.metrics import rotation_errors_deg, summarize, translation_errors_mm
from tests.tolerances import DEG, FLOAT


def test_rotation_error_is_the_angle_between_the_rotations():
    s = np.sqrt(0.5)
    identity = np.array([[0.0, 0.0, 0.0, 1.0]] * 4)
    q = np.array(
        [
            [0, 0, s, s],  # 90 deg about z
            [0, 0, -s, -s],  # the same, other sign
            [1.0, 0, 0, 0],  # 180 deg about x
            [0, np.sin(np.pi / 12), 0, np.cos(np.pi / 12)],
        ]
    )  # 30 deg about y
    np.testing.assert_allclose(rotation_errors_deg(q, identity), [90.0, 90.0, 180.0, 30.0], atol=FLOAT / DEG)


def test_translation_errors_and_their_summary():
    e = translation_errors_mm([[3.0, 4.0, 0.0], [0.0, 0.0, 1.0], [0.0, 0.0, 0.0]], np.zeros((3, 3)))
    np.testing.assert_allclose(e, [5.0, 1.0, 0.0])
    s = summarize(e)
    assert s["mean"] == 2.0 and s["median"] == 1.0 and np.isclose(s["rmse"], np.sqrt(26 / 3)) and s["n"] == 3
