#!/usr/bin/env bash
# Paper system, float32, 2 threads: passive vs active OpenMP waiting (separate processes).
cd "$(dirname "$0")/.."
for policy in PASSIVE ACTIVE; do
  OMP_WAIT_POLICY=$policy python - <<'PY'
import os, time, numpy as np, sys
sys.path.insert(0, ".")
from hexatissue.simulate import Params, initial_state, set_threads
for th in (1, 2):
    set_threads(th)
    sim = initial_state(Params(), seed=0); sim.advance(30, active=False)
    r = []
    for _ in range(5):
        t = time.perf_counter(); sim.advance(100); r.append(100 / (time.perf_counter() - t))
    print(f"OMP_WAIT_POLICY={os.environ['OMP_WAIT_POLICY']} threads={th}: median {np.median(r):.0f} steps/s  {np.round(r).astype(int).tolist()}")
PY
done
uptime
