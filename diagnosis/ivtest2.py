import sys; sys.path.insert(0,'.')
import numpy as np
from tests.classic.test_markerless_noise_in_the_fit import _planes, _cylinders, K, STEREO_SIGMA_1M, T_BASE_CAM
from classic.markerless.point_to_plane import MatchedModel, PlaneFitOptions, solve_point_to_plane
from handeye.core.se3 import make_transform
D = int(sys.argv[2]) if len(sys.argv) > 2 else 40
import os
LOSS=os.environ.get('LOSS','linear'); SC=float(os.environ.get('SC','0.05')); GATE=float(os.environ.get('GATE','1'))
for name, scene in (('cylinders', _cylinders),):
  for noise_out in (False, True):
    ray, z, (m, n, curv, direc) = scene()
    if os.environ.get('ARC'):
        R0 = 0.04
        h = z / 220.0 / 2 * float(os.environ['ARC'])
        phi = (np.random.default_rng(6).uniform(-1, 1, len(z)) * h / R0)[:, None]
        cen = m - R0 * n
        n2 = np.cos(phi) * n + np.sin(phi) * direc
        d2 = -np.sin(phi) * n + np.cos(phi) * direc
        m, n, direc = cen + R0 * n2, n2, d2
    if os.environ.get('SFAC'):
        curv = curv * float(os.environ['SFAC'])
    if os.environ.get('SLIDE'):
        e2 = np.cross(n, direc)
        h = z / 220.0 / 2 * float(os.environ['SLIDE'])
        m = m + (np.random.default_rng(5).uniform(-1, 1, len(z)) * h)[:, None] * e2
    var = (STEREO_SIGMA_1M * z**2) ** 2
    model = MatchedModel(m, n, curv, direc, depth_variance=var if noise_out else None)
    kw = dict(depth_start=(1.0, 0.0), depth_prior_sigma=(0.01, 0.005)) if sys.argv[1] == 'depth' else {}
    opts = PlaneFitOptions(scale_m=SC, loss=LOSS, iterations=8, covariance=False, intrinsics_K_ref=K, **kw)
    errs, zs, dc = [], [], []
    for d in range(D):
        zo = z + np.sqrt(var) * np.random.default_rng([d, 7]).normal(size=z.shape)
        if os.environ.get('GATEP'):
            Tb = T_BASE_CAM
            xb = (ray * zo[:, None]) @ Tb[:3, :3].T + Tb[:3, 3]
            rb = ray @ Tb[:3, :3].T
            pl = np.einsum('ij,ij->i', n, xb - m)
            nr = np.einsum('ij,ij->i', n, rb)
            keep = np.abs(pl / nr) < GATE
        elif os.environ.get('GATEM'):
            Ti = np.linalg.inv(T_BASE_CAM)
            mz = (m @ Ti[:3, :3].T + Ti[:3, 3])[:, 2]
            keep = np.abs(zo - mz) < GATE
        else:
            keep = np.abs(zo - z) < GATE
        v = var.copy()
        if os.environ.get('TRUNC') and GATE < 1:
            from scipy.stats import norm
            a = GATE / np.sqrt(var)
            v = var * (1 - 2 * a * norm.pdf(a) / (2 * norm.cdf(a) - 1))
        mk = MatchedModel(m[keep], n[keep], curv[keep], direc[keep], depth_variance=v[keep] if noise_out else None)
        fit = solve_point_to_plane((ray * zo[:, None])[keep], mk, T_BASE_CAM, opts)
        errs.append(fit.intrinsics - K[[0, 1, 0, 1], [0, 1, 2, 2]])
        zs.append((np.linalg.inv(T_BASE_CAM) @ fit.T_base_cam)[2, 3] * 1e3)
        if fit.depth_correction is not None: dc.append(fit.depth_correction[:2])
    e = np.array(errs); se = e.std(0, ddof=1) / np.sqrt(D)
    print(name, 'noise_out' if noise_out else 'plain', 'fx', f'{e[:,0].mean():+.3f}+-{se[0]:.3f}', 'fy', f'{e[:,1].mean():+.3f}+-{se[1]:.3f}', 'cam z', f'{np.mean(zs):+.3f}+-{np.std(zs)/np.sqrt(D):.3f} mm', 'unit', np.round(np.mean(dc, 0), 5) if dc else '')
