"""Running cell (issue 43): simulated streams replayed through :class:`handeye.watch.CellWatcher`, scored
against the simulator's truth (``stream.json`` and ``cameras.csv`` of :mod:`sim.stream`).

Two streams are rendered (or reused from ``--data``): the ``bumps`` preset (bumps of 0.5 mm / 0.05 deg to
50 mm / 5 deg and a 200 mm / 20 deg re-mount, occlusions, a lighting change, dropouts, 0.1 mm/min drift) and
the ``static`` preset (no camera change; persons, boxes, dimmed lights and dropouts repeated). Each frame is
fed to the watcher in time order, ``t = frame / rate_hz``; a frame whose depth was lost is fed with an empty
depth image (the sensor sent none). The watcher starts from the true first placement (a perfect initial
calibration: the benchmark measures the watching, not the first calibration), with its options and its
recalibration as ``handeye watch`` builds them (:func:`handeye.commands.watch.watch_options`: the check's and the
recalibration's z-buffer at the stride the robot surface was sampled for, 2 beyond 160 pixels of width); the
depth unit is not given: the first learning fits it (``--truth-start`` would give the simulator's).

Printed and written (``--out``):

- per bump: the detection delay (the first alarm, :func:`is_alarm`, at or after the bump, before the next
  camera change; "stale already" where the bump came while an earlier alarm's recalibration was pending),
  the committed calibration's error against the truth of the frame it was committed at, and that error over
  the registration's own sigma;
- per stream, every commit and every refusal counted apart: a commit more than :data:`WRONG_SIGMAS` of its own
  sigmas from the truth (translation or rotation) is a wrong answer reported as a success;
- false alarms: ``moved`` alarms on the static stream per hour (:func:`is_alarm`: a return to ``moved`` while
  collecting after a refusal or a dropout is not one), with the 95 % bounds of a Poisson rate given the
  count, against the watcher's stated rate; on the bumps stream, every alarm but the first after each bump;
- what the watcher said during each occlusion and dropout (the share of their frames it called so);
- the check's cost per frame (wall time of ``feed`` on frames without a recalibration, numpy on one
  thread) and each recalibration's time;
- with ``--profiles``, a detection-delay table: one bumps stream per sensor profile, ``--profile-minutes`` long at
  ``--profile-size`` and ``--profile-rate`` (``--streams`` with no name: only these);
- with ``--plot``, a PNG beside ``--out``: the CUSUM statistic against its threshold over time, with the
  events.

Example::

    python benchmarks/running_cell.py --data /tmp/running-cell --out benchmarks/results/running_cell.md --plot
"""

from __future__ import annotations

import os

if __name__ == "__main__":  # the check on one core: set before numpy starts its thread pools
    for _var in ("OMP_NUM_THREADS", "OPENBLAS_NUM_THREADS", "MKL_NUM_THREADS"):
        os.environ.setdefault(_var, "1")

import argparse  # noqa: E402
import sys  # noqa: E402
import tempfile  # noqa: E402
import time  # noqa: E402
from dataclasses import dataclass, field  # noqa: E402
from pathlib import Path  # noqa: E402

import numpy as np  # noqa: E402

sys.path.insert(0, os.path.dirname(os.path.dirname(os.path.abspath(__file__))))

from benchmarks._report import Report  # noqa: E402
from handeye.core.metrics import pose_error  # noqa: E402
from handeye.core.numbers import parse_int  # noqa: E402
from handeye.core.safe_write import write_figure_atomic  # noqa: E402
from handeye.core.smoke import smoke_test  # noqa: E402

#: The states of a frame the change test watched (not learning, not collecting frames after an alarm).
WATCHING = ("ok", "drift", "occluded", "out_of_view", "dropout")
#: A committed calibration farther than this many of its own sigmas from the truth is counted wrong (as
#: benchmarks/markerless_sensors.py counts the registration's answers).
WRONG_SIGMAS = 3.0
#: The 95 % upper bound of a Poisson mean given 0 counts is -ln(0.05) = 3.0; for k counts scipy's chi2 gives it.
CONFIDENCE = 0.95


def image_size(text: str) -> tuple[int, int]:
    """``WIDTHxHEIGHT`` as two integers from 16 to 4096 (an argparse type), each side in the number grammar of
    :func:`handeye.core.numbers.parse_int`, as ``handeye sim stream --size`` reads it (``int()`` takes ``9_6``
    and full-width digits)."""
    parts = text.lower().split("x")
    try:
        size = tuple(parse_int(v, "--size", ValueError) for v in parts)
    except ValueError:
        size = ()
    if len(size) != 2 or not all(16 <= v <= 4096 for v in size):
        raise argparse.ArgumentTypeError(f"{text!r}: WIDTHxHEIGHT, two integers from 16 to 4096 (e.g. 256x256)")
    return size


def parse_args(argv=None) -> argparse.Namespace:
    p = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    p.add_argument("--data", type=Path, default=None, help="folder of the rendered streams (reused when there)")
    p.add_argument("--sensor", default="d435")
    p.add_argument("--seed", type=int, default=0)
    p.add_argument("--rate", type=float, default=5.0, help="frames per second of the streams")
    p.add_argument("--minutes", type=float, default=None, help="length of the bumps stream (default the preset's)")
    p.add_argument("--static-minutes", type=float, default=3.0, help="length of the static stream")
    p.add_argument("--size", type=image_size, default=(256, 256), help="image WIDTHxHEIGHT")
    p.add_argument(
        "--static-size", type=image_size, default=None, help="the static stream's WIDTHxHEIGHT (default --size)"
    )
    p.add_argument("--static-rate", type=float, default=None, help="the static stream's rate (default --rate)")
    p.add_argument(
        "--profiles",
        nargs="*",
        default=[],
        help="sensor profiles for a delay-per-bump-size table, each on its own bumps stream of --profile-minutes "
        "at --profile-size",
    )
    p.add_argument("--profile-minutes", type=float, default=2.5, help="length of the profiles' bumps streams")
    p.add_argument("--profile-size", type=image_size, default=(128, 128), help="the profiles' streams' size")
    p.add_argument(
        "--profile-rate", type=float, default=None, help="the profiles' streams' frames per second (default --rate)"
    )
    p.add_argument("--null-seconds", type=float, default=10.0, help="seconds the watcher learns 'nothing moved'")
    p.add_argument(
        "--relearn-seconds", type=float, default=3.0, help="seconds the bias is relearnt over after a commit"
    )
    p.add_argument("--recal-frames", type=int, default=30, help="frames a recalibration uses (the watcher's default)")
    p.add_argument("--false-alarms-per-hour", type=float, default=0.1, help="the watcher's stated bound (its default)")
    p.add_argument(
        "--streams",
        nargs="*",
        choices=("bumps", "static"),
        default=["bumps", "static"],
        help="which to replay (none given: only the --profiles)",
    )
    p.add_argument("--workers", type=int, default=2, help="rendering processes")
    p.add_argument("--plot", action="store_true", help="a PNG of the statistic and the events beside --out")
    p.add_argument("--out", default=None, help="write the report here (markdown)")
    return p.parse_args(argv)


# ------------------------------------------------------------------ the streams


def stream_dir(data: Path, preset: str, args, sensor: str | None = None) -> Path:
    """The rendered stream of a preset, rendered now unless ``data/NAME/stream.json`` exists (``NAME`` the
    preset, or ``bumps-SENSOR`` for a profile's stream)."""
    from sim.stream import StreamOverrides, generate_stream

    root = data / (preset if sensor is None else f"{preset}-{sensor}")
    if (root / "stream.json").is_file():
        return root
    minutes, size, rate = args.minutes, args.size, args.rate
    if preset == "static":
        minutes, size, rate = args.static_minutes, args.static_size or args.size, args.static_rate or args.rate
    if sensor is not None:
        minutes, size, rate = args.profile_minutes, args.profile_size, args.profile_rate or args.rate
    overrides = StreamOverrides(minutes, rate, size)
    generate_stream(root, preset, args.seed, sensor or args.sensor, overrides, workers=args.workers, progress=False)
    return root


# ------------------------------------------------------------------ the replay


@dataclass
class Replay:
    """What the watcher did on one stream."""

    events: list = field(default_factory=list)  # (event, T_base_cam after it, segment of the frame)
    states: list = field(default_factory=list)  # the watcher's state after each frame
    cusum: list = field(default_factory=list)  # (t, value, threshold) after each watched frame
    feed_s: list = field(default_factory=list)  # (wall, CPU) time of feed on frames without a recalibration
    recal: list = field(default_factory=list)  # (wall s, result) per registration the watcher asked for
    recal_feed_s: list = field(default_factory=list)  # wall s of each feed that registered (the whole and its halves)
    t: list = field(default_factory=list)


def replay(root: Path, args) -> tuple[Replay, dict, object]:
    """Feed a stream to a fresh watcher; the replay, ``stream.json`` and the dataset."""
    from handeye.commands.watch import watch_options
    from handeye.core.dataset import Dataset
    from handeye.markerless import robot_surface_for
    from handeye.robot.depth_sensors import sensor_profile
    from handeye.watch import CellWatcher, dataset_frames
    from handeye.watch.wiring import WatchFiles
    from sim.stream import read_stream

    ds, doc = Dataset.open(root), read_stream(root)
    K = np.array(ds.meta["intrinsics"]["K"], dtype=float)
    sensor = sensor_profile(doc["sensor"])
    surface, stride = robot_surface_for(ds)
    out = Replay()
    # as handeye watch builds them: the check's z-buffer and the recalibration's at the surface's stride
    options = watch_options(
        doc["rate_hz"],
        stride,
        false_alarms_per_hour=args.false_alarms_per_hour,
        null_seconds=args.null_seconds,
        relearn_seconds=args.relearn_seconds,
        recal_frames=args.recal_frames,
    )
    history = Path(tempfile.mkdtemp(prefix="running-cell-history-"))
    files = WatchFiles(history / "history.jsonl", history / "current.json")
    watcher = CellWatcher(surface, K, ds.truth()[0], sensor, options, files)
    inner = watcher.recalibrate  # the watcher's own, as handeye watch's, timed

    def timed(frames, T_start, **kwargs):
        t0 = time.perf_counter()
        result = inner(frames, T_start, **kwargs)
        out.recal.append((time.perf_counter() - t0, result))
        return result

    watcher.recalibrate = timed
    for frame in dataset_frames(root):
        if abs(frame.t - frame.index / doc["rate_hz"]) > 1e-9 or frame.index != len(out.states):
            raise RuntimeError(f"{root}: frame {frame.index} at t = {frame.t} s, not at frame / rate: replay broken")
        t, segment = frame.t, frame.segment
        recals = len(out.recal)
        t0, c0 = time.perf_counter(), time.process_time()
        events = watcher.feed(frame)
        elapsed = (time.perf_counter() - t0, time.process_time() - c0)
        if len(out.recal) == recals:
            out.feed_s.append(elapsed)
        else:
            out.recal_feed_s.append(elapsed[0])
        out.events += [(e, watcher.T_base_cam.copy(), segment) for e in events]
        out.states.append(watcher.state)
        out.t.append(t)
        if watcher.states is not None:
            out.cusum.append((t, watcher.states.cusum.value, watcher.states.cusum.h))
    return out, doc, ds


# ------------------------------------------------------------------ scoring


def score_bumps(run: Replay, doc: dict, truth: np.ndarray) -> list[dict]:
    """Per bump: delay (to its first alarm, :func:`is_alarm`: a return to 'moved' while collecting after an
    earlier alarm is no detection), committed error, error over sigma (module docstring); ``stale``: the bump
    came while an earlier alarm's recalibration was pending (its frames may mix both camera poses)."""
    changes = sorted(e["t_s"] for e in doc["events"] if e["type"] in ("bump",))
    rows = []
    for e in (e for e in doc["events"] if e["type"] == "bump"):
        later = [t for t in changes if t > e["t_s"]]
        end = later[0] if later else doc["duration_s"]
        inside = [(ev, T, s) for ev, T, s in run.events if e["t_s"] <= ev.t < end]
        moved = next((ev for ev, _, _ in inside if is_alarm(ev)), None)
        after = [(ev, T, s) for ev, T, s in inside if moved is not None and ev.t > moved.t]
        commit = next(((ev, T, s) for ev, T, s in after if ev.state == "recalibrated"), None)
        row = {"bump": e, "delay_s": None if moved is None else moved.t - e["t_s"], "error": None, "ratio": None}
        row["learning"] = e["t_s"] < learnt_at(run)
        before = [ev for ev, _, _ in run.events if ev.t < e["t_s"]]
        row["stale"] = bool(before) and before[-1].stale_since is not None  # an earlier alarm not yet committed
        if commit is not None:
            ev, T, s = commit
            row["error"], row["ratio"] = commit_error(run, T, truth[s])
        row["refused"] = sum(ev.state == "refused" for ev, _, _ in inside)
        row["extra_alarms"] = max(sum(is_alarm(ev) for ev, _, _ in inside) - 1, 0)
        rows.append(row)
    return rows


def commit_error(run: Replay, T_base_cam: np.ndarray, T_true: np.ndarray) -> tuple[tuple, tuple | None]:
    """A committed calibration's error against the truth, ``(mm, deg)``, and that over the sigma of the
    recalibration that gave it (None when no accepted result gave it)."""
    rot_deg, trans_mm = pose_error(T_base_cam, T_true)
    error = (float(trans_mm), float(rot_deg))
    result = next((r for _, r in run.recal if getattr(r, "ok", False) and np.allclose(r.T_base_cam, T_base_cam)), None)
    if result is None:
        return error, None
    sig = result.sigma
    return error, (error[0] / sig["translation_mm"], error[1] / sig["rotation_deg"])


def score_commits(run: Replay, truth: np.ndarray) -> dict:
    """Every commit of a stream against the truth of the frame it was committed at, and the refusals, apart.

    Returns
    -------
    dict
        ``commits``; ``wrong``: those more than :data:`WRONG_SIGMAS` of their own sigmas off (or without a
        sigma); ``refused``: the recalibrations refused.
    """
    commits = [commit_error(run, T, truth[s]) for ev, T, s in run.events if ev.state == "recalibrated"]
    wrong = sum(ratio is None or max(ratio) > WRONG_SIGMAS for _, ratio in commits)
    refused = sum(ev.state == "refused" for ev, _, _ in run.events)
    return {"commits": len(commits), "wrong": wrong, "refused": refused}


def commits_line(run: Replay, truth: np.ndarray) -> str:
    """One line of :func:`score_commits`."""
    c = score_commits(run, truth)
    return (
        f"commits: {c['commits']}, of which {c['wrong']} wrong (more than {WRONG_SIGMAS:g} of their own sigmas from "
        f"the truth: a wrong answer reported as a success); recalibrations refused: {c['refused']}"
    )


def learnt_at(run: Replay) -> float:
    """When the watcher finished learning "nothing moved" (infinity if it never did)."""
    return next((ev.t for ev, _, _ in run.events if ev.previous == "learning"), float("inf"))


def poisson_upper(count: int, level: float = CONFIDENCE) -> float:
    """The ``level`` upper confidence bound of a Poisson mean given ``count`` (Garwood)."""
    from scipy import stats

    return float(stats.chi2.ppf(level, 2 * (count + 1)) / 2)


def poisson_lower(count: int, level: float = CONFIDENCE) -> float:
    """The ``level`` lower confidence bound of a Poisson mean given ``count`` (Garwood; 0 for no count)."""
    from scipy import stats

    return float(stats.chi2.ppf(1.0 - level, 2 * count) / 2) if count > 0 else 0.0


def called(run: Replay, doc: dict, kind: str, state: str) -> list[tuple[dict, float]]:
    """Per interval event (occlusion or dropout): the share of its watched frames (:data:`WATCHING`) the watcher
    put in ``state``; NaN when it watched none of them (learning, or collecting frames to recalibrate)."""
    rate, out = doc["rate_hz"], []
    if kind == "occlusion":
        spans = [(o, o["first_frame"], o["end_frame"]) for o in doc["occlusions"]]
    else:
        spans = [(e, e["frame"], e["end_frame"]) for e in doc["events"] if e["type"] == "dropout"]
    for what, k0, k1 in spans:
        watched = [run.states[k] for k in range(k0, k1) if run.states[k] in WATCHING]
        share = np.mean([s == state for s in watched]) if watched else float("nan")
        out.append(({**what, "t_s": k0 / rate}, float(share)))
    return out


def plot(run: Replay, doc: dict, path: str, title: str) -> None:
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    fig, ax = plt.subplots(figsize=(11, 3.6))
    if run.cusum:
        t, value, h = np.array(run.cusum).T
        ax.plot(t, value, lw=0.8, label="CUSUM")
        ax.plot(t, h, "k--", lw=0.8, label="threshold")
    for e in doc["events"]:
        if e["type"] == "bump":
            ax.axvline(e["t_s"], color="r", lw=1.0)
            ax.text(
                e["t_s"], 1.0, f" {e['translation_mm']:g} mm", color="r", fontsize=7, transform=ax.get_xaxis_transform()
            )
        elif e["type"] == "lighting":
            ax.axvline(e["t_s"], color="orange", lw=0.8, ls=":")
        elif e["type"] == "dropout":
            ax.axvspan(e["t_s"], e["end_t_s"], color="tab:blue", alpha=0.15)
    for o in doc["occlusions"]:
        ax.axvspan(o["first_frame"] / doc["rate_hz"], o["end_frame"] / doc["rate_hz"], color="grey", alpha=0.3)
    for ev, _, _ in run.events:
        if ev.state in ("moved", "recalibrated", "refused"):
            colour = {"moved": "k", "recalibrated": "g", "refused": "m"}[ev.state]
            ax.plot([ev.t], [0], marker="v" if ev.state == "moved" else "^", color=colour, ms=6)
    ax.set_yscale("symlog")
    ax.set_xlabel("time (s)")
    ax.set_title(title + " (red: bumps; grey: occlusions; blue: dropouts; dotted: lights; v moved, ^ recalibrated)")
    if run.cusum:
        ax.legend(loc="upper left", fontsize=7)
    fig.tight_layout()
    write_figure_atomic(fig, path, dpi=110)
    plt.close(fig)


# ------------------------------------------------------------------ report


def watcher_commit() -> str:
    """The commit of handeye/watch this run used, and whether the working tree changed it."""
    import subprocess

    root = Path(__file__).resolve().parents[1]
    try:
        commit = subprocess.run(
            ["git", "log", "-1", "--format=%h", "--", "handeye/watch"], cwd=root, capture_output=True, text=True
        ).stdout.strip()
        dirty = subprocess.run(
            ["git", "status", "--porcelain", "--", "handeye/watch"], cwd=root, capture_output=True, text=True
        ).stdout.strip()
    except OSError:
        return "unknown (no git)"
    return f"{commit or 'unknown'}{' with uncommitted changes' if dirty else ''}"


def _versions() -> str:
    import scipy

    return f"numpy {np.__version__}, scipy {scipy.__version__}"


def unit_line(ds) -> str:
    """The simulated depth unit's systematic errors (the truth the watcher does not know)."""
    cams = ds.cameras()
    scale, offset = cams["depth_scale_true"][0], cams["depth_offset_mm_true"][0]
    z = float(np.linalg.norm(ds.truth()[0][:3, 3] - np.array(ds.meta["recipe"]["stream"]["look_at_m"])))
    return (
        f"depth unit: scale {scale:.4f}, offset {offset:.2f} mm (at the {z:.2f} m to the workspace centre: "
        f"{((scale - 1) * z * 1e3 + offset):+.1f} mm)"
    )


def blind_seconds(run: Replay, doc: dict) -> tuple[float, float]:
    """Seconds the watcher spent learning and stale (:func:`blind_line`)."""
    learning = sum(s == "learning" for s in run.states) / doc["rate_hz"]
    stale = sum(s in ("moved", "refused", "recalibrated") for s in run.states) / doc["rate_hz"]
    return learning, stale


def blind_line(run: Replay, doc: dict) -> str:
    """The time the change test watched nothing: learning (no reference yet: the first seconds, and the first
    frames after each commit) and stale (an alarm until its commit: collecting frames, recalibrating)."""
    learning, stale = blind_seconds(run, doc)
    first = learnt_at(run)
    return (
        f"blind time: {learning:.1f} s learning ({min(first, doc['duration_s']):.1f} s of it the first null, the rest "
        f"after commits), {stale:.1f} s stale (from each alarm to its commit), of {doc['duration_s']:.0f} s"
    )


def state_counts(run: Replay) -> str:
    """How many frames the watcher left in each state."""
    states, counts = np.unique(run.states, return_counts=True)
    return ", ".join(f"{s} {n}" for s, n in zip(states, counts))


def report_bumps(rep: Report, run: Replay, doc: dict, ds) -> None:
    rep.say("## Bumps stream")
    rep.say(unit_line(ds))
    rep.say(f"frames per state: {state_counts(run)}")
    rep.say(blind_line(run, doc))
    rep.say(
        f"{doc['frames']} frames at {doc['rate_hz']:g} Hz ({doc['duration_s']:.0f} s), sensor {doc['sensor']}; "
        f"'nothing moved' learnt by t = {learnt_at(run):.1f} s"
    )
    rep.say()
    rep.say(
        "| bump | t (s) | watcher before it | detected after (s) | committed error (mm / deg) | error / sigma "
        "| refused | extra alarms |"
    )
    rep.say("|---|---|---|---|---|---|---|---|")
    for row in score_bumps(run, doc, ds.truth()):
        e = row["bump"]
        delay = "missed" if row["delay_s"] is None else f"{row['delay_s']:.2f}"
        if row["learning"]:
            delay = "during learning"
        elif row["stale"] and row["delay_s"] is None:
            delay = "stale already"
        err = "none committed" if row["error"] is None else f"{row['error'][0]:.2f} / {row['error'][1]:.3f}"
        ratio = "-" if row["ratio"] is None else f"{row['ratio'][0]:.1f} / {row['ratio'][1]:.1f}"
        size = f"{e['translation_mm']:g} mm / {e['rotation_deg']:g} deg {e['label']}"
        before = run.states[e["frame"] - 1]
        rep.say(
            f"| {size} | {e['t_s']:.1f} | {before} | {delay} | {err} | {ratio} | {row['refused']} "
            f"| {row['extra_alarms']} |"
        )
    rep.say()
    rep.say(
        "detected after: the first alarm between the bump and the next one ('stale already': the bump came "
        "while an earlier alarm's recalibration was pending; a late alarm may have another cause: "
        "the static stream's alarms give the false-alarm rate); committed error: the first calibration committed "
        "after that alarm, against the truth of the frame it was committed at; error / sigma: over the "
        "registration's own sigma (translation / rotation)"
    )
    rep.say(commits_line(run, ds.truth()))
    drift = [ev for ev, _, _ in run.events if ev.state == "drift"]
    rep.say(
        f"drift: {sum(e['type'] == 'drift' for e in doc['events'])} steps of 0.05 mm in the truth; "
        f"the watcher reported 'drift' {len(drift)} times"
    )


def report_intervals(rep: Report, run: Replay, doc: dict) -> None:
    for kind, state in (("occlusion", "occluded"), ("dropout", "dropout")):
        rows = called(run, doc, kind, state)
        if rows:
            cells = ", ".join(
                f"{what.get('shape', '')} t={what['t_s']:.0f}s "
                f"{'not watched' if np.isnan(share) else format(share, '.0%')}".strip()
                for what, share in rows
            )
            rep.say(f"{kind}s called '{state}' (share of their watched frames): {cells}")


def is_alarm(ev) -> bool:
    """Whether an event is an alarm: the 'moved' that made the calibration stale (not a return to 'moved' while
    collecting frames after a refusal or a dropout, which the events also report)."""
    return ev.state == "moved" and ev.stale_since == ev.t


def false_alarm_line(alarms: int, watched_s: float, stated_per_hour: float) -> str:
    """The measured false-alarm rate beside the watcher's stated one (its design under the null learnt, not a
    bound on any stream): the reader sees both, and whether the count shows the rate above the stated one (its
    95 % lower bound, :func:`poisson_lower`, above it)."""
    stated = f"the watcher's stated rate {stated_per_hour:g} per hour"
    if not watched_s > 0:
        return f"{alarms} 'moved' alarms in no watched time: no false-alarm rate (against {stated})"
    hours = watched_s / 3600.0
    lower = poisson_lower(alarms) / hours
    verdict = "shows" if lower > stated_per_hour else "does not show"
    return (
        f"{alarms} 'moved' alarms: {alarms / hours:.1f} per hour (95 % upper bound "
        f"{poisson_upper(alarms) / hours:.1f} per hour) against {stated} (its design while the frames follow the "
        f"null learnt): the count {verdict} a rate above it (95 % lower bound {lower:.1f} per hour)"
    )


def report_static(rep: Report, run: Replay, doc: dict, ds, stated_per_hour: float) -> None:
    rep.say("## Static stream")
    rep.say(unit_line(ds))
    alarms = sum(is_alarm(ev) for ev, _, _ in run.events)
    if learnt_at(run) == float("inf"):
        rep.say(
            f"{doc['frames']} frames at {doc['rate_hz']:g} Hz: the watcher never finished learning 'nothing moved' "
            f"(too few usable frames; the states it gave: {state_counts(run)}); no false-alarm figure"
        )
        report_intervals(rep, run, doc)
        return
    watched_s = sum(s in WATCHING for s in run.states) / doc["rate_hz"]
    rep.say(
        f"{doc['frames']} frames at {doc['rate_hz']:g} Hz, {watched_s:.0f} s watched (frames in the states "
        f"{', '.join(WATCHING)}; first learnt by t = {learnt_at(run):.1f} s); "
        + false_alarm_line(alarms, watched_s, stated_per_hour)
    )
    rep.say(commits_line(run, ds.truth()))
    rep.say(blind_line(run, doc))
    report_intervals(rep, run, doc)


def report_profiles(rep: Report, runs: list[tuple[str, Replay, dict, object]]) -> None:
    """Detection delay per bump size, one row per sensor profile (each its own bumps stream)."""
    if not runs:
        return
    _, _, doc0, _ = runs[0]
    sizes = [f"{e['translation_mm']:g} mm / {e['rotation_deg']:g} deg" for e in doc0["events"] if e["type"] == "bump"]
    rep.say("## Detection delay per sensor profile")
    rep.say(
        f"each profile its own bumps stream: seed {doc0['seed']}, {doc0['frames']} frames at {doc0['rate_hz']:g} Hz "
        f"({doc0['duration_s']:.0f} s), {runs[0][3].meta['recipe']['stream']['image_size']} pixels; seconds from "
        "the bump to the first alarm before the next bump ('learning': it came while the watcher had no reference)"
    )
    rep.say()
    rep.say("| profile | " + " | ".join(sizes) + " | false 'moved' | blind (learning / stale s) |")
    rep.say("|---|" + "---|" * (len(sizes) + 2))
    for name, run, doc, ds in runs:
        cells, rows = [], score_bumps(run, doc, ds.truth())
        for row in rows:
            before = run.states[row["bump"]["frame"] - 1]
            cell = f"{row['delay_s']:.1f}" if row["delay_s"] is not None else "missed"
            cell = "stale already" if row["delay_s"] is None and row["stale"] else cell
            cells.append(cell + (" (learning)" if before == "learning" else ""))
        learning, stale = blind_seconds(run, doc)
        extra = sum(row["extra_alarms"] for row in rows)
        rep.say(f"| {name} | " + " | ".join(cells) + f" | {extra} | {learning:.0f} / {stale:.0f} |")


def report_cost(rep: Report, runs: list[Replay], which: str = "the streams") -> None:
    """The check's cost per frame and the recalibrations' times over ``runs`` (``which`` names them)."""
    if not runs:
        return
    wall, cpu = np.concatenate([r.feed_s for r in runs]).reshape(-1, 2).T * 1e3
    recal = [s for r in runs for s, _ in r.recal]
    steps = [s for r in runs for s in r.recal_feed_s]
    rep.say("## Cost")
    rep.say(
        f"check per frame on {which} (feed without a recalibration, numpy on one thread) over {len(cpu)} frames: "
        "CPU time "
        f"median {np.median(cpu):.1f} ms, 95th percentile {np.percentile(cpu, 95):.1f} ms; wall time median "
        f"{np.median(wall):.1f} ms (the machine's load: {os.getloadavg()[0]:.1f} on {os.cpu_count()} cores)"
    )
    if steps:
        rep.say(
            f"recalibrations: {len(steps)}, {np.median(steps):.1f} s median, {max(steps):.1f} s at most (wall, the "
            f"frame that made each: its frames registered, then each half of them; {len(recal)} registrations, "
            f"{np.median(recal):.1f} s median, {max(recal):.1f} s at most)"
        )


def main(argv=None) -> int:
    args = parse_args(argv)
    Report.cut(args, rate=2.0, minutes=0.5, static_minutes=0.5)  # a smoke run (handeye.core.smoke)
    if smoke_test():
        args.size = (96, 96)
    rep = Report("Running cell: the watcher on simulated streams", "benchmarks/running_cell.py", argv, _versions())
    rep.say(f"watcher: handeye/watch at commit {watcher_commit()}; streams: seed {args.seed}, sensor {args.sensor}")
    rep.say()
    data = args.data or Path(tempfile.mkdtemp(prefix="running-cell-"))
    t0 = time.perf_counter()
    roots = {name: stream_dir(data, name, args) for name in args.streams}
    print(f"streams ready in {time.perf_counter() - t0:.0f} s: {', '.join(map(str, roots.values()))}", file=sys.stderr)
    runs = {}
    for name, root in roots.items():
        runs[name] = replay(root, args)
        if name == "bumps":
            report_bumps(rep, *runs[name])
            report_intervals(rep, *runs[name][:2])
        else:
            report_static(rep, *runs[name], args.false_alarms_per_hour)
        rep.say()
    profiles = []
    for name in args.profiles:
        run, doc, ds = replay(stream_dir(data, "bumps", args, sensor=name), args)
        profiles.append((name, run, doc, ds))
    report_profiles(rep, profiles)
    rep.say()
    if runs:
        report_cost(rep, [run for run, _, _ in runs.values()])
    else:  # only the profiles replayed: their cost
        report_cost(rep, [run for _, run, _, _ in profiles], "the profiles' streams")
    if args.plot and args.out:
        for name, (run, doc, _) in runs.items():
            png = str(Path(args.out).with_suffix("")) + f"_{name}.png"
            plot(run, doc, png, f"{name} stream")
            rep.say(f"plot: {Path(png).name}")
    return rep.write(args.out)


if __name__ == "__main__":
    sys.exit(main())
