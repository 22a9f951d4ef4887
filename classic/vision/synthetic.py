"""Synthetic board views: a known camera looking at a known board, for tests and benchmarks.

:func:`render_view` draws the board as a camera with intrinsics ``K`` and
distortion sees it from ``T_cam_target``: every image pixel is back-projected
(undistorted), intersected with the board plane and looked up in the board
image, supersampled, then Gaussian intensity noise is added.
"""

from __future__ import annotations

import cv2
import numpy as np

from classic.vision.board import BoardSpec
from classic.vision.camera import CameraIntrinsics
from handeye.core.safe_write import write_bytes_atomic, write_text_atomic
from handeye.core.se3 import invert_transform

__all__ = ["render_view", "default_intrinsics"]


def default_intrinsics(width: int = 640, height: int = 480, distorted: bool = True) -> CameraIntrinsics:
    """A plausible camera: 60 degree horizontal field of view, mild barrel distortion."""
    f = 0.5 * width / np.tan(np.radians(30))
    K = np.array([[f, 0, (width - 1) / 2 + 3.0], [0, f * 1.002, (height - 1) / 2 - 2.0], [0, 0, 1]])
    dist = np.array([-0.12, 0.05, 0.001, -0.0005, 0.0]) if distorted else np.zeros(5)
    return CameraIntrinsics(K, dist, width, height)


def render_view(
    spec: BoardSpec,
    intr: CameraIntrinsics,
    T_cam_target: np.ndarray,
    noise_gray: float = 0.0,
    rng: np.random.Generator | None = None,
    supersample: int = 3,
    background: int = 128,
) -> np.ndarray:
    """Image of the board seen by the camera.

    Parameters
    ----------
    spec : BoardSpec
    intr : CameraIntrinsics
        With ``width`` and ``height`` set.
    T_cam_target : array, shape (4, 4)
    noise_gray : float
        Standard deviation of additive Gaussian intensity noise, gray levels.
    rng : numpy.random.Generator, optional
    supersample : int
        Samples per pixel along each axis (anti-aliasing).
    background : int
        Gray level outside the board.

    Returns
    -------
    image : array of uint8, shape (height, width)
    """
    rng = np.random.default_rng(0) if rng is None else rng
    W, H, s = intr.width, intr.height, supersample
    # back-projection of the supersampled grid: undistort a coarse grid, interpolate (the map is smooth)
    step = 4
    gu = np.arange(0, W * s + step, step)
    gv = np.arange(0, H * s + step, step)
    guu, gvv = np.meshgrid((gu + 0.5) / s - 0.5, (gv + 0.5) / s - 0.5)
    pts = np.stack([guu.ravel(), gvv.ravel()], axis=1).reshape(-1, 1, 2)
    criteria = (cv2.TERM_CRITERIA_COUNT | cv2.TERM_CRITERIA_EPS, 40, 1e-10)
    coarse = cv2.undistortPointsIter(pts, intr.K, intr.dist, None, None, criteria).reshape(len(gv), len(gu), 2)
    fine_u = (np.arange(W * s) / step).astype(np.float32)
    fine_v = (np.arange(H * s) / step).astype(np.float32)
    mu, mv = np.meshgrid(fine_u, fine_v)
    xy = np.stack([cv2.remap(coarse[..., k].astype(np.float32), mu, mv, cv2.INTER_CUBIC) for k in (0, 1)], axis=-1)
    xy = xy.reshape(-1, 2).astype(float)
    T_target_cam = invert_transform(T_cam_target)
    R, c = T_target_cam[:3, :3], T_target_cam[:3, 3]
    d = np.column_stack([xy, np.ones(len(xy))]) @ R.T
    with np.errstate(divide="ignore", invalid="ignore"):
        lam = -c[2] / d[:, 2]
    X = c[0] + lam * d[:, 0]
    Y = c[1] + lam * d[:, 1]
    behind = ~(lam > 0)
    # board texture: ppm chosen so a texel is smaller than a sample at the nearest corner
    depth = (T_cam_target @ np.column_stack([spec.corners_target(), np.ones(spec.n_corners)]).T)[2]
    nearest = depth[depth > 0].min() if np.any(depth > 0) else 1.0
    ppm = min(2.0 * s * intr.K[0, 0] / max(nearest, 0.05), 8000.0 / max(spec.size_m))
    if spec.kind == "aruco_grid":  # a pitch whose markers are whole pixels too, so the texture's scale is exact
        n0 = spec.pixels_per_square(ppm)
        ratio = spec.marker_length_m / spec.square_length_m
        n = next((n for n in range(n0, n0 + 1000) if abs(n * ratio - round(n * ratio)) < 1e-6), n0)
        ppm = n / spec.square_length_m
    margin = 2
    tex = spec.render(ppm, margin_px=margin)
    ppm_x = (tex.shape[1] - 2 * margin) / spec.size_m[0]
    ppm_y = (tex.shape[0] - 2 * margin) / spec.size_m[1]
    map_x = (X * ppm_x + margin - 0.5).astype(np.float32)
    map_y = (Y * ppm_y + margin - 0.5).astype(np.float32)
    map_x[behind] = -1e6
    big = cv2.remap(
        tex,
        map_x.reshape(H * s, W * s),
        map_y.reshape(H * s, W * s),
        cv2.INTER_LINEAR,
        borderMode=cv2.BORDER_CONSTANT,
        borderValue=background,
    )
    img = cv2.resize(big.astype(np.float32), (W, H), interpolation=cv2.INTER_AREA)
    if noise_gray > 0:
        img = img + rng.normal(scale=noise_gray, size=img.shape)
    return np.clip(np.round(img), 0, 255).astype(np.uint8)


def make_image_dataset(
    folder,
    n_views: int,
    setup: str = "eye_to_hand",
    spec: BoardSpec | None = None,
    intr: CameraIntrinsics | None = None,
    rng: np.random.Generator | None = None,
    noise_gray: float = 2.0,
    max_tilt_deg: float = 35.0,
):
    """Write a synthetic hand-eye recording: board images, robot poses and the truth.

    The geometry is :func:`handeye.core.synthetic.make_problem`'s, with the board
    centred where that problem puts the target.

    Parameters
    ----------
    folder : str or Path
        Created if missing; receives ``images/view_###.png``, ``robot.csv``
        (``image`` column plus ``T_base_ee``), ``board.json``, ``camera.json``
        and ``truth.json`` (``X`` and ``Y`` by frame name).
    n_views : int
    setup : {"eye_to_hand", "eye_in_hand"}
    spec : BoardSpec, optional
        Default 7x5 squares of 4 cm, 3 cm markers, 5X5_100.
    intr : CameraIntrinsics, optional
        Default :func:`default_intrinsics`.
    rng : numpy.random.Generator, optional
    noise_gray : float
        Image intensity noise.
    max_tilt_deg : float

    Returns
    -------
    problem : handeye.core.synthetic.HandEyeProblem
        With ``T_cam_target`` and ``Y_true`` of the centred board.
    """
    import json
    from pathlib import Path

    from handeye.core.se3 import make_transform, pos_quat_xyzw_from_transform
    from handeye.core.setups import UNKNOWN_NAMES
    from handeye.core.synthetic import make_problem

    rng = np.random.default_rng(0) if rng is None else rng
    spec = spec or BoardSpec(7, 5, 0.04, 0.03, "5X5_100")
    intr = intr or default_intrinsics()
    folder = Path(folder)
    (folder / "images").mkdir(parents=True, exist_ok=True)
    p = make_problem(n_views, setup, rng, max_tilt_deg=max_tilt_deg)
    centre = make_transform(np.eye(3), [-spec.size_m[0] / 2, -spec.size_m[1] / 2, 0.0])
    p.T_cam_target = p.T_cam_target @ centre
    p.Y_true = p.Y_true @ centre  # A_i (Y c) = X (B_i c) in both setups
    rows = ["image,T_base_ee.x,T_base_ee.y,T_base_ee.z,T_base_ee.qx,T_base_ee.qy,T_base_ee.qz,T_base_ee.qw"]
    for k in range(n_views):
        name = f"view_{k:03d}.png"
        _, png = cv2.imencode(".png", render_view(spec, intr, p.T_cam_target[k], noise_gray, rng))
        write_bytes_atomic(folder / "images" / name, png.tobytes())  # cv2.imwrite says nothing when it fails
        t, q = pos_quat_xyzw_from_transform(p.T_base_ee[k])
        rows.append(",".join([name] + [f"{v:.12g}" for v in (*t, *q)]))
    write_text_atomic(folder / "robot.csv", "\n".join(rows) + "\n")
    spec.save(folder / "board.json")
    intr.save(folder / "camera.json")
    x_name, y_name = UNKNOWN_NAMES[setup]
    write_text_atomic(
        folder / "truth.json", json.dumps({x_name: p.X_true.tolist(), y_name: p.Y_true.tolist()}, indent=2)
    )
    return p
