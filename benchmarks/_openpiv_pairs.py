"""Run OpenPIV's ``pyprocess.extended_search_area_piv`` on image pairs (called by bench_piv.py in OpenPIV's venv).

    /work/venv-openpiv/bin/python benchmarks/_openpiv_pairs.py PAIRS.npz OUT.npz WINDOW OVERLAP REPEATS
"""
import sys
import time

import numpy as np
from openpiv import pyprocess

pairs, out, window, overlap, repeats = sys.argv[1], sys.argv[2], int(sys.argv[3]), int(sys.argv[4]), int(sys.argv[5])
data = np.load(pairs)
result = {}
for name in sorted({k.rsplit("_", 1)[0] for k in data.files}):
    a, b = data[name + "_a"].astype(np.int32), data[name + "_b"].astype(np.int32)
    best = np.inf
    for _ in range(repeats):
        t0 = time.process_time()
        u, v, s2n = pyprocess.extended_search_area_piv(a, b, window_size=window, overlap=overlap,
                                                       search_area_size=window, correlation_method="circular",
                                                       subpixel_method="gaussian", sig2noise_method="peak2peak")
        best = min(best, time.process_time() - t0)
    x, y = pyprocess.get_coordinates(a.shape, window, overlap)
    result.update({name + "_x": x, name + "_y": y, name + "_u": u, name + "_v": v, name + "_cpu": best})
np.savez(out, **result)
