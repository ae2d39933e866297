"""Cell flow on the ITASC micropattern islands: statistics, angular velocity about the island, PIV vs tracks.

For each island (pos00-pos02 of the ITASC sample: tracked cell labels, and for pos00 the raw cell channel,
z maximum projection, given as --intensity): ``analyze``, ``flow_summary``, the angular velocity
``sum r x v / sum r^2`` about the centre of the interior cells (per frame and over the movie), the tangential
velocity's share of the mean speed, and where there is a raw channel, the PIV at the valid nodes against the
track field.  Units px and frames (the sample has no calibration).  docs/flow.md.

    NUMBA_NUM_THREADS=1 python scripts/flow_itasc.py PATH/TO/itasc_micropattern
"""
import sys
import warnings

import numpy as np
import tifffile

from hexatissue import IntensityOptions, analyze
from hexatissue.flow import flow_summary


def angular_velocity(rows, centre):
    r, v = rows[["x", "y"]].to_numpy() - centre, rows[["vx", "vy"]].to_numpy()
    return float(np.sum(r[:, 0] * v[:, 1] - r[:, 1] * v[:, 0]) / np.sum(r**2))


def main(root):
    warnings.simplefilter("ignore")
    for pos in ("pos00", "pos01", "pos02"):
        labels = tifffile.imread(f"{root}/{pos}/cell_labels.tif")
        kw = {}
        try:
            kw["intensity"] = IntensityOptions(image=tifffile.imread(f"{root}/{pos}/cell_raw.tif").max(axis=1)
                                               .astype(float))
        except FileNotFoundError:
            pass
        movie = analyze(labels, workers=1, progress=False, **kw)
        cells = movie.cells[~movie.cells["is_border"] & np.isfinite(movie.cells["vx"])]
        centre = cells[["x", "y"]].to_numpy().mean(axis=0)
        per_frame = [angular_velocity(g, centre) for _, g in cells.groupby("frame")]
        r, v = cells[["x", "y"]].to_numpy() - centre, cells[["vx", "vy"]].to_numpy()
        speed = np.hypot(*v.T).mean()
        tangential = np.mean((r[:, 0] * v[:, 1] - r[:, 1] * v[:, 0]) / np.hypot(*r.T))
        print(f"{pos}: {len(cells)} cell-frames, mean speed {speed:.3f} px/frame, angular velocity "
              f"{angular_velocity(cells, centre):.4f} rad/frame (per frame {np.round(per_frame, 4).tolist()}), "
              f"tangential / speed {tangential / speed:.2f}")
        print("  ", {k: round(x, 4) if isinstance(x, float) else x for k, x in flow_summary(movie.cells).items()})
        if "piv_vx" in movie.flow:
            f = movie.flow[movie.flow["valid"]].dropna(subset=["piv_vx", "vx"])
            d = np.hypot(f["piv_vx"] - f["vx"], f["piv_vy"] - f["vy"])
            corr = np.corrcoef(np.r_[f["piv_vx"], f["piv_vy"]], np.r_[f["vx"], f["vy"]])[0, 1]
            print(f"   PIV at {len(f)} nodes: median |PIV - track| {np.median(d):.3f}, median |track| "
                  f"{np.median(np.hypot(f['vx'], f['vy'])):.3f} px/frame, correlation {corr:.3f}")


if __name__ == "__main__":
    main(sys.argv[1])
