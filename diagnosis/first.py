# first passes of one case on paper-real with train pool, pickled
import sys, pickle, time
import os; sys.path.insert(0, os.environ.get('ROOT', '/work/main'))
import numpy as np
from benchmarks.markerless_errors import cases, diagnostic_cases
from benchmarks.markerless_sensors import front_options, observe, placements, told_intrinsics, told_posed
from classic.markerless import register_robot
from handeye.core.dataset import Dataset
from handeye.markerless import robot_surface_for
case_no, out = int(sys.argv[1]), sys.argv[2]
data = sys.argv[3] if len(sys.argv) > 3 else '/work/main/data/sensor-bands/paper-real-1.2-with-train'
ds = Dataset.open(data)
surface, stride = robot_surface_for(ds)
case = (cases() + diagnostic_cases())[case_no - 1]
from dataclasses import replace
mod = os.environ.get('SENSOR_MOD', '')
if mod:
    kv = {k: float(v) for k, v in (i.split('=') for i in mod.split(','))}
    case = {**case, 'sensor': replace(case['sensor'], **kv)}
    print('sensor', case['sensor'], flush=True)
cams = placements(ds, 'test', 5 if 'real' in data else 24)
pool = placements(ds, 'train') if 'train' in data else []
K = told_intrinsics(ds.meta['intrinsics']['K'], case.get('intrinsics'))
T_true = ds.truth()
extra = dict(i.split('=') for i in os.environ.get('OPTS', '').split(',') if i)
extra = {k: (v == 'true') if v in ('true', 'false') else v for k, v in extra.items()}
opts = front_options(case['sensor'], stride, pixel_effect_px=2, **extra)
store = {'cams': cams, 'K': K, 'Ktrue': np.array(ds.meta['intrinsics']['K']), 'first': {}, 'T': {}, 'case': case['name']}
for c in [*cams, *(p for p in pool if p not in cams)]:
    depth, q, _ = observe(ds, c, case['sensor'], int(os.environ.get('SEED', '1')), case.get('registration'))
    posed, T_c = told_posed(surface, q, T_true[c], case.get('joints'))
    t0 = time.process_time()
    r = register_robot(depth, K, posed, options=opts)
    store['first'][c] = r; store['T'][c] = T_c
    print(c, r.ok, round(time.process_time() - t0, 1), flush=True)
pickle.dump(store, open(out, 'wb'))
import classic.markerless.shared_intrinsics as si
Kt = store['Ktrue']; t4 = np.array([Kt[0, 0], Kt[1, 1], Kt[0, 2] + float(os.environ.get('CXEFF', '0')), Kt[1, 2]])
E = [si.estimate_and_sigma(r.intrinsics, False) if 'debiased' in si.estimate_and_sigma.__code__.co_varnames else si.estimate_and_sigma(r.intrinsics) for r in store['first'].values()]
E = [e for e in E if e]
th = np.array([e[0] for e in E]) - t4; sg = np.array([e[1] for e in E])
w = 1 / sg**2
print('n', len(E), 'mean', np.round(th.mean(0), 3), 'se', np.round(th.std(0, ddof=1) / np.sqrt(len(E)), 3), 'ivw', np.round((w * th).sum(0) / w.sum(0), 3), '+-', np.round(1 / np.sqrt(w.sum(0)), 3))

