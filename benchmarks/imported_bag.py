"""Benchmark: the whole pipeline on recordings written as a real cell writes them, imported, labelled, registered.

Run from the repository root::

    python benchmarks/imported_bag.py --out benchmarks/results/imported_bag.md

Per distance band (the camera about 0.7, 1.2 and 1.8 m from the workspace centre): a few placements are
rendered with a sensor profile's depth (D435 by default: its scale, offset and extrinsic drawn per placement,
unknown to the method) and written as ROS 2 bags (:mod:`sim.bag_export`: the robot driving between poses and
stopping for each frame, joint states at 125 Hz with a gripper joint, colour 4 ms after depth, 16UC1
millimetres), then, exactly as a user would, ``handeye import bag``, ``handeye label`` (the board bags) and
``handeye markerless --sensor`` (started 50 mm / 5 deg off the truth, as from a tape measure or the learned
model). Each result is compared with the simulator's truth: error, predicted sigma, their ratio ``z``, the
depth scale and offset against the unit's truth. A placement accepted more than 3 sigmas off is counted wrong.
"""

from __future__ import annotations

import argparse
import json
import os
import sys
import tempfile
import time
from pathlib import Path

import numpy as np

sys.path.insert(0, os.path.dirname(os.path.dirname(os.path.abspath(__file__))))

from benchmarks._bands import BANDS_M  # noqa: E402
from benchmarks._bands import WITH_BOARD as _WITH_BOARD  # noqa: E402
from benchmarks._report import Report  # noqa: E402
from handeye.cli import main as cli  # noqa: E402
from handeye.core.dataset import Dataset  # noqa: E402
from handeye.core.metrics import pose_error  # noqa: E402
from handeye.core.se3 import make_transform, so3_exp  # noqa: E402
from handeye.core.smoke import smoke_test  # noqa: E402

#: The bands as this script's --bands names them ("0.7 m"), from benchmarks/_bands.py.
BANDS = {f"{k} m": v for k, v in BANDS_M.items()}
WITH_BOARD = {f"{k} m": v for k, v in _WITH_BOARD.items()}


def start_off(T: np.ndarray, rng, mm: float = 50.0, deg: float = 5.0) -> np.ndarray:
    """``T`` moved ``mm`` along a random direction and turned ``deg`` about a random axis."""
    axis, direction = rng.normal(size=3), rng.normal(size=3)
    R = so3_exp(np.deg2rad(deg) * axis / np.linalg.norm(axis))
    return T @ make_transform(R, mm * 1e-3 * direction / np.linalg.norm(direction))


def smoke_bands(bands: list[str]) -> list[str]:
    """The bands run: ``bands``, but in a smoke run (:mod:`handeye.core.smoke`) the first without a board and the
    first with one (each branch of :func:`run_band`), as :meth:`Report.cut` cuts the placements and frames."""
    if not smoke_test():
        return bands
    first = {}
    for band in bands:
        first.setdefault(WITH_BOARD[band], band)
    return [band for band in bands if band in first.values()]


def run_band(work: Path, band: str, radius: tuple, args, report: Report) -> list:
    from handeye.core.engine_protocol import EngineOptions
    from sim.bag_export import write_placement_bags
    from sim.cameras import CameraPreset
    from sim.generate import NoiseModel, Recipe, generate

    preset = CameraPreset(
        f"bag-{band}",
        "ur5",
        ((0.0, 360.0),),
        (0,),
        (args.placements,),
        args.frames,
        calibration_views=12,
        radius_m=radius,
        image_size=(256, 256),
        calibration_image_size=(640, 640),
    )
    root = work / band.replace(" ", "")
    t0 = time.perf_counter()
    noise = NoiseModel(pixel_sigma=2.0, joint_sigma_deg=0.01)
    board = WITH_BOARD[band]
    recordings = ("calibration", "data") if board else ("data",)
    recipe = Recipe(preset, args.seed, noise, recordings, sensor=args.sensor)
    generate(root / "sim", recipe, options=EngineOptions(workers=1, progress=False))
    src = Dataset.open(root / "sim")
    data, cal = [], []
    for c in range(len(src)):
        bags = write_placement_bags(src, c, root / "bags")
        data.append(str(bags["data"]))
        cal += [str(bags["calibration"])] if board else []
    from classic.vision.board import BoardSpec

    BoardSpec(**src.meta["board"]).save(root / "board.json")
    t_gen = time.perf_counter() - t0
    out = root / "imported"
    t0 = time.perf_counter()
    argv = ["import", "bag", *data, "--robot", "ur5"]
    argv += ["--calibration", *cal, "--board", str(root / "board.json")] if board else []
    assert cli(argv + ["--out", str(out), "--quiet"]) == 0
    t_import = time.perf_counter() - t0
    t0 = time.perf_counter()
    if board:
        assert cli(["label", str(out), "--quiet"]) == 0
    t_label = time.perf_counter() - t0
    ds, truth, table = Dataset.open(out), src.truth(), src.cameras()
    rng = np.random.default_rng(args.seed)
    rows = []
    for c in range(len(ds)):
        start = root / f"start_{c}.json"
        start.write_text(json.dumps({"T_base_cam": start_off(truth[c], rng).tolist()}))
        res_path = root / f"markerless_{c}.json"
        t0 = time.perf_counter()
        argv = ["markerless", str(out), "--camera", str(c), "--start", str(start), "--sensor", args.sensor]
        cli(argv + ["--quiet", "-o", str(res_path)])
        t_ml = time.perf_counter() - t0
        res = json.loads(res_path.read_text())["cameras"][str(c)]
        cams = ds.cameras()
        row = {
            "camera": c,
            "distance_m": float(np.linalg.norm(truth[c][:3, 3] - np.array(preset.look_at_m))),
            "label": pose_error(ds.labels()[c], truth[c]) if board and cams["label_status"][c] == "ok" else None,
            "label_sigma": (cams["label_sigma_rot_deg"][c], cams["label_sigma_trans_mm"][c]) if board else None,
            "ok": res["status"] == "ok",
            "refused": res["refused"],
            "seconds": t_ml,
        }
        if row["ok"]:
            rot, trans = pose_error(np.array(res["T_base_cam"]["matrix"]), truth[c])
            sig = res["sigma"]
            row.update(err=(rot, trans), z=(rot / sig["rotation_deg"], trans / sig["translation_mm"]))
            d = res["depth"]
            offset_true = table["depth_offset_mm_true"][c] + table["depth_extrinsic_mm_true.z"][c]
            row.update(
                scale_err=abs(d["scale"] - table["depth_scale_true"][c]), offset_err=abs(d["offset_mm"] - offset_true)
            )
        rows.append(row)
    report.say(
        f"## {band}: {len(rows)} placements, {args.frames} data frames at 256x256, "
        f"{'12 board views at 640x640' if board else 'no board'}, sensor {args.sensor}"
    )
    report.say(
        f"render and write the bags {t_gen:.0f} s; handeye import bag {t_import:.1f} s; handeye label {t_label:.1f} s"
    )
    report.say()
    report.say(
        "| camera | distance m | board label mm / deg (sigma mm) | markerless mm / deg | sigma mm / deg "
        "| z trans / rot "
        "| scale error | offset error mm | s |"
    )
    report.say("|---|---|---|---|---|---|---|---|---|")
    for r in rows:
        label = "no board" if not board else "refused"
        if r["label"]:
            label = f"{r['label'][1]:.2f} / {r['label'][0]:.3f} ({r['label_sigma'][1]:.2f})"
        if r["ok"]:
            sig_t, sig_r = r["err"][1] / r["z"][1], r["err"][0] / r["z"][0]
            ml = (
                f"{r['err'][1]:.2f} / {r['err'][0]:.3f} | {sig_t:.2f} / {sig_r:.3f} | {r['z'][1]:.1f} / {r['z'][0]:.1f}"
            )
            ml += f" | {100 * r['scale_err']:.3f} % | {r['offset_err']:.2f}"
        else:
            ml = f"refused: {str(r['refused'])[:60]} | - | - | - | -"
        report.say(f"| {r['camera']} | {r['distance_m']:.2f} | {label} | {ml} | {r['seconds']:.1f} |")
    acc = [r for r in rows if r["ok"]]
    wrong = sum(max(r["z"]) > 3 for r in acc)
    if acc:
        t = [r["err"][1] for r in acc]
        d = [r["err"][0] for r in acc]
        report.say()
        report.say(
            f"markerless: {len(acc)}/{len(rows)} accepted, median {np.median(t):.2f} mm / {np.median(d):.3f} deg, "
            f"worst {max(t):.2f} mm / {max(d):.3f} deg, {wrong} more than 3 sigma off"
        )
    labels = [r["label"][1] for r in rows if r["label"]]
    if labels:
        report.say(f"board label: median {np.median(labels):.2f} mm, worst {max(labels):.2f} mm")
    report.say()
    return rows


def main() -> int:
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--bands", nargs="+", default=list(BANDS), choices=list(BANDS))
    ap.add_argument("--placements", type=int, default=4)
    ap.add_argument("--frames", type=int, default=30)
    ap.add_argument("--sensors", nargs="+", default=["d435"], help="sensor profiles (sim/sensors.py)")
    ap.add_argument("--seed", type=int, default=11)
    ap.add_argument("--work", type=Path, help="keep the datasets and bags here (default: a temporary folder)")
    ap.add_argument("--out", help="write the report here")
    args = ap.parse_args()
    Report.cut(args, placements=1, frames=10)
    import handeye

    report = Report(
        "The whole pipeline on imported bags",
        "benchmarks/imported_bag.py",
        None,
        f"handeye {getattr(handeye, '__version__', '?')}, numpy {np.__version__}",
    )
    with tempfile.TemporaryDirectory() as tmp:
        work = args.work or Path(tmp)
        for sensor in args.sensors:
            for band in smoke_bands(args.bands):
                args.sensor = sensor
                run_band(work / sensor, band, BANDS[band], args, report)
    return report.write(args.out)


if __name__ == "__main__":
    sys.exit(main())
