import sys; sys.path.insert(0,'.')
from dataclasses import replace
import numpy as np
from benchmarks.markerless_errors import cases, parse_option
from benchmarks.markerless_sensors import front_options, observe, placements, told_posed
from classic.markerless import register_robot
from handeye.core.dataset import Dataset
from handeye.markerless import robot_surface_for
from handeye.robot.depth_sensors import PROFILES
sensor_name = sys.argv[1]; extra = dict(parse_option(a) for a in sys.argv[2:])
ds = Dataset.open(__import__('os').environ.get('DS','data/sensor-bands/paper-real-1.2-with-train'))
surface, stride = robot_surface_for(ds)
K = np.array(ds.meta['intrinsics']['K'], float)
sensor = replace(PROFILES['ideal'], noise_quadratic_per_m=0.00358) if sensor_name == 'white' else cases()[0]['sensor']
opts = front_options(sensor, stride, **{'pixel_effect_px': 2, 'intrinsics_model': 'fixed', **extra})
offs = []
for c in placements(ds, 'all')[::2]:
    depth, q, unit = observe(ds, c, sensor, 0, None)
    posed, Tc = told_posed(surface, q, ds.truth()[c], None)
    r = register_robot(depth, K, posed, options=opts)
    offs.append((np.linalg.inv(Tc) @ r.T_base_cam)[:3, 3] * 1e3)
o = np.array(offs)
print(sensor_name, extra, 'camera offset (its frame) mean', np.round(o.mean(0), 2), '+-', np.round(o.std(0, ddof=1) / np.sqrt(len(o)), 2), 'median |err|', np.round(np.median(np.linalg.norm(o, axis=1)), 2))
