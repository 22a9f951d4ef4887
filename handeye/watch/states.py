"""Each frame's state from its check, the change test and a slow trend.

In order, per frame (:class:`FrameStates.classify`):

1. **out_of_view**: fewer than ``min_visible`` model points project into the image;
2. **dropout**: more than ``dropout_fraction`` of them have no depth;
3. **occluded**: more than ``occluded_fraction`` of those with depth see something in front of the arm
   (outside the match window) while few see the background behind it: an occluder can only be in front,
   a moved camera puts model pixels on the background too. These frames do not enter the change test
   (their matched points would, but a half-hidden arm biases the step at the occluder's edge). Not when the
   residuals are consistent: if at least ``1 - occluded_fraction`` of the pixels with depth lie within the
   match window of their median residual, the whole surface is off by one offset (a moved camera, or a depth
   unit whose scale or offset is wrong), which no occluder makes (it leaves the pixels beside it matched);
   such a frame goes on to the change test (a lost frame, when the offset is beyond the window);
4. the frame enters the CUSUM (:mod:`handeye.watch.change`) with ``x = chi2 / c`` (``c`` at the upper bound of a
   :class:`handeye.watch.change.NullScale`, where one is given, which the frame's ``chi2`` then joins unless its
   run ends in an alarm); a frame whose matched
   points fall below ``lost_matched_fraction`` (the surface is off by more than the match window) enters
   with the largest increment. An alarm is **moved** when the corrections of the frames since the CUSUM left
   0 with a positive increment agree (their weighted mean's chi2 per degree of freedom is at least
   ``consistency_ratio`` times their scatter's, or most of them were lost frames), else **occluded** (large
   but inconsistent: a person passing) and the CUSUM is re-armed;
5. **drift**: an EWMA of ``delta - delta_ref`` (weight ``drift_alpha``) outside the ``drift_level`` tail of its
   stationary ``chi2(6)`` (covariance ``c (Sigma alpha / (2 - alpha) + Sigma_ref)``, ``Sigma`` an EWMA of the
   frames', ``Sigma_ref`` the error of ``delta_ref``, :class:`handeye.watch.change.NullModel`): a slow
   consistent trend below the alarm. Reported, never a recalibration; its per-frame tail probability is not
   a false-alarm rate (the EWMA is correlated from frame to frame) and none is stated;
6. else **ok**.
"""

from __future__ import annotations

from collections import deque
from dataclasses import dataclass, replace

import numpy as np
from scipy import stats

from handeye.watch.change import Cusum, NullModel, NullScale, llr
from handeye.watch.check import FrameCheck

__all__ = ["StateOptions", "FrameStates", "screen", "is_lost"]


@dataclass(frozen=True)
class StateOptions:
    """Thresholds of :class:`FrameStates` (module docstring)."""

    min_visible: int = 200
    dropout_fraction: float = 0.5
    occluded_fraction: float = 0.2
    behind_fraction_of_occluders: float = 0.5
    lost_matched_fraction: float = 0.3
    consistency_ratio: float = 0.1  # a first setting: a large move's one-step corrections vary with the arm's pose
    drift_alpha: float = 0.02
    drift_level: float = 1e-4

    def __post_init__(self):
        for key in ("dropout_fraction", "occluded_fraction", "lost_matched_fraction", "drift_alpha", "drift_level"):
            value = getattr(self, key)
            if not 0 < value < 1:
                raise ValueError(f"StateOptions.{key} must lie in (0, 1), got {value}")


def screen(check: FrameCheck, options: StateOptions, occlusion: bool = True) -> tuple[str, str] | None:
    """Steps 1-3 of the module docstring: ``(state, detail)`` of a frame the change test cannot use, else None.

    ``occlusion`` False skips step 3 (against a calibration known to be off, points in front say nothing).
    """
    o = options
    if check.n_visible < o.min_visible:
        return "out_of_view", f"{check.n_visible} model points visible (< {o.min_visible})"
    if check.n_dropout > o.dropout_fraction * check.n_visible:
        return "dropout", f"{check.n_dropout} of {check.n_visible} model pixels without depth"
    occluders, behind = check.fraction(check.n_occluders), check.fraction(check.n_behind)
    consistent = check.fraction(check.n_at_offset) >= 1 - o.occluded_fraction  # one offset: a move or a unit
    if occluders > o.occluded_fraction and behind < o.behind_fraction_of_occluders * occluders:
        if occlusion and not consistent:
            return "occluded", f"{occluders:.0%} of the model's pixels see something in front"
    return None


def is_lost(check: FrameCheck, options: StateOptions) -> bool:
    """Whether the surface is off by more than the match window: no step, or fewer than
    ``lost_matched_fraction`` of the model's pixels with depth matched."""
    return check.delta is None or check.fraction(check.n_matched) < options.lost_matched_fraction


class FrameStates:
    """The classifier of the module docstring, with its memory (the CUSUM, the run's corrections, the EWMA).

    Parameters
    ----------
    null : NullModel
    cusum : Cusum
    options : StateOptions, optional
    scale : NullScale, optional
        The null's scale learnt on from the frames tested: ``null`` (and any null given later) is used with its
        upper bound instead of its own scale.
    """

    def __init__(
        self, null: NullModel, cusum: Cusum, options: StateOptions | None = None, scale: NullScale | None = None
    ):
        self.scale = scale
        self.null = null if scale is None else replace(null, scale=scale.bound)
        self.cusum = cusum
        self.options = options or StateOptions()
        # (delta - ref, covariance), or None for a lost frame: the CUSUM run's frames with a positive increment
        self._run: deque = deque(maxlen=600)
        self._ewma = np.zeros(6)
        self._ewma_cov = None
        self._ewma_frames = 0
        self._drift_bound = float(stats.chi2.isf(self.options.drift_level, 6))

    def rearm(self, null: NullModel | None = None) -> None:
        """After a recalibration: the CUSUM, the run and the EWMA back to 0 (and a new null, if given)."""
        if self.scale is not None:
            self.scale.drop()
        if null is not None:
            self.null = null if self.scale is None else replace(null, scale=self.scale.bound)
        self.cusum.reset()
        self._run.clear()
        self._ewma[:] = 0.0
        self._ewma_cov, self._ewma_frames = None, 0

    def classify(self, check: FrameCheck, drift: bool = True, new_pose: bool = True) -> tuple[str, str]:
        """The frame's state and a short detail (module docstring); ``drift`` False skips step 5 (while the
        reference is still being learnt); ``new_pose``: the arm's pose differs from the previous frame's (counted
        by the :class:`NullScale`)."""
        o = self.options
        unusable = screen(check, o)
        if unusable is not None:
            return unusable
        lost = is_lost(check, o)
        x = np.inf if lost else self.null.statistic(check.delta, check.covariance)
        if llr(x, self.cusum.rho) > 0:  # the frames that push towards an alarm: their directions are compared
            self._run.append(None if lost else (check.delta - self.null.delta_ref, check.covariance))
        alarm = self.cusum.update(x)
        if self.scale is not None and not lost:
            self.scale.add(x * self.null.scale, new_pose)
        if self.cusum.value == 0:
            self._run.clear()
            if self.scale is not None and self.scale.keep():
                self.null = replace(self.null, scale=self.scale.bound)
        detail = f"x {x:.1f}, cusum {self.cusum.value:.1f} / {self.cusum.h:.1f}"
        if alarm:
            if self.scale is not None:
                self.scale.drop()
            consistent, why = self._consistent()
            if consistent:
                return "moved", f"{detail}; {why}"
            self.cusum.reset()
            self._run.clear()
            return "occluded", f"{detail}; alarm without a consistent direction ({why})"
        if drift and not lost and self._drifting(check):
            return "drift", f"{detail}; EWMA of the correction beyond its {o.drift_level:g} tail"
        return "ok", detail

    def _consistent(self) -> tuple[bool, str]:
        """Whether the run's corrections agree on a direction."""
        run = list(self._run)
        seen = [r for r in run if r is not None]
        if len(seen) < len(run) / 2:
            return True, f"{len(run) - len(seen)} of {len(run)} frames off by more than the match window"
        infos = [np.linalg.inv(c) for _, c in seen]
        info = sum(infos)
        mean = np.linalg.solve(info, sum(i @ d for i, (d, _) in zip(infos, seen)))
        c = self.null.scale
        mean_chi2 = float(mean @ info @ mean) / c
        scatter = sum(float((d - mean) @ i @ (d - mean)) for i, (d, _) in zip(infos, seen)) / c
        dof = 6 * max(len(seen) - 1, 1)
        ratio = (mean_chi2 / 6) / max(scatter / dof, 1.0)
        what = f"mean chi2/6 {mean_chi2 / 6:.1f} over scatter/dof {scatter / dof:.1f} = {ratio:.1f}"
        return ratio >= self.options.consistency_ratio, what

    def _drifting(self, check: FrameCheck) -> bool:
        a = self.options.drift_alpha
        d = check.delta - self.null.delta_ref
        self._ewma = (1 - a) * self._ewma + a * d
        cov = check.covariance * self.null.scale
        self._ewma_cov = cov if self._ewma_cov is None else (1 - a) * self._ewma_cov + a * cov
        self._ewma_frames += 1
        if self._ewma_frames < 1.0 / a:
            return False
        # the EWMA's own spread plus the reference's (without its covariance: a median of N frames, pi / 2 / N)
        ref = self.null.ref_covariance
        if ref is None:
            spread = self._ewma_cov * (a / (2 - a) + np.pi / 2 / max(self.null.frames, 1))
        else:
            spread = self._ewma_cov * (a / (2 - a)) + ref * self.null.scale
        stat = float(self._ewma @ np.linalg.solve(spread, self._ewma))
        return stat > self._drift_bound
