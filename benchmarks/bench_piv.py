"""PIV: hexatissue.flow.piv against OpenPIV on the same image pairs (CPU time and agreement).

Image pairs: a 512 x 512 image of 6,000 Gaussian spots (sigma 1.6 px) moved by a translation (2.3, -1.4) px,
a rotation by 0.01 rad about the centre (up to 3.6 px at the corners) and a simple shear dx = 0.01 (y - 256);
and, when the shared real data are present, consecutive frames of the ITASC pos00 raw channel (z max projection).
Windows 32 px, one every 16 px (OpenPIV: window 32, overlap 16, search area 32, circular correlation, Gaussian
peak, ``pyprocess.extended_search_area_piv``, run in its own venv); hexatissue at the same centres, one pass (the
same algorithm) and with its window-offset passes (the default).  CPU seconds of each (best of --repeats, process
time), rms error against the exact displacement (synthetic), rms difference between the two (all).

    NUMBA_NUM_THREADS=1 python benchmarks/bench_piv.py [--python /work/venv-openpiv/bin/python]
"""
import argparse
import subprocess
import sys
import tempfile
import time
from pathlib import Path

import numpy as np

from _timing import REAL_DATA  # benchmarks/_timing.py
from hexatissue.flow.piv import piv_displacements

N, SPOTS, SIGMA, WINDOW, OVERLAP = 512, 6000, 1.6, 32, 16
ITASC = REAL_DATA / "itasc_micropattern" / "pos00"


def render(centres):
    def profile(c):
        d = (np.arange(N)[None, :] - c[:, None] + N / 2) % N - N / 2
        return np.exp(-d**2 / (2 * SIGMA**2))
    return np.round(1000 * (profile(centres[:, 1]).T @ profile(centres[:, 0]))).astype(np.uint16)


def pairs():
    rng = np.random.default_rng(0)
    c = rng.uniform(0, N, (SPOTS, 2))
    mid = N / 2
    a, rot = 0.01, np.array([[np.cos(0.01), -np.sin(0.01)], [np.sin(0.01), np.cos(0.01)]])
    moves = {
        "translation": lambda p: p + [2.3, -1.4],
        "rotation": lambda p: mid + (p - mid) @ rot.T,
        "shear": lambda p: p + np.c_[a * (p[:, 1] - mid), np.zeros(len(p))],
    }
    out = {name: (render(c), render(move(c)), move) for name, move in moves.items()}
    raw = ITASC / "cell_raw.tif"
    if raw.exists():
        import tifffile
        stack = tifffile.imread(raw).max(axis=1)
        out["itasc_pos00_t0-1"] = (stack[0], stack[1], None)
        out["itasc_pos00_t4-5"] = (stack[4], stack[5], None)
    return out


def ours(a, b, x, y, passes, repeats):
    best = np.inf
    for _ in range(repeats):
        t0 = time.process_time()
        dx, dy, _ = piv_displacements(a, b, x, y, WINDOW, passes=passes)
        best = min(best, time.process_time() - t0)
    return dx, dy, best


def rms(d):
    d = d[np.isfinite(d).all(axis=1)]
    return float(np.sqrt(np.mean(np.sum(d**2, axis=1))))


def main():
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--python", default="/work/venv-openpiv/bin/python")
    ap.add_argument("--repeats", type=int, default=3)
    args = ap.parse_args()
    data = pairs()
    with tempfile.TemporaryDirectory() as tmp:
        npz, out = Path(tmp) / "pairs.npz", Path(tmp) / "out.npz"
        np.savez(npz, **{f"{k}_{s}": v[i] for k, v in data.items() for i, s in enumerate("ab")})
        subprocess.run([args.python, str(Path(__file__).with_name("_openpiv_pairs.py")), str(npz), str(out),
                        str(WINDOW), str(OVERLAP), str(args.repeats)], check=True)
        op = dict(np.load(out))
    print("| pair | windows | OpenPIV CPU s | ours 1 pass CPU s | ours default CPU s | OpenPIV rms error px | "
          "ours 1 pass | ours default | rms ours - OpenPIV px |")
    print("|---|---|---|---|---|---|---|---|---|")
    for name, (a, b, move) in data.items():
        x, y = op[name + "_x"].ravel(), op[name + "_y"].ravel()
        # pyprocess (before OpenPIV's transform_coordinates) gives v along the rows, as ours
        theirs = np.c_[op[name + "_u"].ravel(), op[name + "_v"].ravel()]
        one = ours(a, b, x, y, 1, args.repeats)
        full = ours(a, b, x, y, 10, args.repeats)
        row = [name, str(len(x)), f"{float(op[name + '_cpu']):.3f}", f"{one[2]:.3f}", f"{full[2]:.3f}"]
        if move is not None:
            p = np.c_[x, y]
            truth = move(p) - p
            row += [f"{rms(theirs - truth):.3f}", f"{rms(np.c_[one[0], one[1]] - truth):.3f}",
                    f"{rms(np.c_[full[0], full[1]] - truth):.3f}"]
        else:
            row += ["-", "-", "-"]
        row.append(f"{rms(np.c_[full[0], full[1]] - theirs):.3f}")
        print("| " + " | ".join(row) + " |")
        sys.stdout.flush()


if __name__ == "__main__":
    main()
