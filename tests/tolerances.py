"""Every numerical tolerance of the test suite, each with where it comes from.

Tests import from here and nowhere else, so a tolerance is changed (and
re-justified) in one place. Units: rotations in radians, translations in
metres, unless the name says otherwise.
"""

from __future__ import annotations

import numpy as np

# --------------------------------------------------------------------------
# Pure floating-point arithmetic
# --------------------------------------------------------------------------

#: Round trips of closed formulas (so3_exp/so3_log, quaternions, inverses)
#: on unit-size inputs: float64 epsilon is 2.2e-16 and each formula chains
#: some tens of operations, so errors are ~1e-15; 1e-12 leaves three orders
#: of magnitude of headroom while still catching any wrong formula (a wrong
#: sign or factor gives errors of order 1).
#: Also relative (rtol=FLOAT), and for results that are exact in exact arithmetic and reach float64 through
#: at most a few hundred operations: a least-squares fit with an exact answer (the curvatures of a sphere
#: or a cylinder from their normals: measured <= 9e-16 relative), a Rayleigh quotient at an eigenvector
#: (5e-15 on entries ~3), interpolation of a linear ramp, a pose written with repr() and read back through
#: its quaternion, a tangent built from cross products of a unit normal (3e-16). Several of these were
#: 1e-9 or 1e-10 before issue 42 with no derivation; their measured errors of 1e-16 to 1e-14 put them here.
FLOAT = 1e-12

#: so3_log of a rotation within 1e-12 rad of pi: the axis is recovered from
#: the symmetric part of R, whose conditioning is fine at pi (Shepperd's
#: method), but the angle comes through arctan2(|v|, w) with w ~ 1e-12:
#: absolute accuracy ~1e-15 / |v| on the angle, i.e. still ~1e-15. We allow
#: 1e-9, the same bar as noise-free recovery, as the scipy reference itself
#: goes through the same near-singular quantities.
NEAR_PI_ANGLE = 1e-9

#: The same views fitted twice by an iterative solver with parallel reductions (``cv2.calibrateCamera``): the
#: sums are taken in a different order, each rounding at float64's 2.2e-16 relative, over some 1e4 operations
#: on entries of about 500 px, so about 1e-9 px apart at most (1.2e-11 px measured, on an entry that is 0);
#: an absolute bound of 1e-8 px, ten times that, still fails on a fit of different views (tenths of a pixel).
#: Only with OpenCV on one thread: on several, the order of the sums changes with the threads' timing, and once
#: it moved the Levenberg-Marquardt path by 2.8e-7 px (a CI run under load, 2026-12-07).
REFIT_SAME_VIEWS_PX = 1e-8

#: The same formula reached by two code paths (a scalar path and the batched one, a product written out
#: and the same product as a multiple of a stored length): entries of order 1 or below that differ only
#: in the order of a few float64 operations, a few ulps (eps = 2.2e-16) apart; 1e-15 is 4.5 eps. Any
#: other formula is off by far more than rounding.
SAME_FORMULA = 1e-15

#: ``rtol=ABSOLUTE_ONLY`` beside a derived ``atol``: the bound is absolute. numpy's default relative
#: slack (1e-7 of |expected| in assert_allclose, 1e-5 in np.allclose) is derived from nothing and would
#: widen a derived absolute bound on the larger entries (1e-7 m on a 1 m translation, 1e5 x FLOAT).
ABSOLUTE_ONLY = 0.0
#: ``atol=RELATIVE_ONLY`` beside a derived ``rtol``: the bound is relative to each expected entry, so an
#: entry that is exactly zero (or NaN, with equal_nan) must come back exactly.
RELATIVE_ONLY = 0.0

#: A pose, an error or a depth written to a dataset table and read back (write_table prints repr(),
#: exact; a pose comes back through its quaternion, FLOAT per entry) and compared with one computed
#: again from what was read: an angle from arctan2 moves by ~1e-16 rad, relative 1e-16 / angle, and the
#: labels' errors are above 1e-4 degree (2e-6 rad, their own noise), so ~1e-10 relative; 1e-9. A wrong
#: column or unit (degrees for radians, mm for m) is off by order 1.
RECOMPUTED_ERROR_RTOL = 1e-9

# --------------------------------------------------------------------------
# Noise-free recovery
# --------------------------------------------------------------------------

#: Noise-free synthetic data: every solver must return the true X (and Y) to
#: this, in every matrix entry (rotation entries are unitless, translations
#: in metres, all of order 1). Measured errors are ~1e-14 (a few hundred
#: float64 operations); 1e-9 is five orders of magnitude above that and
#: eight below the smallest error a real algebra mistake could produce
#: (a wrong transpose or sign gives errors of order 0.1 to 1).
EXACT = 1e-9

#: Quantities that vanish in exact arithmetic but are computed through a Gram
#: matrix (singular values as square roots of eigenvalues of P^T P, e.g. the
#: axis diversity s2 / s1 of motions about one axis): eigenvalues carry an
#: absolute error ~eps * s1^2, so the singular values ~sqrt(eps) * s1 =
#: 1.5e-8 s1 (measured 2.7e-9). 1e-6 leaves headroom and is still 2e4 below
#: the diversity at which diagnostics refuse the data (0.02).
GRAM_FLOOR = 1e-6

# --------------------------------------------------------------------------
# Agreement with OpenCV on noisy data, as fractions of the injected noise
# --------------------------------------------------------------------------
# The injected camera noise (per-axis sigma, rad and m) sets the scale: two
# *different* estimators differ by a sizeable fraction of it (measured on the
# 20-pose data of the agreement test: Park vs Horaud, the closest pair,
# 0.007 to 0.03 sigma; Park vs Andreff, Tsai or Daniilidis 0.03 to 3 sigma),
# while two implementations of the *same* algebra differ only by rounding
# (~1e-13 sigma measured).

#: Same algorithm as OpenCV (Park, Horaud, Andreff, Daniilidis, Shah, Li):
#: difference <= 1e-3 sigma, in rad for rotation and in m for translation.
#: Far below the estimator's own spread (~1 sigma) and far above rounding, so
#: any real algorithmic difference (a different weighting, pairing, sign or
#: normalisation) shows up.
SAME_ALGORITHM_FRACTION = 1e-3

#: Tsai, the known difference. OpenCV 4.x's CALIB_HAND_EYE_TSAI is not the
#: exact least-squares minimiser of Tsai's eq. 12 over all motion pairs: its
#: result has a larger residual on that same linear system than ours (which
#: is the exact minimiser). Reproducing its output shows that it leaves out
#: the motion pairs with small rotations (about 17 degrees and below on our
#: data) and solves eq. 12 on the rest. So the test asserts
#: (a) our rotation's eq-12 residual <= OpenCV's (ours is the minimiser), up
#:     to TSAI_RESIDUAL_RTOL, and
#: (b) the two agree within TSAI_OPENCV_FRACTION of the noise sigma: the
#:     dropped pairs are few and carry little rotation information, so the
#:     estimates differ by a small fraction of the noise. (a) is the sharp
#:     check (only the exact minimiser passes it); (b) bounds the size of the
#:     known difference. Measured on 20-pose
#:     problems (20 data sets): 0.012 to 0.041 sigma; the fewer the poses,
#:     the larger the share of dropped pairs (up to 0.14 sigma measured with
#:     12 poses), which is why the Tsai comparison uses 20 poses.
TSAI_OPENCV_FRACTION = 0.05
#: Relative slack on "our residual <= OpenCV's": the two residuals are sums
#: of the same ~500 squared terms computed in a different order.
TSAI_RESIDUAL_RTOL = 1e-10

#: OpenCV's Daniilidis takes quaternion signs as its matrix-to-quaternion
#: conversion returns them; below 120 degrees (trace of R > 0) that is the
#: w > 0 sign our implementation aligns to, so both agree. The agreement test
#: asserts every motion pair stays below this.
DANIILIDIS_MAX_PAIR_ANGLE_DEG = 120.0

# --------------------------------------------------------------------------
# Refinement and its uncertainty
# --------------------------------------------------------------------------

#: LM never accepts a step that raises the cost; cost_final <= cost_initial
#: up to rounding of two sums of ~100 squares of order 1.
COST_RTOL = 1e-9

#: The covariance comes from a pseudo-inverse of J^T J: symmetric and PSD up
#: to rounding relative to its largest entry / eigenvalue.
COVARIANCE_RTOL = 1e-9

#: Relations that hold exactly in exact arithmetic but go through the 12x12
#: pseudo-inverse of J^T J (condition number ~1e3 to 1e6 here) and LM's
#: damping: sigma = sqrt(trace) of a covariance block, doubling both noise
#: scales doubles every sigma, a given noise scale is reported back. Rounding
#: is ~1e-16 x condition <= 1e-10; 1e-9 relative. Also a clustered (sandwich) covariance against the
#: same sandwich written by hand, and the two-way one with both groupings the same against the one-way
#: (C + C - C): measured 8e-14 relative (these were 1e-10 and 1e-8 before issue 42).
SCALE_RTOL = 1e-9

#: Two LM runs on the same fixed cost from different closed-form starts must
#: reach the same minimum. LM stops when the relative cost decrease is below
#: 1e-12; near the minimum the cost is quadratic, cost = c0 + |d / sigma|^2,
#: so the parameters are left within sqrt(1e-12 * c0) sigma of it, with c0
#: ~ 6 N = 72 (normalised residuals): ~1e-5 sigma. 1e-4 of the predicted
#: sigma is therefore an optimiser tolerance, 1e4 below the statistical
#: error; with the scales *estimated* the two runs may differ more (the
#: scales depend on the start), so this is only checked with the noise given.
LM_START_FRACTION = 1e-4

#: handeye.core.keypoint_fit.likelihood_fit (stops at a relative cost change ftol = 1e-10) against
#: scipy.optimize.least_squares (1e-15) on the same Cauchy cost. As for LM_START_FRACTION, a stop at
#: relative change ftol leaves the parameters within sqrt(ftol c0) sigma of the minimum, c0 <= 3 x 60 = 180
#: whitened residuals: 1.3e-4 sigma; the pose's sigma from 60 keypoints (4e-3 normalised across, 2 cm in
#: depth, at 1-2 m) is ~3 mm along the line of sight and less across, so <= 4e-7 m (and rad) per entry
#: (measured <= 6e-8);
#: 1e-6 is 2.5 above that and 1e3 below the noise's own effect, which the test requires to be > 1e-4 m.
KEYPOINT_FIT_AGREEMENT = 1e-6

#: Predicted sigma vs Monte Carlo RMS error over MC_TRIALS trials. For an
#: error vector e ~ N(0, C) in R^3, |e|^2 has mean tr C and variance
#: 2 tr(C^2) <= 2 (tr C)^2, so the mean of |e|^2 over M trials has relative
#: standard deviation <= sqrt(2 / M) and the RMS (its square root) <=
#: sqrt(1 / (2 M)) = 0.091 for M = 60. Three standard deviations (0.27) plus
#: the per-trial noise-scale estimate (averaged over the trials, small) and
#: the linearisation of the model at 0.2 deg noise (negligible) stay below
#: 0.35: |MC / predicted - 1| <= 0.35.
MC_TRIALS = 60
MC_SIGMA_RATIO = 0.35

#: "The estimate lies within SIGMA_BOUND predicted sigma of the truth": sigma
#: is the RMS norm sqrt(tr C) of a Gaussian 3-D error, and P(|e| > 4 sqrt(tr C))
#: is largest when all the variance is on one axis, P(|z| > 4) = 6e-5.
SIGMA_BOUND = 4.0

#: The noise scales estimated from the residuals (3N - 6 degrees of freedom
#: per block, ~30 here) have relative standard deviation ~1 / sqrt(2 x 30) =
#: 0.13, plus the small robot noise folded in: within a factor 2 of the
#: injected per-axis sigma is more than five standard deviations wide, and a
#: wrong scale (e.g. radians read as degrees, a missing sqrt(3)) falls out.
NOISE_ESTIMATE_FACTOR = 2.0

#: A camera noise scale estimated along the line of sight from 40 poses' residuals less what the fit
#: absorbs (~34 degrees of freedom): relative standard deviation 1 / sqrt(2 x 34) = 0.12; 0.35 is 2.9 of
#: them (P(fail) 0.4 % for a seeded draw), while the along-sight scale mixed with the across-sight ones
#: (0.3 mm against 3 mm) comes out low by a factor 2 or more.
LINE_OF_SIGHT_SCALE_RTOL = 0.35

#: Trials for "the refined median error is no worse than the closed form".
REFINE_TRIALS = 30

# --------------------------------------------------------------------------
# Maximum-likelihood refinement, scale, time offset
# --------------------------------------------------------------------------

#: Monte Carlo trials of the ML refinement told the noise model (camera and robot noise).
ML_TRIALS = 120
#: RMS error over ML_TRIALS against the predicted sigma and against the Cramér–Rao bound: the RMS
#: of a 3-D Gaussian error over M trials has relative standard deviation <= sqrt(1 / (2 M)) = 0.065
#: for M = 120; three of them (0.19) plus the linearisation at these noise levels (well below 1 %)
#: stay inside 0.25. A refinement that ignored the robot noise or the lever arm is off by more (the
#: robot's rotation noise through a 5-8 cm lever is of the camera noise's order here).
ML_SIGMA_RATIO = 0.25
#: Central differences of the residuals with h = 1e-6 on entries of order 1: truncation ~h^2, rounding
#: ~eps / h ~ 1e-10; relative to the largest entry, 1e-6 is far below any real derivative mistake.
#: (With h = 1e-5, as where a mesh's posed points are differenced, truncation is ~1e-10 of the entries
#: and rounding ~2e-11: the same bound.) Both errors scale with the differenced function, so the bound is
#: absolute: JACOBIAN_RTOL x the Jacobian's largest entry, or x the differenced positions' largest (metres)
#: where the derivatives are velocities of points (a column can be zero: a joint that moves nothing).
#: Checks that were rtol 1e-5 per entry, or 1e-8 and 1e-6 absolute on entries of order 1, before issue 42.
#: (h = 1e-4 on focal lengths and a principal point of ~150 px is the same relative step, 7e-7: measured
#: 3e-13 against entries of 7e-3 per px; that check was 1e-9 absolute, now 6.6e-9.)
JACOBIAN_RTOL = 1e-6
#: Coverage of a 1-sigma interval by a Gaussian estimate: 68.3 %; over M = 200 trials its binomial
#: standard deviation is 3.3 %, so 4 of them give [55 %, 82 %].
COVERAGE_RANGE = (0.55, 0.82)
COVERAGE_TRIALS = 200

#: A 10^4-pose set (bounded motion pairs, classic.pairs): the reported sigma against the Cramér–Rao
#: bound's. The noise scales are estimated from ~3 x 10^4 residual components per block (relative
#: standard deviation 1 / sqrt(2 x 3e4) = 0.004) and the linearisation at 0.1 deg is far below 1 %;
#: 0.1 is 25 standard deviations wide, while a covariance that counted the poses' motion pairs as
#: independent data would be off by a factor sqrt(pairs per pose) >= 1.4.
LARGE_SET_SIGMA_RTOL = 0.1
#: Peak memory (tracemalloc, MB) of calibrate() on 10^4 poses: its per-pose arrays (a 6N x 12
#: Jacobian and its few working copies, 6 kB a pose with the (N, 6, 6) covariances) take ~60 MB and the
#: at most classic.pairs.MAX_PAIRS motion pairs about 100 MB; 400 MB is well above both and 1 / 30 of
#: what all 5 x 10^7 pairs took before the pairs were bounded (11.5 GB).
LARGE_SET_PEAK_MB = 400.0

# --------------------------------------------------------------------------
# Robust fitting
# --------------------------------------------------------------------------

#: With the outliers flagged exactly, the robust fit sees the same inliers
#: as a fit on the outlier-free data; only the loss differs (Cauchy vs
#: linear), which moves the estimate by a fraction of its own spread. So its
#: error must stay within this multiple of the outlier-free error (or of the
#: outlier-free predicted sigma, when the outlier-free error happens to be
#: tiny). Measured ratios: up to ~1.4.
ROBUST_ERROR_FACTOR = 2.0

#: The non-robust closed form on the same data must fail badly: gross errors
#: of 10 to 90 degrees and 5 to 30 cm on 20 % or more of the poses pull it
#: many sigma off; "badly" = more than this multiple of the outlier-free error.
NONROBUST_FAILURE_FACTOR = 10.0

#: RMS of the inlier pose residual norms after a robust fit, in units of
#: sqrt(3) x the per-axis camera noise: a 3-D residual with per-axis sigma has
#: RMS norm sqrt(3) sigma (slightly less after fitting 12 parameters); over
#: ~15 inliers (45 degrees of freedom) the sample RMS has relative standard
#: deviation ~1 / sqrt(90) = 0.1, so a factor 2 is ten standard deviations
#: away, while a single kept gross outlier (>= 5 cm, >= 10 deg) would raise
#: the RMS more than tenfold. Measured: 0.7 to 1.2.
INLIER_RMS_FACTOR = 2.0

# --------------------------------------------------------------------------
# Unit conversions used by the tests
# --------------------------------------------------------------------------

DEG = np.pi / 180.0
MM = 1e-3

# --------------------------------------------------------------------------
# ChArUco vision (tests/vision)
# --------------------------------------------------------------------------
# Pixel quantities are in pixels (suffix _PX). The synthetic camera is
# classic.vision.synthetic.default_intrinsics(): 640 x 480, fx ~ 554 px.

#: BoardSpec.corners_target() vs OpenCV's getChessboardCorners(), which are
#: float32: relative rounding 2^-24 = 6e-8 of coordinates <= 0.3 m, i.e.
#: <= 2e-8 m. 1e-7 m leaves a factor 5; a wrong order or offset is off by a
#: whole square (>= 1e-2 m).
FLOAT32_M = 1e-7

#: A value stored as float32 after at most three float32 roundings (each <= 2^-24 relative: a cast, a product of
#: two cast factors such as a 16-bit depth times its unit): <= 3 x 2^-24 relative; 2^-22 leaves a factor 4/3. A
#: millimetre lost on a metre (a wrong unit, a frame paired with another frame's value) is 1e-3 relative.
FLOAT32_RTOL = 2.0**-22

#: A ROS header stamp holds whole nanoseconds since the epoch: written as one a time is rounded by <= 0.5 ns, and
#: read back as float64 seconds (about 1.7e9 s, in [2^30, 2^31): spacing 2^-22 s) by <= 2^-23 s; a difference of
#: two such times is off by <= 2^-22 s + 1 ns (0.24 us). A frame paired with the next one is a frame period
#: (>= 1 ms) off.
ROS_STAMP_S = 2.0**-22 + 1e-9

#: Corners detected on a flat image from BoardSpec.render at a scale with a
#: whole number of pixels per square: each corner is an exact symmetric saddle
#: on a pixel boundary, which cornerSubPix's fixed point is; ChArUco's sub-pixel
#: refinement stops once a step is below cornerRefinementMinAccuracy = 0.1 px,
#: so the corner is within 0.1 px. A pixel-centre convention slip (half a pixel
#: on each axis) puts it 0.71 px off.
FLAT_CORNER_PX = 0.1

#: Systematic corner error of render_view (a property of the renderer, not of
#: the detector). It samples the board s x s times per pixel (s = supersample
#: = 3) and box-averages the samples, so an edge is placed to within half a
#: sample, 1 / (2 s) = 0.17 px; the texture under the samples has whole texels
#: per square (BoardSpec.render), square edges on texel boundaries, which
#: bilinear lookup reproduces without bias. Rounded up: 0.25 px per axis. The
#: part that varies from corner to corner shows in the residuals and so in any
#: noise estimate made from them; the part common to a view's corners is
#: absorbed by its pose and is invisible there, so the tests bound it
#: separately: by a common shift of RENDER_BIAS_PX per axis propagated through
#: the pose's Jacobian (tests/vision/_helpers.common_shift_floor) for one view,
#: and by the measured per-view mean corner error propagated through the
#: hand-eye Jacobian for the end-to-end test (the worst case over 10 views with
#: independent signs, ~80 predicted sigma, would make that test vacuous).
RENDER_BIAS_PX = 0.25

#: Marker-grid corners (classic.vision.aruco_grid): a marker corner is a convex L, not a saddle, and
#: cornerSubPix on a blurred L settles inside the marker, measured 0.15 to 0.3 px toward its centre on
#: rendered views with ~5 px per bit cell (noise-free and at noise_gray 2). 0.4 px leaves a third on top;
#: a corner snapped to an inner bit or the wrong corner is whole bit cells (>= 4 px) off.
MARKER_CORNER_BIAS_PX = 0.4

#: Circle-grid centres (classic.vision.circle_grid): a blob's centre is the centroid of the imaged circle,
#: which is not the image of the circle's centre under perspective (the near side is magnified more).
#: The tests compute that offset for every circle from the true pose (the centroid of the projected
#: boundary polygon, 256 points, against the projected centre) and add it to RENDER_BIAS_PX; measured
#: 0.005 to 0.03 px on the test views. The polygon's own error at 256 points is ~1e-4 of the radius.
CIRCLE_CENTROID_POLYGON_POINTS = 256

#: A detected corner vs its true projection: common bias <= RENDER_BIAS_PX per
#: axis (sqrt(2) RENDER_BIAS_PX in 2-D) plus noise of per-axis sigma estimated
#: from the view's RMS; the 2-D noise norm is Rayleigh, P(> 5 sigma) =
#: exp(-12.5) = 4e-6 per corner, 1e-3 over the ~200 corners of the test views.
#: The per-view mean error is bounded alike by RENDER_BIAS_PX + 5 sigma / sqrt(M).
CORNER_SIGMA_BOUND = 5.0

#: "Within the noise" when sigma is *estimated* from the same data's
#: residuals: |error| <= 5 sqrt(tr C) for a 3-D block (or 5 std for a scalar)
#: plus the bias floor. For a known C, P(|e| > k sqrt(tr C)) <= P(|z| > k) (see
#: SIGMA_BOUND): 6e-7 at k = 5. The estimated sigma has relative standard
#: deviation 1 / sqrt(2 dof) <= 0.11 (one view: 2M - 6 = 42 dof; more elsewhere),
#: so 5 estimated sigmas are below 4 true ones only if the estimate is 20 % low,
#: a 2-standard-deviation event at the fewest dof: overall P(fail) < 1e-3.
ESTIMATED_SIGMA_BOUND = 5.0

#: Intrinsics from rendered views: overall RMS reprojection error. The corner
#: error budget is RENDER_BIAS_PX per axis (0.35 px in 2-D, worst case, of which
#: the common part is absorbed by the view poses) plus intensity-noise jitter
#: (< 0.1 px at noise_gray = 2); 0.5 px stays above that budget, while a
#: missing or wrong distortion model leaves px-level residuals at the image
#: edges. The floors of the parameters' comparison with the truth: a shift
#: common to every view is a principal-point shift, so cx and cy get
#: RENDER_BIAS_PX; the focal lengths and the distortion none (a shift does not
#: scale, and the texture's scale is exact in x and y alike).
INTRINSICS_MAX_RMS_PX = 0.5

#: Our projection (pinhole and OpenCV's distortion model, 5 to 14 coefficients) against cv2.projectPoints,
#: both float64: the same polynomial evaluated in another order, rounding ~eps x |u| (<= 1000 px) x some
#: tens of operations ~1e-12 px (measured 1e-13 px); 1e-9 px is 1e3 above that. A coefficient taken in the
#: wrong place moves points near the image edge by 0.01 px or more.
OPENCV_PROJECTION_PX = 1e-9

#: Pixel noise estimated from the PnP residuals of several views, pooled (per axis, degrees of freedom
#: corrected): ~6 views x 2 axes x 35 corners less 6 x 6 pose parameters = ~380 degrees of freedom, a
#: relative standard deviation of 1 / sqrt(2 x 380) = 0.036; 0.2 is 5.5 of them, while a sigma taken per
#: 2-D residual (a factor sqrt(2)) or without the dof correction on few corners is off by more.
POOLED_SIGMA_RTOL = 0.2

#: Noise-free reprojection refinement of pixel quantities (fx, fy, cx, cy ~ 300
#: to 560 px): the optimiser stops at xtol = ftol = gtol = 1e-12 relative, i.e.
#: ~1e-9 px on quantities of ~500 px (measured ~1e-12 px); 1e-6 px is still
#: 5e6 below the 1 % focal perturbation the test starts from.
EXACT_PX = 1e-6

#: ReprojectionResult.sigma vs sqrt(trace) of s^2 (J^T J)^-1 with J from our
#: own central differences (step 1e-6, relative error ~1e-9) at the same point:
#: scipy's forward-difference Jacobian (relative step sqrt(eps) = 1.5e-8) has
#: relative error ~1e-7; 1e-4 relative is far above both, while a unit slip
#: (degrees vs radians: 57x; mm vs m: 1000x) or a wrong block is not.
SIGMA_JACOBIAN_RTOL = 1e-4

#: Seeded problems for "the reprojection refinement's median X error is below
#: that of the pose-based calibration on PnP poses": the reprojection estimate
#: is the maximum-likelihood one under pixel noise, and the PnP poses carry
#: strongly anisotropic (depth) errors that the pose-based cost weights
#: isotropically, so the gap is a large factor; 20 trials make the median
#: comparison stable.
REPROJECTION_TRIALS = 20

#: A robust (Cauchy) reprojection fit with one grossly wrong view: its
#: predicted sigma should describe the remaining views, i.e. match the sigma of
#: the linear fit without that view. Dropping 1 of 15 views changes sigma by
#: sqrt(15 / 14) = 1.04, the noise-scale estimate (~650 dof) by a few %, and
#: the Cauchy weights of inlier residuals at 0.3 px noise on a 1 px scale are
#: mostly near 1 (1 / (1 + 0.3^2) = 0.92 at one sigma): a factor 2 either way
#: is far outside all of that.
ROBUST_SIGMA_FACTOR = 2.0

# --------------------------------------------------------------------------
# Rendering (sim): a sphere of radius 0.015 m on the flange, 0.6-1.0 m from the camera
# --------------------------------------------------------------------------

#: The marker is an icosphere (642 vertices): its facets lie within r (1 - cos(4.5 deg)) = 0.05 mm of the
#: sphere, 0.015 px at 1 m, so a pixel centre can only change sides of the silhouette when it lies within
#: that distance of it: a few pixels of the ~40 on the outline at most. A principal point off by half a
#: pixel moves a whole side of the outline (6-15 pixels).
MAX_MASK_MISMATCH_PX = 3
#: Depth against the ray-sphere intersection, on the pixels within 60 % of the projected radius (further
#: out the surface grazes the ray and a facet's 0.05 mm sag becomes millimetres along it): the sag over
#: cos(37 deg) = 0.8, plus the depth buffer's resolution at ~1 m (24 bits over znear..zfar: < 0.1 mm).
CORE_FRACTION = 0.6
DEPTH_M = 2e-4

# -------------------------------------------------------------------------- robot model and simulated sensors

#: The UR URDFs write their angles to 12 significant digits (1.57079632679 = pi/2 - 4.9e-12,
#: 3.14159265359 = pi + 2.1e-12), so the links after each such joint frame turn by that much against the
#: DH table; at most three of them act on under 1 m of arm: <= 1.5e-11 m (measured 4e-12 m on the UR5).
#: 1e-10 m; a wrong link length or sign is off by centimetres.
URDF_ROUNDED_ANGLES_M = 1e-10
#: sim.recording solves the IK to a pose-error norm of 1e-9 (radians and metres, flange frame), so the
#: reached flange pose's entries are off by at most that times (1 + lever), and a board pose held on the
#: flange (lever < 0.5 m) by <= 1.5e-9; 1e-8 leaves a factor ~7, while a wrong joint solution is off by
#: millimetres to metres.
IK_REACHED = 1e-8
#: A unit-variance field correlated over L pixels (a Gaussian filter of sigma L) has about
#: N / (4 pi L^2) independent samples in N pixels; its sample sigma's relative spread is about
#: sqrt(pi L^2 / N). Four of them (P(fail) ~ 6e-5 for a Gaussian estimate).
CORRELATED_FIELD_SPREADS = 4.0
#: Nearest-pixel sampling across an edge puts a square's edge within half a pixel of its true place; its
#: centroid, an average over the edge's pixels, within that too.
NEAREST_PX = 0.5
#: The sample standard deviation of n = 200 independent draws has a relative standard deviation
#: 1 / sqrt(2 n) = 0.05; clipping each draw at 2.5 sigma (sim.sensors.draw_systematic) lowers the
#: standard deviation by 1.1 % (sqrt(E[min(z^2, 6.25)]) = 0.989). 0.2 leaves 0.189 for the sampling, 3.8
#: of its standard deviations (P(fail) ~ 1e-4), while a sigma read as a variance or in the wrong unit
#: is off by far more.
CLIPPED_DRAWS_STD_RTOL = 0.2

# -------------------------------------------------------------------------- datasets

#: Depth PNGs store 0.1 mm units (sim.generate.DEPTH_SCALE_M): rounding adds at most half a unit.
DEPTH_QUANTUM_M = 0.5e-4

#: Classic labels against truth. Their sigma is estimated from the corner residuals (ESTIMATED_SIGMA_BOUND
#: applies); corner errors that differ between views show in those residuals, because the hand-eye
#: reprojection model has 12 parameters for all views and cannot absorb a view's shift. What it can absorb
#: unseen is a shift common to every corner of every view, i.e. a camera-model error such as the principal
#: point: tests/sim/test_render.py resolves that to 0.2 px (it fails on a principal point off by 0.2 px), so
#: the floor is that shift seen from the camera: 0.2 px / f in rotation, times the distance in translation.
LABEL_COMMON_SHIFT_PX = 0.2

# -------------------------------------------------------------------------- learned

#: Targets are float32 (torch's default): a camera position of up to ~2000 mm is stored to
#: 2000 * 2^-24 = 1.2e-4 mm per coordinate; a distance from three such coordinates (and the
#: truth's) differs from the float64 one by well under 1e-3 mm.
FLOAT32_POSITION_MM = 1e-3

#: The share of 2000 replay-buffer draws in which a frame is kept, against its probability p = 0.4
#: (4 of 10 frames): binomial standard deviation sqrt(p (1 - p) / 2000) = 0.011, so 0.05 is 4.6 of them;
#: over the 10 frames P(fail) ~ 4e-5.
REPLAY_FREQUENCY_ATOL = 0.05

#: The mean of two float32 weight tensors as torch's AveragedModel forms it (a running mean: a + (b - a) / 2,
#: or a lerp) against (a + b) / 2: each rounds two or three times at half an ulp, 2^-25 = 3e-8 of the
#: operands' size, so <= 1.8e-7 relative; 1e-6 leaves a factor 5. Where a and b nearly cancel the
#: relative bound fails and the absolute one holds: 3 x 3e-8 x |a| with the weights of these small networks
#: below 1 in size (only batch norm's scales start at 1, and those do not cancel): 1e-7. A mean over the
#: wrong epochs moves the weights by a whole Adam step (1e-3).
FLOAT32_AVERAGE_RTOL = 1e-6
FLOAT32_AVERAGE_ATOL = 1e-7

#: A rotation predicted by a float32 network (torch's default) and built from its unit quaternion: each
#: entry a sum of a few products rounded at 2^-24 = 6e-8, so R R^T - I is within ~10 of those (6e-7); 1e-6.
FLOAT32_ROTATION = 1e-6

# -------------------------------------------------------------------------- data-parallel training (learned)

#: The gradient of one batch on 2 ranks (each a slice, batch norm over the whole batch) against one
#: process: the same float32 sums (2^-24 = 6e-8 relative per operation) in another order and split.
#: The longest sums (a first-layer weight: 24 samples x 16 x 16 pixels = 6144 terms) round to about
#: sqrt(6144) x 6e-8 = 5e-6 of the tensor's largest entry; measured 8e-6, as one process on 1 thread
#: against 2. 1e-4 leaves a factor 10; batch norm per slice, or a wrong weight of a slice's loss, is off
#: by order 1.
DDP_GRADIENT_RTOL = 1e-4

#: A parameter tensor whose gradient is below this fraction of the network's largest gradient entry
#: has a gradient that is mathematically zero (a convolution's bias before batch norm, the heatmaps'
#: bias before the softmax), rounding noise only: measured <= 2e-6, while every other tensor's is
#: above 1e-2.
ZERO_GRADIENT_FRACTION = 1e-4

#: What training changed in a tensor (parameters with a gradient, running variances) after 9 Adam
#: steps of learning rate 1e-3, 2 or 3 ranks against one process: the L2 norm of the difference relative
#: to that of the change. Adam divides each entry's gradient by its own running scale, so an entry whose
#: gradient is near zero (a ReLU feature active in one sample of a batch) moves by up to lr per step in
#: a direction set by rounding: 26 of 65984 entries of one layer differ by 6e-5 on 3 ranks, all others
#: by about 1e-7. Over a tensor they weigh little: measured <= 1.6e-4 (one process on 1 thread against
#: 2: 1.2e-5); batch norm per slice gives 0.5 to 1.7.
DDP_UPDATE_RTOL = 1e-2

#: Predictions of the trained networks, relative to their largest magnitude: Adam moves the biases of
#: zero gradient by a full step (lr) in the direction of the rounding noise, up to 9e-3 after 9 steps,
#: and batch norm in evaluation mode sees them through its lagging running mean. Measured 1.3e-3 (one
#: process on 1 thread against 2: 1e-3).
DDP_PREDICTION_RTOL = 1e-2

#: The ``tiny`` preset end to end, 2 processes against 1 (same seed): every time step's test-subset
#: errors and the final summaries, relative. The same mechanism over some 60 training calls; measured
#: 1.5e-3, as one process on 1 thread against 2 (1.1e-3).
DDP_RUN_RTOL = 1e-2

# --------------------------------------------------------------------------
# Real recordings (benchmarks/data/real, tests/test_real_recordings.py)
# --------------------------------------------------------------------------

#: The median hold-out prediction error of a real recording's default fit (camera pose predicted from the
#: robot pose, fit on the other poses) over the RMS of the same fit's residuals on all poses. For Gaussian
#: residuals the median of an error's norm is 0.89 of its RMS (Maxwell distribution: 1.54 over 1.73
#: sigma per axis) and a held-out pose adds the estimate's own error, a factor sqrt(1 + p / n) = 1.15 for
#: the 12 parameters and 42 poses; 1.5 leaves room for the heavier tails of a real recording. A wrong fit
#: (the wrong setup) predicts with errors many times its residual's scale, or is refused.
HOLDOUT_OVER_RESIDUAL = 1.5
#: A pose read from a real recording's file: its rotation block orthonormal to this (the files print
#: 17 significant digits, and the readers re-orthonormalise within their printed-rotation tolerance).
RECORDED_ROTATION = 1e-9
#: Pose matrices printed with six decimals (a common robot export): each entry rounded by <= 5e-7 (unitless
#: rotation entries; translations in mm, i.e. 5e-10 m). Inverting such a pose adds the rotation's rounding
#: times the translation, three terms of <= 5e-7 x 1 m: <= 1.5e-6 m; 1e-5 leaves a factor 6, while a
#: transposed rotation or a translation in the wrong unit is off by order 0.1 to 1000.
PRINTED_SIX_DECIMALS = 1e-5
#: Distances of a metric recording: a robot flange and a target seen by a camera lie between 1 cm and 5 m
#: from their frames' origins; millimetres read as metres land at 1000 times that.
METRIC_RANGE_M = (0.01, 5.0)

# --------------------------------------------------------------------------
# Closed forms on motions near a half turn (tests/classic/test_half_turn.py)
# --------------------------------------------------------------------------

#: A closed form's error against the truth on a half-turn set, in units of one motion pair's noise.
#: A motion pair combines two poses on each side, so its rotation noise per axis is
#: ``s_m = sqrt(2 (s_cam^2 + s_robot^2))`` and its translation noise
#: ``sqrt(2 (t_cam^2 + t_robot^2)) + L s_m``, with ``L`` the largest camera-to-target distance (the
#: lever a rotation error moves a translation by). A closed form that uses all pairs does no worse
#: than one pair; SIGMA_BOUND (4) sigma of a 3-D error's norm, sqrt(3) per-axis sigmas, for the tail.
#: (Not Tsai where X itself turns by nearly 180 degrees: its parameter P_X / sqrt(4 - |P_X|^2) is
#: singular there, 1.2 degrees at X = 179.94 degrees, OpenCV's 0.9; the tests' sets have X away from it.)
#: Measured at most 0.10 of this in rotation and translation (7 methods, 4 kinds of set, 2 setups,
#: 10 seeds); a pair of opposite quaternion signs moved Tsai and Daniilidis by 2 to 180 degrees (2 to
#: 160 times the rotation bound, 1.1 degrees at the tests' noise).
HALF_TURN_PAIR_SIGMAS = SIGMA_BOUND * np.sqrt(3.0)
#: Issue 39's target, not a noise bound: each closed form within 1 degree of OpenCV's same method, or
#: closer to the truth than OpenCV's, on motions up to 180 degrees.
OPENCV_SAME_METHOD_DEG = 1.0

# --------------------------------------------------------------------------
# The robot's pose error in the image path's sigma (tests/vision/test_robot_noise.py)
# --------------------------------------------------------------------------

#: Trials of the coverage test and the views of each (the issue asks 95 % of 100 trials in the benchmark,
#: benchmarks/vision_robot_noise.py; the test runs fewer with a binomial bound that still has power).
ROBOT_COVERAGE_TRIALS = 30
ROBOT_COVERAGE_VIEWS = 25
#: Of ROBOT_COVERAGE_TRIALS, at least this many errors within 3 reported sigma (the norm of a 3-D error
#: against 3 sqrt(tr C)). An honest Gaussian sigma covers with p >= 0.997 (the worst case, a 1-D error:
#: P(chi2_1 <= 9)); with p = 0.99 (estimated variance components) P(<= 26 of 30) = 2.2e-4. A sigma 3x too
#: small covers with p <= P(chi2_1 <= 1) = 0.683, and P(>= 27 of 30) <= 0.55 %: the bound fails it.
ROBOT_COVERAGE_MIN = 27
#: An exact robot: the sigma against the corners-only model's. The robot's variance is estimated from the
#: views' pose offsets; at zero truth its estimate is zero or within a few standard errors, each about
#: sqrt(2 / V) of the views' pose variance from their corners, and X's variance grows by that fraction at
#: most: 3 standard errors give sqrt(1 + 3 sqrt(2 / V)) = 1.36 for V = 25 (measured 1.18 at most).
EXACT_ROBOT_SIGMA_FACTOR = float(np.sqrt(1.0 + 3.0 * np.sqrt(2.0 / ROBOT_COVERAGE_VIEWS)))

#: The estimated robot error against the truth (0.05 deg, 0.5 mm per axis), median over the coverage
#: trials: a standard deviation estimated from about 3 V = 75 per-axis draws has a relative standard
#: deviation near sqrt(1 / (2 * 75)) = 0.08 per trial, its median over 30 trials 0.02; 0.15 is 7 of those
#: (the corner noise's share of the views' pose offsets adds to the spread).
ROBOT_ESTIMATE_RTOL = 0.15
#: Halves check: the RMS over M trials of |d| / sqrt(tr C_d) for a Gaussian d is 1 with a relative standard
#: deviation <= sqrt(1 / (2 M)) (a 1-D d); 3 of them for M = 10: |ratio - 1| <= 0.67. A corners-only sigma
#: with this robot error is 3 to 5 times too small and fails it.
HALVES_TRIALS = 10
HALVES_RATIO_TOL = 3.0 * np.sqrt(1.0 / (2 * HALVES_TRIALS))
#: The same bound on the RMS of error / sigma over 10 trials of the refinement's other paths (intrinsics
#: refined, a full distortion model): |RMS - 1| <= 3 sqrt(1 / 20) = 0.67; corners-only it is 3 to 5.
FEW_TRIALS_SIGMA_RMS_TOL = 3.0 * np.sqrt(1.0 / (2 * 10))

# --------------------------------------------------------------------------
# Outliers named against a fit without them (tests/classic/test_outliers_default.py)
# --------------------------------------------------------------------------

#: The translation residual reported for a pose displaced by an injected gross error (1.8 m here), against
#: that displacement: the pose's own noise (1 mm, 0.1 deg through a lever of ~1 m: 2 mm) and the robust
#: fit's error (which leaves the pose out: millimetres) add a few mm, 0.3 %; 5 % (90 mm) is far above that,
#: while a residual in the wrong unit or of another pose is off by far more.
INJECTED_OUTLIER_RTOL = 0.05

#: A count of clean sets with a pose named is tested against the binomial quantile at this upper tail: a
#: correct test (the stated alpha) fails it with probability at most 1e-3, while one that names at twice
#: the stated rate fails it often (at alpha 0.1 and 150 sets: the quantile is 29 against a mean of 30).
FALSE_ALARM_TAIL = 1e-3

# --------------------------------------------------------------------------
# Rounding at a scale, and robust spreads (issue 42: the last literal tolerances)
# --------------------------------------------------------------------------

#: A residual of points of size r (metres) that is zero, or a small remainder, in exact arithmetic (a point's
#: distance from a sphere through it, the second-order residual's fourth-order rest): each coordinate rounds
#: at eps r (eps = 2.2e-16), a unit direction's normalisation and the scaling by r put a point off its surface
#: by up to ~1.5 eps r, two points and a dot product with a unit normal by ~4 eps r. 8 eps, times the points'
#: scale r, and absolute (the remainder itself can be 1e-14 m or less, far below any relative bound's reach).
#: Measured 1.8 eps r (200 draws of 200 points on a 5 cm sphere); a wrong curvature term is off by its own
#: size (>= 4e-14 m there, 200 eps r; a 1 % error in it, 1e-6 m).
POINT_ROUNDING_EPS = 8 * np.finfo(float).eps

#: The robust sigma 1.4826 MAD of N independent Gaussian values has relative standard deviation
#: MAD_SD_SQRT_N / sqrt(N) (MAD's asymptotic variance 1.36 sigma^2 / N: an efficiency of 37 %). Second
#: differences of a noise image along its rows and columns (two per pixel, neighbours sharing pixels) count
#: as one per pixel: their spread's standard deviation is 1.36 that of as many independent values (measured
#: over 2000 noise images of 60 x 80), under sqrt(2).
MAD_SD_SQRT_N = 1.167

#: ``learned.keypoints.keypoint_loss`` charges a heatmap's spread s (px) as sqrt(s^2 + 1e-6), a floor that keeps
#: its gradient finite at a single peak: high by 1e-6 / (2 s^2) relative, 2.5e-7 at the smallest spread the
#: tests charge (half a cell's diagonal, 1.41 px), float64 rounding (1e-16) nothing beside it. 1e-6 relative is
#: four times the floor's effect; a spread off by a tenth of a cell or a missing square root is off by 5 % or
#: more.
KEYPOINT_SPREAD_RTOL = 1e-6

#: A rotation fitted to a float32 unit quaternion's label, against that label by eq. 2
#: (``learned.metrics.rotation_errors_deg``, 360 / pi x the quaternion distance d for small angles): each
#: component rounds at 2^-24 relative, so the label's norm is 1 within sum q_i^2 2^-24 = 2^-24, and the fit,
#: which sees the normalised rotation, returns it at distance d = | |q| - 1 | <= 2^-24 from the label. Twice
#: that, for the second order and the float64 fit's rounding: 1.4e-5 deg (measured 4.6e-7). A rotation error a
#: fit can make (a camera turned, a keypoint off) is 1e-3 deg and up.
FLOAT32_QUATERNION_DEG = 360.0 / np.pi * 2 * 2.0**-24

#: One float32 network's prediction on a CUDA device and on the CPU, ``T_base_cam`` per entry (metres,
#: unitless rotation entries). The test turns TF32 off (cuDNN's convolutions use it by default: 10 mantissa
#: bits), so both devices compute in float32 and differ only in the order of their sums. A sum of K products
#: rounds to within K 2^-24 of the sum of their magnitudes (Higham's gamma_K): the tiny preset's widest sum
#: has K = 1031 terms (its first dense layer), 6.1e-5 of its outputs' size, over its 6 layers 3.7e-4; the
#: translation head's normalised output (of order 1) times its 500 mm scale moves by <= 0.4 mm, a rotation
#: entry, through its unit quaternion, by <= 7e-4. 1e-3 (1 mm; 1e-3 per rotation entry) is above both
#: worst cases; weights lost in the reload (a layer at its initial values, batch norm's running statistics
#: dropped) move the prediction by centimetres and degrees.
DEVICE_PREDICTION_ATOL = 1e-3

#: OpenCV's SGBM sub-pixel fit pulls a disparity toward whole pixels ("pixel locking") by up to a quarter
#: pixel (tests/sim/test_stereo.py measures its first harmonic at about 0.2 px). Periodic in the disparity, a
#: pull of amplitude a averages, over a surface whose disparities span L pixels, to at most a / (pi L): the
#: integral of a sine over the part of a period left over, a / pi, shared by L periods.
SGBM_LOCKING_MAX_PX = 0.25


#: Tail probability at which a count of false alarms is called inconsistent with the stated rate's mean (a
#: Poisson upper quantile; the CUSUM's bound is a mean rate, and rare alarms are Poisson at most): one run in
#: a thousand of a correct watcher fails; a fault that multiplies the rate (the depth unit left uncorrected:
#: the statistic follows the arm's pose for whole dwells) gives counts several times the mean, far beyond.
FALSE_ALARM_COUNT_TAIL = 1e-3

#: bfloat16 keeps 8 significant bits (7 stored): a rounding to nearest moves a value by at most 2^-8 of it (the
#: unit roundoff 2^-p of p significant bits, as float32's 2^-24 above). A regression network's bfloat16 encoder
#: rounds each layer's input and weights, so to first order a layer's output moves by at most 2 x 2^-8 of the
#: magnitude of its terms, and L layers by 2 L 2^-8; the tiny networks' 3 convolutions and the float32 head's
#: first dense layer fed by them: 2 x 4 x 2^-8 = 0.031 of the raw output's size (measured 1e-4 to 5e-4 over
#: seeds 0-4: the worst case of every rounding in one direction is far off). An encoder left in float32 differs
#: by 0 (the test also asks for a difference).
BF16_ENCODER_RTOL = 8 * 2.0**-8

#: The markerless fit's per-pixel depth effect eliminated in closed form (classic.markerless.pixel_effect) against
#: the joint solve with one unknown per pixel: the same numbers in exact arithmetic, through two linear solves of
#: 5 and 45 unknowns on well-conditioned random normal equations (condition ~1e2): float64's 2.2e-16 times that
#: and the few hundred terms summed, about 1e-13 relative; 1e-10 leaves room and still fails on any wrong term
#: (a prior dropped or doubled moves the step by percents).
PIXEL_EFFECT_SCHUR_RTOL = 1e-10

#: The per-pixel effect's variance from the method of moments within this many of its sampling standard
#: deviations (the spread derived in the test from the pixels' count): 4 leaves a 6e-5 chance of a false failure.
PIXEL_EFFECT_SIGMA_SDS = 4.0

#: The per-pixel effect's variance components (one-way random effects, ANOVA) within this many of their standard
#: errors, each derived in the test from the design (the within mean square's chi^2(N - k), each pixel's between
#: term (s_p sigma_p^2 + v) chi^2(1), their ratio's by the delta method): 4 leaves a 6e-5 chance per check of a
#: false failure (normal tail). The total variance in place of the within one moves the ratio by
#: log(1 + mean(g^2) sigma_p^2 / v), 0.55 at the test's sizes, against 4 x 0.035 (the old code failed by it).
PIXEL_VARIANCE_SPLIT_SDS = 4.0

#: The field repeated per image pixel (classic.markerless.repeated_error) against its truth: its variance from one
#: draw has a relative sd of sqrt(2 / n) over the n = area / (4 pi L^2) independent cells the frames see, and the
#: predicted covariance of its pull against a Monte Carlo one over M fields the same plus sqrt(2 / M), each derived
#: in the test from its sizes; 4 of them leave a 6e-5 chance of a false failure (normal tail), while the temporal
#: noise taken in (4 times the field's variance) or the correlation dropped (a factor 4 pi L^2 / 1 = 50) fail.
REPEATED_FIELD_SDS = 4.0

#: The spheres' scene with a fixed pattern (tests/classic/test_markerless_repeated_error.py): the errors' RMS in
#: predicted sigmas over M draws within this many of its sd, sqrt(1 / (2 M)) (derived in the test), of 1: 3 leaves
#: a 0.3 % chance of a false failure for the seeded draws; the frame-clustered sigma alone is short by 2.04 there.
REPEATED_SCENE_SDS = 3.0

#: A unit vector printed with three decimals (classic.least_squares.require_determined's direction) against the
#: exact one: each component rounded by <= 5e-4, so the difference's norm is <= sqrt(3) x 5e-4 = 8.7e-4; 1e-3 keeps
#: that, while a direction off by a degree (1.7e-2) or another axis (order 1) fails.
PRINTED_THREE_DECIMALS_UNIT_VECTOR = 1e-3

#: A figure that a smoke run's training prints (``docs/make_examples.py``'s ``TRAINS``: the learned guide's errors,
#: their differences and ratios) against the one its page shows, relative: the same steps on the same data move
#: them with the order of the float32 sums, which the torch thread count and the CPU's kernels set. Measured on the
#: guide's three steps with 1 and 2 threads and torch and oneDNN held to AVX-512, AVX2 and no vector unit
#: (``ATEN_CPU_CAPABILITY``, ``ONEDNN_MAX_CPU_ISA``; AMD EPYC, 2026-12-06): at most 0.68 % (selection's error
#: against the baseline, -112.20 against -111.44 mm; the learned poses 0.34 %, the classic and hybrid columns
#: identical); 2 % is three times that, while one epoch more on each later step moves the reservoir's mean by 8 %.
SMOKE_TRAINED_RTOL = 0.02

#: The running cell's change statistic x (handeye.watch.change: chi2(6) when nothing moved, after the null's fit) of
#: frames at the truth, each within chi2(6)'s upper quantile at this tail over the frames a test checks (Bonferroni:
#: a correct check fails one run in 10 000), tests/watch/test_check_native_size.py.
WATCH_STATISTIC_TAIL = 1e-4

#: ... and that quantile widened by the null's fitted scale being low by this many of its standard errors (derived in
#: the test from the frames it is fitted on): 3.1 leaves a one-sided normal tail of 1e-3. Over 40 frames (sd 12 %)
#: the bound is 1.6x chi2(6)'s quantile: 52.7 for 10 frames; measured at most 16.6 there, and a camera moved by
#: 1 mm / 0.1 deg gives 443 and more at 848x480.
WATCH_STATISTIC_SCALE_SDS = 3.1

#: The recorded joints' error learnt by the watcher (handeye.watch.change.fit_joint_variance), its sigma against
#: the truth, relative: Huber's profile likelihood from 300 synthetic frames whose joints' part is as large as the
#: pixels' is off by 0.1 % on average and scatters by 4.7 % (100 draws, at most 12 %); learnt from the 120 frames
#: (40 arm poses) of tests/watch/test_joint_noise.py's precise stream, by -5.5 % and 6.4 % (30 seeds, 0.86 to
#: 1.15 of the truth: the joints' and the pixels' models are approximations there). 0.3 is that bias and 3.8 of
#: those standard errors (a one-sided normal tail of 1e-4); a watcher that takes the joints as exact learns 0.
JOINT_VARIANCE_REL = 0.3
#: The same fit on frames with no joints' part (the truth 0), as a sigma in the units of a joints' part as large as
#: the pixels' (``sqrt(found / a)``, a = 1): over 120 draws of tests/watch/test_joint_noise.py's synthetic frames
#: it is 0 in 56 % and a half-normal's positive side otherwise, its sigma in variance 1.3e-3 (sqrt(2 E[found^2])),
#: the largest 5.3e-3 (0.073 as a sigma). 0.1 (1e-2 in variance: 7.9 of those sigmas, twice the largest draw) is
#: crossed by a fit that takes a tenth of the pixels' part for the joints'.
JOINT_VARIANCE_NULL_SIGMA = 0.1

#: The check's step moved by the joints against its derivative (handeye.watch.check.FrameCheck.joint_gain),
#: relative: the finite difference holds the association's discreteness (pixels chosen again, silhouette points
#: matched or not), 3 to 12 % over 8 poses of tests/watch/test_joint_noise.py's arm at 0.05 deg; a gain in the
#: wrong frame (R for R^T) is 33 to 440 % off.
JOINT_GAIN_REL = 0.25

#: The split check's depth-unit excess (tests/classic/test_markerless_depth_unit_split.py): over N draws, the full
#: answer's squared errors over the mean squared sigma is chi-square with N degrees of freedom for an honest Gaussian
#: sigma; held within its quantiles at this tail (one run in a thousand fails a correct sigma, on either side) ...
DEPTH_UNIT_CHI2_TAIL = 1e-3
#: ... with the upper one widened by the mean squared sigma's own error: each draw's excess is measured from G groups
#: (G - 1 degrees of freedom: the variance of its estimate is 2 / (G - 1) of its square), so the mean over N draws
#: has a relative standard error of sqrt(2 / ((G - 1) N)), 4.1 % for G = 4, N = 400; the bound divides by 1 less
#: this many of them (a one-sided normal tail of 1e-4). The clipping at 0 only widens the sigma. Without a shared
#: error, the mean clipped excess over the draws is held within as many of its standard errors of its expectation.
DEPTH_UNIT_SIGMA_SES = 3.7

#: The shared intrinsics' pooled prior (tests/classic/test_markerless_shared_intrinsics.py): over N draws of 7
#: consistent placements, the pool's squared error over its squared sigma, averaged over the draws and the four
#: parameters, is chi-square(1)'s mean 1 without the Birge widening, with a standard error of sqrt(2 / (4 N)); the
#: widening only lowers it, to E[1 / max(X / k, 1)] for X chi-square with k = 6 degrees of freedom. Held between
#: that expectation and 1, each widened by this many standard errors (a one-sided normal tail of 3e-5).
SHARED_INTRINSICS_SES = 4.0

#: The pooled focal length's error, as a share of the error of the camera matrix told (0.7 % = 0.78 px at the
#: small preset's f = 111 px), tests/sim/test_markerless.py: each placement's estimate keeps its given prior's
#: pull (the prior's share of the posterior, ratio^2, at most 0.12 there; doubled by fy's correlation, told off
#: alike: 0.24), which the pool averages without removing, plus 3 of the pool's sigmas (about 0.11 px: 0.42 of the
#: error told): 0.66. A pool that took nothing from the frames (the given matrix) is at 1.
SHARED_POOL_ERROR_SHARE = 0.7
