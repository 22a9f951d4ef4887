"""Frames with a known camera pose per camera, built so a small network can learn them quickly.

Each camera's images encode its azimuth smoothly: the colour channels are
sinusoids whose phase is the azimuth and the depth is a ramp whose slope
follows the elevation, so cameras close in azimuth look alike and a network
can interpolate within a region, while regions (azimuth sectors) look
different: training on one region only pulls predictions away from another's.
"""

from __future__ import annotations

import numpy as np

from handeye.core.se3 import quat_xyzw_from_matrix
from learned.data import FrameSet


def _look_at_rotation(position: np.ndarray, target: np.ndarray) -> np.ndarray:
    z = (target - position) / np.linalg.norm(target - position)
    x = np.cross(z, [0.0, 0.0, 1.0])
    x /= np.linalg.norm(x)
    return np.column_stack([x, np.cross(z, x), z])


def make_frames(
    rng: np.random.Generator,
    regions=((0.0, 90.0), (180.0, 270.0)),
    train_per_region=4,
    test_per_region=2,
    frames_per_camera=12,
    size=(32, 32),
) -> FrameSet:
    """Frames of cameras spread over azimuth regions; targets are the exact camera poses (label = truth)."""
    w, h = size
    u, v = np.meshgrid(np.linspace(0, 1, w), np.linspace(0, 1, h))
    rgb, depth, pose_base_ref, t_mm, q_xyzw, camera, region, split = [], [], [], [], [], [], [], []
    cam_id = 0
    for r, (a0, a1) in enumerate(regions):
        n = train_per_region + test_per_region
        azimuths = np.linspace(a0, a1, n + 2)[1:-1]
        is_test = np.zeros(n, bool)
        is_test[np.arange(1, n, max(1, n // test_per_region))[:test_per_region]] = True
        for k, az in enumerate(azimuths):
            a, el = np.radians(az), np.radians(35.0)
            position = 1.5 * np.array([np.cos(el) * np.cos(a), np.cos(el) * np.sin(a), np.sin(el)])
            R = _look_at_rotation(position, np.array([0.0, 0.0, 0.3]))
            quat = quat_xyzw_from_matrix(R)  # w >= 0
            for _ in range(frames_per_camera):
                phase = a + rng.normal(scale=0.02)
                img = np.stack(
                    [
                        np.sin(2 * np.pi * u + phase),
                        np.cos(2 * np.pi * v + phase),
                        np.sin(2 * np.pi * (u + v) + 2 * phase),
                    ]
                )
                rgb.append(np.clip(127.5 + 120 * img + rng.normal(scale=3, size=img.shape), 0, 255).astype(np.uint8))
                depth.append((1.0 + 0.5 * np.cos(a) * u + 0.5 * np.sin(a) * v)[None].astype(np.float16))
                pose_base_ref.append(np.concatenate([rng.uniform(-0.4, 0.4, 3), [0.0, 0.0, 0.0, 1.0]]))
                t_mm.append(1000 * position)
                q_xyzw.append(quat)
                camera.append(cam_id)
                region.append(r)
                split.append("test" if is_test[k] else "train")
            cam_id += 1
    n = len(camera)
    t_mm, q_xyzw = np.array(t_mm, np.float32), np.array(q_xyzw, np.float32)
    return FrameSet(
        np.array(rgb),
        np.array(depth),
        np.array(pose_base_ref, np.float32),
        t_mm,
        q_xyzw,
        np.array(camera),
        np.array(region),
        np.array(split),
        t_mm.astype(float),
        q_xyzw.astype(float),
        "truth",
        (w, h),
    )


#: The counting tests' setting: three regions of 3 training poses and 1 test pose, 10 frames each, a small
#: network, two epochs on the first step and one on each later step (the strategies' arithmetic is exact).
FRAMES_PER_CAMERA = 10
TRAIN_PER_REGION = 3


def count_setting():
    """``(preset, first, later)`` of the counting tests (imported here, so this module stays torch-free)."""
    from learned.presets import Preset
    from learned.trainer import TrainConfig

    return (
        Preset("count", (32, 32), (4, 8, 8), (16,), repeats=1),
        TrainConfig(epochs=2, batch_size=16),
        TrainConfig(epochs=1, batch_size=16),
    )


def count_frames() -> FrameSet:
    """The counting tests' frames: three regions 120 deg apart."""
    return make_frames(
        np.random.default_rng(0),
        regions=((0, 60), (120, 180), (240, 300)),
        train_per_region=TRAIN_PER_REGION,
        test_per_region=1,
        frames_per_camera=FRAMES_PER_CAMERA,
    )
