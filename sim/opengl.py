"""The one place where OpenGL camera conventions meet OpenCV's.

pyrender cameras look down their -z axis with y up; OpenCV cameras look down
+z with y down. The pose of the OpenCV camera in the OpenGL camera frame is
``T_GLCAM_CVCAM = diag(1, -1, -1, 1)``, so ``T_world_glcam = T_world_cvcam @
T_GLCAM_CVCAM`` (the matrix is its own inverse). OpenGL puts pixel centres at
half-integers, OpenCV at integers: the principal point moves by half a pixel.
Nothing outside ``sim/`` sees an OpenGL pose.
"""

from __future__ import annotations

import numpy as np

__all__ = ["T_GLCAM_CVCAM", "gl_camera_pose", "gl_principal_point"]

#: Pose of the OpenCV camera frame in the OpenGL camera frame (and the reverse: it is an involution).
T_GLCAM_CVCAM = np.diag([1.0, -1.0, -1.0, 1.0])


def gl_camera_pose(T_world_cvcam: np.ndarray) -> np.ndarray:
    """``T_world_glcam`` of an OpenCV camera pose, for pyrender.

    Parameters
    ----------
    T_world_cvcam : array, shape (4, 4)

    Returns
    -------
    T_world_glcam : array, shape (4, 4)
    """
    return np.asarray(T_world_cvcam, dtype=float) @ T_GLCAM_CVCAM


def gl_principal_point(cx: float, cy: float) -> tuple[float, float]:
    """pyrender's ``IntrinsicsCamera`` principal point for an OpenCV one (pixel centres at integers).

    pyrender maps a camera-frame point to window coordinates ``fx x / z + cx``,
    in which pixel ``i`` spans ``[i, i + 1)``; OpenCV puts pixel ``i``'s centre
    at ``i``. So the OpenGL principal point is half a pixel further.
    """
    return cx + 0.5, cy + 0.5
