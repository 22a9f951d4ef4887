"""The markerless registration's answer or refusal (:class:`MarkerlessResult`), and how it is built from the best
start's fit: its residuals, the acceptance test, the intrinsics' and joint offsets' summaries.
"""

from __future__ import annotations

from dataclasses import dataclass, field, replace

import numpy as np

from classic.clustered_covariance import pose_sigma
from classic.markerless.depth_analysis import DepthAnalysis
from classic.markerless.intrinsics import intrinsics_summary
from classic.markerless.kinematics import joint_offsets_summary
from classic.markerless.options import MarkerlessOptions
from classic.markerless.point_to_plane import PlaneFit
from classic.markerless.problem import Outcome, Problem
from classic.markerless.sigma import depth_summary, in_quadrature, registration_terms, sampling_sigma
from handeye.core.errors import HandEyeInputError

__all__ = ["MarkerlessResult", "RefusedError", "build_result", "refused_result"]


class RefusedError(HandEyeInputError):
    """Raised by :meth:`MarkerlessResult.require` when the registration refused to answer."""


@dataclass
class MarkerlessResult:
    """A camera pose from the robot's surface, or a refusal with its reason.

    Attributes
    ----------
    T_base_cam : array, shape (4, 4) or None
        None when refused.
    refused : str or None
        Why no answer is given (too few robot pixels, did not converge, residual too large,
        start outside the basin); None when accepted.
    covariance : array, shape (6, 6)
        Of the camera's right perturbation ``(omega, v)``: rotation (rad) and position (m), camera frame. The whole
        of what :attr:`sigma` adds: the noise's covariance (``diagnostics`` ``covariance_noise``; with
        ``static_parts`` the moving parts' alone), plus the repeated error's (``sigma_repeated``), plus each bounded
        term (the sampling bias, the depth-to-colour extrinsic, the groups' scatter, the static parts' pull) as an
        isotropic block, a third of its square per axis; so ``pose_sigma(covariance, R_base_cam)`` is :attr:`sigma`.
    sigma : dict
        ``rotation_deg`` and ``translation_mm``: predicted RMS error of the estimate, in quadrature: the noise
        the frame-clustered covariance sees, the model's sampling bias bound, the frames' disagreement between
        groups (``diagnostics`` ``sigma_noise``, ``sigma_sampling``, ``sigma_consistency``), the bounded part
        of the depth-to-colour registration (``registration``), with ``static_parts`` their pull on the answer
        (``sigma_static``), and with ``repeated_error_px`` what a depth error repeated at one image position in every
        frame adds (``sigma_repeated``: with the field's ``field_mm_at_1m`` and ``length_px`` as measured).
    residual_mm_per_frame : array, shape (N,)
        RMS point-to-plane residual of the matched points of each frame.
    matched_fraction : float
        Visible model points landing on the observed surface, over all frames.
    start : str
        Which start led to the answer.
    diagnostics : dict
        Among others ``fitted_parts``: ``"moving"`` (the fine stage fitted the parts that move over the recording)
        or ``"all"`` (``static_parts``, or no part moved); with ``static_parts`` beside moving parts,
        ``static_matches``: the static parts' matches fitted, one per z-buffer cell however many frames saw it
        (a repeated error counted once), and ``sigma_static``: how far they moved the answer from the moving parts'
        alone, added whole to the sigma, which is otherwise the moving parts' own (``sigma_noise``: their
        covariance's): the static parts may move the answer, not narrow its sigma. ``covariance_noise``: the
        noise's covariance alone (6 lists of 6), the part of :attr:`covariance` the frames measure. ``noise_bias``
        (with the depth scale and offset estimated): the bias the depth noise itself gives a fit that scales the
        observed depth (:meth:`classic.markerless.problem.Problem.depth_debiased`): the ``scale`` and ``offset_mm``
        taken off the depth unit reported, and the ``rotation_deg`` and ``translation_mm`` it would move the pose
        by, not taken off (on 50-100 frames that made the pose worse). ``sigma_shared_floor`` (with
        :attr:`MarkerlessOptions.intrinsics_floor_prior_sigma`): what was added in quadrature to keep :attr:`sigma`
        no narrower than under that prior, and that sigma as ``floor``.
    depth : dict
        The sensor's depth as the registration found it: ``model``, and with ``"scale-offset"`` the
        ``scale`` and ``offset_mm`` of ``d_obs = scale d + offset`` with their sigmas (``scale_sigma``,
        ``offset_sigma_mm``: the fit's, plus what an error repeated per image pixel adds and the split check's
        groups' scatter beyond their noise (``diagnostics["sigma_consistency"]["depth_variance"]``), as the pose's
        has them);
        ``observability``: the same sigmas from the frames' spread alone (given the
        intrinsics), which decide a refusal for too little depth range; ``range_m`` (the matched depths' 10th
        and 90th percentiles), and the
        noise used (``noise_source``, ``noise_mm_at_median_depth``). With ``stereo_fb_px_m``, ``pixel_locking_px``:
        the matcher's disparity error ``sin`` and ``cos`` coefficients (pixels) with their sigmas, and its
        ``amplitude``.
    intrinsics : dict
        The depth camera's intrinsics as the registration found them: ``model`` (``"estimated"`` or ``"fixed"``),
        ``given`` (``f_x, f_y, c_x, c_y`` of the camera matrix given), and when estimated per name (``fx``,
        ``fy``, ``cx``, ``cy``) the ``estimate``, its ``change`` from the value given, ``sigma``,
        ``prior_sigma``, ``ratio`` (what the frames leave of the sigma over the prior's) and ``determined``
        (the ratio below ``intrinsics_determined_share``); pixels.
    registration : dict
        How the depth-to-colour registration was treated, per part: ``shift_px`` (the depth image's shift against
        the camera model: ``estimated`` with the principal point, its change ``dx``, ``dy`` and ``sigma``; or
        ``taken as exact`` with the intrinsics fixed), ``rotation`` and ``translation`` of the depth-to-colour
        extrinsic (``bounded``: the sigma per axis, ``sigma_deg`` or ``sigma_mm``, added to the pose's over the
        three axes as ``rss_deg``, ``rss_mm``).
    joint_offsets : dict
        The robot's joint zero offsets (true joint = recorded + offset) as the registration found them: ``model``
        (``"estimated"`` or ``"fixed"``, with a ``reason`` when fixed for want of twists), and when estimated
        ``joints``: per joint its ``status`` (``"estimated"``; ``"absorbed"``: it moves every fitted part
        rigidly, so its offset is part of the pose, which is then the camera in the robot's kinematic base frame;
        ``"not seen"``), ``estimate_deg``, ``sigma_deg``, ``prior_sigma_deg``, ``ratio`` (what the frames leave
        of the sigma over the prior's) and ``determined``; ``note`` on the absorbed ones.
    depth_analysis : DepthAnalysis or None
        What the depth frames alone showed (noise, mixed and moving pixels), for a registration of the same frames
        under another camera matrix (``register_robot(depth_analysis=...)``): two bit masks, N H W / 4 bytes (1.6
        MB for 100 frames at 256x256); not in :meth:`to_dict`.
    """

    T_base_cam: np.ndarray | None
    refused: str | None
    covariance: np.ndarray
    sigma: dict
    residual_mm_per_frame: np.ndarray
    matched_fraction: float
    start: str
    diagnostics: dict = field(default_factory=dict)
    depth: dict = field(default_factory=dict)
    intrinsics: dict = field(default_factory=dict)
    registration: dict = field(default_factory=dict)
    joint_offsets: dict = field(default_factory=dict)
    depth_analysis: DepthAnalysis | None = field(default=None, repr=False, compare=False)

    @property
    def ok(self) -> bool:
        return self.refused is None

    def require(self) -> np.ndarray:
        """``T_base_cam``, or :class:`RefusedError` with the reason."""
        if self.refused is not None:
            raise RefusedError(f"markerless registration refused: {self.refused}")
        return self.T_base_cam

    def to_dict(self) -> dict:
        """JSON-serialisable summary."""
        from handeye.core.se3 import pos_quat_xyzw_from_transform

        out = {
            "status": "ok" if self.ok else "refused",
            "refused": self.refused,
            "start": self.start,
            "matched_fraction": self.matched_fraction,
            "sigma": self.sigma,
            "depth": self.depth,
            "intrinsics": self.intrinsics,
            "joint_offsets": self.joint_offsets,
            "registration": self.registration,
            "residual_mm_per_frame": [float(x) for x in self.residual_mm_per_frame],
            "diagnostics": self.diagnostics,
        }
        if self.T_base_cam is not None:
            t, q = pos_quat_xyzw_from_transform(self.T_base_cam)
            out["T_base_cam"] = {
                "matrix": self.T_base_cam.tolist(),
                "translation_m": t.tolist(),
                "quaternion_xyzw": q.tolist(),
            }
        return out


def refused_result(reason: str, diag: dict) -> MarkerlessResult:
    """A refusal: no pose, no sigma; only the reason and what was seen."""
    n = diag["frames"]
    nan_sigma = {"rotation_deg": np.nan, "translation_mm": np.nan}
    return MarkerlessResult(None, reason, np.full((6, 6), np.nan), nan_sigma, np.full(n, np.nan), 0.0, "", diag)


#: The groups' scatter where it was not checked.
_NO_SPLIT = {"rotation_deg": 0.0, "translation_mm": 0.0}
#: :func:`_answer_terms`' parts of a refusal (read only): none.
_NO_TERMS = {
    "split": None,
    "static": (),
    "repeated": (),
    "repeated_covariance": np.zeros((6, 6)),
    "unit": None,
    "intrinsics": None,
}


def build_result(problem: Problem, best: Outcome, diag: dict) -> MarkerlessResult:
    """The best start's fit as the answer with its sigma, or refused with the reason; ``diag`` completed."""
    opts, fit = problem.opts, best.fit
    z_med, lever_m = best.geometry
    res_frame, rms_mm, inl = _residuals_mm(fit, best.matches[1], problem.n)
    noise_mm = float(problem.sigma_z(z_med) * 1e3)
    expected_mm = float(np.hypot(noise_mm, opts.model_floor_m * 1e3))
    sampling = sampling_sigma(z_med, lever_m, problem.K_given, opts)
    # the depth camera is what the registration finds; the colour camera's pose carries the extrinsic's error
    registration = registration_terms(opts, fit, problem.theta_given)
    extrinsic = {
        "rotation_deg": registration["rotation"]["rss_deg"],
        "translation_mm": registration["translation"]["rss_mm"],
    }
    # the depth unit with the depth noise's own bias taken out (the pose, intrinsics and joints are the fit's)
    debiased, noise_bias = problem.depth_debiased(fit, best.matches)
    depth_fit = fit if debiased is None else replace(fit, depth_correction=debiased)
    depth = depth_summary(depth_fit, opts, best.depth_range, problem.noise_source, noise_mm)
    refused = _refusal(opts, best.matched, rms_mm, expected_mm, best.step, depth)
    covariance, parts = fit.covariance, _NO_TERMS
    if not refused:
        covariance, parts = _answer_terms(problem, best, fit.covariance)
    split, static, repeated, unit_shared = parts["split"], parts["static"], parts["repeated"], parts["unit"]
    noise = pose_sigma(covariance, best.T[:3, :3])
    if fit.depth_correction is not None and unit_shared is not None:  # the depth's sigma widened as the pose's
        depth = depth_summary(depth_fit, opts, best.depth_range, problem.noise_source, noise_mm, unit_shared)
    # the whole: the noise's and the repeated error's covariances, each bounded term an isotropic block
    bounded = _bounded_terms(sampling, extrinsic, parts)
    whole = covariance + parts["repeated_covariance"] + sum((_isotropic(t) for t in bounded), np.zeros((6, 6)))
    sigma = in_quadrature(noise, *bounded, *repeated)
    floor = None if refused else _floor_under_stated_prior(problem, best, (sampling, extrinsic))
    if floor is not None:  # no narrower than the answer's sigma under the stated prior
        lack = {k: float(np.sqrt(max(floor[k] ** 2 - sigma[k] ** 2, 0.0))) for k in sigma}
        diag["sigma_shared_floor"] = {**lack, "floor": floor}
        whole = whole + _isotropic(lack)
        sigma = pose_sigma(whole, best.T[:3, :3])
    diag.update(
        {
            "inlier_rms_mm": rms_mm,
            "expected_rms_mm": expected_mm,
            "last_step": float(best.step),
            "matched_points": int(inl.sum()),
            "fitted_parts": "all" if problem.fitted_part is None else "moving",
            **({"static_matches": int(problem.static_rows(best.matches[0]).sum())} if problem.static_once else {}),
            **({"sigma_static": static[0]} if static else {}),
            **({"noise_bias": noise_bias} if noise_bias is not None else {}),
            "sigma_noise": noise,
            "covariance_noise": covariance.tolist(),
            "sigma_sampling": sampling,
            "sigma_consistency": split,
            **({"sigma_repeated": repeated[0]} if repeated else {}),
        }
    )
    return MarkerlessResult(
        None if refused else best.T,
        refused,
        whole,
        sigma,
        res_frame,
        best.matched,
        best.name,
        diag,
        depth,
        _intrinsics_result(fit, problem, parts["intrinsics"]),
        registration=registration,
        joint_offsets=_joint_offsets_result(fit, problem, opts),
    )


def _answer_terms(problem: Problem, best: Outcome, covariance: np.ndarray) -> tuple[np.ndarray, dict]:
    """What the accepted answer ``best.T`` adds to the fit's noise ``covariance`` (6, 6) under the problem's current
    priors: the groups' scatter (``split``, a bounded term or None), with ``static_parts`` their pull (``static``,
    whose covariance then replaces ``covariance``: the moving parts' own), the error repeated at one image position
    (``repeated``, its ``repeated_covariance``) and the depth unit's shared covariance (``unit``, or None).
    Returns the noise's covariance and those parts."""
    opts = problem.opts
    # what the frames share and differ in by depth or image position: the groups' scatter
    split = problem.split_check(best.T, best.matches) if opts.split_check else None
    # the static parts' repeated error: the moving parts' own covariance, and the static parts' pull added whole
    static = []
    if problem.static_once:
        pull, covariance = problem.static_pull(best.T, best.matches)
        static = [pull]
    # an error repeated at one image position in every frame: the covariance between frames the clustering omits
    repeated, repeated_covariance, unit, intrinsics = [], np.zeros((6, 6)), None, None
    if opts.repeated_error_px > 0:
        shared = problem.repeated_error(best.T, best.matches)
        repeated, repeated_covariance = [_repeated_term(shared, best.T[:3, :3])], shared["covariance"][:6, :6]
        unit = shared["covariance"][6:8, 6:8]
        intrinsics = shared.get("intrinsics_covariance")
    if split and "depth_variance" in split:  # the groups' scatter in the depth unit, as in the pose
        unit = (0.0 if unit is None else unit) + np.diag(split["depth_variance"])
    parts = {"split": split, "static": static, "repeated": repeated, "repeated_covariance": repeated_covariance}
    return covariance, {**parts, "unit": unit, "intrinsics": intrinsics}


def _floor_under_stated_prior(problem: Problem, best: Outcome, bounded: tuple) -> dict | None:
    """The sigma the answer ``best.T`` would have under :attr:`MarkerlessOptions.intrinsics_floor_prior_sigma`
    (the stated prior, where the registration ran under a pooled one): its covariance and every term that depends
    on the priors found again at the same matches (no step taken), with the ``bounded`` terms that do not; None
    without a floor prior or with the intrinsics fixed."""
    stated = problem.opts.intrinsics_floor_prior_sigma
    if stated is None or not problem.estimate_intrinsics:
        return None
    with problem.intrinsics_prior(stated):
        fit, _ = problem._solve(best.T, best.matches, iterations=0)
        covariance, parts = _answer_terms(problem, best, fit.covariance)
    return in_quadrature(pose_sigma(covariance, best.T[:3, :3]), *_bounded_terms(*bounded, parts), *parts["repeated"])


def _bounded_terms(sampling: dict, extrinsic: dict, parts: dict) -> tuple:
    """The bounded sigma terms of an answer: the sampling bias, the depth-to-colour extrinsic, the groups' scatter
    (zero where not checked) and, with ``static_parts``, the static parts' pull; each ``rotation_deg``,
    ``translation_mm``."""
    return (sampling, extrinsic, parts["split"] or _NO_SPLIT, *parts["static"])


def _repeated_term(repeated: dict, R_base_cam: np.ndarray) -> dict:
    """The pose's sigma from :attr:`PlaneFit.repeated`, with the repeated field's sigma (mm at 1 m) and
    correlation length (pixels) measured."""
    term = pose_sigma(repeated["covariance"][:6, :6], R_base_cam)
    return {**term, "field_mm_at_1m": repeated["sigma_m_at_1m"] * 1e3, "length_px": repeated["length_px"]}


def _isotropic(term: dict) -> np.ndarray:
    """A sigma term (``rotation_deg``, ``translation_mm``: RMS over the three axes) as a covariance of ``(omega, v)``
    (rad, m), shape (6, 6): a third of its square on each axis, the same in every frame."""
    rotation_rad2 = np.radians(term["rotation_deg"]) ** 2 / 3
    translation_m2 = (term["translation_mm"] * 1e-3) ** 2 / 3
    return np.diag([rotation_rad2] * 3 + [translation_m2] * 3)


def _residuals_mm(fit: PlaneFit, frame: np.ndarray, n: int) -> tuple[np.ndarray, float, np.ndarray]:
    """The inliers' (weight above 1/2) RMS residual per frame (``frame``: each residual's, NaN where none) and over
    all frames, millimetres, and the inliers."""
    inl = fit.weights > 0.5
    group = frame
    res_frame = np.array(
        [
            np.sqrt(np.mean(fit.residuals_m[inl & (group == i)] ** 2)) * 1e3 if np.any(inl & (group == i)) else np.nan
            for i in range(n)
        ]
    )
    rms_mm = float(np.sqrt(np.mean(fit.residuals_m[inl] ** 2)) * 1e3) if inl.any() else np.inf
    return res_frame, rms_mm, inl


def _intrinsics_result(fit: PlaneFit, problem: Problem, repeated: np.ndarray | None = None) -> dict:
    """:attr:`MarkerlessResult.intrinsics` of the final fit; ``repeated`` (4, 4): what an error repeated at one image
    position in every frame adds to their covariance (a fixed pattern pulls each placement's focal length its own
    way, which the frames' clustering cannot see), as the pose's and the depth unit's sigmas have it."""
    if fit.intrinsics is None:
        return {"model": "fixed", "given": [float(x) for x in problem.theta_given]}
    return intrinsics_summary(
        fit.intrinsics,
        fit.intrinsics_covariance if repeated is None else fit.intrinsics_covariance + repeated,
        fit.intrinsics_covariance_frames,
        problem.K_given,
        problem.intrinsics_prior_sigma,
        problem.opts.intrinsics_determined_share,
    )


def _refusal(opts: MarkerlessOptions, matched: float, rms_mm: float, expected_mm: float, step: float, depth: dict):
    """Why the fit is no calibration (outside the basin, residual too large, not converged, depth not observable),
    or None."""
    observe = depth.get("observability", {})  # the frames' geometry alone decides whether the depth is observable
    if matched < opts.min_matched_fraction:
        return (
            f"start outside the basin: only {matched:.0%} of the visible model lands on the observed surface "
            f"(at least {opts.min_matched_fraction:.0%} needed)"
        )
    if rms_mm > opts.max_residual_ratio * expected_mm:
        return f"residual too large: {rms_mm:.2f} mm RMS against {expected_mm:.2f} mm expected from the depth noise"
    if step > 1e-4:
        return f"did not converge: last step {step:.2g} (rad + m)"
    if observe.get("scale_sigma", 0.0) > opts.max_depth_prior_share * opts.depth_scale_prior_sigma or (
        observe.get("offset_sigma_mm", 0.0) > opts.max_depth_prior_share * opts.depth_offset_prior_sigma_m * 1e3
    ):
        return (
            f"depth scale and offset not observable: the matched depths span {depth['range_m'][0]:.2f}-"
            f"{depth['range_m'][1]:.2f} m, which leaves the scale at {observe['scale_sigma']:.2%} and the offset at "
            f"{observe['offset_sigma_mm']:.1f} mm (1 sigma; at most {opts.max_depth_prior_share:.0%} of the prior's "
            f"{opts.depth_scale_prior_sigma:.2%} and {opts.depth_offset_prior_sigma_m * 1e3:.1f} mm); move the arm "
            "nearer to and farther from the camera, or take the depth as exact (depth_model='fixed')"
        )
    return None


def _joint_offsets_result(fit, problem, opts: MarkerlessOptions) -> dict:
    """:attr:`MarkerlessResult.joint_offsets` of the final fit."""
    if problem.s.joint_twists_base is None:
        return {"model": "fixed", "reason": "the surface carries no joint twists"}
    if opts.joint_offsets_model == "fixed":
        return {"model": "fixed", "reason": "joint_offsets_model='fixed': the recorded joints taken as exact"}
    if problem.joint_estimated is None:  # every joint absorbed or not seen
        return joint_offsets_summary(
            problem.joint_offsets, problem.joint_status, None, None, problem.joint_prior_sigma, 0
        )
    return joint_offsets_summary(
        problem.joint_offsets,
        problem.joint_status,
        fit.joint_offsets_covariance,
        fit.joint_offsets_covariance_frames,
        problem.joint_prior_sigma,
        opts.joint_offset_determined_share,
    )
