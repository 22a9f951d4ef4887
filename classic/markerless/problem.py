"""The markerless registration's fitting problem for one camera placement: the depth frames and the model, the state
the stages share (depth correction, intrinsics, joint offsets), the z-buffered model, the projective association and
the point-to-plane fit of its matches. The stages that drive it are :mod:`classic.markerless.register`'s.
"""

from __future__ import annotations

from contextlib import contextmanager
from typing import NamedTuple

import numpy as np
from scipy.spatial import cKDTree

from classic.markerless.consistency import frame_splits, split_excess
from classic.markerless.depth import backproject
from classic.markerless.depth_analysis import DepthAnalysis, analyse_depth, depth_key
from classic.markerless.gating import crease_flags_from_first_frame, near_a_crease, within_gate
from classic.markerless.intrinsics import camera_matrix, intrinsics_vector, prior_sigma_px, rays_for
from classic.markerless.kinematics import joint_status, moved_surface
from classic.markerless.point_to_plane import (
    MatchedModel,
    PlaneFit,
    PlaneFitOptions,
    apply_right,
    corrected_points,
    solve_point_to_plane,
)
from classic.markerless.sigma import depth_bins, image_tiles
from classic.markerless.surface_frames import RobotSurfaceFrames
from classic.markerless.visibility import project, visible_points, zbuffer_grid
from handeye.core.errors import HandEyeInputError
from handeye.core.metrics import pose_error
from handeye.core.se3 import invert_transform, so3_log

__all__ = ["Problem", "Outcome"]


_FRAME_KEY_M = 1000.0  # frames kept apart in the KD-tree by this offset on a 4th coordinate


def _moving_parts(surface: RobotSurfaceFrames) -> np.ndarray:
    """Whether each sample's part moves between frames: the RMS spread of its centroid over the frames above 2 cm."""
    n_parts, n_fr = int(surface.part.max()) + 1, int(surface.frame.max()) + 1
    key = surface.part * n_fr + surface.frame
    count = np.bincount(key, minlength=n_parts * n_fr).reshape(n_parts, n_fr)
    sums = np.stack(
        [np.bincount(key, surface.points_base[:, k], minlength=n_parts * n_fr) for k in range(3)], axis=-1
    ).reshape(n_parts, n_fr, 3)
    spread = np.zeros(n_parts)
    for k in range(n_parts):
        seen = count[k] > 0
        cent = sums[k, seen] / count[k, seen, None]
        spread[k] = np.sqrt(((cent - cent.mean(0)) ** 2).sum(1).mean()) if len(cent) > 1 else 0.0
    return spread[surface.part] > 0.02


#: Draws of the added noise (each as +e and -e) over which :meth:`Problem.depth_debiased` averages the bias: one
#: draw's own scatter was a quarter of the scale's bias it measured (sphere scenes, 4 mm at 1 m, 8 frames: 0.0011 to
#: 0.0020 over four draws); three halve that, at six refits of the final matches.
NOISE_PAIRS = 3
#: Gauss-Newton iterations of each such refit: it starts at the answer, a noise's pull away from its own optimum.
REFIT_ITERATIONS = 2
#: Draws of the added noise, and Gauss-Newton iterations of each refit, for each group of the split check
#: (:meth:`Problem.split_check`): the groups' noise bias is taken out of their depth unit before their scatter is
#: measured. One pair of one iteration keeps the check's added cost to a sixth of the whole answer's correction; on
#: the d435 benchmark (``benchmarks/results/markerless_depth_unit_sigma.md``) the scale's RMS error over sigma came
#: out 1.03 / 0.87 / 0.96 with it, 1.00 / 0.82 / 0.94 with three pairs of two (20 / 30 / 60 frames).
GROUP_NOISE_PAIRS = 1
GROUP_REFIT_ITERATIONS = 1


class Outcome(NamedTuple):
    """The fine stage's outcome from one start (:mod:`classic.markerless.register`); ``fit`` None: too few points
    matched."""

    name: str  # the start's
    T: np.ndarray  # T_base_cam
    fit: PlaneFit | None  # the last fit, on the last matches
    step: float  # the last step, rad + m
    matched: float  # the visible model's fraction landing on the observed surface
    geometry: tuple | None = None  # the matched points' median depth and RMS spread about their centroid, metres
    depth_range: tuple | None = None  # their depths' 10th and 90th percentiles, metres
    matches: tuple | None = None  # (model points, frames, observed points) of the last fit


class Problem:
    """Everything the stages share for one camera placement."""

    def __init__(self, depth_m, K, surface, opts, analysis: DepthAnalysis | None = None):
        """``analysis``: the frames' own findings from an earlier registration of them (:func:`analyse_depth`),
        used where it holds for these frames and options (:func:`depth_key`), else found again."""
        self.K, self.s, self.opts = K, surface, opts
        self.depth_correction = (1.0, 0.0)  # (k, c[, a, b]), estimated by the fine stage
        # the camera matrix given, which back-projects the depth once (self.P), and the intrinsics estimated,
        # which project the model (self.K)
        self.K_given = K
        self.theta_given = intrinsics_vector(K)
        self.theta = self.theta_given
        self.estimate_intrinsics = opts.intrinsics_model == "estimate"
        self.intrinsics_prior_sigma = prior_sigma_px(opts.intrinsics_prior_sigma, self.theta_given)
        if analysis is None or analysis.key != depth_key(depth_m, opts.depth_sigma_m_at_1m):
            analysis = analyse_depth(depth_m, opts.depth_sigma_m_at_1m)
        self.analysis = analysis  # the noise, the mixed pixels (treated as missing) and the moving ones
        self.noise_source = analysis.noise_source
        mixed = analysis.mixed
        self.n_mixed = int(mixed.sum())
        depth_m = np.where(mixed, 0.0, depth_m)
        self.n, self.h, self.w = depth_m.shape
        self.P = backproject(depth_m, K)  # (N, H, W, 3), NaN without depth, as the sensor reports it
        f, r, c = np.nonzero(analysis.moving)
        self.n_moving = len(f)
        rng = np.random.default_rng(opts.seed)
        if len(f) > opts.max_points:
            keep = np.sort(rng.choice(len(f), opts.max_points, replace=False))
            f, r, c = f[keep], r[keep], c[keep]
        self.moving_frame, self.moving_p_cam = f, self.P[f, r, c]
        self.moving_part = _moving_parts(surface)
        # the model points the fine stage fits: the moving parts' (MarkerlessOptions.static_parts)
        self.fitted_part = self.moving_part if self.moving_part.any() and not opts.static_parts else None
        # static parts fitted beside moving ones: seen at the same pixels in every frame, their matches count once
        # (static_once)
        self.static_once = bool(opts.static_parts and self.moving_part.any())
        self._init_joints(surface, opts)  # the joints whose offsets the fine stage estimates
        # the coarse stages work on a subset of the model (their windows are centimetres)
        m = len(surface.frame)
        self.coarse_subset = (
            np.sort(rng.choice(m, opts.max_model_points, replace=False)) if m > opts.max_model_points else np.arange(m)
        )
        cs = self.coarse_subset
        self.tree = cKDTree(np.c_[surface.points_base[cs], surface.frame[cs] * _FRAME_KEY_M])
        self._crease, self._crease_tree = None, None  # near_crease's flags (and its per-frame tree where needed)

    @contextmanager
    def intrinsics_prior(self, relative_sigma):
        """The intrinsics' prior sigma set to ``relative_sigma`` (``f_x``, ``f_y`` relative, ``c_x``, ``c_y`` pixels, as
        :attr:`MarkerlessOptions.intrinsics_prior_sigma`) for the block, then restored."""
        kept = self.intrinsics_prior_sigma
        self.intrinsics_prior_sigma = prior_sigma_px(relative_sigma, self.theta_given)
        try:
            yield
        finally:
            self.intrinsics_prior_sigma = kept

    def sigma_z(self, z):
        """Depth noise sigma at depth ``z`` (metres): given, or measured, or the fallback."""
        return self.analysis.sigma_z(z, self.opts.depth_sigma_m_at_1m)

    def _init_joints(self, surface, opts):
        """Which joints' offsets the fine stage estimates (:func:`classic.markerless.kinematics.joint_status`)."""
        self.joint_estimated, self.joint_status = None, None
        twists = surface.joint_twists_base
        if twists is None or opts.joint_offsets_model != "estimate":
            self.joint_offsets = np.zeros(0 if twists is None else twists.shape[2])
            return
        n_joints = twists.shape[2]
        prior = np.atleast_1d(np.asarray(opts.joint_offset_prior_deg, dtype=float))
        if len(prior) not in (1, n_joints):
            raise HandEyeInputError(
                f"joint_offset_prior_deg has {len(prior)} values for a robot of {n_joints} joints "
                f"(give 1 or {n_joints})"
            )
        self.joint_prior_sigma = np.radians(np.broadcast_to(prior, (n_joints,))).copy()
        fitted = np.ones(len(surface.part), bool) if self.fitted_part is None else self.fitted_part
        self.joint_status = joint_status(twists, surface.frame[fitted], surface.part[fitted])
        self.joint_estimated = np.array([s == "estimated" for s in self.joint_status])
        self.joint_offsets = np.zeros(n_joints)
        # rigid over the moving parts (the base rotation): estimated only where static parts are fitted, and kept
        # only where they determine it (hold_undetermined)
        moving = fitted & self.moving_part if self.moving_part.any() else fitted
        self.joint_rigid = np.array(
            [s == "absorbed" for s in joint_status(twists, surface.frame[moving], surface.part[moving])]
        )
        if not self.joint_estimated.any():
            self.joint_estimated = None

    def hold_undetermined(self, fit) -> bool:
        """Hold at 0 the joints rigid over the moving parts that the fitted static parts did not determine.

        With static parts fitted, the base rotation's offset is estimated: the base does not turn with it. A
        round base cannot tell it from the camera's rotation about the base's axis, and it would stay at its prior
        with the prior's sigma in the pose's; it is then absorbed into the pose as with the moving parts alone
        (the camera in the kinematic base frame). Returns whether any joint was held (the fit is to be redone).
        """
        if self.joint_estimated is None or fit.joint_offsets_covariance_frames is None:
            return False
        est = np.flatnonzero(self.joint_estimated)
        sd = np.sqrt(np.maximum(np.diag(fit.joint_offsets_covariance_frames), 0.0))
        share = self.opts.joint_offset_determined_share
        weak = [j for i, j in enumerate(est) if self.joint_rigid[j] and sd[i] >= share * self.joint_prior_sigma[j]]
        if not weak:
            return False
        delta = self.joint_offsets.copy()
        for j in weak:
            self.joint_estimated[j], self.joint_status[j], delta[j] = False, "absorbed", 0.0
        self.set_joint_offsets(delta)
        if not self.joint_estimated.any():
            self.joint_estimated = None
        return True

    def set_joint_offsets(self, delta):
        """Move the model by the joint offsets ``delta`` (radians, all joints) from now on."""
        self.joint_offsets = np.asarray(delta, dtype=float)

    def model_points(self, idx):
        """The points (base frame) of the model points ``idx``, moved by the current joint offsets (their normals
        not turned: the z-buffer and the projections need none; the fits move the matched ones themselves)."""
        s = self.s
        if not self.joint_offsets.any():
            return s.points_base[idx]
        return moved_surface(
            s.points_base[idx], None, s.frame[idx], s.part[idx], s.joint_twists_base, self.joint_offsets
        )[0]

    def set_intrinsics(self, theta):
        """Project the model with the intrinsics ``theta`` ``(f_x, f_y, c_x, c_y)`` from now on."""
        self.theta = np.asarray(theta, dtype=float)
        self.K = camera_matrix(self.theta)

    def corrected(self, q_obs):
        """Observed camera-frame points with the current intrinsics and depth correction."""
        if not np.array_equal(self.theta, self.theta_given):
            with np.errstate(invalid="ignore", divide="ignore"):  # points without depth stay NaN
                q_obs = rays_for(q_obs, self.K_given, self.theta)[0]
        if self.depth_correction == (1.0, 0.0):
            return q_obs
        return corrected_points(q_obs, *self.depth_correction, stereo_fb_px_m=self.opts.stereo_fb_px_m)

    # -- visibility

    def visible(self, T_base_cam, subset=None):
        """Visible model points (indices into the whole model), their pixels and camera-frame points.

        The z-buffer's pixels are ``zbuffer_stride`` image pixels wide (twice that on a ``subset``),
        as sparse as the model's samples; each visible point's pixel is where it projects in the image.
        """
        T_cam_base = invert_transform(T_base_cam)
        pts, nrm, frm = self.s.points_base, self.s.normals_base, self.s.frame
        if subset is not None:
            pts, nrm, frm = pts[subset], nrm[subset], frm[subset]
        stride = self.opts.zbuffer_stride * (1 if subset is None else 2)
        # facing the camera, tested in the base frame (n . (p - c) < 0), before anything is transformed; on the
        # model at the recorded joints (the offsets turn a normal by tenths of a degree), then the front moved
        front = np.flatnonzero(np.einsum("ij,ij->i", nrm, pts - T_base_cam[:3, 3]) < 0)
        sel = front if subset is None else subset[front]
        p = self.model_points(sel) @ T_cam_base[:3, :3].T + T_cam_base[:3, 3]
        idx = visible_points(p, None, frm[front], *zbuffer_grid(self.K, self.h, self.w, stride))
        p = p[idx]
        uv = np.rint(project(p, self.K)).astype(np.int64)
        inside = (uv[:, 0] >= 0) & (uv[:, 0] < self.w) & (uv[:, 1] >= 0) & (uv[:, 1] < self.h)
        return sel[idx[inside]], uv[inside][:, ::-1], p[inside]

    # -- stage 4's association and fits (the stages: classic.markerless.register)

    def nearest(self, p_base, frame, window_m):
        """Each point's nearest model point of its frame (the coarse stages' subset), within ``window_m``: whether
        one was found, and for those found its index into the whole model."""
        d, j = self.tree.query(np.c_[p_base, frame * _FRAME_KEY_M], distance_upper_bound=window_m, workers=-1)
        ok = np.isfinite(d)
        return ok, self.coarse_subset[j[ok]]

    def associate(self, T, gate_m, cached=None):
        """Projective matches: each visible model point and the observed point in its pixel.

        ``cached`` (indices of visible points from an earlier pose) skips the z-buffer: the points
        are only projected again, for iterations where the pose moves by less than a pixel.
        """
        if cached is None:
            idx, pix, p_cam = self.visible(T)
        else:
            idx = cached
            T_cam_base = invert_transform(T)
            p_cam = self.model_points(idx) @ T_cam_base[:3, :3].T + T_cam_base[:3, 3]
            uv = np.rint(project(p_cam, self.K)).astype(np.int64)
            inside = (uv[:, 0] >= 0) & (uv[:, 0] < self.w) & (uv[:, 1] >= 0) & (uv[:, 1] < self.h) & (p_cam[:, 2] > 0)
            idx, p_cam, pix = idx[inside], p_cam[inside], uv[inside][:, ::-1]
        f = self.s.frame[idx]
        q_obs = self.P[f, pix[:, 0], pix[:, 1]]
        q = self.corrected(q_obs)
        has_depth = np.isfinite(q[:, 2]) & (q_obs[:, 2] > 0)
        close = has_depth & within_gate(q, p_cam, self.s.normals_base[idx] @ T[:3, :3], gate_m)
        if self.opts.crease_radius_m is not None:
            close &= ~self.near_crease(idx)
        if self.opts.max_incidence_deg is not None:
            close &= self._facing(T, idx, p_cam)
        return idx, f, q_obs, q, has_depth, close

    def near_crease(self, idx: np.ndarray) -> np.ndarray:
        """Whether each model sample ``idx`` lies within ``crease_radius_m`` of a crease
        (:func:`classic.markerless.gating.near_a_crease`, among its own frame's samples): found on the first
        frame's samples and repeated where every frame holds them in its order
        (:func:`classic.markerless.gating.crease_flags_from_first_frame`), else each sample as it is first
        matched."""
        if self._crease is None:
            s = self.s
            flags = crease_flags_from_first_frame(
                s.points_base, s.normals_base, s.frame, s.part, self.opts.crease_radius_m
            )
            self._crease = np.full(len(s.points_base), -1, np.int8) if flags is None else flags
        if self._crease.dtype == bool:
            return self._crease[idx]
        if self._crease_tree is None:  # -1: not yet found, 0 / 1: found
            self._crease_tree = cKDTree(np.c_[self.s.points_base, self.s.frame * _FRAME_KEY_M])
        new = np.unique(idx[self._crease[idx] < 0])
        if len(new):
            self._crease[new] = near_a_crease(self._crease_tree, self.s.normals_base, new, self.opts.crease_radius_m)
        return self._crease[idx] == 1

    def _facing(self, T, idx, p_cam):
        """Whether each model point's normal is within ``max_incidence_deg`` of its ray (camera frame ``p_cam``)."""
        n_cam = self.s.normals_base[idx] @ T[:3, :3]  # R^T n, row-wise
        cos = np.abs(np.einsum("ij,ij->i", n_cam, p_cam)) / np.linalg.norm(p_cam, axis=1)
        return cos > np.cos(np.radians(self.opts.max_incidence_deg))

    def _solve(self, T, matches, iterations, covariance=True, repeated=False, prior_widened=1.0, noise_times=1.0):
        """Point-to-plane fit of fixed ``matches`` (model points ``m``, frames ``f``, observed ``q_obs``) from ``T``
        and the current depth correction, intrinsics and joint offsets; returns the fit and the median expected
        residual. ``repeated``: with the covariance an error repeated per pixel adds (``PlaneFit.repeated``).
        ``prior_widened``: every prior's sigma times this (:meth:`depth_debiased`).
        ``noise_times``: the depth noise's variance the fit takes out of its equations, times this."""
        m, f, q_obs = matches
        sigma_z = self.sigma_z(q_obs[:, 2])
        expected = float(np.median(np.sqrt(sigma_z**2 + self.opts.model_floor_m**2)))
        curved = self.s.curvatures is not None
        estimate_depth = self.opts.depth_model == "scale-offset"
        if estimate_depth or self.estimate_intrinsics:
            observed = q_obs  # as back-projected with the camera matrix given; the fit corrects it
        else:
            observed = self.corrected(q_obs)
        intrinsics = {}
        if self.estimate_intrinsics:
            intrinsics = {
                "intrinsics_K_ref": self.K_given,
                "intrinsics_start": self.theta,
                "intrinsics_prior": (self.theta_given, self.intrinsics_prior_sigma * prior_widened),
            }
        joints, twists = {}, None
        if self.joint_estimated is not None:  # the model posed at the recorded joints; the fit moves it
            e = self.joint_estimated
            twists = self.s.joint_twists_base[f[:, None], self.s.part[m][:, None], np.flatnonzero(e)]  # (M, E, 6)
            joints = {
                "joint_start": self.joint_offsets[e],
                "joint_prior_sigma": self.joint_prior_sigma[e] * prior_widened,
            }
        model = MatchedModel(
            self.s.points_base[m],
            self.s.normals_base[m],
            curvatures=self.s.curvatures[m] if curved else None,
            direction_base=self.s.direction_base[m] if curved else None,
            joint_twists=twists,
            depth_variance=noise_times * sigma_z**2,
        )
        options = PlaneFitOptions(
            scale_m=expected * 2,
            loss="cauchy",
            iterations=iterations,
            covariance=covariance,
            depth_start=self.depth_correction if estimate_depth else None,
            depth_prior_sigma=(
                self.opts.depth_scale_prior_sigma * prior_widened,
                self.opts.depth_offset_prior_sigma_m * prior_widened,
            ),
            stereo_fb_px_m=self.opts.stereo_fb_px_m,
            pixel_locking_prior_px=self.opts.pixel_locking_prior_px * prior_widened,
            pixel_effect=self.opts.pixel_effect_px > 0,
            repeated_radius_px=self.opts.repeated_error_px if repeated else 0,
            **intrinsics,
            **joints,
        )
        pixel = self._pixels(q_obs) if self.opts.pixel_effect_px > 0 else None
        group = np.where(self.static_rows(m), self.n, f)  # the static parts' matches: one cluster, as one view
        uv = np.rint(project(q_obs, self.K_given)).astype(np.int64) if repeated else None
        cross = self._cross_groups(q_obs) if covariance else None  # the covariance's alone
        fit = solve_point_to_plane(observed, model, T, options, group=group, cross_group=cross, pixel=pixel, uv=uv)
        return fit, expected

    def static_rows(self, m):
        """Whether each matched model point (``m``, indices, shape (M,)) is on a static part counted once
        (:meth:`_once_per_cell`): bool, shape (M,); all False unless ``static_once``."""
        return ~self.moving_part[m] if self.static_once else np.zeros(len(m), bool)

    def _once_per_cell(self, m, q_obs):
        """Which matches (model points ``m``, shape (M,); observed ``q_obs``, shape (M, 3), as back-projected with the
        camera matrix given) the fine stage fits, bool, shape (M,): every one on a moving part, and on the static
        parts one per z-buffer cell.

        A static part is seen at the same pixels in every frame, so the sensor's error there (a fixed pattern,
        multipath on the static scene) and the model's are one error repeated in every frame: n_frames copies of one
        sample, not n_frames samples. Kept once per cell of ``zbuffer_stride`` pixels (the z-buffer gives one visible
        point per cell and frame), they weigh as one frame's matches, and the covariance takes them as one cluster
        (:meth:`_solve`), however many frames saw them.
        """
        static = self.static_rows(m)
        if not static.any():
            return np.ones(len(m), bool)
        uv = np.rint(project(q_obs[static], self.K_given)).astype(np.int64) // self.opts.zbuffer_stride
        first = np.unique(uv[:, 1] * self.w + uv[:, 0], return_index=True)[1]
        keep = ~static
        keep[np.flatnonzero(static)[first]] = True
        return keep

    def _pixels(self, q_obs):
        """Each observed point's image cell (``pixel_effect_px`` square) as one integer (``q_obs`` as back-projected
        with the camera matrix given, so its pixel is found again exactly)."""
        uv = np.rint(project(q_obs, self.K_given)).astype(np.int64) // self.opts.pixel_effect_px
        return uv[:, 1] * self.w + uv[:, 0]

    def _cross_groups(self, q_obs):
        """The covariance's clusterings beside the frames: depth bins, and image tiles where asked; None without
        any (the frame-clustered covariance is then the only one, not computed twice)."""
        crosses = [
            c
            for c in (
                depth_bins(q_obs[:, 2], self.opts.depth_clusters),
                image_tiles(q_obs, self.K_given, self.w, self.opts.image_tiles),
            )
            if c is not None
        ]
        return crosses or None

    def fitted_matches(self, idx, close):
        """The matches the fine stage fits: ``close`` ones on the parts it fits (``static_parts``)."""
        return close if self.fitted_part is None else close & self.fitted_part[idx]

    def fit_matches(self, T, idx, f, q_obs, close, covariance=True):
        """The fit of the ``close`` matches (the static parts' once per cell, :meth:`_once_per_cell`), adopted
        (:meth:`adopt`); returns it, the median expected residual and the matches ``(model points, frames, observed
        points)``."""
        sel = np.flatnonzero(close)
        sel = sel[self._once_per_cell(idx[sel], q_obs[sel])]
        matches = (idx[sel], f[sel], q_obs[sel])
        iterations = 3 if self.opts.depth_model == "fixed" else 5
        fit, expected = self._solve(T, matches, iterations, covariance)
        self.adopt(fit)
        return fit, expected, matches

    def depth_debiased(self, fit, matches, pairs=NOISE_PAIRS, draw_key=(), iterations=REFIT_ITERATIONS):
        """The depth correction ``(k, c, ...)`` of ``fit`` (the current state: adopted) with the bias the depth
        noise itself gives it taken out, and how far that moved the sensor's ``scale`` and ``offset_mm`` (with
        ``rotation_deg`` and ``translation_mm``: how far the same extrapolation would move the pose, not applied);
        ``(None, None)`` where the depth is taken as exact or a stereo matcher's pixel locking is estimated (below).
        The state is left as it was. ``pairs``: draws of the noise (each as ``+e`` and ``-e``); ``draw_key``: a
        tuple of ints that keys the draws' random stream beside the options' seed (the split check's groups);
        ``iterations``: of each refit.

        Only the depth unit reported takes it (:func:`classic.markerless.result.build_result`): applied to the pose
        as well, it moved the pose by about as much as the bias it took out on 50-100 frames and made the accuracy
        worse (``benchmarks/results/markerless_depth_unit_sigma.md``), while the scale's bias was 2 to 7 of its
        sigmas on 20-60 frames.

        The fit scales the observed points, ``k q_obs + c r``, so the depth's noise is in the regressor of ``k``
        as well as in the residual: least squares shrinks ``k`` by the noise's variance over the spread that
        tells the scale from the offset (errors in variables), which only the arm's range of depths and its size
        in the image do; 20 frames leave that spread a few centimetres and ``k`` a few tenths of a per cent low,
        the offset the other way, at the depths' middle. The bias is first order in the noise's variance, the
        noise's own pull on the answer first order in the noise: the matches solved again from the answer
        (:data:`REFIT_ITERATIONS`) with a noise of the same sigma added along their rays (:meth:`sigma_z`), once
        ``+e`` and once ``-e`` (its first-order pull cancels in the pair), move it by the bias once more, and the
        answer is taken that far back (simulation-extrapolation to no noise), over :data:`NOISE_PAIRS` draws of
        ``e``. The priors keep in the refits the weight they had in the answer (their sigmas widened as the
        residuals' variance grows): the noise's bias is taken out, not the priors' pull. Not with a stereo
        matcher's pixel locking estimated (``stereo_fb_px_m``): its pattern is periodic in the depth as observed,
        which the added noise smears, and the extrapolation would take the smearing for the noise's bias (a locking
        of 0.15 px came out 6 of its sigmas high on the sphere scenes).
        """
        if fit.depth_correction is None or self.opts.stereo_fb_px_m:
            return None, None
        m, f, q_obs = matches
        rng = np.random.default_rng([self.opts.seed, 41, *draw_key])
        e = rng.normal(size=(pairs, len(q_obs))) * self.sigma_z(q_obs[:, 2]) / q_obs[:, 2]  # relative
        T = fit.T_base_cam
        # the residuals' variance the added noise gives (the priors' information is taken in its units)
        k0, c0 = fit.depth_correction[:2]
        gain = k0 * q_obs[:, 2] * np.einsum("ij,ij->i", self.s.normals_base[m], q_obs @ T[:3, :3].T / q_obs[:, 2:3])
        w, r = fit.weights, fit.residuals_m
        variance = float(np.sum(w * r**2))
        kept = (self.depth_correction, self.theta, self.joint_offsets)
        self.adopt(fit)
        refits = []
        for draw in e:
            widen = float(np.sqrt(1 + np.sum(w * (gain * draw) ** 2) / max(variance, 1e-30)))
            for sign in (1.0, -1.0):
                noisier = (m, f, q_obs * (1 + sign * draw)[:, None])
                refits.append(self._solve(T, noisier, iterations, False, prior_widened=widen, noise_times=2.0)[0])
        self.depth_correction, (theta, delta) = kept[0], kept[1:]
        self.set_intrinsics(theta)
        self.set_joint_offsets(delta)
        # twice the answer less the noisier ones' mean
        depth = tuple(
            float(v) for v in 2 * np.asarray(fit.depth_correction) - np.mean([g.depth_correction for g in refits], 0)
        )
        xi = np.mean(
            [
                np.r_[so3_log(T[:3, :3].T @ g.T_base_cam[:3, :3]), T[:3, :3].T @ (g.T_base_cam[:3, 3] - T[:3, 3])]
                for g in refits
            ],
            axis=0,
        )
        rot_deg, trans_mm = pose_error(apply_right(T, -xi), T)
        k1, c1 = depth[:2]
        moved = {
            "scale": float(1 / k0 - 1 / k1),
            "offset_mm": float((c1 / k1 - c0 / k0) * 1e3),
            "rotation_deg": float(rot_deg),
            "translation_mm": float(trans_mm),
        }
        return depth, moved

    def restart(self):
        """No depth correction, the intrinsics given and no joint offsets: the state a start begins from."""
        self.depth_correction = (1.0, 0.0)
        self.set_intrinsics(self.theta_given)
        self.set_joint_offsets(np.zeros_like(self.joint_offsets))

    def adopt(self, fit):
        """Take the fit's depth correction, intrinsics and joint offsets as the current ones."""
        if fit.depth_correction is not None:
            self.depth_correction = fit.depth_correction
        if fit.intrinsics is not None:
            self.set_intrinsics(fit.intrinsics)
        if fit.joint_offsets is not None:
            delta = np.zeros_like(self.joint_offsets)
            delta[self.joint_estimated] = fit.joint_offsets
            self.set_joint_offsets(delta)

    def split_check(self, T, matches):
        """Groups of the frames solved again from the final matches, from the current depth correction, intrinsics
        and joint offsets (those of the fit that made the matches): the sigma their scatter adds
        (:func:`classic.markerless.consistency.split_excess`), the pose's and, with the depth scale and offset
        estimated, the depth unit's (``depth_variance``), each group's unit with the depth noise's own bias taken
        out (:meth:`depth_debiased`, :data:`GROUP_NOISE_PAIRS` draws of :data:`GROUP_REFIT_ITERATIONS`). The state
        is left as it was."""
        m, f, q_obs = matches
        shared = self.static_rows(m)  # the static parts' matches: seen by every frame, in every group
        asked = iter(range(1, 1 << 30))  # each group's own draws of the noise

        def solve(mask):
            mask = mask | shared
            mine = (m[mask], f[mask], q_obs[mask])
            fit, _ = self._solve(T, mine, iterations=5)
            if fit.depth_correction is None:
                return fit.T_base_cam, fit.covariance
            debiased, _ = self.depth_debiased(
                fit, mine, pairs=GROUP_NOISE_PAIRS, draw_key=(next(asked),), iterations=GROUP_REFIT_ITERATIONS
            )
            kc = fit.depth_correction[:2] if debiased is None else debiased[:2]
            return fit.T_base_cam, fit.covariance, (np.asarray(kc), fit.depth_covariance[:2, :2])

        return split_excess(solve, f, frame_splits(f[~shared], q_obs[~shared], self.n))

    def repeated_error(self, T, matches) -> dict:
        """What an error repeated at one image position in every frame adds to the covariance of the answer ``T``
        (:func:`classic.markerless.repeated_error.repeated_error_covariance`): the final ``matches`` linearised at
        ``T`` and the current depth correction, intrinsics and joint offsets (no step taken)."""
        fit, _ = self._solve(T, matches, iterations=0, repeated=True)
        return fit.repeated

    def static_pull(self, T, matches) -> tuple[dict, np.ndarray]:
        """What the static parts counted once moved the answer ``T``, and the moving parts' own covariance: the final
        ``matches`` of the moving parts solved again alone, from ``T`` and the current depth correction, intrinsics
        and joint offsets. Returns the difference as a sigma term (``rotation_deg``, ``translation_mm``) and that
        fit's covariance, shape (6, 6).

        Their error repeats in every frame, so the frames cannot measure it: the covariance holds them as one
        cluster, whose score the fit itself shrinks where they decide a direction the moving parts leave loose
        (the focal length, the distance along the axis and the depth offset together), and the split check has
        them in every group. So they may move the answer, but not narrow its sigma: the sigma is the moving parts'
        own, and their pull is added to it whole.
        """
        m, f, q_obs = matches
        moving = ~self.static_rows(m)
        alone = (m[moving], f[moving], q_obs[moving])
        fit, _ = self._solve(T, alone, iterations=5)
        rot_deg, trans_mm = pose_error(fit.T_base_cam, T)
        return {"rotation_deg": float(rot_deg), "translation_mm": float(trans_mm)}, fit.covariance
