"""Benchmark: the markerless calibration on depth as real sensors report it, with and without depth self-calibration.

Either let it render the test placements itself, per distance band (``native`` is the preset's own distance;
``0.7`` and ``1.8`` put every camera that far from the workspace centre, the preset's layout otherwise kept)::

    python benchmarks/markerless_sensors.py --presets paper-real paper-sim --bands native 0.7 1.8 \\
        --max-placements 8 --out benchmarks/results/markerless_sensors.md

or run it on datasets rendered without depth noise (the sensor adds its own) and labelled::

    handeye sim generate --preset paper-real --out data/paper-real-clean-depth --seed 1 --noise 2,0,0.01
    handeye label data/paper-real-clean-depth
    handeye sim generate --preset paper-sim --out data/paper-sim-clean-depth --seed 1 --noise 2,0,0.01
    handeye label data/paper-sim-clean-depth
    python benchmarks/markerless_sensors.py --data data/paper-real-clean-depth data/paper-sim-clean-depth \\
        --out benchmarks/results/markerless_sensors.md

Per dataset and per sensor profile of :data:`handeye.robot.depth_sensors.PROFILES`, every test placement's true depth is
turned into what that sensor reports (:func:`sim.sensors.apply_sensor`: a scale, offset and extrinsic error
drawn per placement, noise as its principle grows it, correlated noise, flying pixels, holes), and registered
twice, the scale and offset unknown to the method both times:

- **self-calibrated**: the default, estimating the depth scale and offset with the pose and measuring the noise
  on the static background (``MarkerlessOptions()``, with the profile's depth-to-colour extrinsic sigma and,
  for the stereo profiles, their ``f B``, with which the matcher's pull toward whole disparities is estimated
  too: what ``handeye markerless --sensor NAME`` does);
- **depth taken as exact**: ``depth_model="fixed"`` and the depth noise assumed to be 1 mm at 1 m, as the
  registration did before it calibrated the depth (the camera matrix taken as exact too).

The self-calibrated mode estimates the depth camera's intrinsics with the pose as well (the default since issue
41); ``--modes`` adds ``"self-calibrated; intrinsics taken as exact"`` (the camera matrix fixed, as before).
``--intrinsics-error fx=0.007,fy=0.007,cx=3`` tells the method a camera matrix that far off the one the depth was
rendered with (focal lengths relative, principal point in pixels), a factory calibration's error; the
intrinsics' errors against the truth are printed under the table::

    python benchmarks/markerless_sensors.py --presets paper-real paper-sim --bands 1.2 --max-placements 5 \
        --profiles d435 --modes "self-calibrated; intrinsics taken as exact,self-calibrated" \
        --intrinsics-error fx=0.007,fy=0.007,cx=3 --out benchmarks/results/markerless_intrinsics.md

``--joint-offsets 0.2,-0.3,0.15,-0.1,0.25,-0.2`` gives the robot joint zero offsets (degrees, true joint = recorded
+ offset): the depth is rendered at the true joints ``q`` and the method is told ``q - delta``. Joint 1 (the base
rotation) then cannot be told from the camera's pose (:mod:`classic.markerless.kinematics`); the truth the error is
measured against is the camera in the robot's kinematic base frame, ``T_kin = T_base_link1(q_told)
T_base_link1(q_true)^-1 T_phys = exp(-delta_1 xi_1) T_phys`` (``xi_1`` joint 1's twist, fixed in the base frame;
exact for a rotation about the base axis). The mode ``"self-calibrated, joint offsets taken as exact"`` fixes them::

    python benchmarks/markerless_sensors.py --data data/sensor-bands/paper-sim-1.2 --profiles d435 \
        --max-placements 5 --modes "self-calibrated; joint offsets taken as exact,self-calibrated" \
        --joint-offsets 0.2,-0.3,0.15,-0.1,0.25,-0.2 --out benchmarks/results/markerless_joint_offsets.md

Each of a real cell's sensor errors alone (issue 41): ``--registration-error du=1,dv=0,roll=0`` misregisters every
depth image against the camera model it is paired with (pixels, degrees about the principal point), and
``--fixed-pattern 3.6`` adds a fixed-pattern noise of that sigma at 1 m (mm, growing with depth squared), the same
in every frame of a placement; the profile ``d435-real-cell`` draws both per placement::

    python benchmarks/markerless_sensors.py --data data/sensor-bands/paper-real-1.2 --max-placements 5 \
        --profiles d435 --modes self-calibrated --fixed-pattern 3.6 --out benchmarks/results/markerless_sensor_errors.md

A placement accepted more than 3 predicted sigmas from the truth is a wrong answer reported as a success: the
defect this benchmark counts. The ChArUco label of the same placements (from the colour images, which the depth
sensor does not touch) is printed beside. At 0.7 m the camera is inside the arm's reach and the simulator finds
no board view the arm can hold, so that band has no label.
"""

from __future__ import annotations

import argparse
import os
import sys
import time
from dataclasses import replace
from pathlib import Path

import numpy as np

sys.path.insert(0, os.path.dirname(os.path.dirname(os.path.abspath(__file__))))

from benchmarks._bands import BANDS_M  # noqa: E402
from benchmarks._bands import WITH_BOARD as BANDS_WITH_BOARD  # noqa: E402
from benchmarks._report import Report  # noqa: E402
from classic.markerless import MarkerlessOptions, register_robot  # noqa: E402
from handeye.core.dataset import Dataset  # noqa: E402
from handeye.core.metrics import pose_error  # noqa: E402
from handeye.core.numbers import NumberError, parse_float  # noqa: E402
from handeye.core.smoke import smoke_test  # noqa: E402
from handeye.markerless import robot_surface_for  # noqa: E402
from handeye.robot.depth_sensors import PROFILES  # noqa: E402
from sim.sensors import apply_sensor, draw_systematic  # noqa: E402

WRONG_SIGMAS = 3.0
#: Distance bands, camera to workspace centre (m); ``native`` keeps the preset's own.
BANDS = {"native": None, **BANDS_M}
#: Bands where the simulator can record a board held by the arm (see the module docstring).
WITH_BOARD = {"native": True, **BANDS_WITH_BOARD}


def render_band(work: Path, preset_name: str, band: str, seed: int, train: bool = False) -> Path:
    """The preset's test placements at ``band``, rendered with exact depth and labelled (where a board fits); with
    ``train`` its train placements too (into ``<preset>-<band>-with-train``).

    Resumes: a dataset already rendered in ``work`` is kept.
    """
    from handeye.cli import main as cli
    from handeye.core.engine_protocol import EngineOptions
    from sim.cameras import get_preset
    from sim.generate import NoiseModel, Recipe, generate

    preset = get_preset(preset_name)
    k = len(preset.region_azimuths_deg)
    name = f"{preset_name}-{band}" + ("-with-train" if train else "")
    preset = replace(preset, name=name) if train else replace(preset, name=name, train_per_region=(0,) * k)
    if smoke_test():  # a smoke run measures one placement (Report.cut): it renders that one, board and label too
        preset = replace(
            preset, region_azimuths_deg=preset.region_azimuths_deg[:1], train_per_region=(0,), test_per_region=(1,)
        )
    if BANDS[band] is not None:
        preset = replace(preset, radius_m=BANDS[band])
    root = work / name
    recordings = ("calibration", "data") if WITH_BOARD[band] else ("data",)
    noise = NoiseModel(pixel_sigma=2.0, joint_sigma_deg=0.01)
    generate(root, Recipe(preset, seed, noise, recordings), options=EngineOptions(progress=False))
    if WITH_BOARD[band] and not (root / "labels.done").exists():
        if cli(["label", str(root), "--quiet"]) != 0:
            raise SystemExit(f"labelling {root} failed")
        (root / "labels.done").write_text("")
    return root


def smoke_profiles(names: list[str], first: bool) -> list[str]:
    """The profiles a dataset is measured with: ``names``, but in a smoke run (:mod:`handeye.core.smoke`) one per
    sensing principle and fixed pattern (every branch of :func:`sim.sensors.apply_sensor`) on the first dataset,
    and the first of those on the others (the same loop, table and notes for each)."""
    if not smoke_test():
        return names
    kinds = {(PROFILES[n].principle, PROFILES[n].fixed_pattern_sigma_m_at_1m > 0): n for n in reversed(names)}
    kept = [n for n in names if n in kinds.values()]
    return kept if first else kept[:1]


def smoke_bands(names: list[str], first: bool) -> list[str]:
    """The bands a preset is rendered at: ``names``, but in a smoke run (:mod:`handeye.core.smoke`) the first band
    only for every preset after the first (the first preset renders every band: each branch of :func:`render_band`,
    the preset's own distance or a band's, with a board or without), as :func:`smoke_profiles` cuts the profiles."""
    return names if first or not smoke_test() else names[:1]


def placements(ds: Dataset, split: str, at_most: int | None = None) -> list[int]:
    """The split's placements; with ``at_most``, that many spread evenly over them (every region kept)."""
    table = ds.cameras()
    cams = [c for c in range(len(ds)) if split == "all" or table["split"][c] == split]
    if at_most and len(cams) > at_most:
        cams = [cams[i] for i in np.linspace(0, len(cams) - 1, at_most).round().astype(int)]
    return cams


def observe(ds: Dataset, c: int, sensor, seed: int, registration: dict | None = None, unit: int | None = None):
    """The placement's depth frames as ``sensor`` reports them, its joints, and the unit's truth.

    ``registration`` (:func:`parse_registration_error`): the depth image's misregistration, instead of the
    profile's draw. ``unit``: the sensor's systematic errors (scale, offset, misregistration, fixed pattern) are
    those drawn for this placement number instead of ``c``'s, so that several placements share one unit.
    """
    t = ds.select(c, "data")
    K = np.array(ds.meta["intrinsics"]["K"])
    truth = draw_systematic(sensor, seed, c if unit is None else unit)
    if registration:
        truth = replace(
            truth,
            registration_px=np.array([registration["du"], registration["dv"]]),
            registration_roll_deg=registration["roll"],
        )
    rng = np.random.default_rng([seed, c, 3])
    depth = np.stack(
        [apply_sensor(ds.depth_m(c, d), K, sensor, truth, rng, rgb=ds.rgb(c, r)) for d, r in zip(t["depth"], t["rgb"])]
    )
    return depth, ds.joints(t), truth


def _key_numbers(text: str, option: str, keys: tuple) -> dict:
    """``k=number,...`` of ``keys`` (those not given 0), numbers in the project's strict grammar."""
    out = dict.fromkeys(keys, 0.0)
    for item in filter(None, text.split(",")):
        key, _, value = (part.strip() for part in item.partition("="))
        if key not in out:
            raise argparse.ArgumentTypeError(f"{option}: unknown key {key!r} ({', '.join(keys)})")
        try:
            out[key] = parse_float(value, option)
        except NumberError:
            raise argparse.ArgumentTypeError(f"{option}: {item!r} is not key=number") from None
    return out


def parse_intrinsics_error(text: str) -> dict:
    """``fx=0.007,cx=3``: the relative focal errors (``fx``, ``fy``) and the principal point's (``cx``, ``cy``, px)."""
    return _key_numbers(text, "--intrinsics-error", ("fx", "fy", "cx", "cy"))


def parse_registration_error(text: str) -> dict:
    """``du=1,dv=0,roll=0``: the depth image's shift (pixels) and roll (degrees) against the colour camera."""
    return _key_numbers(text, "--registration-error", ("du", "dv", "roll"))


def with_errors(sensor, fixed_pattern_mm: float | None = None, fixed_pattern_px: float | None = None):
    """``sensor`` with a fixed-pattern noise of ``fixed_pattern_mm`` at 1 m (its correlation length
    ``fixed_pattern_px``, the profile's noise correlation length by default), named after it."""
    if fixed_pattern_mm is None:
        return sensor
    length = sensor.correlation_px if fixed_pattern_px is None else fixed_pattern_px
    return replace(
        sensor,
        name=f"{sensor.name} + fixed pattern {fixed_pattern_mm:g} mm at 1 m",
        fixed_pattern_sigma_m_at_1m=fixed_pattern_mm * 1e-3,
        fixed_pattern_px=length,
    )


def told_intrinsics(K: np.ndarray, error: dict | None) -> np.ndarray:
    """The camera matrix the method is told: the true ``K`` with ``error`` (:func:`parse_intrinsics_error`)."""
    K = np.array(K, dtype=float)
    if error:
        K[0, 0] *= 1 + error["fx"]
        K[1, 1] *= 1 + error["fy"]
        K[0, 2] += error["cx"]
        K[1, 2] += error["cy"]
    return K


def kinematic_truth(T_phys: np.ndarray, twists: np.ndarray, offsets_rad: np.ndarray) -> np.ndarray:
    """The camera in the robot's kinematic base frame when its joints read ``offsets_rad`` less than they stand.

    ``exp(-delta_1 xi_1) T_phys``, ``xi_1`` joint 1's twist (base frame; the same for every part it moves and
    every configuration where its axis is fixed in the base): what ``T_base_link1(q_told) T_base_link1(q_true)^-1``
    is for a rotation about the base axis. ``twists``: (n_parts, n_joints, 6) of one frame.
    """
    from scipy.linalg import expm

    moved = np.flatnonzero(np.abs(twists[:, 0]).max(axis=1) > 0)
    if not len(moved) or not offsets_rad[0]:
        return T_phys
    w, v = twists[moved[-1], 0, :3], twists[moved[-1], 0, 3:]
    hat = np.zeros((4, 4))
    hat[:3, :3] = [[0, -w[2], w[1]], [w[2], 0, -w[0]], [-w[1], w[0], 0]]
    hat[:3, 3] = v
    return expm(-offsets_rad[0] * hat) @ T_phys


def told_posed(surface, q: np.ndarray, T_base_cam: np.ndarray, joint_offsets_deg=None) -> tuple:
    """The robot's surface at the joints the method is told, and the camera pose it should find.

    Parameters
    ----------
    surface : handeye.markerless robot surface (``robot_surface_for``'s)
    q : array, shape (n_frames, n_joints)
        The joints as they stand (radians).
    T_base_cam : array, shape (4, 4)
        The camera in the robot's physical base frame (metres).
    joint_offsets_deg : array, shape (n_joints,), or None
        Joint zero offsets (degrees): the method is told ``q`` less these.

    Returns
    -------
    posed : the surface posed at the told joints
    T_base_cam : array, shape (4, 4)
        The camera in the kinematic base frame of the told joints (:func:`kinematic_truth`); as given without
        offsets.
    """
    if joint_offsets_deg is None:
        return surface.posed(q), T_base_cam
    delta = np.radians(joint_offsets_deg)
    if len(delta) != q.shape[1]:
        raise SystemExit(f"--joint-offsets gives {len(delta)} values for a robot of {q.shape[1]} joints")
    posed = surface.posed(q - delta)
    return posed, kinematic_truth(T_base_cam, posed.joint_twists_base[0], delta)


def front_options(sensor, stride: int, **options) -> MarkerlessOptions:
    """The front's self-calibrated registration for ``sensor``'s profile: its depth-to-colour spreads (the
    registration's offset and roll) and stereo baseline stated, the z-buffer at ``stride``, ``options`` further
    :class:`MarkerlessOptions` fields (a field of the profile's among them replaces the profile's)."""
    profile = {
        "zbuffer_stride": stride,
        "depth_extrinsic_sigma_m": sensor.extrinsic_sigma_m,
        "depth_extrinsic_sigma_deg": sensor.registration_roll_sigma_deg,  # the profile's depth-to-colour roll spread
        "stereo_fb_px_m": sensor.stereo_fb_px_m,
    }
    return MarkerlessOptions(**{**profile, **options})


def parse_joint_offsets(text: str) -> np.ndarray:
    """``0.2,-0.3,...``: joint zero offsets in degrees, one per joint."""
    try:
        return np.array([parse_float(x.strip(), "--joint-offsets") for x in text.split(",")])
    except NumberError:
        raise argparse.ArgumentTypeError(f"--joint-offsets: {text!r} is not comma-separated finite degrees") from None


def run_profile(
    ds,
    surface,
    stride,
    cams,
    sensor,
    seed,
    intrinsics_error=None,
    modes=None,
    registration=None,
    joint_offsets=None,
    options=None,
):
    """Per placement and mode: (status, err_deg, err_mm, sigma_deg, sigma_mm, s, depth dict, truth, intrinsics).

    ``intrinsics_error``: the method is told a camera matrix this far off the one the depth was rendered with
    (:func:`told_intrinsics`); ``"self-calibrated"`` takes it with a factory camera matrix's uncertainty
    (:data:`classic.markerless.intrinsics.INTRINSICS_PRIORS`), ``"self-calibrated, intrinsics taken as exact"``
    as exact. ``joint_offsets`` (degrees, one per joint): the method is told the joints less these, and the truth
    is the camera in the kinematic base frame (:func:`kinematic_truth`). Each row ends with the joint offsets' dict.
    ``options``: further :class:`MarkerlessOptions` fields of the self-calibrated modes (a dict).
    """
    K = told_intrinsics(ds.meta["intrinsics"]["K"], intrinsics_error)
    T_true = ds.truth()
    self_calibrated = front_options(sensor, stride, **(options or {}))
    all_modes = {
        "self-calibrated": self_calibrated,
        "self-calibrated, intrinsics taken as exact": replace(self_calibrated, intrinsics_model="fixed"),
        "self-calibrated, joint offsets taken as exact": replace(self_calibrated, joint_offsets_model="fixed"),
        "depth taken as exact": MarkerlessOptions(
            zbuffer_stride=stride, depth_model="fixed", depth_sigma_m_at_1m=0.001, intrinsics_model="fixed"
        ),
    }
    modes = {m: all_modes[m] for m in (modes or ("self-calibrated", "depth taken as exact"))}
    rows = {m: [] for m in modes}
    for c in cams:
        depth, q, truth = observe(ds, c, sensor, seed, registration)
        posed, T_c = told_posed(surface, q, T_true[c], joint_offsets)
        for mode, opts in modes.items():
            t0 = time.perf_counter()
            res = register_robot(depth, K, posed, options=opts)
            dt = time.perf_counter() - t0
            if res.ok:
                rot, mm = pose_error(res.T_base_cam, T_c)
                rows[mode].append(
                    (
                        "ok",
                        rot,
                        mm,
                        res.sigma["rotation_deg"],
                        res.sigma["translation_mm"],
                        dt,
                        res.depth,
                        truth,
                        res.intrinsics,
                        res.joint_offsets,
                    )
                )
            else:
                rows[mode].append(
                    ("refused", np.nan, np.nan, np.nan, np.nan, dt, res.depth, truth, res.intrinsics, res.joint_offsets)
                )
            print(f"  camera {c}, {mode}: {rows[mode][-1][:6]} {res.refused or ''}", file=sys.stderr, flush=True)
    return rows


def summary_row(name: str, rows: list) -> str:
    ok = [r for r in rows if r[0] == "ok"]
    n = len(rows)
    cells = [name, f"{len(ok)}/{n}"]
    if not ok:
        return "| " + " | ".join(cells + ["-"] * 6 + [f"{np.median([r[5] for r in rows]):.1f}"]) + " |"
    e = np.array([[r[1], r[2], r[3], r[4]] for r in ok])
    z_t, z_r = e[:, 1] / e[:, 3], e[:, 0] / e[:, 2]
    wrong = int(np.sum((z_t > WRONG_SIGMAS) | (z_r > WRONG_SIGMAS)))
    cells += [
        f"{np.median(e[:, 1]):.2f} / {np.median(e[:, 0]):.3f}",
        f"{e[:, 1].max():.2f} / {e[:, 0].max():.3f}",
        f"{np.sqrt(np.mean(z_t**2)):.2f} / {np.sqrt(np.mean(z_r**2)):.2f}",
        f"{wrong}",
    ]
    cal = [r for r in ok if "scale" in r[6]]
    if cal:
        ds_ = np.array([r[6]["scale"] - r[7].scale for r in cal])
        do_ = np.array([r[6]["offset_mm"] - r[7].offset_m * 1e3 for r in cal])
        cells += [f"{np.median(np.abs(ds_)) * 100:.3f} %", f"{np.median(np.abs(do_)):.2f} mm"]
    else:
        cells += ["-", "-"]
    cells.append(f"{np.median([r[5] for r in rows]):.1f}")
    return "| " + " | ".join(cells) + " |"


def joint_offsets_line(name: str, rows: list, truth_deg: np.ndarray | None) -> str | None:
    """The estimated joint offsets against the truth, medians over the accepted placements (None when they were
    taken as exact or no offsets were given)."""
    ok = [r for r in rows if r[0] == "ok" and r[9].get("model") == "estimated"]
    if not ok or truth_deg is None:
        return None
    cells = []
    for j in range(len(truth_deg)):
        status = ok[0][9]["joints"][j]["status"]
        if status != "estimated":
            cells.append(f"J{j + 1} {status}")
            continue
        err = np.array([r[9]["joints"][j]["estimate_deg"] - truth_deg[j] for r in ok])
        sd = np.array([r[9]["joints"][j]["sigma_deg"] for r in ok])
        det = sum(r[9]["joints"][j]["determined"] for r in ok)
        cells.append(
            f"J{j + 1} {np.median(np.abs(err)):.3f} deg (sigma {np.median(sd):.3f}, worst z "
            f"{np.max(np.abs(err) / sd):.1f}, determined {det}/{len(ok)})"
        )
    return f"- {name}: joint offsets' error, median: " + "; ".join(cells)


def intrinsics_line(name: str, rows: list, K_true: np.ndarray) -> str | None:
    """The estimated intrinsics against the true camera matrix, medians over the accepted placements (None when
    they were taken as exact)."""
    ok = [r for r in rows if r[0] == "ok" and r[8].get("model") == "estimated"]
    if not ok:
        return None
    truth = {"fx": K_true[0, 0], "fy": K_true[1, 1], "cx": K_true[0, 2], "cy": K_true[1, 2]}
    cells = []
    for key in ("fx", "fy", "cx", "cy"):
        err = np.array([r[8][key]["estimate"] - truth[key] for r in ok])
        sd = np.array([r[8][key]["sigma"] for r in ok])
        ratio = np.array([r[8][key]["ratio"] for r in ok])
        cells.append(
            f"{key} {np.median(np.abs(err)):.2f} px (sigma {np.median(sd):.2f}, ratio {np.median(ratio):.2f}, "
            f"determined {sum(r[8][key]['determined'] for r in ok)}/{len(ok)})"
        )
    return f"- {name}: intrinsics' error, median: " + "; ".join(cells)


def sigma_line(name: str, rows: list) -> str | None:
    """The predicted sigma beside the error, medians over the accepted placements (None without any)."""
    ok = [r for r in rows if r[0] == "ok"]
    if not ok:
        return None
    e = np.array([[r[1], r[2], r[3], r[4]] for r in ok])
    return (
        f"- {name}: sigma, median {np.median(e[:, 3]):.2f} mm / {np.median(e[:, 2]):.3f} deg "
        f"(error median {np.median(e[:, 1]):.2f} mm / {np.median(e[:, 0]):.3f} deg)"
    )


def versions() -> str:
    import scipy

    return f"python {sys.version.split()[0]}, numpy {np.__version__}, scipy {scipy.__version__}"


def main():
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--data", type=Path, nargs="*", default=[], help="datasets rendered without depth noise")
    ap.add_argument("--presets", nargs="*", default=[], help="render these presets' test placements (paper-real ...)")
    ap.add_argument("--bands", nargs="+", default=["native"], choices=list(BANDS), help="with --presets")
    ap.add_argument("--work", type=Path, default=Path("data/sensor-bands"), help="where --presets renders")
    ap.add_argument("--profiles", default=",".join(PROFILES), help="comma-separated (default all)")
    ap.add_argument("--split", default="test", help="test (default), train or all")
    ap.add_argument("--max-placements", type=int, help="at most this many per dataset, spread over its placements")
    ap.add_argument("--seed", type=int, default=0, help="seed of the sensors' draws")
    ap.add_argument(
        "--intrinsics-error",
        type=parse_intrinsics_error,
        help="tell the method a camera matrix this far off the true one: fx=0.007,fy=0.007,cx=3,cy=0 "
        "(relative focal errors, principal point in pixels)",
    )
    ap.add_argument(
        "--registration-error",
        type=parse_registration_error,
        help="shift and rotate every depth image against the camera model it is paired with: du=1,dv=0,roll=0 "
        "(pixels, degrees about the principal point), instead of the profile's draw",
    )
    ap.add_argument(
        "--fixed-pattern",
        type=float,
        metavar="SIGMA_MM_AT_1M",
        help="add a fixed-pattern depth noise, the same in every frame of a placement, of this sigma at 1 m "
        "(growing with depth squared), correlated over --fixed-pattern-px",
    )
    ap.add_argument(
        "--fixed-pattern-px",
        type=float,
        help="the fixed pattern's correlation length in the sensor's own pixels (default: the profile's "
        "correlation_px, its matching window)",
    )
    ap.add_argument(
        "--modes",
        default="self-calibrated,depth taken as exact",
        help="comma-separated: self-calibrated, 'self-calibrated, intrinsics taken as exact' (written with a "
        "semicolon: 'self-calibrated; intrinsics taken as exact'), depth taken as exact",
    )
    ap.add_argument(
        "--joint-offsets",
        type=parse_joint_offsets,
        metavar="DEG,DEG,...",
        help="robot joint zero offsets, degrees, one per joint (true = recorded + offset): the depth is rendered at "
        "the true joints, the method told the recorded ones; the error is measured against the camera in the "
        "robot's kinematic base frame (joint 1's offset moves it: exp(-delta_1 xi_1) T_phys)",
    )
    Report.add_out(ap)
    args = ap.parse_args()
    Report.cut(args, max_placements=1)
    rep = Report("Markerless calibration on real sensors' depth", "benchmarks/markerless_sensors.py", None, versions())
    emit = rep.say
    emit(
        "Wrong: accepted more than 3 predicted sigmas from the truth (translation or rotation). z: error over "
        "predicted sigma, RMS over the accepted placements (1 when the sigma is right). Scale and offset: the "
        "median absolute error of the estimate against the unit's truth."
    )
    if not args.data and not args.presets:
        ap.error("give --data or --presets")
    if args.registration_error:
        r = args.registration_error
        emit(
            f"\nEvery depth image is misregistered against the camera model it is paired with: shifted du "
            f"{r['du']:+g} px, dv {r['dv']:+g} px, rotated {r['roll']:+g} deg about the principal point."
        )
    if args.fixed_pattern is not None:
        emit(
            f"\nA fixed-pattern depth noise is added, the same in every frame of a placement: {args.fixed_pattern:g} "
            "mm at 1 m (growing with depth squared), correlated over "
            + ("the profile's correlation_px" if args.fixed_pattern_px is None else f"{args.fixed_pattern_px:g} px")
            + " (the sensor's own pixels)."
        )
    if args.joint_offsets is not None:
        emit(
            "\nThe robot's joints read less than they stand by "
            + ", ".join(f"J{j + 1} {v:+g}" for j, v in enumerate(args.joint_offsets))
            + " deg: the depth is rendered at the true joints, the method told the recorded ones. Truth: the camera "
            "in the robot's kinematic base frame, exp(-delta_1 xi_1) T_phys (joint 1 turns about the base's fixed "
            "axis, which no registration can tell from the camera's pose)."
        )
    if args.intrinsics_error:
        emit(
            "\nThe method is told a camera matrix off the one the depth was rendered with: "
            + ", ".join(f"{k} {v:+g}" + (" px" if k in ("cx", "cy") else "") for k, v in args.intrinsics_error.items())
            + " (fx, fy relative)."
        )
    roots = list(args.data)
    for i, preset in enumerate(args.presets):
        for band in smoke_bands(args.bands, first=i == 0):
            t0 = time.perf_counter()
            roots.append(render_band(args.work, preset, band, args.seed + 1))
            print(f"{roots[-1]}: ready in {time.perf_counter() - t0:.0f} s", flush=True)
    for i, root in enumerate(roots):
        ds = Dataset.open(root)
        noise = ds.meta.get("recipe", {}).get("noise", {}).get("depth_sigma_m_at_1m", 0.0)
        if noise or ds.meta.get("recipe", {}).get("sensor"):
            emit(f"\nwarning: {root} already has depth noise; the sensors add theirs on top")
        surface, stride = robot_surface_for(ds)
        cams = placements(ds, args.split, args.max_placements)
        T_true = ds.truth()
        look_at = np.array(ds.meta.get("recipe", {}).get("preset", {}).get("look_at_m", (0.0, 0.0, 0.0)))
        dist = np.median([np.linalg.norm(T_true[c][:3, 3] - look_at) for c in cams])
        w, h = ds.meta["intrinsics"]["width"], ds.meta["intrinsics"]["height"]
        n_frames = len(ds.select(cams[0], "data")["depth"])
        emit()
        emit(
            f"## {ds.root.name}: {len(cams)} {args.split} placements, {n_frames} frames at {w}x{h}, cameras "
            f"{dist:.2f} m from the workspace centre (median)"
        )
        emit()
        if "T_base_cam_label.x" in ds.cameras():
            labels = ds.labels()
            lab = np.array([pose_error(labels[c], T_true[c]) for c in cams])
            emit(
                f"ChArUco label of the same placements (colour): median {np.median(lab[:, 1]):.2f} mm / "
                f"{np.median(lab[:, 0]):.3f} deg, worst {lab[:, 1].max():.2f} mm / {lab[:, 0].max():.3f} deg"
            )
        else:
            emit("ChArUco label: none (no board view the arm can hold at this distance)")
        emit()
        emit(
            "| sensor, depth | accepted | median mm / deg | worst mm / deg | z RMS trans / rot | wrong (> 3 sigma) "
            "| scale error | offset error | s per placement |"
        )
        emit("|---|---|---|---|---|---|---|---|---|")
        notes = []
        for name in smoke_profiles(args.profiles.split(","), first=i == 0):
            sensor = with_errors(PROFILES[name], args.fixed_pattern, args.fixed_pattern_px)
            modes = [m.strip().replace(";", ",") for m in args.modes.split(",")]
            rows = run_profile(
                ds,
                surface,
                stride,
                cams,
                sensor,
                args.seed,
                args.intrinsics_error,
                modes,
                args.registration_error,
                args.joint_offsets,
            )
            for mode, r in rows.items():
                emit(summary_row(f"{name}, {mode}", r))
            K_true = np.array(ds.meta["intrinsics"]["K"])
            notes += filter(None, (intrinsics_line(f"{name}, {m}", r, K_true) for m, r in rows.items()))
            notes += filter(None, (joint_offsets_line(f"{name}, {m}", r, args.joint_offsets) for m, r in rows.items()))
            notes += filter(None, (sigma_line(f"{name}, {m}", r) for m, r in rows.items()))
        if notes:  # after the table, which they would cut
            emit()
            for line in notes:
                emit(line)
    if args.out:
        args.out.parent.mkdir(parents=True, exist_ok=True)
    return rep.write(args.out)


if __name__ == "__main__":
    sys.exit(main())
