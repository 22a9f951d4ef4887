import sys, os; sys.path.insert(0, os.environ.get('ROOT', '/tmp/x'))
from dataclasses import replace
import numpy as np
from benchmarks.markerless_sensors import front_options, observe, placements, told_posed
from classic.markerless import register_robot
from handeye.core.dataset import Dataset
from handeye.markerless import robot_surface_for
from handeye.robot.depth_sensors import PROFILES
ds = Dataset.open(os.environ.get('DS'))
surface, stride = robot_surface_for(ds)
K = np.array(ds.meta['intrinsics']['K'], float)
s1 = replace(PROFILES['ideal'], noise_quadratic_per_m=0.00358)
if os.environ.get('SENSOR'):
    s1 = PROFILES[os.environ['SENSOR']]
    mod = os.environ.get('SENSOR_MOD', '')
    if mod:
        s1 = replace(s1, **{k: float(v) for k, v in (i.split('=') for i in mod.split(','))})
extra = dict(i.split('=') for i in os.environ.get('OPTS', '').split(',') if i)
extra = {k: None if v == 'none' else (v == 'true') if v in ('true', 'false') else (float(v) if v[0].isdigit() else v) for k, v in extra.items()}
opts = front_options(s1, stride, pixel_effect_px=2, **extra)
T_true = ds.truth(); rows = []
sel = placements(ds, 'all')[int(os.environ.get('START', '0'))::int(os.environ.get('STEP', '2'))]
for c in sel:
    d1, q, _ = observe(ds, c, s1, int(os.environ.get('SEED', '0')))
    posed, Tc = told_posed(surface, q, T_true[c], None)
    r = register_robot(d1, K, posed, options=opts)
    off = (np.linalg.inv(Tc) @ r.T_base_cam)[:3, 3] * 1e3
    i = r.intrinsics
    rows.append((i['fx']['estimate'] - K[0, 0], off[2]))
    print(c, np.round(rows[-1], 3), flush=True)
v = np.array(rows); se = v.std(0, ddof=1) / np.sqrt(len(v))
print(f'full registration fx {v[:,0].mean():+.3f} +- {se[0]:.3f}  z {v[:,1].mean():+.2f} +- {se[1]:.2f}')
