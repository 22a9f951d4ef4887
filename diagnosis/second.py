# second passes of pickled first passes, pooling variants; per test placement: pooled prior - truth, camera error in camera frame
import sys, pickle, time, os
import os; sys.path.insert(0, os.environ.get('ROOT', '/work/main'))
from dataclasses import replace
import numpy as np
from benchmarks.markerless_errors import cases, diagnostic_cases
from benchmarks.markerless_sensors import front_options, observe, told_posed
from classic.markerless import register_robot
import classic.markerless.shared_intrinsics as si
from handeye.core.dataset import Dataset
from handeye.markerless import robot_surface_for
pk, variant = sys.argv[1], sys.argv[2]
cx_eff = float(sys.argv[3]) if len(sys.argv) > 3 else 0.0
data = sys.argv[4] if len(sys.argv) > 4 else '/work/main/data/sensor-bands/paper-real-1.2-with-train'
S = pickle.load(open(pk, 'rb'))
ds = Dataset.open(data)
surface, stride = robot_surface_for(ds)
case = [c for c in cases() + diagnostic_cases() if c['name'] == S['case']][0]
K, Kt = S['K'], S['Ktrue'].copy(); Kt[0, 2] += cx_eff
truth4 = np.array([Kt[0, 0], Kt[1, 1], Kt[0, 2], Kt[1, 2]])
opts = front_options(case['sensor'], stride, pixel_effect_px=2)
first = S['first']
def est(r):
    e = si.estimate_and_sigma(r.intrinsics)
    return e
allest = np.array([est(first[c])[0] - truth4 for c in first if est(first[c])])
print('first passes (all pool) theta - truth: mean', np.round(allest.mean(0), 3), 'sd', np.round(allest.std(0), 3))
if variant == 'once':
    orig = si._weighted_pool
    given = np.array([K[0, 0], K[1, 1], K[0, 2], K[1, 2]])
    gsig = np.array(opts.intrinsics_prior_sigma) * np.array([K[0, 0], K[1, 1], 1, 1])
    def wp(others):
        outs = []
        for t, sd in others:
            p = 1 / sd**2 - 1 / gsig**2
            seen = p > 1e-6 / gsig**2
            p = np.where(seen, p, 1e-12 / gsig**2)
            outs.append((np.where(seen, (t / sd**2 - given / gsig**2) / p, given), 1 / np.sqrt(p)))
        m, s, b = orig(outs)
        prec = 1 / s**2 + 1 / gsig**2
        return (m / s**2 + given / gsig**2) / prec, 1 / np.sqrt(prec), b
    si._weighted_pool = wp
errs = []
for c in S['cams']:
    depth, q, _ = observe(ds, c, case['sensor'], int(os.environ.get('SEED', '1')), case.get('registration'))
    posed, T_c = told_posed(surface, q, ds.truth()[c], case.get('joints'))
    def register(cc, K_prior, starts, so):
        if variant == 'oracle':
            K_prior = Kt; so = replace(so, intrinsics_prior_sigma=(1e-5, 1e-5, 0.01, 0.01))
        return register_robot(depth, K_prior, posed, starts=starts, options=so, depth_analysis=first[cc].depth_analysis)
    out = si.second_passes(first, K, opts, register, only=[c])
    prior, res = out[c]
    pk4 = np.array([prior.K[0, 0], prior.K[1, 1], prior.K[0, 2], prior.K[1, 2]]) - truth4
    e2 = est(res)[0] - truth4 if est(res) else np.full(4, np.nan)
    Ti = np.linalg.inv(T_c)
    d = (Ti @ res.T_base_cam)[:3, 3] * 1e3
    d1 = (Ti @ first[c].T_base_cam)[:3, 3] * 1e3
    errs.append(np.linalg.norm(d))
    print(c, 'prior-truth', np.round(pk4, 3), 'own1', np.round(est(first[c])[0] - truth4, 2), '2nd', np.round(e2, 3), 'cam err mm 2nd', np.round(d, 2), '1st', np.round(d1, 2), 'sig', round(res.sigma['translation_mm'], 2), flush=True)
print(variant, 'median', round(float(np.median(errs)), 2), 'worst', round(float(np.max(errs)), 2))
