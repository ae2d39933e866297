"""The bundled MPF run: stress inferred from its junction network beside the simulator's own cell stress.

The simulator's stress needs the phase fields, which the bundled store (``hexatissue/sample_data/mpf_small/run.zarr``) does
not keep; its command (hexatissue/sample_data/mpf_small/README.md: 60 cells, periodic 140 x 151 box, seed 1) is rerun with
``patches_every`` set, which reproduces it to 1.5e-3 px (README there), e.g.::

    hexatissue simulate --out /tmp/mpf.zarr --cells 60 --size 140 151 --steps 60000 --save-every 200 \
        --relax 5000 --dr 1e-5 --patch 61 --seed 1 --threads 1 --advection central --patches-every 100

For every frame with fields, hexatissue analyses its label image with force inference (periodic box,
curved and straight junctions); the simulator's longitudinal p-atic stress
``simulate.stress.cell_stress(phi, theta_c, k_phi, p)`` is computed from the same fields, with ``theta_c =
arg(gamma_p) / p`` of hexatissue's shape tensor.  Compared per cell: ``sigma_par`` (p = 2) against the inferred
Batchelor stress's deviatoric part along ``theta_c``, Re[((xx - yy) / 2 + i xy) e^{-2 i theta_c}], and
``sigma_par`` (p = 6) against the inferred hexatic moment along ``theta_c``, Re[(stress6_re + i stress6_im)
e^{-6 i theta_c}]: Pearson and Spearman correlations over the cells with both.  Usage::

    python benchmarks/compare_mpf_stress.py --run RUN.zarr
"""
from __future__ import annotations

import argparse
import sys
import warnings
from pathlib import Path

import numpy as np
import pandas as pd

sys.path.insert(0, str(Path(__file__).resolve().parents[1]))

import hexatissue as ht  # noqa: E402
from hexatissue.mechanics import cell_stress as cell_stress_of  # noqa: E402
from hexatissue.simulate.store import read_run  # noqa: E402
from hexatissue.simulate.stress import cell_stress  # noqa: E402


def compare(path):
    """Per frame with fields and per junction model and p: (cells, Pearson r, Spearman rho)."""
    from scipy.stats import spearmanr

    run = read_run(path)
    if run.patches is None:
        raise SystemExit(f"{path} keeps no phase fields: rerun it with patches_every (module docstring)")
    out = {}
    for k, frame in enumerate(run.patches.frame):
        labels = np.asarray(run.labels[int(frame)])
        phi_all = np.asarray(run.patches.phi[k], float)
        for curved in (True, False):
            with warnings.catch_warnings():
                warnings.simplefilter("ignore")
                movie = ht.analyze(labels, box=run.box,
                                   mechanics=ht.MechanicsOptions(enabled=True, sd=False, curved=curved))
            stress = cell_stress_of(movie.cells, pd.DataFrame(movie.tables["vertices"]),
                                    pd.DataFrame(movie.tables["edges"]), movie.tables["edges"]["tension"].to_numpy(),
                                    movie.cells["pressure"].to_numpy(), run.box)
            cells = pd.concat([movie.cells.reset_index(drop=True),
                               stress[["stress6_re", "stress6_im"]].reset_index(drop=True)], axis=1).set_index("cell")
            phi = phi_all[cells.index.to_numpy() - 1]  # label c is patch c - 1
            for p in (2, 6):
                theta = np.angle((cells[f"gamma{p}_re"] + 1j * cells[f"gamma{p}_im"]).to_numpy()) / p
                simulated = cell_stress(phi, theta, run.params.k_phi, p)
                if p == 2:
                    moment = (cells["stress_xx"] - cells["stress_yy"]) / 2 + 1j * cells["stress_xy"]
                else:
                    moment = cells["stress6_re"] + 1j * cells["stress6_im"]
                inferred = np.real(moment.to_numpy() * np.exp(-1j * p * theta))
                ok = np.isfinite(inferred) & np.isfinite(simulated)
                out[(int(frame), curved, p)] = (int(ok.sum()), float(np.corrcoef(inferred[ok], simulated[ok])[0, 1]),
                                                float(spearmanr(inferred[ok], simulated[ok]).statistic))
    return out


def main():
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--run", type=Path, required=True)
    args = parser.parse_args()
    for (frame, curved, p), (n, r, rho) in compare(args.run).items():
        print(f"frame {frame:>3}, {'curved' if curved else 'straight'} junctions, p = {p}: {n} cells, "
              f"Pearson r = {r:.3f}, Spearman rho = {rho:.3f}")


if __name__ == "__main__":
    main()
