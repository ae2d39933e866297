"""
Hexatic order γ6 and its defects
================================

The shape function γ6 of every cell (a complex number: ``|γ6|`` is 1 for a regular hexagon, its argument
divided by 6 the cell's six-fold orientation), its coarse-grained field Γ6 on a grid, and the ±1/6
topological defects of that field, on the first frame of the bundled EpiCure movie.
The definitions, conventions and checks are on the page :doc:`order <../order>`.
"""
import matplotlib.pyplot as plt
import numpy as np

import hexatissue as ht
from hexatissue.plot import plot_order_field, plot_stars
from hexatissue.samples import sample_path

source = ht.open_source(sample_path("epicure_notum"))
# only the frame stages matter here: no tracking, flow or T1 events on a single frame
movie = ht.analyze(source.frame(0), order=ht.OrderOptions(p=(6, 2)))
cells = movie.cells
interior = cells[~cells["is_border"] & np.isfinite(cells["gamma6_re"])]
gamma6 = interior["gamma6_re"] + 1j * interior["gamma6_im"]
print(f"{len(interior)} interior cells: mean |gamma6| = {np.abs(gamma6).mean():.3f}, "
      f"|mean gamma6| = {abs(gamma6.mean()):.3f}")

# %%
# Six-legged stars at the cell centres: orientation Arg(γ6)/6, length proportional to ``|γ6|``.
fig, ax = plt.subplots(figsize=(7, 4.6))
plot_stars(cells, p=6, polygons=movie.polygons(0), ax=ax, calibration=movie.calibration)
plt.show()

# %%
# sphinx_gallery_thumbnail_number = 2
# The coarse-grained field Γ6 (stars on the valid grid nodes, shaded by ``|Γ6|``) and its defects:
# +1/6 red discs, -1/6 blue triangles. Nodes whose disk is not wholly on interior cells are not valid
# and carry no star; defects are found only between valid nodes.
grid = movie.table_at("grid", 0)
defects = movie.table_at("defects", 0)
print(defects[["x", "y", "charge", "p"]])
fig, ax = plt.subplots(figsize=(7.4, 4.6))
plot_order_field(grid, defects[defects["p"] == 6], p=6, polygons=movie.polygons(0), ax=ax,
                 calibration=movie.calibration)
plt.show()

# %%
# The same for p = 2 (nematic cell elongation): bars instead of stars, ±1/2 defects.
fig, ax = plt.subplots(figsize=(7.4, 4.6))
plot_order_field(grid, defects[defects["p"] == 2], p=2, polygons=movie.polygons(0), ax=ax,
                 calibration=movie.calibration)
plt.show()
