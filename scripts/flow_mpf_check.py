"""Track-based cell velocities against the MPF simulator's own centroid velocities, by save interval.

A 16-cell run at the paper's density and speed is saved every 10 steps; its label images, subsampled every
k frames, go through ``hexatissue.analyze`` (overlap tracking, centred differences); each cell's velocity is
compared with the simulator's centroid velocity (centred difference over 20 steps of its phi^2-weighted
centroid).  Prints, per interval, the rms speed and the rms difference (px per 10 steps).  docs/flow.md.

    NUMBA_NUM_THREADS=1 python scripts/flow_mpf_check.py [--out /tmp/fine.zarr]
"""
import argparse

import numpy as np

import hexatissue
from hexatissue.simulate import Params, read_run, run_simulation

SAVE = 10


def main():
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--out", default="/tmp/flow_mpf_check.zarr")
    ap.add_argument("--steps", type=int, default=6000)
    args = ap.parse_args()
    run_simulation(args.out, Params(n_cells=16, Lx=72, Ly=78), steps=args.steps, save_every=SAVE, relax=1000, seed=3,
                   threads=1, progress=False, overwrite=True)
    run = read_run(args.out)
    n, t_all = run.params.n_cells, run.n_frames
    sim = run.cells.sort_values(["cell", "frame"])
    xy = sim[["x_unwrapped", "y_unwrapped"]].to_numpy().reshape(n, t_all, 2)
    truth = np.full((n, t_all, 2), np.nan)
    truth[:, 1:-1] = (xy[:, 2:] - xy[:, :-2]) / 2
    labels = np.asarray(run.labels[:])
    print("| steps between frames | rms speed (px/10 steps) | rms difference | relative |")
    print("|---|---|---|---|")
    for k in (1, 2, 5, 10, 20, 40):
        frames = np.arange(0, t_all, k)
        cells = hexatissue.analyze(list(labels[frames]), box=run.box, workers=1, progress=False).cells
        first = cells[cells["frame"] == 0].set_index("track")["cell"]
        idx = first.reindex(cells["track"]).to_numpy().astype(int) - 1
        ref = truth[idx, frames[cells["frame"].to_numpy()]]
        ours = cells[["vx", "vy"]].to_numpy() / k
        ok = np.isfinite(ours[:, 0]) & np.isfinite(ref[:, 0])
        e = np.sqrt(np.mean(np.sum((ours[ok] - ref[ok]) ** 2, 1)))
        s = np.sqrt(np.mean(np.sum(ref[ok] ** 2, 1)))
        print(f"| {SAVE * k} | {s:.4f} | {e:.4f} | {e / s:.2f} |")


if __name__ == "__main__":
    main()
