"""The baseline segmenter of the synthetic benchmark: membrane movies -> touching cell labels.

The per-frame segmenter is :func:`hexatissue.mesh.segment.segment_membranes`
(smoothing, h-minima seeds, watershed, small-cell cleanup; its docstring has
the steps), the same one ``hexatissue analyze --kind membrane-map`` uses.  A
rendered benchmark can so be segmented, analysed and scored on any machine:
a baseline to beat, not a competitor to learned segmenters such as Cellpose.

Output labels are *touching* (no 0-valued membranes and no background):
``hexatissue analyze`` reads them with ``kind="touching"`` (auto-detected)
without the membrane-sharing step, so the cell ids of its tables are the
ids of these labels.
"""
from __future__ import annotations

import numpy as np

from ..errors import InputError
from ..mesh.segment import segment_membranes
from ..progress import progress

__all__ = ["segment_membranes", "segment_movie"]


def segment_movie(stack, *, sigma=1.0, h=0.1, min_area=30, periodic=False, show_progress=True) -> np.ndarray:
    """:func:`segment_membranes` on every frame of a ``T x rows x cols`` membrane movie.

    Each frame is segmented on its own (ids are not consistent over time:
    ``hexatissue analyze`` tracks the cells by overlap).  A progress bar
    shows the frames done.

    Returns
    -------
    (T, rows, cols) uint32 array
        Touching labels of every frame.
    """
    n = len(stack)
    if np.ndim(stack[0]) != 2:
        raise InputError(f"stack must be a T x rows x cols movie; got frames of shape {np.shape(stack[0])}")
    frames = [segment_membranes(stack[t], sigma=sigma, h=h, min_area=min_area, periodic=periodic)
              for t in progress(range(n), enabled=show_progress, desc="baseline segmentation", unit="frame")]
    return np.stack(frames)
