"""Workflows: what reads and writes folders or runs simulations, above the table-to-table stages.

- :func:`save_movie_figures`: the standard figures of an analysis (``hexatissue analyze --figures``).
- :func:`report`: figures and a Markdown summary of a results folder (``hexatissue report``).
- :func:`sweep`: MPF parameter sweeps, simulated and analysed in parallel, resumable.
- :func:`figure3`: the paper's Fig. 3e-g from the runs of a sweep; :func:`timing_vs_frame_spacing`: its
  Fig. 3g timing when only every k-th frame is analysed.
"""
from .figures import save_movie_figures
from .figure3 import figure3, loglog_slope, timing_vs_frame_spacing
from .report import report
from .sweep import sweep

__all__ = ["save_movie_figures", "report", "sweep", "figure3", "loglog_slope", "timing_vs_frame_spacing"]
