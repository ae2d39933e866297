"""
T1 events and the deformation budget
====================================

The multiphase-field run bundled with the package (``mpf_small``: 60 active cells in a periodic box,
301 frames) analysed with the deformation budget switched on: its T1 events, told apart as T1 cycles
(undone later) and intercalations (permanent), and the tissue's cumulative shear split into cell shape
change and the contributions of T1s (the triangle method; see :doc:`t1 <../t1>` and
:doc:`deformation <../deformation>`).
"""
import matplotlib.pyplot as plt
import numpy as np

import hexatissue as ht
from hexatissue.plot import plot_deformation_budget, plot_labels
from hexatissue.samples import sample_path

source = ht.open_source(sample_path("mpf_small"))
print(source)
movie = ht.analyze(source, deformation=ht.DeformationOptions(enabled=True))
events = movie.events
print(events["kind"].value_counts())

# %%
# Where and when the T1s happened: every event's quartet centre, coloured by its first frame, over the
# cells of the last frame. The box is periodic, so events near one edge continue at the other.
t = len(movie) - 1
fig, ax = plt.subplots(figsize=(6, 6))
plot_labels(polygons=movie.polygons(t), box=movie.box, ax=ax, calibration=movie.calibration)
points = ax.scatter(events["x"], events["y"], c=events["frame_start"], s=12, cmap="viridis",
                    marker=None)
fig.colorbar(points, ax=ax, shrink=0.7, label="frame of the T1")
ax.set_title(f"{len(events)} T1 events over the cells of frame {t}")
plt.show()

# %%
# The events table: one row per T1, with the four cells (``cell_a``/``cell_b`` lose their contact,
# ``cell_c``/``cell_d`` gain one), its kind and, with the deformation stage, its share of the tissue's
# T1 shear.
print(events[["event", "kind", "frame_start", "cell_a", "cell_b", "cell_c", "cell_d",
              "shear_xx", "shear_xy"]].head(8).to_string())
per_window = np.bincount(events["frame_start"] // 50, minlength=len(movie) // 50 + 1)
print("T1s per 50 frames:", per_window)

# %%
# The deformation budget of the whole tissue: cumulative shear (xx, xy) and growth, each contribution a
# line; the sum of the parts (dashed) lies on the total (black). Where the tissue opens a hole (the
# warning printed above names the frames), the cells around it are border cells, and their comings and
# goings show as the term "cells entering / leaving".
fig = plot_deformation_budget(movie.deformation, calibration=movie.calibration)
plt.figure(fig)  # the package draws on its own Figure; this hands it to pyplot, which shows it here
plt.show()
