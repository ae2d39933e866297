"""Each stage's presentation: its figures, its report section, its napari layers and its widget fields.

A stage's entry in :data:`hexatissue.stages.STAGES` names its views module
(``Stage.views``: a module name, which :func:`stage_views` imports, or a
:class:`StageView` itself); the analysis never imports it.  The module sits on the analysis floor, so it may
draw with :mod:`hexatissue.plot` and :mod:`hexatissue.analysis`; its
``VIEW`` is a :class:`StageView`.  The consumers iterate the list and know
no stage by name:

- ``hexatissue analyze --figures`` (:func:`hexatissue.workflows.save_movie_figures`)
  calls every view's ``figures``;
- ``hexatissue report`` (:func:`hexatissue.workflows.report`) joins every
  view's report sections, by rank, with its own analyses;
- the napari plugin (:func:`hexatissue.napari.layers.movie_layers`) stacks
  every view's layers, by rank, and its legend entries; its analyze widget
  shows every view's widget fields.

Every function here takes a :class:`~hexatissue.Movie` (a results folder
read back, or the return value of :func:`hexatissue.analyze`) and returns
nothing, or an empty list, when the Movie lacks what it shows (a stage that
did not run).
"""
from __future__ import annotations

import importlib
from dataclasses import dataclass, field
from pathlib import Path
from typing import Callable

from ..io import write_table
from ..stored import StoredTable

__all__ = ["StageView", "Section", "LayerMaker", "WidgetField", "Report", "stage_views", "report_sections",
           "layer_makers", "legend_rows", "widget_fields", "movie_figures", "shown_frames", "single", "columns",
           "has_column"]


def columns(movie, name, wanted):
    """Table ``name`` of ``movie`` for a function that reads only the ``wanted`` columns; None when it is absent.

    A table kept on disk in parts (:class:`~hexatissue.stored.StoredTable`,
    ``read_results(lazy=True)``) is read with only the ``wanted`` columns it
    has, every row: the memory of those columns, not of the table.  A table
    in memory is returned as it is (no copy); the function reads the same
    columns of it.
    """
    table = movie.tables.get(name)
    if isinstance(table, StoredTable):
        present = set(table.columns)
        return table.read([c for c in dict.fromkeys(wanted) if c in present])
    return table


def has_column(movie, name, column) -> bool:
    """Table ``name`` of ``movie`` is present and has ``column`` (read from its schema when on disk)."""
    table = movie.tables.get(name)
    return table is not None and column in table.columns


def shown_frames(movie) -> list[int]:
    """The frames figures are drawn for: the first and the last."""
    return sorted({0, len(movie) - 1}) if len(movie) else []


@dataclass(frozen=True)
class Section:
    """A part of the report: ``run(movie, report)`` -> Markdown lines (:class:`Report` holds the folder and the
    numbers).  Sections follow each other by ``rank`` (the report's own analyses have ranks 41-44); ``tracked``:
    only for movies whose frames were tracked (more than one frame, not independent images)."""

    rank: float
    run: Callable
    tracked: bool = False


@dataclass(frozen=True)
class LayerMaker:
    """napari layers of a Movie: ``make(movie, p)`` -> a list of layer data tuples ``(data, kwargs, type)``
    (:mod:`hexatissue.views.layerdata`; no napari import), stacked bottom to top by ``rank``."""

    rank: float
    make: Callable


def single(make) -> Callable:
    """A :class:`LayerMaker`'s ``make`` of ``make(movie)`` -> one layer data tuple, or None when the Movie has
    nothing to show."""
    def layers(movie, p):
        layer = make(movie)
        return [] if layer is None else [layer]
    return layers


@dataclass(frozen=True)
class WidgetField:
    """A field of the stage's options class that the napari analyze widget offers
    (:func:`hexatissue.napari.widget.option_widget`): its widget ``name`` (default ``{stage}_{field}``), ``label``
    and number ``limits`` (``min``, ``max``, ``step``)."""

    field: str
    name: str | None = None
    label: str | None = None
    limits: dict = field(default_factory=dict)


@dataclass(frozen=True)
class StageView:
    """What a stage shows.

    Attributes
    ----------
    figures : callable, optional
        ``figures(movie, folder, source=None)`` -> list of the PNG paths
        written (``analyze --figures``; ``source``: the labels drawn underneath).
    report : tuple of Section
    layers : tuple of LayerMaker
    legend : callable, optional
        ``legend(movie, p)`` -> list of ``(label, symbol, color)`` rows of the
        napari legend, as its layers draw them.
    widget : tuple of WidgetField
    """

    figures: Callable | None = None
    report: tuple = ()
    layers: tuple = ()
    legend: Callable | None = None
    widget: tuple = ()


def _view(entry) -> StageView | None:
    if entry is None or isinstance(entry, StageView):
        return entry
    return importlib.import_module(entry).VIEW


def stage_views(stages=None) -> list:
    """``(stage, view)`` of every entry of ``stages`` (default :data:`hexatissue.stages.STAGES`, read when called)
    that has a view, in list order; a views module named by several entries comes once, with the first."""
    if stages is None:
        from .. import stages as stage_list  # the list as it is now (a test may extend it)

        stages = stage_list.STAGES
    out, seen = [], set()
    for stage in stages:
        key = stage.views if isinstance(stage.views, str) else id(stage.views)
        if stage.views is None or key in seen:
            continue
        seen.add(key)
        out.append((stage, _view(stage.views)))
    return out


def report_sections(extra=(), stages=None) -> list:
    """Every view's report :class:`Section` and the ``extra`` ones, by rank (ties: list order)."""
    sections = [s for _, view in stage_views(stages) for s in view.report] + list(extra)
    return sorted(sections, key=lambda s: s.rank)


def layer_makers(stages=None) -> list:
    """Every view's :class:`LayerMaker`, by rank (ties: list order)."""
    return sorted((m for _, view in stage_views(stages) for m in view.layers), key=lambda m: m.rank)


def legend_rows(movie, p=6, stages=None) -> list:
    """``(label, symbol, color)`` of every view's legend, in list order."""
    return [row for _, view in stage_views(stages) if view.legend is not None for row in view.legend(movie, p)]


def widget_fields(stages=None) -> list:
    """``(options class, WidgetField)`` of every view's widget fields, in list order."""
    return [(stage.options, f) for stage, view in stage_views(stages) for f in view.widget]


def movie_figures(movie, folder, source=None, stages=None) -> list:
    """Every view's figures of ``movie`` in ``folder`` (created if needed); the paths written, sorted."""
    folder = Path(folder)
    written = []
    for _, view in stage_views(stages):
        if view.figures is not None:
            written += view.figures(movie, folder, source)
    return sorted(set(written))


@dataclass
class Report:
    """What the report's sections share: the report folder ``out``, the files ``written``, the key ``numbers``
    (returned by :func:`hexatissue.workflows.report` and written beside it) and the report's parameters
    (see :func:`hexatissue.workflows.report`)."""

    out: Path
    written: list = field(default_factory=list)
    numbers: dict = field(default_factory=dict)
    p: int = 6
    order_p: tuple = (6,)
    dl: float = 0.0
    dt: int | None = None
    n_control: int = 5
    seed: object = 0
    include_border: bool = False
    control: str = "cells"

    def figure(self, path, caption) -> list:
        """Record a figure written to ``path``; its Markdown lines."""
        self.written.append(path)
        return [f"![{caption}]({Path(path).relative_to(self.out).as_posix()})", ""]

    def table(self, table, name):
        """Write ``table`` as ``out/name`` (CSV) and record it."""
        self.written.append(write_table(table, self.out / name))
