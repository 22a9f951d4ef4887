"""Board detections without rendering: corners projected through the camera with pixel noise, robot poses
with an error the solver is not told, wrapped as the ``Views`` that ``handeye detect`` writes."""

from __future__ import annotations

from dataclasses import dataclass
from pathlib import Path

import numpy as np

from classic.vision.detect import Detection, estimate_pose
from classic.vision.views import View, Views
from handeye.core.synthetic import make_problem
from tests.vision._helpers import CENTRE, INTR, SPEC, corners_in_image

#: The issue's robot pose error per axis (deg, mm), and the corner detection's noise (px per axis).
ROBOT_ERROR = (0.05, 0.5)
CORNER_NOISE_PX = 0.1


@dataclass
class SyntheticRecording:
    """Views of a centred board, the robot poses as recorded (with their error) and the truth."""

    views: Views
    T_base_ee: np.ndarray
    X_true: np.ndarray
    Y_true: np.ndarray
    setup: str


def corner_views(setup: str, n_views: int, rng: np.random.Generator, robot_error=ROBOT_ERROR, intr=INTR):
    """Corner ids and pixels per view, the recorded robot poses, and the true X and Y.

    The corners come from the true poses through ``intr``; ``make_problem`` then moves the recorded
    ``T_base_ee`` by ``robot_error`` (deg, mm per axis: ``R <- R exp(w)``, ``t <- t + n``), which the solver
    is not told.
    """
    p = make_problem(n_views, setup, rng, robot_noise=robot_error)
    ids, uv = zip(*(corners_in_image(T, intr, CORNER_NOISE_PX, rng) for T in p.T_cam_target @ CENTRE))
    return list(ids), list(uv), p.T_base_ee, p.X_true, p.Y_true @ CENTRE


def recording(setup: str, n_views: int, rng: np.random.Generator, robot_error=ROBOT_ERROR) -> SyntheticRecording:
    """:func:`corner_views` as ``Views`` with their PnP poses, as ``handeye detect`` would leave them."""
    ids, uv, T_base_ee, X, Y = corner_views(setup, n_views, rng, robot_error)
    views = []
    for k, (i, u) in enumerate(zip(ids, uv)):
        det = Detection(i, u, 0, (INTR.width, INTR.height))
        views.append(View(f"view_{k:03d}.png", det, estimate_pose(det, SPEC, INTR)))
    return SyntheticRecording(Views(views, SPEC, INTR, Path(".")), T_base_ee, X, Y, setup)
