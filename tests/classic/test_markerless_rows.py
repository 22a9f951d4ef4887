"""``cross_rows`` is ``np.cross`` over the last axis, bit for bit (the registration's results must not move)."""

from __future__ import annotations

import numpy as np

from classic.markerless.rows import cross_rows


def test_cross_rows_is_np_cross_bit_for_bit_broadcast_and_into_a_view():
    rng = np.random.default_rng(7)
    a, b = rng.normal(size=(500, 3)) * 1e3, rng.normal(size=(500, 3)) * 1e-3
    np.testing.assert_array_equal(cross_rows(a, b), np.cross(a, b))
    np.testing.assert_array_equal(cross_rows(a[:, None], b[None, :7]), np.cross(a[:, None], b[None, :7]))
    J = np.zeros((500, 6))
    out = cross_rows(a, b, out=J[:, 3:])
    assert out.base is J
    np.testing.assert_array_equal(J[:, 3:], np.cross(a, b))
    assert not J[:, :3].any()
