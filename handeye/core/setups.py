"""The two hand-eye setups and the one equation both reduce to.

Both setups are written as ``A_i Y = X B_i`` with ``B_i = T_cam_target(i)``
(what the camera measures), ``X`` the camera's pose and ``Y`` the target's:

=============  ===============  ==============  =================  ===============
setup          ``A_i``          ``X``           ``Y``              check
=============  ===============  ==============  =================  ===============
eye_to_hand    ``T_base_ee``    ``T_base_cam``  ``T_ee_target``    ``T_base_target = A_i Y = X B_i``
eye_in_hand    ``T_ee_base``    ``T_ee_cam``    ``T_base_target``  ``T_ee_target = A_i Y = X B_i``
=============  ===============  ==============  =================  ===============

so eye-in-hand only inverts the robot poses (as OpenCV's documentation does in
the other direction). Motions between poses i and j then satisfy
``A_ij X = X B_ij`` with ``A_ij = A_j A_i^-1`` and ``B_ij = B_j B_i^-1``.
"""

from __future__ import annotations

import numpy as np

from handeye.core.errors import HandEyeInputError
from handeye.core.se3 import invert_transform

__all__ = ["SETUPS", "UNKNOWN_NAMES", "normalize_setup", "robot_side_poses"]

SETUPS = ("eye_to_hand", "eye_in_hand")

#: Frame names of (X, Y) for each setup.
UNKNOWN_NAMES = {
    "eye_to_hand": ("T_base_cam", "T_ee_target"),
    "eye_in_hand": ("T_ee_cam", "T_base_target"),
}


def normalize_setup(setup: str) -> str:
    """Canonical setup name; accepts ``eye-to-hand``, ``eye_to_hand``, any case.

    Parameters
    ----------
    setup : str

    Returns
    -------
    setup : {"eye_to_hand", "eye_in_hand"}

    Raises
    ------
    HandEyeInputError
        For any other name.
    """
    key = str(setup).strip().lower().replace("-", "_").replace(" ", "_")
    if key not in SETUPS:
        raise HandEyeInputError(
            f"unknown setup {setup!r}: use 'eye_to_hand' (static camera, target on the robot) "
            "or 'eye_in_hand' (camera on the robot, static target)"
        )
    return key


def robot_side_poses(T_base_ee: np.ndarray, setup: str) -> np.ndarray:
    """The ``A_i`` of ``A_i Y = X B_i``: ``T_base_ee`` or its inverse ``T_ee_base``.

    Parameters
    ----------
    T_base_ee : array, shape (N, 4, 4)
    setup : {"eye_to_hand", "eye_in_hand"}

    Returns
    -------
    A : array, shape (N, 4, 4)
    """
    return T_base_ee if normalize_setup(setup) == "eye_to_hand" else invert_transform(T_base_ee)
