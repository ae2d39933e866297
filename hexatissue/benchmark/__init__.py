"""Synthetic benchmark: a baseline segmenter and the scorer of predictions against exact truth."""
from .baseline import segment_membranes, segment_movie
from .score import SCORE_NAMES, Scores, match_points, plot_scores, score, score_to_folder

__all__ = ["segment_membranes", "segment_movie", "score", "score_to_folder", "plot_scores", "match_points", "Scores",
           "SCORE_NAMES"]
