"""The continual learner beside the watcher: every committed camera pose offered to it, its training in the
background, its prediction an extra start of the markerless recalibration.

:class:`BackgroundLearner` wraps a :class:`learned.calibrator.ContinualCalibrator` (or anything with its
``observe(FrameSet) -> dict`` and ``predict(rgb, depth_m, pose_base_ref)``):

- as a :class:`handeye.watch.CellWatcher` ``on_commit`` hook it takes the committed ``T_base_cam`` and the
  frames it came from and queues them; one worker thread turns them into a :class:`learned.data.FrameSet` (the
  committed calibration is the target, ``T_base_ref`` from the robot's kinematics, the images at the preset's
  size; its camera pose number the calibration's version, or the next unused one where the learner has seen that
  number or there is no history) and calls ``observe``, whose novelty test decides whether it trains. The hook
  returns at once: the check never waits for the training (it shares the CPU with it, though: give the process a
  core for each);
- as the watcher's ``extra_starts`` it gives ``{"learned": T_base_cam}`` predicted from the collected frames,
  when a model is trained and not training at that moment (a prediction never waits for a training either:
  while one runs the recalibration starts from the last calibration alone; with ``in_process`` the training
  runs in a child process and the prediction comes from the model before it).

The training shares the machine's cores with the check: on the 2-core development machine (load about 9) the
check's median cost per frame went from 4-8 ms to 12-20 ms while a ``tiny`` preset trained, in a thread or a
child process alike; give the learner cores of its own on a cell.

:meth:`BackgroundLearner.close` ends it (``with`` does too): with ``wait`` (a stream's end) after every queued
offer is learnt; without (the watch stopped by an error or Ctrl-C) the queued offers are dropped and reported, a
training in a child process is terminated and the process joined, and a training in the worker thread, which
cannot be interrupted, is waited for; so no training outlives the watch.

Frames without colour (a source without a colour topic) are not offered: the network takes RGB-D. A user runs::

    handeye watch BAG --sensor d435 --camera-start start.json --history cell.jsonl \\
        --learner cell.pt --learner-preset cpu      # loads cell.pt when it is there, saves it after each training
"""

from __future__ import annotations

import queue
import threading
from collections.abc import Callable
from pathlib import Path

import numpy as np

from handeye.core.se3 import pos_quat_xyzw_from_transform

__all__ = ["BackgroundLearner", "frame_set"]

#: Seconds between looks at ``close(wait=False)`` and at the child's life while a child process trains.
STOP_POLL_S = 0.1


def frame_set(frames: list, T_base_cam: np.ndarray, reference: Callable, K: np.ndarray, image_size: tuple, camera: int):
    """Watcher frames as the learner's :class:`learned.data.FrameSet` of one camera pose.

    Parameters
    ----------
    frames : list of Frame
        Each with ``rgb`` (H, W, 3).
    T_base_cam : array, shape (4, 4), or None
        The target (the committed calibration); None: unknown (NaN), for a prediction.
    reference : callable
        ``reference(q (N, nq)) -> T_base_ref (N, 4, 4)`` (:meth:`handeye.robot.model.Robot.fk_ref`).
    K : array, shape (3, 3)
        The native images' camera matrix.
    image_size : (int, int)
        ``(width, height)`` of the learner's input.
    camera : int
        The camera pose's number (the calibration's version).

    Returns
    -------
    learned.data.FrameSet
    """
    from learned.data import FrameSet, pose_targets, resize_image

    n, (w, h) = len(frames), image_size
    rgb = np.stack(
        [resize_image(np.asarray(f.rgb, np.uint8), (w, h), nearest=False).transpose(2, 0, 1) for f in frames]
    )
    depth = np.stack([resize_image(np.asarray(f.depth_m, np.float32), (w, h), nearest=True)[None] for f in frames])
    q = np.stack([np.asarray(f.joints, dtype=float) for f in frames])
    t_m, q_xyzw = pos_quat_xyzw_from_transform(np.asarray(reference(q), dtype=float).reshape(n, 4, 4))
    target = np.full((4, 4), np.nan) if T_base_cam is None else np.asarray(T_base_cam, dtype=float)
    t_mm, q_cam = pose_targets(np.repeat(target[None], n, axis=0))
    native_h, native_w = frames[0].depth_m.shape
    k_norm = [K[0, 0] / native_w, K[1, 1] / native_h, (K[0, 2] + 0.5) / native_w, (K[1, 2] + 0.5) / native_h]
    return FrameSet(
        rgb.astype(np.uint8),
        depth.astype(np.float16),
        np.concatenate([t_m, q_xyzw], axis=1).astype(np.float32),
        t_mm.astype(np.float32),
        q_cam.astype(np.float32),
        np.full(n, int(camera)),
        np.zeros(n, int),
        np.array(["train"] * n),
        np.full((n, 3), np.nan),
        np.full((n, 4), np.nan),
        "markerless",
        (w, h),
        joints=q.astype(np.float32),
        intrinsics_norm=np.tile(np.array(k_norm, np.float32), (n, 1)),
    )


class BackgroundLearner:
    """A continual learner fed by the watcher's commits, training in a thread (module docstring).

    Parameters
    ----------
    calibrator : learned.calibrator.ContinualCalibrator
        Or anything with ``observe``, ``predict``, ``preset.image_size`` and ``models`` (empty: untrained).
    reference : callable
        ``reference(q (N, nq)) -> T_base_ref (N, 4, 4)``: the robot's :meth:`~handeye.robot.model.Robot.fk_ref`.
    K : array, shape (3, 3)
        The camera matrix of the frames' images.
    save_path : str or Path, optional
        Where the calibrator is saved after each offer it trained on.
    in_process : bool
        Train in a child process (spawned, one torch thread), the calibrator sent there and back: the watcher's
        process keeps its interpreter (no GIL shared with the training) and predicts with the last model
        meanwhile. False: in the worker thread, the calibrator locked (no prediction while it trains).

    Attributes
    ----------
    reports : list of str
        One line per offer (its outcome, or the error that stopped it), in order.
    """

    def __init__(
        self,
        calibrator,
        reference: Callable,
        K: np.ndarray,
        save_path: str | Path | None = None,
        in_process: bool = False,
    ):
        self.calibrator = calibrator
        self.reference = reference
        self.K = np.asarray(K, dtype=float)
        self.save_path = None if save_path is None else Path(save_path)
        self.in_process = bool(in_process)
        self.reports: list[str] = []
        self._busy = threading.Lock()  # held while the calibrator trains or predicts
        self._offers: queue.Queue = queue.Queue()
        self._worker: threading.Thread | None = None
        self._pending = 0  # offers queued or being learnt
        self._cameras: set[int] = set()  # the camera pose numbers given to offers
        self._idle = threading.Condition()
        self._stopping = False  # close() without waiting: queued offers dropped, a child's training ended
        self._closed = False

    @property
    def image_size(self) -> tuple:
        return tuple(self.calibrator.preset.image_size)

    def __call__(self, T_base_cam: np.ndarray, frames: list, version: int | None = None) -> None:
        """Offer a committed camera pose (the ``on_commit`` hook): queued, never waited for."""
        if not frames:  # a version the watcher took from the history (a rollback): nothing new to learn
            return
        if any(getattr(f, "rgb", None) is None for f in frames):
            self.reports.append(f"learner: version {version} not offered: frames without colour")
            return
        if self._closed:
            self.reports.append(f"learner: version {version} not offered: the learner is closed")
            return
        with self._idle:
            self._pending += 1
        self._offers.put((np.array(T_base_cam, dtype=float), list(frames), version))
        if self._worker is None:
            self._worker = threading.Thread(target=self._work, name="handeye-learner", daemon=True)
            self._worker.start()

    def _work(self) -> None:
        while True:
            item = self._offers.get()
            if item is None:  # close()
                return
            T, frames, version = item
            try:
                if self._stopping:
                    raise _Stopped
                data = frame_set(frames, T, self.reference, self.K, self.image_size, self._camera(version))
                out = self._observe(data)
                trained = any(isinstance(v, dict) and v.get("novel") for v in out.values()) or out.get("first")
                if trained and self.save_path is not None:
                    with self._busy:
                        self.calibrator.save(self.save_path)
                self.reports.append(f"learner: version {version} observed: {_summary(out)}")
            except _Stopped:
                self.reports.append(f"learner: version {version} not learnt: the watch stopped")
            except Exception as exc:  # the learner never stops the watcher: its failure is reported
                self.reports.append(f"learner: version {version} failed: {type(exc).__name__}: {exc}")
            finally:
                with self._idle:
                    self._pending -= 1
                    self._idle.notify_all()

    def _camera(self, version: int | None) -> int:
        """The offer's camera pose number: the calibration's version unless the learner has seen that number (a
        state loaded from another history) or there is none (no history), then the next unused one."""
        seen = {int(c) for e in getattr(self.calibrator, "history", []) for c in e.get("cameras", [])}
        seen |= self._cameras
        camera = version if version is not None and version not in seen else max(seen, default=-1) + 1
        self._cameras.add(camera)
        return camera

    def _observe(self, data) -> dict:
        """``observe`` here (the calibrator locked) or in a child process (the calibrator replaced after)."""
        if not self.in_process:
            with self._busy:
                return self.calibrator.observe(data)
        import multiprocessing

        ctx = multiprocessing.get_context("spawn")
        answer, sender = ctx.Pipe(duplex=False)
        child = ctx.Process(target=_observe_child, args=(self.calibrator, data, sender), name="handeye-learner")
        child.start()
        sender.close()
        try:
            while not answer.poll(STOP_POLL_S):
                if self._stopping:
                    raise _Stopped
                if not child.is_alive() and not answer.poll():
                    raise RuntimeError(f"the training process ended (exit code {child.exitcode}) without an answer")
            ok, payload = answer.recv()
        finally:  # stopped or failed: no training outlives this call
            if child.is_alive():
                child.terminate()
            child.join()
            answer.close()
        if not ok:
            raise payload
        calibrator, out = payload
        with self._busy:
            self.calibrator = calibrator
        return out

    def starts(self, frames: list) -> dict:
        """``{"learned": T_base_cam}`` predicted from ``frames`` (the watcher's ``extra_starts``); ``{}`` when
        untrained, training now, or the frames have no colour, and when the prediction fails or is not a rigid
        transform (a line in :attr:`reports` says why: the learner never stops the watcher, and the registration
        raises on a start that is not a rigid transform)."""
        from handeye.core.validation import check_transforms

        if not getattr(self.calibrator, "models", None) or any(getattr(f, "rgb", None) is None for f in frames):
            return {}
        if not self._busy.acquire(blocking=False):
            return {}
        try:
            data = frame_set(frames, None, self.reference, self.K, self.image_size, 0)
            T = self.calibrator.predict(data.rgb, data.depth_m, data.pose_base_ref)
            return {"learned": check_transforms(T, "the learned T_base_cam")[0]}
        except Exception as exc:  # reported: the recalibration starts without it
            self.reports.append(f"learner: no start: {type(exc).__name__}: {exc}")
            return {}
        finally:
            self._busy.release()

    def wait(self, timeout_s: float | None = None) -> bool:
        """Wait for the offers queued to be learnt (at the end of a replay); whether they all were."""
        with self._idle:
            return self._idle.wait_for(lambda: self._pending == 0, timeout_s)

    def close(self, wait: bool = True) -> None:
        """End the worker (module docstring): with ``wait`` after the queued offers are learnt; without, they are
        dropped (each reported) and a child process's training terminated. Returns when the worker has ended;
        later offers are refused (reported)."""
        self._closed = True
        if not wait:
            self._stopping = True
        if self._worker is not None:
            self._offers.put(None)
            self._worker.join()

    def __enter__(self) -> "BackgroundLearner":
        return self

    def __exit__(self, kind, exc, tb) -> None:
        self.close(wait=kind is None)


def _observe_child(calibrator, data, sender) -> None:
    """A spawned process's target: ``(True, (calibrator, answer))`` or ``(False, the exception)`` sent back."""
    try:
        result = (True, _observe_elsewhere(calibrator, data))
    except Exception as exc:  # sent back to be reported by the worker thread
        result = (False, exc)
    try:
        sender.send(result)
    except Exception as exc:  # an answer or exception that does not pickle
        sender.send((False, RuntimeError(f"the training's answer could not be sent back: {type(exc).__name__}: {exc}")))
    finally:
        sender.close()


class _Stopped(Exception):
    """The watch stopped (``close(wait=False)``): the offer is dropped."""


def _observe_elsewhere(calibrator, data, threads: int = 1) -> tuple:
    """In the child process: ``observe`` with ``threads`` torch threads; the calibrator and its answer."""
    try:
        import torch

        torch.set_num_threads(threads)
    except ImportError:
        pass
    return calibrator, calibrator.observe(data)


def _summary(out: dict) -> str:
    parts = []
    for kind, v in out.items():
        if isinstance(v, dict) and "novel" in v:
            err = v.get("sample_error")
            parts.append(
                f"{kind} {'novel, trained' if v['novel'] else 'known, skipped'}"
                + ("" if err is None else f" (sample error {float(err):.2f})")
            )
    return ", ".join(parts) or "observed"
