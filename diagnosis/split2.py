# noise-free fit at the truth on rows within 2 cm, split: which rows carry the noise-free bias
import sys, os; sys.path.insert(0, os.environ.get('ROOT', '.'))
from dataclasses import replace
import numpy as np
from benchmarks.markerless_sensors import front_options, observe, placements, told_posed
from classic.markerless.problem import Problem
from classic.markerless.depth import backproject
from classic.markerless.visibility import project
from handeye.core.dataset import Dataset
from handeye.markerless import robot_surface_for
from handeye.robot.depth_sensors import PROFILES
ds = Dataset.open(os.environ.get('DS', 'data/sensor-bands/paper-sim-1.2'))
surface, stride = robot_surface_for(ds)
K = np.array(ds.meta['intrinsics']['K'], float)
s1 = replace(PROFILES['ideal'], noise_quadratic_per_m=0.00358)
s0 = replace(PROFILES['ideal'], noise_quadratic_per_m=0.0)
opts = front_options(s1, stride, pixel_effect_px=2)
T_true = ds.truth()
rows = {}
sel_pl = [int(a) for a in sys.argv[1].split(',')]
for c in [p for i, p in enumerate(placements(ds, 'all')) if i in sel_pl]:
    d1, q, _ = observe(ds, c, s1, 0)
    d0, _, _ = observe(ds, c, s0, 0)
    posed, Tc = told_posed(surface, q, T_true[c], None)
    pr = Problem(d1, K, posed, opts)
    idx, f, q1, qq, has, close = pr.associate(Tc, 0.02)
    ok = np.isfinite(q1[:, 2])
    uv = np.rint(project(np.where(ok[:, None], q1, [0, 0, 1.0]), K)).astype(int)
    q0 = backproject(d0, K)[f, uv[:, 1], uv[:, 0]]
    Ti = np.linalg.inv(Tc)
    p_cam = pr.model_points(idx) @ Ti[:3, :3].T + Ti[:3, 3]
    n_cam = pr.s.normals_base[idx] @ Tc[:3, :3]
    dz = q0[:, 2] - p_cam[:, 2]
    plane = np.einsum('ij,ij->i', n_cam, q0 - p_cam)
    g0 = ok & np.isfinite(q0[:, 2]) & (np.abs(dz) < 0.02)
    static = pr.static_rows(idx)
    part = pr.s.part[idx]
    small = np.abs(dz) < 0.004
    from classic.markerless.problem import _FRAME_KEY_M
    from scipy.spatial import cKDTree
    key_pts = np.c_[pr.s.points_base, pr.s.frame * _FRAME_KEY_M]
    tree = cKDTree(key_pts)
    u = np.unique(idx)
    nb = tree.query_ball_point(key_pts[u], r=float(os.environ.get('CR', '0.008')))
    crease_u = np.array([np.min(pr.s.normals_base[j] @ pr.s.normals_base[i]) < np.cos(np.radians(35)) for i, j in zip(u, nb)])
    crease = np.zeros(pr.s.points_base.shape[0], bool); crease[u] = crease_u
    near_crease = crease[idx]
    with np.errstate(invalid='ignore', divide='ignore'):
        ray = q0 / q0[:, 2:3]
        tst = np.einsum('ij,ij->i', n_cam, p_cam) / np.einsum('ij,ij->i', n_cam, ray)
        d0 = np.linalg.norm(ray * tst[:, None] - p_cam, axis=1)
    bad = g0 & (np.abs(plane) >= 0.002)
    print('plane>2mm rows', int(bad.sum()), 'near crease', int((bad & near_crease).sum()), 'd0>4mm', int((bad & (d0 > 0.004)).sum()), '| all g0 near crease', int((g0 & near_crease).sum()), flush=True)
    variants = {
        'no sample near a crease': g0 & ~near_crease,
        'tangential offset < 4 mm': g0 & (d0 < 0.004),
        'all within 2 cm': g0,
        'plane residual < 2 mm': g0 & (np.abs(plane) < 0.002),
        'plane residual < 5 mm': g0 & (np.abs(plane) < 0.005),
    }
    for key, sel in variants.items():
        pr.restart()
        fit, _, _ = pr.fit_matches(Tc, idx, f, np.where(np.isfinite(q0), q0, np.nan), pr.fitted_matches(idx, sel))
        off = (Ti @ fit.T_base_cam)[:3, 3] * 1e3
        rows.setdefault(key, []).append((pr.theta[0] - K[0, 0], off[2], int(sel.sum())))
    mis = g0 & ~small
    print(c, 'rows', int(g0.sum()), 'beyond 4 mm', int(mis.sum()), 'of them static', int((mis & static).sum()), 'parts', np.bincount(part[mis]), {k: np.round(v[-1][:2], 3) for k, v in rows.items()}, flush=True)
for k, v in rows.items():
    v = np.array(v, float); se = v.std(0, ddof=1) / np.sqrt(len(v))
    print(f'{k:40s} fx {v[:,0].mean():+.3f} +- {se[0]:.3f}  z {v[:,1].mean():+.2f} +- {se[1]:.2f} mm  rows {v[:,2].mean():.0f}')
