import sys; sys.path.insert(0,'.')
from dataclasses import replace
import numpy as np
from benchmarks.markerless_sensors import front_options, observe, placements, told_posed
from classic.markerless.problem import Problem
from classic.markerless.depth import backproject
from handeye.core.dataset import Dataset
from handeye.markerless import robot_surface_for
from handeye.robot.depth_sensors import PROFILES
from classic.markerless.visibility import project

ds = Dataset.open('data/sensor-bands/paper-sim-1.2')
surface, stride = robot_surface_for(ds)
K = np.array(ds.meta['intrinsics']['K'], float)
s1 = replace(PROFILES['ideal'], noise_quadratic_per_m=0.00358)
s0 = replace(PROFILES['ideal'], noise_quadratic_per_m=0.0)
import sys as _s
opts = front_options(s1, stride, pixel_effect_px=2, intrinsics_model=_s.argv[1])
T_true = ds.truth()
rows = {}
def rec(key, problem, T_true_c):
    fx = problem.theta[0] - K[0,0]
    T = problem._last.T_base_cam
    off = (np.linalg.inv(T_true_c) @ T)[:3, 3] * 1e3
    k, c = problem.depth_correction[:2]
    rows.setdefault(key, []).append((fx, off[2], -c / k * 1e3))
stats = []
for c in placements(ds, 'all')[::2]:
    d1, q, _ = observe(ds, c, s1, 0)
    d0, _, _ = observe(ds, c, s0, 0)
    posed, Tc = told_posed(surface, q, T_true[c], None)
    pr = Problem(d1, K, posed, opts)
    idx, f, q1, qq, has, close = pr.associate(Tc, float(__import__('os').environ.get('G','0.02')))
    ok = np.isfinite(q1[:, 2])
    uv = np.rint(project(np.where(ok[:, None], q1, [0,0,1.0]), K)).astype(int)
    P0 = backproject(d0, K)
    q0 = P0[f, uv[:, 1], uv[:, 0]]
    Tinv = np.linalg.inv(Tc)
    pz = (pr.model_points(idx) @ Tinv[:3, :3].T + Tinv[:3, 3])[:, 2]
    g0 = ok & np.isfinite(q0[:, 2]) & (np.abs(q0[:, 2] - pz) < float(__import__('os').environ.get('G','0.02')))
    g1 = close & np.isfinite(q0[:, 2])
    fit0 = pr.fitted_matches(idx, g0); fit1 = pr.fitted_matches(idx, g1)
    e = (q1[:, 2] - q0[:, 2]) / pr.sigma_z(q0[:, 2])
    stats.append((np.nanmean(e[fit0]), np.nanstd(e[fit0]), np.nanmean(e[fit1]), np.nanstd(e[fit1])))
    rng = np.random.default_rng(c)
    fresh = q0 * (1 + rng.normal(size=len(q0)) * pr.sigma_z(q0[:, 2]) / q0[:, 2])[:, None]
    for key, Q, sel in [('noisefree rows g0', q0, fit0), ('dataset noise, rows g0', q1, fit0),
                        ('fresh noise, rows g0', fresh, fit0), ('dataset noise, rows g1 (noisy gate)', q1, fit1),
                        ('fresh noise, rows g1', fresh, fit1)]:
        pr.restart()
        fit, _, _ = pr.fit_matches(Tc, idx, f, np.where(np.isfinite(Q), Q, np.nan), sel)
        pr._last = fit
        rec(key, pr, Tc)
    print(c, 'noise/sigma mean,std g0 %.3f %.3f g1 %.3f %.3f' % stats[-1], {k: np.round(v[-1], 3) for k, v in rows.items()}, flush=True)
for k, v in rows.items():
    v = np.array(v)
    print(f'{k:40s} fx {v[:,0].mean():+.3f} +- {v[:,0].std(ddof=1)/np.sqrt(len(v)):.3f}  z {v[:,1].mean():+.2f} +- {v[:,1].std(ddof=1)/np.sqrt(len(v)):.2f}  offset {v[:,2].mean():+.2f} +- {v[:,2].std(ddof=1)/np.sqrt(len(v)):.2f} mm')
