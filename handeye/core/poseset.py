"""Paired poses as a file gives them, and the units they may come in: shared by the pose-file readers.

Its own module so that :mod:`handeye.core.posefile` (which reads easy_handeye's YAML through
:mod:`handeye.core.easy_handeye`) and :mod:`handeye.core.easy_handeye` both import it, and not each other.
"""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np

__all__ = ["UNIT_SCALE", "PoseSet"]

#: Metres per unit of a pose file's translations.
UNIT_SCALE = {"m": 1.0, "mm": 1e-3}


@dataclass
class PoseSet:
    """Paired poses read from a file.

    Attributes
    ----------
    T_base_ee : array, shape (N, 4, 4)
    T_cam_target : array, shape (N, 4, 4)
    source : str
    rows : list of int
        The file's row (CSV line number, YAML line number, or JSON list index) of each pose, for messages.
    frames : dict
        Frame names the file gives, by the project's name (``base``, ``ee``, ``cam``, ``target``); empty
        when it gives none (easy_handeye2 sample files may).
    """

    T_base_ee: np.ndarray
    T_cam_target: np.ndarray
    source: str
    rows: list = field(default_factory=list)
    frames: dict = field(default_factory=dict)
