"""OpenCV 4.x for the benchmarks that compare with it, and its hand-eye method flags by this project's names."""

from __future__ import annotations

import sys


def opencv():
    """``cv2``, or exit with what to install (OpenCV 5 has no ``calibrateHandEye``)."""
    try:
        import cv2
    except ImportError:
        sys.exit('this benchmark compares with OpenCV 4.x: pip install "handeye[test]"')
    if not hasattr(cv2, "calibrateHandEye"):
        sys.exit(f"OpenCV {cv2.__version__} has no calibrateHandEye (OpenCV 5 dropped it): install opencv 4.x")
    return cv2


cv2 = opencv()
#: AX=XB methods (``cv2.calibrateHandEye``) and AX=YB methods (``cv2.calibrateRobotWorldHandEye``).
CV_AXXB = {
    "tsai": cv2.CALIB_HAND_EYE_TSAI,
    "park": cv2.CALIB_HAND_EYE_PARK,
    "horaud": cv2.CALIB_HAND_EYE_HORAUD,
    "andreff": cv2.CALIB_HAND_EYE_ANDREFF,
    "daniilidis": cv2.CALIB_HAND_EYE_DANIILIDIS,
}
CV_AXYB = {"shah": cv2.CALIB_ROBOT_WORLD_HAND_EYE_SHAH, "li": cv2.CALIB_ROBOT_WORLD_HAND_EYE_LI}
