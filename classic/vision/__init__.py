"""ChArUco vision: board specs, detection, PnP, intrinsics, reprojection refinement.

Needs OpenCV 4.x (``pip install "handeye[vision]"``); importing this package
without it raises an error naming the extra. ``import classic`` alone never
imports OpenCV.

Target frame (OpenCV's ChArUco board frame, stated once): origin at the outer
top-left corner of the board as drawn by :meth:`BoardSpec.render`, x along the
columns of squares (right in the drawing), y along the rows (down), z into the
board. Inner corner ``k = r * (squares_x - 1) + c`` sits at
``((c + 1) L, (r + 1) L, 0)`` metres, ``L`` the square length.
"""

from handeye.core.optional import require_package

require_package("cv2", extra="vision", purpose="ChArUco board detection")

from classic.vision.board import BoardSpec  # noqa: E402
from classic.vision.camera import CameraIntrinsics  # noqa: E402
from classic.vision.detect import Detection, ViewPose, detect_board, estimate_pose  # noqa: E402
from classic.vision.images import read_image  # noqa: E402
from classic.vision.intrinsics import IntrinsicsResult, calibrate_intrinsics  # noqa: E402
from classic.vision.reprojection import ReprojectionOptions, ReprojectionResult, refine_reprojection  # noqa: E402

__all__ = [
    "BoardSpec",
    "CameraIntrinsics",
    "Detection",
    "ViewPose",
    "detect_board",
    "estimate_pose",
    "read_image",
    "IntrinsicsResult",
    "calibrate_intrinsics",
    "ReprojectionOptions",
    "ReprojectionResult",
    "refine_reprojection",
]
