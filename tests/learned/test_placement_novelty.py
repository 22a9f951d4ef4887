"""Selection's placement-level novelty (keypoint model): a pose is judged by the one pose fitted to all its frames.

The network's predictions are replaced by exact keypoints seen from a known, displaced camera pose per
placement, so the placement error is known in advance: the displacement.
"""

from __future__ import annotations

from dataclasses import replace

import numpy as np
import pytest

pytest.importorskip("torch")

import learned.keypoints  # noqa: E402
import learned.trainer  # noqa: E402
from handeye.core.errors import HandEyeInputError  # noqa: E402
from handeye.core.se3 import matrix_from_quat_xyzw  # noqa: E402
from learned.continual_step import sample_error  # noqa: E402
from learned.data import with_keypoints  # noqa: E402
from learned.experiment import time_steps  # noqa: E402
from learned.keypoints import keypoint_targets  # noqa: E402
from learned.model import make_network  # noqa: E402
from learned.presets import Preset  # noqa: E402
from learned.strategies import make_strategy  # noqa: E402
from learned.trainer import TrainConfig, placement_error  # noqa: E402
from tests.learned._synthetic import make_frames  # noqa: E402
from tests.tolerances import FLOAT, FLOAT32_QUATERNION_DEG  # noqa: E402

PRESET = Preset("novelty", (32, 32), (4, 8, 8), (16,), repeats=1)
FIRST, LATER = TrainConfig(epochs=1, batch_size=16), TrainConfig(epochs=1, batch_size=16)
K_NORM = np.array([0.9, 0.9, 0.5, 0.5])
FRAMES_PER_CAMERA = 10


@pytest.fixture(scope="module")
def kframes():
    """Synthetic frames with 6 keypoints per frame 1.2-1.8 m in front of the labelled camera, inside the image."""
    frames = make_frames(
        np.random.default_rng(0),
        regions=((0, 60), (120, 180), (240, 300)),
        train_per_region=3,
        test_per_region=1,
        frames_per_camera=FRAMES_PER_CAMERA,
    )
    rng = np.random.default_rng(5)
    n, k = len(frames), 6
    z = rng.uniform(1.2, 1.8, (n, k))
    xy = rng.uniform(0.15, 0.85, (n, k, 2))
    p_cam = np.stack([(xy[..., 0] - 0.5) / 0.9 * z, (xy[..., 1] - 0.5) / 0.9 * z, z], axis=-1)
    R = matrix_from_quat_xyzw(frames.q_base_cam_xyzw.astype(float))
    p_base = np.einsum("nij,nkj->nki", R, p_cam) + frames.t_base_cam_mm[:, None, :] / 1000.0
    return replace(with_keypoints(frames, p_base), intrinsics_norm=np.tile(K_NORM, (n, 1)))


def _fake_predictions(monkeypatch, kframes, shift_mm_of_camera):
    """The "network" sees each camera displaced by ``shift_mm_of_camera[c]`` mm along the base x axis."""
    shift = np.array([[shift_mm_of_camera.get(int(c), 0.0), 0.0, 0.0] for c in kframes.camera])
    pred = keypoint_targets(
        kframes.keypoints_base.astype(float),
        kframes.t_base_cam_mm + shift,
        kframes.q_base_cam_xyzw,
        kframes.intrinsics_norm,
    )
    monkeypatch.setattr(learned.trainer, "predict", lambda model, frames, index=None, **kw: pred[np.asarray(index)])
    monkeypatch.setattr(learned.keypoints, "model_residual_stats", lambda model: None)  # the plain 3-D to 3-D fit


def _is_displacement(err, shift_mm, scale_mm):
    """``err`` (mm, deg) is the displacement and no turn: to float64 rounding (FLOAT) of positions of up to
    ``scale_mm``, and to a float32 label quaternion's rounding."""
    assert abs(err[0] - shift_mm) <= FLOAT * scale_mm, err
    assert abs(err[1]) <= FLOAT32_QUATERNION_DEG, err


def test_placement_error_is_the_displacement_of_the_fitted_pose(kframes, monkeypatch):
    cams = kframes.cameras("train")
    _fake_predictions(monkeypatch, kframes, {int(cams[0]): 0.0, int(cams[1]): 20.0})
    model = make_network(PRESET.model_config("keypoints", n_keypoints=6))
    exact = placement_error(model, kframes, np.flatnonzero(kframes.camera == cams[0]))
    shifted = placement_error(model, kframes, np.flatnonzero(kframes.camera == cams[1]))
    # the predictions are exact for the float32 labels: the fit is exact to rounding
    scale_mm = np.abs(kframes.t_base_cam_mm).max() + 20.0
    _is_displacement(exact, 0.0, scale_mm)
    _is_displacement(shifted, 20.0, scale_mm)
    # the novelty measure uses every frame of the pose, and draws nothing
    rng = np.random.default_rng(0)
    state = rng.bit_generator.state
    err, n = sample_error(model, kframes, np.flatnonzero(kframes.camera == cams[1]), 0.1, rng, "placement")
    _is_displacement(err, 20.0, scale_mm)
    assert n == FRAMES_PER_CAMERA and rng.bit_generator.state == state


def test_placement_error_refuses_frames_of_two_placements_and_the_papers_networks(kframes):
    model = make_network(PRESET.model_config("keypoints", n_keypoints=6))
    two = np.flatnonzero(np.isin(kframes.camera, kframes.cameras("train")[:2]))
    with pytest.raises(HandEyeInputError, match="one camera placement"):
        placement_error(model, kframes, two)
    with pytest.raises(HandEyeInputError, match="keypoint model"):
        placement_error(make_network(PRESET.model_config("translation")), kframes, two[:3])
    with pytest.raises(ValueError, match="keypoint model"):
        make_strategy(
            "selection", PRESET.model_config("translation"), FIRST, LATER, np.random.default_rng(0), novelty="placement"
        )
    with pytest.raises(ValueError, match="unknown novelty"):
        make_strategy(
            "selection", PRESET.model_config("translation"), FIRST, LATER, np.random.default_rng(0), novelty="pose"
        )


def test_selection_skips_exactly_the_placements_below_the_threshold(kframes, monkeypatch):
    steps = time_steps(kframes)
    later = [int(c) for s in steps[1:] for c in s]
    # alternate 5 mm and 20 mm displacements over the later poses; the threshold, 10 mm, lies between
    shift = {c: (5.0 if i % 2 == 0 else 20.0) for i, c in enumerate(later)}
    _fake_predictions(monkeypatch, kframes, shift)
    sel = make_strategy(
        "selection",
        PRESET.model_config("keypoints", n_keypoints=6),
        FIRST,
        LATER,
        np.random.default_rng(1),
        c1=4,
        threshold_mm=10.0,
        threshold_deg=1.0,
        novelty="placement",
    )
    for k, cams in enumerate(steps):
        sel.step(k, cams, kframes, last=k == len(steps) - 1)
    assert sel.skipped == [c for c in later if shift[c] == 5.0]
    assert [c for s in sel.trained_on[1:] for c in s] == [c for c in later if shift[c] == 20.0]
    assert sel.evaluated == len(later) * FRAMES_PER_CAMERA  # every frame of every later pose


def test_the_forgetting_finding_reads_the_placement_matrix_where_one_was_recorded():
    """Per frame naive improves on S1 (0.5x); per placement it forgets (4x): the report says both."""
    from learned.report import findings

    runs = [
        {
            "strategy": "naive",
            "network": net,
            "repeat": 0,
            "matrix": [[200.0, 300.0], [100.0, 90.0]],  # steps x subsets, per-frame means
            "placement_matrix": [[5.0, 40.0], [20.0, 6.0]],
        }
        for net in ("translation", "orientation")
    ]
    lines = findings({"strategies": ["naive"], "runs": runs, "family": "keypoints", "preset": {}})
    per_frame = [x for x in lines if x.startswith("translation: naive forgets S1:")]
    per_placement = [x for x in lines if x.startswith("translation: naive forgets S1, per placement")]
    assert "(0.5x" in per_frame[0] and "NOT reproduced" in per_frame[0]
    assert "5.00 mm after step 1, 20.00 mm at the last step (4.0x" in per_placement[0]
    assert per_placement[0].endswith(": reproduced")
    # a run without the matrix (the paper's networks, or saved before it existed): the per-frame line alone
    lines = findings({"strategies": ["naive"], "runs": [{**r, "placement_matrix": []} for r in runs], "preset": {}})
    assert not any("per placement" in x for x in lines)
