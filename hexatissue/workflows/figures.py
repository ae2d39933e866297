"""The standard figures of an analysis (``hexatissue analyze --figures``): every stage's, from its views module."""
from __future__ import annotations

from pathlib import Path

from ..views import movie_figures, shown_frames

__all__ = ["save_movie_figures", "shown_frames"]


def save_movie_figures(movie, folder, source=None) -> list[Path]:
    """PNG figures of the first and last frame of ``movie``: every stage's figures
    (:func:`hexatissue.views.movie_figures`; the cell polygons, and the p-legged stars and the Gamma_p field with
    its defects for every p).

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
        The files written (``[frameNNNN_]polygons.png``, ``[frameNNNN_]stars{p}.png``,
        ``[frameNNNN_]gamma{p}_defects.png``), sorted.
    """
    return movie_figures(movie, folder, source)
