"""The report's sections as HTML bodies, one function each, from :class:`handeye.report.build.ReportData`."""

from __future__ import annotations

from html import escape

import numpy as np

from handeye.core.setups import UNKNOWN_NAMES
from handeye.report import html
from handeye.report.tables import POSE_HEADERS, holdout_rows, motion_rows, noise_text, pose_rows

__all__ = [
    "truth_errors",
    "result_section",
    "method_section",
    "residuals_section",
    "frames_section",
    "motion_section",
    "holdout_section",
    "reprojection_section",
]

_CONVENTIONS = (
    '<p class="note"><code>T_a_b</code> is the pose of frame b in frame a (<code>p_a = T_a_b p_b</code>). '
    "Quaternions x, y, z, w (scalar last, w &ge; 0); roll-pitch-yaw in the ROS convention "
    "<code>R = Rz(yaw) Ry(pitch) Rx(roll)</code>. The 1-sigma is the predicted RMS of the error's norm "
    "(square root of the trace of the covariance block).</p>"
)


def _level(ok: bool) -> str:
    return "ok" if ok else "warn"


def _warnings(items: list[str]) -> str:
    return '<ul class="warnings">' + "".join(f"<li>{escape(w)}</li>" for w in items) + "</ul>" if items else ""


def _holdout_card(check) -> tuple[str, str, str, str]:
    s = check.summary
    low, high = min(s["ratio_rotation"], s["ratio_translation"]), max(s["ratio_rotation"], s["ratio_translation"])
    level = "ok" if 0.5 <= low and high <= 2 else ("warn" if high <= 3 else "bad")
    return (
        "hold-out error / sigma",
        f"{s['ratio_translation']:.2f} / {s['ratio_rotation']:.2f}",
        "translation / rotation; 1 when right",
        level,
    )


def truth_errors(data, final: tuple) -> dict | None:
    """The error of the leading calibration against the truth (``calibrate --truth``), per frame name.

    Parameters
    ----------
    data : handeye.report.build.ReportData
    final : tuple
        ``(X, Y, sigma, label)`` of the calibration the report leads with.

    Returns
    -------
    dict or None
        Frame name -> ``rotation_deg``, ``translation_mm`` (the error's angle and length) and ``sigma_rotation_deg``,
        ``sigma_translation_mm`` (its predicted 1-sigma); None without a truth.
    """
    if not data.truth:
        return None
    from handeye.core.metrics import pose_error

    X, Y, sigma, _ = final
    out = {}
    for block, name, T in zip("XY", UNKNOWN_NAMES[data.setup], (X, Y)):
        if name in data.truth:
            rot, trans = pose_error(T, data.truth[name])
            out[name] = {
                "rotation_deg": float(rot),
                "translation_mm": float(trans),
                "sigma_rotation_deg": float(sigma[f"{block}_rotation_deg"]),
                "sigma_translation_mm": float(sigma[f"{block}_translation_mm"]),
            }
    return out


def _truth_table(errors: dict) -> str:
    """The error against the truth beside the predicted 1-sigma, one row per frame name."""
    rows = [
        [
            escape(name),
            f"{e['translation_mm']:.3f}",
            f"{e['sigma_translation_mm']:.3f}",
            f"{e['rotation_deg']:.4f}",
            f"{e['sigma_rotation_deg']:.4f}",
        ]
        for name, e in errors.items()
    ]
    head = ["pose", "error [mm]", "1-sigma [mm]", "error [deg]", "1-sigma [deg]"]
    return (
        "<p>Error against the truth given with <code>--truth</code> (the angle between the rotations and the "
        "distance between the translations), beside the predicted 1-sigma; an error within about 3 sigma is "
        "what the noise explains.</p>" + html.table(head, rows, numeric=(1, 2, 3, 4))
    )


def result_section(data, final: tuple, check) -> str:
    """Headline numbers and X, Y by frame name (translation, quaternion, roll-pitch-yaw, 1-sigma).

    Parameters
    ----------
    data : handeye.report.build.ReportData
    final : tuple
        ``(X, Y, sigma, label)`` of the calibration the report leads with.
    check : handeye.report.holdout.HoldOutCheck or None
    """
    res, names = data.result, UNKNOWN_NAMES[data.setup]
    X, Y, sigma, label = final
    r = res.residuals
    items = [
        ("residual RMS per pose", f"{r.rms_translation_mm:.2f} mm", f"{r.rms_rotation_deg:.3f} deg", ""),
        (f"1-sigma {names[0]}", f"{sigma['X_translation_mm']:.2f} mm", f"{sigma['X_rotation_deg']:.3f} deg", ""),
    ]
    errors = truth_errors(data, final)
    for name, e in (errors or {}).items():
        within = (
            e["translation_mm"] <= 3 * e["sigma_translation_mm"] and e["rotation_deg"] <= 3 * e["sigma_rotation_deg"]
        )
        items.append(
            (f"error vs truth {name}", f"{e['translation_mm']:.2f} mm", f"{e['rotation_deg']:.3f} deg", _level(within))
        )
    if check is not None and len(check.indices):
        items.append(_holdout_card(check))
    motion = res.diagnostics["motion"]
    items.append(
        (
            "axis diversity",
            f"{motion['axis_diversity']:.2f}",
            f"max rotation {motion['max_rotation_deg']:.0f} deg",
            _level(not motion["warnings"]),
        )
    )
    n_out = int((~r.inliers).sum())
    items.append(("outlier poses", f"{n_out} of {len(r.inliers)}", "excluded from the fit", _level(n_out == 0)))
    rep = data.images.calibration.reprojection if data.images is not None else None
    if rep is not None:
        items.append(
            (
                "reprojection RMS",
                f"{rep.rms_px:.3f} px",
                f"{len(rep.outlier_views)} outlier views",
                _level(not rep.outlier_views),
            )
        )
    body = html.cards(items)
    body += f"<p>The camera and target poses by frame name, {escape(label)}:</p>"
    body += html.table(list(POSE_HEADERS), pose_rows(list(zip(names, (X, Y))), sigma), numeric=(1, 2, 3, 4))
    if errors:
        body += _truth_table(errors)
    if rep is not None:
        body += "<p>Pose-based (on the PnP poses), the refinement's start:</p>"
        body += html.table(
            list(POSE_HEADERS), pose_rows(list(zip(names, (res.X, res.Y))), res.sigma), numeric=(1, 2, 3, 4)
        )
    return body + _CONVENTIONS


def method_section(data) -> str:
    """Setup, input, method, loss, refinement, the noise model and the checks; the calibration's warnings."""
    res = data.result
    d = res.diagnostics
    ref = d["refinement"]
    method = res.method + (" (closed-form start, then maximum likelihood)" if "+" in res.method else "")
    converged = "converged" if ref["converged"] else "NOT converged"
    rows = [
        ("setup", data.setup.replace("_", "-")),
        ("input", data.source),
        ("poses", f"{len(res.residuals.inliers)} ({int(res.residuals.inliers.sum())} inliers)"),
        ("method", method),
        ("loss", ref["loss"] + (f", then {ref['then']}" if ref.get("then") else "")),
        ("refinement", f"{ref['iterations']} evaluations, {converged}"),
        ("noise model", noise_text(d["noise_model"])),
        ("variance factor", f"{ref['variance_factor']:.3f} (residuals against the noise model; 1 when it fits)"),
    ]
    if d.get("outliers"):
        rows.append(("outlier poses", ", ".join(map(str, d["outliers"]))))
    if "consistency" in d:
        c = d["consistency"]
        rows.append(
            (
                "consistency check",
                f"passed: quick fit {c['fit_residual_deg']:.3f} deg / "
                f"{c['fit_residual_mm']:.2f} mm, angle mismatch {c['angle_mismatch_deg']:.3f} deg",
            )
        )
    if "scale" in d:
        rows.append(("camera translation scale", f"{d['scale']['value']:.6f} ± {d['scale']['sigma']:.6f}"))
    body = html.key_values(rows)
    if data.warnings:
        body += "<p>Warnings:</p>" + _warnings(data.warnings)
    return body


def residuals_section(data, png) -> str:
    """The residual bar chart."""
    return html.figure(
        png,
        "Disagreement of each measured T_cam_target with the calibration's prediction X⁻¹ A Y, "
        "rotation (top) and translation (bottom); outliers, excluded from the fit, in red; dashed: the "
        "inliers' RMS.",
        data.command,
        "residual per pose",
    )


def frames_section(data, png) -> str:
    """The 3-D frames."""
    x_name, y_name = UNKNOWN_NAMES[data.setup]
    if data.setup == "eye_to_hand":
        parts = (
            f"the target on the flange ({y_name}) at a few poses, a plate in its x-y plane; the static camera "
            f"({x_name}), a pyramid along its optical axis z"
        )
    else:
        parts = (
            f"the camera on the flange ({x_name}) at a few poses, a pyramid along its optical axis z; the static "
            f"target ({y_name}), a plate in its x-y plane"
        )
    return html.figure(
        png,
        f"The calibrated cell in the robot base frame: the base, the end-effector at every pose "
        f"(its path in grey), {parts}. Axes x red, y green, z blue; equal aspect. Left the whole cell, "
        "right a close-up of the poses.",
        data.command,
        "frames in 3-D",
    )


def motion_section(data, png) -> str:
    """The motion figure, the motion diagnostics and their warnings."""
    motion = data.result.diagnostics["motion"]
    body = html.figure(
        png,
        "Motion diversity of the robot poses used: the rotation angle of every motion pair "
        "(dashed: the warning level), their rotation axes on the unit sphere, and the spread of those "
        "axes (s2/s1 is the axis diversity).",
        data.command,
        "motion diversity",
    )
    body += html.table(["quantity", "value", "meaning"], motion_rows(motion), numeric=(1,))
    return body + _warnings(motion["warnings"])


def holdout_section(data, check, error: str | None, png) -> str:
    """The hold-out check: what it does, its summary, the refused folds, the figure."""
    if check is None or not len(check.indices):
        return f"<p>No hold-out check: {escape(error or 'every fold was refused')}.</p>"
    s = check.summary
    inside = s["within_3_sigma"]
    badge = "" if inside == 1 else (" warn" if inside >= 0.9 else " bad")
    body = (
        f"<p>Every inlier pose is held out once: {s['folds']} folds of k = {s['k']}. Each fold calibrates on the "
        "other poses (same options), predicts the held-out poses' <code>T_cam_target = X⁻¹ A Y</code> from their "
        "robot poses, and compares the prediction with the measurement. The predicted sigma adds the "
        "measurement's noise (the fold's noise model) and the fold's uncertainty of X and Y. "
        f'<span class="badge{badge}">{100 * inside:.0f}% within 3 sigma</span></p>'
    )
    body += html.table(["", "rotation", "translation"], holdout_rows(s), numeric=(1, 2))
    if s["refused"]:
        body += "<p>Refused folds:</p>" + _warnings(s["refused"])
    extra = " (pose-based, on the PnP poses)" if data.images is not None else ""
    return body + html.figure(
        png,
        f"Held-out prediction error of T_cam_target per pose{extra}: bars, the error "
        "(red beyond 3 sigma); black ticks, the predicted 1-sigma; amber ticks, 3 sigma.",
        data.command,
        "hold-out prediction error per pose",
    )


def reprojection_section(data, overlays, rms_png, grid_png) -> str:
    """Per-view reprojection RMS, the views that were not used, the overlay grid."""
    rep = data.images.calibration.reprojection
    what = (
        "the reprojection refinement's X, Y and intrinsics"
        if rep is not None
        else "the pose-based X and Y and the detection's intrinsics"
    )
    body = (
        f"<p>Each view's board corners predicted from its robot pose alone (<code>X⁻¹ A Y</code>, with {what}) "
        "against the detected ones. Views flagged by the refinement (RMS above 3x the median) are outliers; "
        "pose-based outliers were excluded from the refinement; rejected views had no pose.</p>"
    )
    body += html.figure(rms_png, "Reprojection RMS per view, in pixels.", data.command, "reprojection RMS per view")
    odd = [o for o in overlays if o.status != "used"]
    if odd:
        body += html.table(
            ["image", "status", "RMS [px]", "reason"],
            [[o.image, o.status, "-" if np.isnan(o.rms_px) else f"{o.rms_px:.3f}", o.reason or ""] for o in odd],
            numeric=(2,),
        )
    return body + html.figure(
        grid_png,
        "Views cropped to the board: detected corners (green circles), predicted "
        "corners (red crosses), residuals magnified (amber; the legend gives the factor); "
        "outlier and excluded views framed in red, rejected in grey, first.",
        data.command,
        "reprojection overlays",
    )
