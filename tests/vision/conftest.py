"""Rendered views shared by the vision tests: rendering is the slow part, so each view is drawn once."""

from __future__ import annotations

from dataclasses import dataclass
from pathlib import Path

import cv2
import numpy as np
import pytest

from classic.vision.synthetic import render_view
from handeye.core.synthetic import HandEyeProblem, make_problem
from tests.vision._helpers import CENTRE, INTR, SPEC, board_pose

#: Seeds of the single-view poses, and the image noise levels each is drawn with.
POSE_SEEDS = (0, 1, 2, 3)
NOISE_LEVELS = (2.0, 8.0)
#: Hand-eye recordings: views per setup and the seed of each.
HANDEYE_VIEWS = 10
HANDEYE_SEEDS = {"eye_to_hand": 10, "eye_in_hand": 11}
HANDEYE_NOISE_GRAY = 2.0


@dataclass
class RenderedView:
    seed: int
    noise_gray: float
    T_cam_target: np.ndarray
    image: np.ndarray


@dataclass
class Recording:
    problem: HandEyeProblem
    paths: list[Path]


@pytest.fixture(scope="session")
def rendered_views() -> list[RenderedView]:
    """One view per (pose seed, noise level): board 0.4 to 0.8 m away, tilted 10 to 40 degrees."""
    views = []
    for seed in POSE_SEEDS:
        T = board_pose(np.random.default_rng(seed))
        for noise in NOISE_LEVELS:
            image = render_view(SPEC, INTR, T, noise, np.random.default_rng([seed, int(noise)]))
            views.append(RenderedView(seed, noise, T, image))
    return views


@pytest.fixture(scope="session")
def handeye_recordings(tmp_path_factory) -> dict[str, Recording]:
    """A hand-eye recording per setup: make_problem's geometry with the board centred, views as PNG files."""
    out = {}
    for setup, seed in HANDEYE_SEEDS.items():
        rng = np.random.default_rng(seed)
        p = make_problem(HANDEYE_VIEWS, setup, rng)
        p.T_cam_target = p.T_cam_target @ CENTRE
        p.Y_true = p.Y_true @ CENTRE  # A_i (Y c) = X (B_i c) in both setups
        folder = tmp_path_factory.mktemp(setup)
        paths = []
        for k, T in enumerate(p.T_cam_target):
            path = folder / f"view_{k:03d}.png"
            assert cv2.imwrite(str(path), render_view(SPEC, INTR, T, HANDEYE_NOISE_GRAY, rng))
            paths.append(path)
        out[setup] = Recording(p, paths)
    return out
