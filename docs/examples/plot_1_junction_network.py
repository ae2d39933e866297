"""
Junction network of the bundled movie
=====================================

Analyse the EpiCure sample bundled with the package (a tracked label movie of a *Drosophila* notum,
11 frames of 160 x 257 px; the TIFF gives the pixel size, 0.2 µm) and draw the junction network of its first frame:
the cells' polygons over the label image, and the vertices, three-fold and four-fold.
"""
import matplotlib.pyplot as plt

import hexatissue as ht
from hexatissue.plot import plot_labels
from hexatissue.samples import sample_path

source = ht.open_source(sample_path("epicure_notum"))
print(source.calibration)
movie = ht.analyze(source)
print(movie)

# %%
# Each table is a pandas DataFrame with ids in columns; ``x`` is the column and ``y`` the row, in pixels.
frame = movie.frame(0)
print(frame.cells[["cell", "x", "y", "polygon_area", "n_sides", "is_border"]].head())
print(frame.vertices["degree"].value_counts().sort_index())

# %%
# The polygons over the labels (grey crosses: border cells, which touch the image edge or the background),
# and the vertices coloured by their degree: the four-fold vertices are contacts shorter than
# ``MeshOptions.merge_distance`` (2 px), where a T1 may be under way.
fig, ax = plt.subplots(figsize=(8, 4.6), layout="constrained")
plot_labels(source.frame(0), frame.polygons(), cells=frame.cells, ax=ax, calibration=movie.calibration)
for degree, colour in ((3, "k"), (4, "tab:red")):
    v = frame.vertices[frame.vertices["degree"] == degree]
    ax.plot(v["x"], v["y"], "o", ms=3 if degree == 3 else 5, color=colour, label=f"{degree}-fold ({len(v)})")
ax.legend(loc="upper left", bbox_to_anchor=(1.01, 1.0), fontsize=8, title="vertices")
ax.set_title("frame 0: cells, polygons and vertices")
plt.show()

# %%
# Interior cells' numbers of sides (border cells excluded), over every frame of the movie.
interior = movie.cells[~movie.cells["is_border"] & (movie.cells["n_sides"] >= 3)]
counts = interior["n_sides"].value_counts().sort_index()
print(f"mean number of sides of {len(interior)} interior cell-frames: {interior['n_sides'].mean():.3f}")
fig, ax = plt.subplots(figsize=(5, 3))
ax.bar(counts.index, counts.to_numpy() / counts.sum(), color="0.5")
ax.set_xlabel("number of sides")
ax.set_ylabel("fraction of interior cells")
plt.show()
