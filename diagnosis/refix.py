# fixed pairing at the truth vs pairing re-made at the iterate, paper-sim, white noise, camera matrix estimated
import sys, os; sys.path.insert(0, '/tmp/x')
from dataclasses import replace
import numpy as np
from benchmarks.markerless_sensors import front_options, observe, placements, told_posed
from classic.markerless.problem import Problem
from handeye.core.dataset import Dataset
from handeye.markerless import robot_surface_for
from handeye.robot.depth_sensors import PROFILES
ds = Dataset.open(os.environ.get('DS', 'data/sensor-bands/paper-sim-1.2'))
surface, stride = robot_surface_for(ds)
K = np.array(ds.meta['intrinsics']['K'], float)
s1 = replace(PROFILES['ideal'], noise_quadratic_per_m=0.00358)
opts = front_options(s1, stride, pixel_effect_px=2)
GATE = float(os.environ.get('GATE', '0.01'))
T_true = ds.truth()
rows = {}
def rec(key, pr, T, Tc):
    off = (np.linalg.inv(Tc) @ T)[:3, 3] * 1e3
    k, c = pr.depth_correction[:2]
    rows.setdefault(key, []).append((pr.theta[0] - K[0, 0], off[2], c / k * 1e3))
for c in placements(ds, 'all')[::2]:
    d1, q, _ = observe(ds, c, s1, 0)
    posed, Tc = told_posed(surface, q, T_true[c], None)
    pr = Problem(d1, K, posed, opts)
    idx, f, q1, qq, has, close = pr.associate(Tc, GATE)
    pr.restart()
    fit, _, m0 = pr.fit_matches(Tc, idx, f, q1, close)
    rec('paired at the truth, fitted once', pr, fit.T_base_cam, Tc)
    T = fit.T_base_cam
    for it in range(12):
        idx, f, q1, qq, has, close = pr.associate(T, GATE)
        fit, _, _ = pr.fit_matches(T, idx, f, q1, close)
        T = fit.T_base_cam
        if it in (0, 3, 11):
            rec(f'then re-paired at the iterate x{it + 1}', pr, T, Tc)
    print(c, {k: np.round(v[-1], 3) for k, v in rows.items()}, flush=True)
for k, v in rows.items():
    v = np.array(v); se = v.std(0, ddof=1) / np.sqrt(len(v))
    print(f'{k:40s} fx {v[:,0].mean():+.3f} +- {se[0]:.3f}  z {v[:,1].mean():+.2f} +- {se[1]:.2f}  offset {v[:,2].mean():+.2f} +- {se[2]:.2f} mm')
