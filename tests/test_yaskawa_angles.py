"""Yaskawa (Motoman) poses: Rx, Ry, Rz in degrees about the fixed axes, read with the Fanuc W, P, R columns.

A Yaskawa controller's pose ``(X, Y, Z, Rx, Ry, Rz)`` in the robot (base) frame turns about the fixed x
axis by Rx, then the fixed y by Ry, then the fixed z by Rz: ``R = Rz(Rz) Ry(Ry) Rx(Rx)``, Fanuc's
``W, P, R`` convention with ``(W, P, R) = (Rx, Ry, Rz)``. Checked against elementary rotations composed by
hand, and through a pose file.
"""

from __future__ import annotations

import numpy as np
import pytest

from handeye.core.posefile import read_pose_file
from handeye.core.robot_angles import matrix_from_fanuc_wpr
from tests.tolerances import EXACT, FLOAT


def _about(axis: int, deg: float) -> np.ndarray:
    """Rotation about a fixed axis (0 x, 1 y, 2 z) by ``deg`` degrees, written out by hand."""
    c, s = np.cos(np.radians(deg)), np.sin(np.radians(deg))
    i, j = [(1, 2), (2, 0), (0, 1)][axis]
    R = np.eye(3)
    R[i, i], R[i, j], R[j, i], R[j, j] = c, -s, s, c
    return R


@pytest.mark.parametrize("rx,ry,rz", [(30.0, 0.0, 0.0), (0.0, -45.0, 0.0), (0.0, 0.0, 120.0), (-170.5, 12.25, 88.0)])
def test_yaskawa_rx_ry_rz_are_fanuc_w_p_r(rx, ry, rz):
    # fixed axes, x first: a vector turned about x, then about the (unmoved) y, then about the (unmoved) z
    v = np.array([0.3, -0.5, 0.8])
    turned = _about(2, rz) @ (_about(1, ry) @ (_about(0, rx) @ v))
    np.testing.assert_allclose(matrix_from_fanuc_wpr([rx, ry, rz]) @ v, turned, atol=FLOAT)


def test_yaskawa_pose_file_through_fanuc_columns(tmp_path):
    """Yaskawa's X Y Z in mm and Rx Ry Rz in degrees, as the pendant shows them, in the .x .y .z .w .p .r columns."""
    poses = [(450.0, -120.0, 300.0, 180.0, 0.0, 90.0), (500.5, 20.0, 250.0, -170.5, 12.25, 88.0)]
    camera = "0,0,0.5,0,0,0,1"
    header = ",".join(f"T_base_ee.{c}" for c in "xyzwpr") + "," + ",".join(f"T_cam_target.{c}" for c in "xyz")
    header += ",T_cam_target.qx,T_cam_target.qy,T_cam_target.qz,T_cam_target.qw"
    rows = [",".join(f"{v:g}" for v in p) + "," + camera for p in poses]
    path = tmp_path / "yaskawa.csv"
    path.write_text(header + "\n" + "\n".join(rows) + "\n")
    T = read_pose_file(path).T_base_ee
    for k, (x, y, z, rx, ry, rz) in enumerate(poses):
        np.testing.assert_allclose(T[k, :3, 3], np.array([x, y, z]) / 1000, atol=EXACT)  # millimetres by default
        np.testing.assert_allclose(T[k, :3, :3], _about(2, rz) @ _about(1, ry) @ _about(0, rx), atol=EXACT)
