"""
Tissue flow
===========

Cell velocities (centred differences along the tracks), the velocity and vorticity fields on the Γ6
grid, and the flow's statistics, for the bundled multiphase-field run (``mpf_small``: 60 self-propelled
cells in a periodic box, one frame every 200 iterations; see :doc:`flow <../flow>`).
"""
import matplotlib.pyplot as plt
import numpy as np

import hexatissue as ht
from hexatissue.flow import correlation_length, velocity_correlation, velocity_statistics
from hexatissue.plot import plot_flow
from hexatissue.samples import sample_path

source = ht.open_source(sample_path("mpf_small"))
movie = ht.analyze(source)
cells = movie.cells
print(cells[["frame", "cell", "track", "x", "y", "vx", "vy"]].iloc[100:105].to_string())

# %%
# The flow of one frame: velocity arrows on the valid grid nodes over the vorticity, in the run's units
# (px per iteration: the run is calibrated in simulation iterations).
t = 150
fig, ax = plt.subplots(figsize=(6.6, 6))
plot_flow(movie.table_at("flow", t), polygons=movie.polygons(t), box=movie.box,
          calibration=movie.calibration, ax=ax)
plt.show()

# %%
# Mean speed and polar order (``|mean of v/|v||``: 0 for random directions, 1 when every cell moves the
# same way) per frame.
stats = velocity_statistics(cells)
fig, (a, b) = plt.subplots(1, 2, figsize=(9, 3.2), layout="constrained")
a.plot(stats["frame"], stats["mean_speed"], lw=0.8)
a.set_xlabel("frame")
a.set_ylabel("mean speed (px/frame)")
b.plot(stats["frame"], stats["polar_order"], lw=0.8)
b.set_xlabel("frame")
b.set_ylabel("polar order")
plt.show()

# %%
# Spatial correlation of the velocity fluctuations, with standard errors from resampling the frames, and
# its decay length from an exponential fit (NaN, with the reason, when the data do not support one).
correlation = velocity_correlation(cells, box=movie.box)
spacing = float(np.sqrt(np.median(cells["area"])))
xi = correlation_length(correlation, spacing=spacing)
if xi.reason:
    print(f"no correlation length: {xi.reason}")
else:
    print(f"correlation length: {xi.length:.1f} +- {xi.sd:.1f} px ({xi.length / spacing:.2f} cell spacings)")
fig, ax = plt.subplots(figsize=(5, 3.4))
ax.errorbar(correlation["r"], correlation["correlation"], yerr=correlation["correlation_sd"], fmt="o-",
            ms=3, lw=0.8)
ax.axhline(0, color="0.6", lw=0.6)
ax.set_xlabel("distance r (px)")
ax.set_ylabel("C(r)")
plt.show()
