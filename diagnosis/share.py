import sys, pickle, os
sys.path.insert(0, '/tmp/x')
import numpy as np
import classic.markerless.shared_intrinsics as si
A = pickle.load(open('/tmp/diag/L1.pkl', 'rb')); B = pickle.load(open('/tmp/diag/L2.pkl', 'rb'))
Kt = A['Ktrue']; Kg = B['K']
t4 = np.array([Kt[0, 0], Kt[1, 1], Kt[0, 2], Kt[1, 2]]); g4 = np.array([Kg[0, 0], Kg[1, 1], Kg[0, 2], Kg[1, 2]])
sp = np.array([0.007 * g4[0], 0.007 * g4[1], 3.0, 3.0])
rows = []
for c in A['first']:
    a = si.estimate_and_sigma(A['first'][c].intrinsics); b = si.estimate_and_sigma(B['first'][c].intrinsics)
    if not a or not b: continue
    shift = b[0] - a[0]; off = g4 - t4
    pred = b[1] ** 2 / sp ** 2
    act = np.where(np.abs(off) > 0, shift / np.where(off == 0, 1, off), np.nan)
    rows.append((act[0], pred[0], act[2], pred[2], b[1][0], a[1][0]))
    print(c, 'fx actual share %.3f predicted %.3f | cx actual %.3f predicted %.3f | sigma fx %.3f (exact given %.3f)' % rows[-1])
r = np.array(rows); print('mean fx actual %.3f predicted %.3f ; cx actual %.3f predicted %.3f' % tuple(np.nanmean(r[:, :4], 0)))
