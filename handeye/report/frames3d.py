"""The calibrated cell in 3-D: base, camera, target and end-effector frames in the robot base frame."""

from __future__ import annotations

from pathlib import Path

import numpy as np

from handeye.report.style import AXIS_COLORS, COLORS, pyplot, save_figure

__all__ = ["cell_frames", "frames_figure"]


def cell_frames(setup: str, X: np.ndarray, Y: np.ndarray, T_base_ee: np.ndarray) -> dict:
    """Every frame of the cell in the base frame, from the calibration and the robot poses.

    Parameters
    ----------
    setup : {"eye_to_hand", "eye_in_hand"}
    X, Y : array, shape (4, 4)
        ``T_base_cam`` and ``T_ee_target`` (eye-to-hand) or ``T_ee_cam`` and ``T_base_target`` (eye-in-hand).
    T_base_ee : array, shape (N, 4, 4)

    Returns
    -------
    dict
        ``T_base_ee``, ``T_base_cam`` and ``T_base_target``, each of shape (N, 4, 4): one per pose
        (the static one repeated).
    """
    n = len(T_base_ee)
    if setup == "eye_to_hand":
        return {"T_base_ee": T_base_ee, "T_base_cam": np.broadcast_to(X, (n, 4, 4)), "T_base_target": T_base_ee @ Y}
    return {"T_base_ee": T_base_ee, "T_base_cam": T_base_ee @ X, "T_base_target": np.broadcast_to(Y, (n, 4, 4))}


def _axes(ax, T, length, lw=1.6, alpha=1.0):
    o = T[:3, 3]
    for k in range(3):
        e = o + length * T[:3, k]
        ax.plot(*np.stack([o, e]).T, color=AXIS_COLORS[k], lw=lw, alpha=alpha, solid_capstyle="round")


def _frustum(ax, T_base_cam, size):
    """A camera pyramid along the optical axis (+z), x right, y down."""
    c = np.array([[-0.8, -0.6, 1.0], [0.8, -0.6, 1.0], [0.8, 0.6, 1.0], [-0.8, 0.6, 1.0]]) * size
    p = c @ T_base_cam[:3, :3].T + T_base_cam[:3, 3]
    o = T_base_cam[:3, 3]
    for k in range(4):
        ax.plot(*np.stack([o, p[k]]).T, color=COLORS["ink"], lw=0.8, alpha=0.7)
        ax.plot(*np.stack([p[k], p[(k + 1) % 4]]).T, color=COLORS["ink"], lw=0.8, alpha=0.7)


def _board(ax, T_base_target, size_xy):
    from mpl_toolkits.mplot3d.art3d import Poly3DCollection

    w, h = size_xy
    c = np.array([[0, 0, 0], [w, 0, 0], [w, h, 0], [0, h, 0]], dtype=float)
    p = c @ T_base_target[:3, :3].T + T_base_target[:3, 3]
    ax.add_collection3d(Poly3DCollection([p], facecolor=COLORS["accent"], alpha=0.25, edgecolor=COLORS["accent"]))


def _shown(n: int, most: int) -> np.ndarray:
    return np.unique(np.linspace(0, n - 1, min(n, most)).round().astype(int))


def _panel(ax, f: dict, setup: str, shown: np.ndarray, board, with_base: bool, title: str, view: tuple) -> None:
    """One view of the cell; its extent (and so the axis length) fits what it shows."""
    keys = ("T_base_ee", "T_base_cam", "T_base_target")
    pts = np.concatenate([f[k][:, :3, 3] for k in keys] + ([np.zeros((1, 3))] if with_base else []))
    centre = 0.5 * (pts.min(axis=0) + pts.max(axis=0))
    half = 0.55 * float(np.max(pts.max(axis=0) - pts.min(axis=0))) + 0.02
    L = 0.16 * half
    if with_base:
        _axes(ax, np.eye(4), 1.6 * L, lw=2.6)
        ax.text(*(-0.3 * L * np.ones(3)), "base", fontsize=9, weight="bold", color=COLORS["ink"])
    ee = f["T_base_ee"][:, :3, 3]
    ax.plot(*ee.T, color=COLORS["muted"], lw=0.8, alpha=0.8)
    for T in f["T_base_ee"]:
        _axes(ax, T, 0.45 * L, lw=1.0, alpha=0.75)
    moving = "T_base_target" if setup == "eye_to_hand" else "T_base_cam"
    board = board or (0.6 * L, 0.45 * L)
    for i in shown:
        cam, tgt = f["T_base_cam"][i], f["T_base_target"][i]
        ax.plot(*np.stack([cam[:3, 3], tgt[:3, 3]]).T, color=COLORS["muted"], lw=0.7, ls=":")
        mount = tgt if setup == "eye_to_hand" else cam
        ax.plot(*np.stack([f["T_base_ee"][i][:3, 3], mount[:3, 3]]).T, color=COLORS["ink"], lw=1.2)
        _axes(ax, f[moving][i], 0.8 * L)
        if setup == "eye_to_hand":
            _board(ax, tgt, board)
        else:
            _frustum(ax, cam, 0.7 * L)
    static = f["T_base_cam"][0] if setup == "eye_to_hand" else f["T_base_target"][0]
    _axes(ax, static, 1.2 * L, lw=2.2)
    label = {"fontsize": 9, "color": COLORS["ink"]}
    if setup == "eye_to_hand":
        _frustum(ax, static, 1.0 * L)
        ax.text(*static[:3, 3] + 0.3 * L, "camera", weight="bold", **label)
        ax.text(*f["T_base_target"][shown[0]][:3, 3] + 0.3 * L, "target", **label)
    else:
        _board(ax, static, board)
        ax.text(*static[:3, 3] + 0.3 * L, "target", weight="bold", **label)
        ax.text(*f["T_base_cam"][shown[0]][:3, 3] + 0.3 * L, "camera", **label)
    ax.text(*ee[shown[-1]] - 0.4 * L, "ee", **label)
    for k, setter in enumerate((ax.set_xlim, ax.set_ylim, ax.set_zlim)):
        setter(centre[k] - half, centre[k] + half)
    ax.set_box_aspect((1, 1, 1))
    for setter, name in ((ax.set_xlabel, "x [m]"), (ax.set_ylabel, "y [m]"), (ax.set_zlabel, "z [m]")):
        setter(name, labelpad=2)
    ax.tick_params(labelsize=7, pad=0)
    ax.view_init(elev=view[0], azim=view[1])
    ax.set_title(title, fontsize=10)


def frames_figure(
    path: str | Path,
    setup: str,
    X: np.ndarray,
    Y: np.ndarray,
    T_base_ee: np.ndarray,
    board_size_m: tuple[float, float] | None = None,
    most: int = 5,
) -> Path:
    """Draw the cell in the base frame and a close-up of the poses; equal aspect, axes x red, y green, z blue.

    Parameters
    ----------
    path : str or Path
        Output PNG.
    setup : {"eye_to_hand", "eye_in_hand"}
    X, Y : array, shape (4, 4)
        The calibration's camera and target poses (:mod:`handeye.core.setups`).
    T_base_ee : array, shape (N, 4, 4)
        Robot poses of the calibration.
    board_size_m : (float, float), optional
        The board's extent along the target's x and y, drawn as a plate from the target's origin;
        default a schematic plate.
    most : int
        Moving camera or target frames drawn at this many poses (the end-effector at all).

    Returns
    -------
    Path
    """
    plt = pyplot()
    from matplotlib.lines import Line2D

    f = cell_frames(setup, X, Y, T_base_ee)
    shown = _shown(len(T_base_ee), most)
    fig = plt.figure(figsize=(11.5, 5.6))
    _panel(
        fig.add_subplot(1, 2, 1, projection="3d"),
        f,
        setup,
        shown,
        board_size_m,
        True,
        "the cell in the robot base frame",
        (22, -58),
    )
    _panel(
        fig.add_subplot(1, 2, 2, projection="3d"),
        f,
        setup,
        shown,
        board_size_m,
        False,
        "close-up of the poses (base out of view)",
        (24, 32),
    )
    mount = "target" if setup == "eye_to_hand" else "camera"
    handles = [Line2D([], [], color=c, lw=2, label=f"{a} axis") for c, a in zip(AXIS_COLORS, "xyz")]
    handles += [
        Line2D([], [], color=COLORS["muted"], lw=0.8, label="end-effector path"),
        Line2D([], [], color=COLORS["ink"], lw=1.2, label=f"flange to {mount}"),
        Line2D([], [], color=COLORS["muted"], lw=0.8, ls=":", label="camera to target"),
    ]
    fig.legend(handles=handles, loc="lower center", ncol=6, bbox_to_anchor=(0.5, 0.0))
    fig.subplots_adjust(left=0.0, right=0.97, top=0.95, bottom=0.08, wspace=0.08)
    return save_figure(fig, path)
