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
FLOAT = 1e-12

#: so3_log of a rotation within 1e-12 rad of pi: the axis is recovered from
#: the symmetric part of R, whose conditioning is fine at pi (Shepperd's
#: method), but the angle comes through arctan2(|v|, w) with w ~ 1e-12:
#: absolute accuracy ~1e-15 / |v| on the angle, i.e. still ~1e-15. We allow
#: 1e-9, the same bar as noise-free recovery, as the scipy reference itself
#: goes through the same near-singular quantities.
NEAR_PI_ANGLE = 1e-9

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
#: is ~1e-16 x condition <= 1e-10; 1e-9 relative.
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

#: Trials for "the refined median error is no worse than the closed form".
REFINE_TRIALS = 30

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
