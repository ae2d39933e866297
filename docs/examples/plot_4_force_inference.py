"""
Force inference: junction tensions and cell pressures
=====================================================

Infer every junction's tension and every cell's pressure of the first frame of the bundled EpiCure movie
from the force balance at its vertices (Bayesian, with the prior weight chosen by ABIC; see
:doc:`mechanics <../mechanics>`). Tensions are relative (the frame's mean interior tension is 1) and
each comes with its posterior standard deviation.
"""
import matplotlib.pyplot as plt
import numpy as np

import hexatissue as ht
from hexatissue.plot import plot_tension_histogram, plot_tensions
from hexatissue.samples import sample_path

source = ht.open_source(sample_path("epicure_notum"))
movie = ht.analyze(source.frame(0), mechanics=ht.MechanicsOptions(enabled=True))
print(movie.force_fit.T.to_string(header=False))

# %%
# ``force_fit`` says how the frame was fitted. On an open image the vertices on the tissue's edge have no
# equation, so there are fewer equations than unknowns and the balance leaves extended modes free:
# ``n_free`` counts the unknowns with a component in them. The Bayesian prior (tensions near their mean)
# settles those modes, and the posterior s.d. says how sure each tension is.

# %%
# Tensions with their posterior s.d.: junctions next to the image edge have one free end and carry no
# tension (NaN).
edges = movie.edges
known = edges[np.isfinite(edges["tension"])]
print(f"{len(known)} of {len(edges)} junctions have a tension; "
      f"median relative s.d. {np.median(known['tension_sd'] / known['tension']):.3f}")
print(known[["edge", "cell_a", "cell_b", "length", "tension", "tension_sd"]].head().to_string())

# %%
# The network coloured by tension.
fig, ax = plt.subplots(figsize=(7.4, 4.8))
plot_tensions(edges, movie.vertices, calibration=movie.calibration, ax=ax)
plt.show()

# %%
# Their distribution, and the cells' pressures (relative to the mean tension per pixel).
fig, ax = plt.subplots(figsize=(5, 3.4))
plot_tension_histogram(edges, ax=ax)
plt.show()
pressure = movie.cells["pressure"]
print(f"pressure of {np.isfinite(pressure).sum()} cells: mean {np.nanmean(pressure):.4f}, "
      f"s.d. {np.nanstd(pressure):.4f} (tension/px)")
