"""The standard figures of an analysis: polygons, p-legged stars, Gamma_p field with defects."""
from __future__ import annotations

from pathlib import Path

__all__ = ["save_movie_figures", "shown_frames"]


def shown_frames(movie) -> list[int]:
    """The frames figures are drawn for: the first and the last."""
    return sorted({0, len(movie) - 1}) if len(movie) else []


def save_movie_figures(movie, folder, source=None) -> list[Path]:
    """PNG figures of the first and last frame of ``movie`` (one set per symmetry order).

    Parameters
    ----------
    movie : Movie
        From :func:`hexatissue.analyze` or :func:`hexatissue.read_results`.
    folder : str or Path
        Output folder (created if needed).
    source : Source, optional
        The movie's source; its label image is drawn underneath when given.

    Returns
    -------
    list of pathlib.Path
        The files written (see :func:`hexatissue.plot.save_analysis_figures`).
    """
    from ..plot import save_analysis_figures

    order = movie.options.get("order")
    orders = order.p if order is not None else (6,)
    single = len(movie) == 1
    written = []
    for t in shown_frames(movie):
        frame = movie.frame(t)
        labels = source.frame(t) if source is not None and source.kind == "labels" else None  # polygons: no image
        prefix = "" if single else f"frame{t:04d}_"
        for q in orders:
            grid = defects = None
            if movie.grid is not None and f"Gamma{q}_re" in movie.grid.columns:
                grid = movie.table_at("grid", t)
                defects = movie.table_at("defects", t)
                defects = defects[defects["p"] == q]
                if len(grid) == 0:
                    continue
            written += save_analysis_figures(frame, folder, labels=labels, grid=grid, defects=defects, p=q,
                                             prefix=prefix)
    return sorted(set(written))
