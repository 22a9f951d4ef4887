"""The report's 2-D figures: residual per pose, hold-out check, motion diversity."""

from __future__ import annotations

from pathlib import Path

import numpy as np

from handeye.report.style import COLORS, pyplot, save_figure

__all__ = ["residuals_figure", "holdout_figure", "motion_figure"]


def _bars(ax, labels, values, outlier, ylabel):
    colors = [COLORS["outlier"] if o else COLORS["inlier"] for o in outlier]
    x = np.arange(len(values))
    ax.bar(x, values, color=colors, width=0.72, edgecolor="white", linewidth=0.5)
    ax.set_ylabel(ylabel)
    ax.set_xticks(x)
    ax.set_xticklabels(labels, rotation=90 if max(map(len, labels), default=0) > 3 else 0, fontsize=8)
    ax.set_xlim(-0.7, len(values) - 0.3)
    ax.grid(axis="x", visible=False)
    return x


def _warning_line(ax, draw, level: float, label: str) -> None:
    """A warning level as a dashed line, ``draw`` being ``ax.axvline`` or ``ax.axhline``, and the legend naming it."""
    draw(level, color=COLORS["outlier"], ls="--", lw=1, label=label)
    ax.legend(loc="upper right", fontsize=8, frameon=True, framealpha=0.92, edgecolor="none")


def residuals_figure(
    path: str | Path,
    rotation_deg: np.ndarray,
    translation_mm: np.ndarray,
    inliers: np.ndarray,
    labels: list[str] | None = None,
) -> Path:
    """Bar chart of each pose's residual, rotation and translation, outliers in their own colour.

    Parameters
    ----------
    path : str or Path
        Output PNG.
    rotation_deg, translation_mm : array, shape (N,)
        Norm of each pose's residual of ``T_cam_target`` (:class:`classic.result.PoseResiduals`).
    inliers : array of bool, shape (N,)
    labels : list of str, optional
        Tick label per pose; default the pose index.

    Returns
    -------
    Path
    """
    plt = pyplot()
    from matplotlib.lines import Line2D
    from matplotlib.patches import Patch

    n = len(rotation_deg)
    labels = labels or [str(i) for i in range(n)]
    out = ~np.asarray(inliers, dtype=bool)
    fig, axes = plt.subplots(2, 1, figsize=(max(6.5, 0.32 * n + 2), 4.8), sharex=True)
    panels = ((axes[0], rotation_deg, "deg", "rotation"), (axes[1], translation_mm, "mm", "translation"))
    rms = []
    for ax, v, unit, name in panels:
        _bars(ax, labels, v, out, f"{name} [{unit}]")
        rms.append(f"{float(np.sqrt(np.mean(np.asarray(v)[~out] ** 2))):.3g} {unit}")
        ax.axhline(float(rms[-1].split()[0]), color=COLORS["ink"], lw=1, ls="--")
        ax.set_ylim(0, float(np.max(v, initial=0)) * 1.12 + 1e-12)
    axes[1].set_xlabel("pose")
    handles = [
        Patch(color=COLORS["inlier"], label="inlier"),
        Patch(color=COLORS["outlier"], label="outlier (excluded)"),
        Line2D([], [], color=COLORS["ink"], lw=1, ls="--", label=f"RMS of inliers ({rms[0]}, {rms[1]})"),
    ]
    fig.legend(handles=handles, loc="upper right", ncol=3, bbox_to_anchor=(1.0, 1.0))
    fig.tight_layout(rect=(0, 0, 1, 0.95))
    return save_figure(fig, path)


def holdout_figure(path: str | Path, check) -> Path:
    """Held-out prediction error per pose with its predicted 1- and 3-sigma.

    Parameters
    ----------
    path : str or Path
    check : handeye.report.holdout.HoldOutCheck

    Returns
    -------
    Path
    """
    plt = pyplot()
    from matplotlib.lines import Line2D
    from matplotlib.patches import Patch

    labels = [str(i) for i in check.indices]
    fig, axes = plt.subplots(1, 2, figsize=(max(9.0, 0.5 * len(labels) + 3), 3.4))
    s = check.summary
    for ax, err, sig, unit, name, ratio in (
        (axes[0], check.rotation_deg, check.sigma_rotation_deg, "deg", "rotation", s["ratio_rotation"]),
        (axes[1], check.translation_mm, check.sigma_translation_mm, "mm", "translation", s["ratio_translation"]),
    ):
        x = _bars(ax, labels, err, err > 3 * sig, f"prediction error [{unit}]")
        ax.plot(x, sig, ls="none", marker="_", ms=14, mew=2.2, color=COLORS["ink"])
        ax.plot(x, 3 * sig, ls="none", marker="_", ms=14, mew=2.2, color=COLORS["accent"])
        ax.set_xlabel("held-out pose")
        ax.set_title(f"{name}: RMS error / RMS sigma = {ratio:.2f}", fontsize=10)
        ax.set_ylim(0, max(float(np.max(3 * sig, initial=0)), float(np.max(err, initial=0))) * 1.15 + 1e-12)
    handles = [
        Patch(color=COLORS["inlier"], label="error within 3 sigma"),
        Patch(color=COLORS["outlier"], label="beyond 3 sigma"),
        Line2D([], [], ls="none", marker="_", ms=12, mew=2.2, color=COLORS["ink"], label="predicted 1 sigma"),
        Line2D([], [], ls="none", marker="_", ms=12, mew=2.2, color=COLORS["accent"], label="3 sigma"),
    ]
    fig.legend(handles=handles, loc="lower center", ncol=4, bbox_to_anchor=(0.5, -0.08))
    fig.tight_layout()
    return save_figure(fig, path)


def motion_figure(path: str | Path, A: np.ndarray, motion: dict, pairs: str = "all") -> Path:
    """The robot's motions: their rotation angles, their axes on the sphere, the axes' spread.

    Parameters
    ----------
    path : str or Path
    A : array, shape (N, 4, 4)
        Robot-side poses (:func:`handeye.core.setups.robot_side_poses`) of the poses used.
    motion : dict
        ``diagnostics["motion"]`` of the result (:class:`classic.diagnostics.MotionDiagnostics`).
    pairs : {"all", "consecutive"}

    Returns
    -------
    Path
    """
    plt = pyplot()
    from classic.diagnostics import THRESHOLDS
    from classic.motions import motions_from_poses
    from classic.pairs import pair_indices

    m = motions_from_poses(A, A, *pair_indices(len(A), pairs))
    q = m.q_A
    angle = np.degrees(2.0 * np.arctan2(np.linalg.norm(q[:, :3], axis=1), np.abs(q[:, 3])))
    axis = q[:, :3] * np.sign(q[:, 3:4] + (q[:, 3:4] == 0))
    axis = axis / np.maximum(np.linalg.norm(axis, axis=1, keepdims=True), 1e-12)
    axis *= np.where(axis @ np.asarray(motion["dominant_axis"]) < 0, -1.0, 1.0)[:, None]  # one hemisphere

    fig = plt.figure(figsize=(11.5, 3.6))
    ax0 = fig.add_subplot(1, 3, 1)
    counts, _, _ = ax0.hist(angle, bins=min(24, max(6, len(angle) // 4)), color=COLORS["inlier"], edgecolor="white")
    ax0.set_ylim(0, 1.25 * float(np.max(counts, initial=1)))  # room for the legend
    level = THRESHOLDS["max_rotation_warn_deg"]
    _warning_line(ax0, ax0.axvline, level, f"warning level ({level:g} deg)")
    ax0.set_xlabel("rotation between two poses [deg]")
    ax0.set_ylabel("motion pairs")
    ax0.set_title(f"rotation angles (max {motion['max_rotation_deg']:.1f} deg)", fontsize=10)

    ax1 = fig.add_subplot(1, 3, 2, projection="3d")
    u, v = np.mgrid[0 : 2 * np.pi : 40j, 0 : np.pi : 20j]
    ax1.plot_wireframe(np.cos(u) * np.sin(v), np.sin(u) * np.sin(v), np.cos(v), color=COLORS["grid"], lw=0.4)
    sc = ax1.scatter(*axis.T, c=angle, cmap="viridis", s=10, depthshade=False, edgecolors="none")
    ax1.set_box_aspect((1, 1, 1))
    for setter in (ax1.set_xticklabels, ax1.set_yticklabels, ax1.set_zticklabels):
        setter([])
    for setter, name in ((ax1.set_xlabel, "x"), (ax1.set_ylabel, "y"), (ax1.set_zlabel, "z")):
        setter(name, labelpad=-12)
    ax1.set_title("rotation axes of the motions", fontsize=10)
    fig.colorbar(sc, ax=ax1, shrink=0.65, pad=0.08, label="angle [deg]")

    ax2 = fig.add_subplot(1, 3, 3)
    s = np.asarray(motion["axis_singular_values"], dtype=float)
    ratio = s / s[0] if s[0] > 0 else s
    ax2.bar(["s1", "s2", "s3"], ratio, color=[COLORS["inlier"], COLORS["accent"], COLORS["muted"]], width=0.6)
    level = THRESHOLDS["axis_diversity_warn"]
    _warning_line(ax2, ax2.axhline, level, f"s2/s1 warning level ({level:g})")
    ax2.set_ylim(0, 1.08)
    ax2.set_ylabel("singular value / s1")
    ax2.set_title(f"axis diversity s2/s1 = {motion['axis_diversity']:.2f}", fontsize=10)
    ax2.grid(axis="x", visible=False)
    fig.tight_layout()
    return save_figure(fig, path)
