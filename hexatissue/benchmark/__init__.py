"""Synthetic benchmarks: rendered microscopy movies with their exact truth, a baseline segmenter, a scorer.

- :mod:`~hexatissue.benchmark.truth`: ground-truth movies (:class:`Truth`) from MPF runs and the
  scripted Voronoi movies of :mod:`hexatissue.synthetic`, and an active vertex model that logs its own T1s
  (:mod:`~hexatissue.benchmark.vertex_model`);
- :mod:`~hexatissue.benchmark.render`: OpenCV rendering of the membrane (and nuclear) channel
  (:class:`RenderOptions`, :class:`Renderer`);
- :mod:`~hexatissue.benchmark.make`: a benchmark folder on disk (:func:`make_benchmark`);
- :mod:`~hexatissue.benchmark.baseline`: the scikit-image baseline segmenter;
- :mod:`~hexatissue.benchmark.score`: scores of a prediction against the truth (:func:`score`);
- :mod:`~hexatissue.benchmark.command`: ``hexatissue benchmark make | baseline | score``.
"""
from .baseline import segment_membranes, segment_movie
from .make import make_benchmark
from .render import Renderer, RenderOptions, render
from .score import SCORE_NAMES, Scores, plot_scores, score, score_to_folder
from .truth import (Truth, crop_labels, truth_from_labels, truth_from_run, truth_from_t1, truth_from_vertex_model,
                    truth_from_voronoi)

__all__ = ["Truth", "truth_from_labels", "truth_from_run", "truth_from_voronoi", "truth_from_t1", "truth_from_vertex_model",
           "crop_labels",
           "RenderOptions", "Renderer", "render", "make_benchmark", "segment_membranes", "segment_movie", "score",
           "score_to_folder", "plot_scores", "Scores", "SCORE_NAMES"]
