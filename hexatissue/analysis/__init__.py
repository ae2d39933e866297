"""The paper's tissue-scale analyses (Armengol-Collado et al., Fig. 3e–g): functions from tables to tables.

- :func:`t1_defect_proximity`: T1 events vs random cells, distance to the nearest ±1/p defect (Fig. 3e).
- :func:`migration_table`, :func:`migration_populations`: displacement vs defect density in
  subregions and time windows, slow and fast populations (Fig. 3f).
- :func:`cell_timing`, :func:`timing_test`, :func:`timing_across_runs`: intercalation intervals vs
  T1-cycle periods (Fig. 3g).

What reads or writes folders or runs simulations (sweeps, Fig. 3 from a sweep, the report) is in
:mod:`hexatissue.workflows`.

Positions are in px with x = column, y = row, origin at the centre of pixel (0, 0); times in frames.
"""
from .migration import (DEFAULT_DL, PAPER_WINDOW_ITERATIONS, MigrationPopulations, cell_displacements, cell_steps,
                        frames_per_window, migration_populations, migration_table)
from .mixture import GaussianMixture1D, fit_gaussian_mixture
from .plots import plot_migration, plot_t1_defect_distances, plot_timing, plot_timing_vs_parameter
from .proximity import (ProximityResult, compare_distances, nearest_defect, random_cell_distances,
                        random_vertex_distances, t1_defect_distances, t1_defect_proximity)
from .timing import cell_timing, in_time_units, timing_across_runs, timing_summary, timing_test

__all__ = [
    "nearest_defect", "t1_defect_distances", "random_cell_distances", "random_vertex_distances",
    "t1_defect_proximity", "compare_distances", "ProximityResult",
    "frames_per_window", "cell_steps", "cell_displacements", "migration_table", "migration_populations",
    "MigrationPopulations", "DEFAULT_DL", "PAPER_WINDOW_ITERATIONS",
    "GaussianMixture1D", "fit_gaussian_mixture",
    "cell_timing", "in_time_units", "timing_summary", "timing_test", "timing_across_runs",
    "plot_t1_defect_distances", "plot_migration", "plot_timing", "plot_timing_vs_parameter",
]
