"""The depth noise's own bias taken out of a registration's intrinsics (and, asked, its pose): simulation-extrapolation.

The depth noise biases what the fine stage estimates, by an amount the placements share and pooling them does not
average away: with a D435's noise at 1.2 m the focal lengths come out 0.2-0.4 px low and the camera about 1 mm too
far along its axis (``docs/benchmarks/markerless.md``, 'The focal length's noise bias'). It comes from two places
of opposite sign: the second-order residual's curvature term, whose tangential offset holds the noise (errors in
variables), and which matches the gate keeps. A closed form for the first alone made the pooled answers worse; no
model of the second was found. So the bias is measured instead, as :meth:`Problem.depth_debiased` measures the
depth unit's (Cook and Stefanski's simulation-extrapolation): the fine stage is run again on the frames with a
second draw of their own noise added (:meth:`Problem.with_added_noise`), from the answer and its state, at the
second pass's finest gate, :data:`NOISIER_FINE_ITERATIONS` times. That moves the estimate by the bias once more:
the bias grows with the noise's variance (on the analytic sphere scenes of the tests the focal length's mean error
was -0.16, -0.32 and -0.47 px at once, twice and three times the variance). The answer is taken that far back,
``2 theta - theta_noisier``.

- **The intrinsics** (``intrinsics_noise_debiased``, the first pass's default): one draw; reported beside the fit's
  as ``intrinsics["noise_debiased"]``, the estimate the placements pool. The draw's own pull on the estimate is as
  large as the noise's in the answer, so its sigma is sqrt 2 times the fit's (first order); pooled over many
  placements the pulls average out, the bias does not.
- **The pose** (``pose_noise_debiased``, off by default): the draw and its negative, whose first-order pulls
  cancel, their mean move taken back. Alone, with the intrinsics free, the pose's noise is large and the
  extrapolation's own scatter cost more than the bias it took out; under the pool's camera matrix it took the
  camera's bias along its axis out, the medians mixed, for 3 s of CPU more per placement (the option's note).
"""

from __future__ import annotations

from dataclasses import replace

import numpy as np

from classic.markerless.point_to_plane import apply_right
from classic.markerless.problem import Problem
from classic.markerless.result import MarkerlessResult
from classic.markerless.shared_intrinsics import SECOND_PASS_GATES_M, estimate_and_sigma
from handeye.core.metrics import pose_error
from handeye.core.se3 import so3_log

__all__ = ["noise_debiased", "NOISIER_FINE_ITERATIONS", "POSE_SIGNS"]

#: Associations of the noisier fine stage, from the answer and its state: on three paper-real placements with the
#: d435 profile its focal length after 5, 10 and 20 came within 0.01-0.12 px of each other, the association's own
#: wander from one to the next (2 and 3: up to 0.4 px off); about 0.25 s of CPU each at 100 frames.
NOISIER_FINE_ITERATIONS = 5
#: The draws of the pose's extrapolation: the draw and its negative, whose first-order pulls cancel.
POSE_SIGNS = (1.0, -1.0)


def noise_debiased(problem: Problem, result: MarkerlessResult, fine) -> MarkerlessResult:
    """``result`` with the depth noise's own bias taken out where its options ask for it.

    Parameters
    ----------
    problem : Problem
        The registration's, in the state of its answer.
    result : MarkerlessResult
        Its answer (returned as it is when refused, or when neither option asks).
    fine : callable
        ``fine(problem, T_base_cam, name)`` -> outcome with ``fit``: the fine stage
        (:func:`classic.markerless.register._fine`, passed in: that module calls this one).

    Returns
    -------
    MarkerlessResult
        With ``intrinsics_noise_debiased``: ``intrinsics["noise_debiased"]`` (``estimate``, ``sigma``, ``noisier``:
        4 each, pixels, ``(f_x, f_y, c_x, c_y)``), where the intrinsics were estimated. With
        ``pose_noise_debiased``: ``T_base_cam`` moved back by the noisier answers' mean move (camera frame), the move
        (``rotation_deg``, ``translation_mm``) added to the sigma in quadrature and recorded as
        ``diagnostics["noise_debiased_pose"]``. Where the noisier fine stage kept too few matches, the reason in
        ``diagnostics["noise_debiased"]`` and the answer as it was.
    """
    opts = problem.opts
    if not result.ok:
        return result
    fitted = estimate_and_sigma(result.intrinsics, debiased=False)
    intrinsics = opts.intrinsics_noise_debiased and fitted is not None
    if not (intrinsics or opts.pose_noise_debiased):
        return result
    T = result.T_base_cam
    fits = []
    for sign in POSE_SIGNS if opts.pose_noise_debiased else (1.0,):
        noisier = problem.with_added_noise(seed=0, sign=sign)
        noisier.opts = replace(
            opts, fine_gates_m=SECOND_PASS_GATES_M, fine_iterations=min(opts.fine_iterations, NOISIER_FINE_ITERATIONS)
        )
        outcome = fine(noisier, T, "noisier")
        if outcome.fit is None:
            why = "not taken out: the fine stage on the noisier frames kept too few matches"
            return replace(result, diagnostics={**result.diagnostics, "noise_debiased": why})
        fits.append(outcome.fit)
    if intrinsics:
        noisier_theta = np.mean([f.intrinsics for f in fits], axis=0)
        entry = {
            "estimate": [float(x) for x in 2 * fitted[0] - noisier_theta],
            "sigma": [float(x) for x in fitted[1] * (np.sqrt(2.0) if len(fits) == 1 else 1.0)],
            "noisier": [float(x) for x in noisier_theta],
        }
        result = replace(result, intrinsics={**result.intrinsics, "noise_debiased": entry})
    if opts.pose_noise_debiased:
        result = _pose_taken_back(result, [f.T_base_cam for f in fits])
    return result


def _pose_taken_back(result: MarkerlessResult, noisier: list) -> MarkerlessResult:
    """``result``'s pose moved back by the mean move (right perturbation, camera frame) of the ``noisier`` answers'
    poses from it; the move added to the sigma in quadrature (:meth:`MarkerlessResult.widened`: the correction is
    taken as uncertain as it is large) and recorded with its camera-frame translation ``move_cam_mm``."""
    T = result.T_base_cam
    xi = np.mean([np.r_[so3_log(T[:3, :3].T @ Tn[:3, :3]), T[:3, :3].T @ (Tn[:3, 3] - T[:3, 3])] for Tn in noisier], 0)
    T_back = apply_right(T, -xi)
    rot_deg, trans_mm = pose_error(T_back, T)
    term = {
        "rotation_deg": float(rot_deg),
        "translation_mm": float(trans_mm),
        "move_cam_mm": [float(v * 1e3) for v in -xi[3:]],
    }
    return replace(result, T_base_cam=T_back).widened(term, "noise_debiased_pose")
