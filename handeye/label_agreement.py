"""The board's label and the markerless label of each camera placement side by side, and how far apart.

On a real cell there is no truth: two independent calibrations that agree within their sigmas are the
evidence. Per placement: each label's status and sigma, their difference (mm, deg) and that difference
over the two sigmas combined (``z``: about 1 when both sigmas are right, beyond 3 a disagreement one of
them does not explain), and each against the truth where the dataset has one (a simulated dataset).
"""

from __future__ import annotations

import numpy as np

from handeye.core.dataset import Dataset
from handeye.core.metrics import pose_error
from handeye.core.tables import markdown_table

__all__ = ["agreement_rows", "agreement_table"]


def agreement_rows(ds: Dataset, split: str = "all") -> list[dict]:
    """Per camera placement, both labels and their difference.

    Parameters
    ----------
    ds : Dataset
        Labelled (``handeye label``) and markerless-labelled (``handeye markerless --write-labels``).
    split : {"test", "train", "all"}

    Returns
    -------
    list of dict
        ``camera``, ``label_status``, ``markerless_status``, ``diff_mm``, ``diff_deg``, ``z_trans``, ``z_rot``
        (NaN where either is missing), ``label_vs_truth`` and ``markerless_vs_truth`` ((deg, mm) or None).

    Raises
    ------
    DatasetError
        Either label missing from the dataset (naming the command that writes it).
    """
    board, markerless, truth = ds.labels(), ds.markerless_labels(), ds.truth()
    cams = ds.cameras()
    rows = []
    for c in range(len(ds)):
        if split != "all" and cams["split"][c] != split:
            continue
        row = {
            "camera": c,
            "label_status": str(cams["label_status"][c]),
            "markerless_status": str(cams["markerless_status"][c]),
        }
        both = np.isfinite(board[c]).all() and np.isfinite(markerless[c]).all()
        rot, trans = pose_error(markerless[c], board[c]) if both else (np.nan, np.nan)
        s_t = np.hypot(cams["label_sigma_trans_mm"][c], cams["markerless_sigma_trans_mm"][c])
        s_r = np.hypot(cams["label_sigma_rot_deg"][c], cams["markerless_sigma_rot_deg"][c])
        row.update(diff_mm=float(trans), diff_deg=float(rot), z_trans=float(trans / s_t), z_rot=float(rot / s_r))
        row.update(sigma_label=(cams["label_sigma_trans_mm"][c], cams["label_sigma_rot_deg"][c]))
        row.update(sigma_markerless=(cams["markerless_sigma_trans_mm"][c], cams["markerless_sigma_rot_deg"][c]))
        for name, T in (("label_vs_truth", board[c]), ("markerless_vs_truth", markerless[c])):
            ok = np.isfinite(truth[c]).all() and np.isfinite(T).all()
            row[name] = tuple(float(v) for v in pose_error(T, truth[c])) if ok else None
        rows.append(row)
    return rows


def _pair(values, fmt="{:.3f} / {:.4f}") -> str:
    return "-" if values is None or not np.all(np.isfinite(values)) else fmt.format(*values)


def agreement_table(ds: Dataset, split: str = "all") -> str:
    """Markdown table of :func:`agreement_rows`, and a line counting the placements that disagree beyond 3 sigma."""
    rows = agreement_rows(ds, split)
    has_truth = any(r["label_vs_truth"] or r["markerless_vs_truth"] for r in rows)
    headers = [
        "camera",
        "board label (sigma mm / deg)",
        "markerless (sigma mm / deg)",
        "apart mm / deg",
        "z trans / rot",
    ]
    headers += ["board vs truth mm / deg", "markerless vs truth"] if has_truth else []
    body = []
    for r in rows:
        board = _pair(r["sigma_label"]) if r["label_status"] == "ok" else r["label_status"][:40]
        ml = _pair(r["sigma_markerless"]) if r["markerless_status"] == "ok" else r["markerless_status"][:40]
        line = [
            r["camera"],
            board,
            ml,
            _pair((r["diff_mm"], r["diff_deg"])),
            _pair((r["z_trans"], r["z_rot"]), "{:.1f} / {:.1f}"),
        ]
        if has_truth:
            line += [_pair(r[k][::-1] if r[k] else None) for k in ("label_vs_truth", "markerless_vs_truth")]
        body.append(line)
    compared = [r for r in rows if np.isfinite(r["z_trans"])]
    apart = sum(max(r["z_trans"], r["z_rot"]) > 3 for r in compared)
    summary = (
        f"{len(compared)} of {len(rows)} placements have both labels; {apart} apart by more than 3 combined sigmas"
    )
    return "\n".join(markdown_table(headers, body)) + "\n\n" + summary
