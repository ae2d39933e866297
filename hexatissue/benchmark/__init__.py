"""Synthetic benchmark: a baseline segmenter and the scorer of predictions against exact truth."""
from .baseline import segment_membranes, segment_movie

__all__ = ["segment_membranes", "segment_movie"]
