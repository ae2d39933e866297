"""Synthetic benchmarks: rendered microscopy movies with their exact truth (issue 15).

- :mod:`~hexatissue.benchmark.truth`: ground-truth movies (:class:`Truth`) from MPF runs and the
  scripted Voronoi movies of :mod:`hexatissue.synthetic`;
- :mod:`~hexatissue.benchmark.render`: OpenCV rendering of the membrane (and nuclear) channel
  (:class:`RenderOptions`, :class:`Renderer`);
- :mod:`~hexatissue.benchmark.make`: a benchmark folder on disk (:func:`make_benchmark`);
- :mod:`~hexatissue.benchmark.command`: ``hexatissue benchmark ...``.
"""
from .make import make_benchmark
from .render import Renderer, RenderOptions, render
from .truth import Truth, crop_labels, truth_from_labels, truth_from_run, truth_from_t1, truth_from_voronoi

__all__ = ["Truth", "truth_from_labels", "truth_from_run", "truth_from_voronoi", "truth_from_t1", "crop_labels",
           "RenderOptions", "Renderer", "render", "make_benchmark"]
