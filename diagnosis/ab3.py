import sys; sys.path.insert(0,'.')
import numpy as np, pickle, os
from dataclasses import replace
from benchmarks.markerless_errors import cases
from benchmarks.markerless_sensors import front_options, observe, placements, told_posed, told_intrinsics
from classic.markerless import register_robot
from classic.markerless.shared_intrinsics import second_passes, leave_one_out_priors
from classic.markerless.intrinsics import intrinsics_vector
from handeye.core.dataset import Dataset
from handeye.core.metrics import pose_error
from handeye.markerless import robot_surface_for
ci = int(sys.argv[1]); data = sys.argv[2]; ntest = int(sys.argv[3]); tag = sys.argv[4]
ds = Dataset.open(data)
surface, stride = robot_surface_for(ds)
case = cases()[ci - 1]
K = told_intrinsics(ds.meta['intrinsics']['K'], case.get('intrinsics'))
K_true = np.array(ds.meta['intrinsics']['K'], float)
opts = front_options(case['sensor'], stride, pixel_effect_px=2, intrinsics_noise_debiased=True, **case.get('options', {}))
T_true = ds.truth()
test = placements(ds, 'test')[:ntest]
allc = placements(ds, 'all') if 'with-train' in data else test
cache = f'/tmp/ab_{tag}_{ci}_v3.pkl'
frames, first, truthK = {}, {}, {}
for c in allc:
    depth, q, unit = observe(ds, c, case['sensor'], 0, case.get('registration'))
    posed, Tc = told_posed(surface, q, T_true[c], case.get('joints'))
    truthK[c] = intrinsics_vector(K_true) + np.r_[0, 0, unit.registration_px]
    if c in test: frames[c] = (depth, posed, Tc)
if os.path.exists(cache):
    first = pickle.load(open(cache, 'rb'))
else:
    for c in allc:
        depth, q, unit = observe(ds, c, case['sensor'], 0, case.get('registration'))
        posed, Tc = told_posed(surface, q, T_true[c], case.get('joints'))
        first[c] = register_robot(depth, K, posed, options=opts)
        print('first', c, flush=True, file=sys.stderr)
    pickle.dump({c: replace(r, depth_analysis=None) for c, r in first.items()}, open(cache, 'wb'))
def register(c, K_prior, starts, o):
    depth, posed, _ = frames[c]
    return register_robot(depth, K_prior, posed, starts=starts, options=o)
plain = {c: replace(r, intrinsics={k: v for k, v in r.intrinsics.items() if k != 'noise_debiased'}) for c, r in first.items()}
for name, fr in (('fit', plain), ('debiased', first)):
    out = second_passes(fr, K, opts, register, only=test)
    errs = []
    for c in test:
        prior, res = out[c]
        T = res.T_base_cam
        off = (np.linalg.inv(frames[c][2]) @ T)[:3, 3] * 1e3
        mm = pose_error(T, frames[c][2])[1]
        errs.append(mm)
        print(f'{name} cam {c}: prior fx err {prior.K[0,0]-truthK[c][0]:+.3f} fy {prior.K[1,1]-truthK[c][1]:+.3f} cx {prior.K[0,2]-truthK[c][2]:+.3f} cy {prior.K[1,2]-truthK[c][3]:+.3f}  second fx err {res.intrinsics["fx"]["estimate"]-truthK[c][0]:+.3f} | err {mm:.2f} mm, cam off {np.round(off,2)} sigma {res.sigma["translation_mm"]:.2f}', flush=True)
    print(f'{name}: median {np.median(errs):.2f} worst {np.max(errs):.2f}', flush=True)

