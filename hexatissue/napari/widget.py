"""Dock widget: run :func:`hexatissue.analyze` on an open Labels layer and add the result layers.

The analysis runs in a napari thread worker (the viewer stays responsive),
in one process (forking a process pool from a Qt application is not safe),
with a per-frame progress bar in napari's activity dock.  That bar is a Qt
widget, so it lives in the main thread: the worker's tqdm bar only relays
its count through a queued Qt signal (:func:`_relay_bar`); a napari
``progress`` made in the worker creates widgets from that thread, which
aborts a shown viewer (rc 134, "Cannot make QOpenGLContext current in a
different thread").  The result layers
take the input layer's scale, translate and units (so they lie exactly over
it), and its calibration when its units are physical.
"""
from __future__ import annotations

from dataclasses import fields

from magicgui.widgets import (CheckBox, ComboBox, Container, FloatSpinBox, Label, LineEdit, PushButton, SpinBox,
                              create_widget)

from ..errors import InputError
from ..options import OPTION_CLASSES
from ..views import widget_fields
from .layers import aligned, movie_layers, with_movie

__all__ = ["AnalyzeWidget", "run_analysis", "option_widget", "layer_calibration"]


def layer_calibration(scale, units) -> dict | None:
    """The :meth:`hexatissue.Calibration.to_dict` of a napari layer's ``scale`` and ``units`` (last axis: the
    pixel side; first of three: the frame interval), or None when neither axis has a physical unit.

    An axis whose unit is napari's ``"pixel"`` (its default: no physical
    unit) stays uncalibrated (px, frames), whatever its scale.
    """
    from ..units import Calibration

    units = [str(u) for u in units]
    cal = {}
    if units[-1] != "pixel":
        cal |= {"pixel_size": float(scale[-1]), "length_unit": units[-1]}
    if len(units) >= 3 and units[0] != "pixel":
        cal |= {"frame_interval": float(scale[0]), "time_unit": units[0]}
    return Calibration(**cal).to_dict() if cal else None


def _is_default_axis_labels(labels) -> bool:
    """napari's default labels are the negative axis indices ('-3', '-2', '-1')."""
    n = len(labels)
    return tuple(str(a) for a in labels) == tuple(str(i - n) for i in range(n))


def option_widget(options_class, field_name, *, name=None, label=None, **limits):
    """A magicgui widget for one field of a stage's options class, as ``hexatissue analyze`` offers it.

    Its choices, default and help (the tooltip) come from the field
    (:func:`hexatissue.options.cli_field`); a field whose default is None
    (chosen from the data) shows 0, which :meth:`AnalyzeWidget.start` reads
    back as None.  ``limits``: ``min``, ``max``, ``step`` of a number.
    """
    f = {f.name: f for f in fields(options_class)}[field_name]
    name = name or f"{options_class.stage}_{field_name}"
    label = label or field_name.replace("_", " ")
    tooltip = f.metadata.get("help")
    choices = f.metadata.get("argparse", {}).get("choices")
    if choices:
        return ComboBox(choices=choices, value=f.default, name=name, label=label, tooltip=tooltip)
    annotation = f.type if isinstance(f.type, str) else f.type.__name__
    if annotation == "bool":
        return CheckBox(value=f.default, name=name, label=label, tooltip=tooltip)
    number = FloatSpinBox if annotation.startswith("float") else SpinBox
    return number(value=0 if f.default is None else f.default, name=name, label=label, tooltip=tooltip, **limits)


def _field_names():
    """``{widget name: (options class, field name)}`` of every stage view's widget fields, in list order."""
    return {f.name or f"{cls.stage}_{f.field}": (cls, f.field) for cls, f in widget_fields()}


def run_analysis(labels, *, p=6, pixel_size=None, length_unit="um", calibration=None, progress=True, **fields):
    """``analyze`` of a label array with the widget's options; returns the result layers (no labels layer).

    Parameters
    ----------
    labels : array
        ``(T, rows, cols)`` or ``(rows, cols)`` label images (a Labels layer's data).
    p : int
        Order of gamma_p, Gamma_p and the defects (drawn as p-legged stars).
    pixel_size : float, optional
        Pixel side in ``length_unit``; None keeps ``calibration``'s (or px).
    length_unit : str
        Unit of ``pixel_size``.
    calibration : dict, optional
        :meth:`hexatissue.Calibration.to_dict` of the layer (set by this
        plugin's reader), so the new layers line up with it.
    progress : bool or tqdm class
        Progress bar (see :func:`hexatissue.analyze`).
    **fields
        The stages' option fields the widget offers, by widget name
        (:func:`hexatissue.views.widget_fields`: ``merge_distance``,
        ``radius`` (None: the default), ``mechanics``, ``track_mode``,
        ``flow``, ``deformation``); the others keep their defaults.

    Returns
    -------
    list of (data, kwargs, layer_type)
        :func:`~hexatissue.napari.layers.movie_layers` on the Movie's
        calibration, each with the Movie in ``metadata["movie"]`` (for the
        writers); the widget then puts them on its input layer's grid.
    """
    from ..pipeline import analyze
    from ..source import open_source
    from ..units import Calibration

    names = _field_names()
    unknown = sorted(set(fields) - set(names))
    if unknown:
        raise TypeError(f"run_analysis() got unexpected keyword argument(s) {unknown}; the widget's fields are "
                        f"{sorted(names)}")
    given = {"order": {"p": (int(p),)}}  # the order drawn is the order analysed
    for name, value in fields.items():
        cls, field_name = names[name]
        given.setdefault(cls.stage, {})[field_name] = value
    options = {stage: OPTION_CLASSES[stage](**values) for stage, values in given.items()}
    source = open_source(labels)
    if calibration:
        cal = Calibration.from_dict(calibration)
        source = source.with_calibration(pixel_size=cal.pixel_size, length_unit=cal.length_unit,
                                         frame_interval=cal.frame_interval, time_unit=cal.time_unit)
    if pixel_size is not None:
        source = source.with_calibration(pixel_size=pixel_size, length_unit=length_unit)
    movie = analyze(source, workers=1, progress=progress, **options)
    return with_movie(movie_layers(movie, p=int(p)), movie)


class AnalyzeWidget(Container):
    """Labels layer, p, the stages' fields (:func:`hexatissue.views.widget_fields`: merge distance, radius (0 =
    default), force inference, track mode, tissue flow, deformation budget), pixel size (0 = keep) and Analyze.
    The result layers are drawn on the input layer's grid (scale, translate, units; see
    :func:`hexatissue.napari.layers.aligned`)."""

    def __init__(self, napari_viewer):
        import napari

        stage_fields = [option_widget(cls, f.field, name=f.name, label=f.label, **f.limits)
                        for cls, f in widget_fields()]
        # children are reached by name (self.layer, self.p, ...), as magicgui containers do
        super().__init__(widgets=[
            create_widget(annotation=napari.layers.Labels, name="layer", label="labels"),
            SpinBox(value=6, min=2, max=12, name="p", label="p", tooltip="symmetry order of gamma_p, Gamma_p "
                    "and the defects"),
            *stage_fields,
            FloatSpinBox(value=0.0, min=0.0, max=1e6, step=0.01, name="pixel_size", label="pixel size (0 = keep)"),
            LineEdit(value="um", name="length_unit", label="length unit"),
            PushButton(text="Analyze", name="run"),
            Label(value="", name="status")])
        self.viewer = napari_viewer
        self.worker = None
        self._input = None  # the layer being analysed: its grid for the result layers
        self._bar = self._relay = None  # the main thread's progress bar and the worker's relay to it
        self.run.changed.connect(self.start)

    def _stage_values(self) -> dict:
        """The stages' fields by widget name; a number field whose default is None (chosen from the data) reads 0
        as None."""
        out = {}
        for name, (cls, field_name) in _field_names().items():
            value = getattr(self, name).value
            default = {f.name: f.default for f in fields(cls)}[field_name]
            out[name] = None if default is None and value == 0 else value
        return out

    def start(self, *_):
        """Start the analysis of the chosen layer in a thread worker; returns the worker (None if no layer)."""
        from napari.qt.threading import thread_worker

        layer = self.layer.value
        if layer is None:
            self.status.value = "choose a Labels layer"
            return None
        calibration = layer.metadata.get("calibration") or layer_calibration(layer.scale, layer.units)
        options = {"p": self.p.value, "pixel_size": self.pixel_size.value or None,
                   "length_unit": self.length_unit.value, "calibration": calibration, **self._stage_values()}
        self._input = layer
        data = layer.data[0] if layer.multiscale else layer.data  # read lazily, frame by frame, by open_source
        self.status.value = f"analysing {layer.name}..."
        self.run.enabled = False
        relay = _relay_class()()  # made here, in the main thread: its signal's slot runs here
        relay.step.connect(self._show_progress)
        self.worker = thread_worker(_checked_analysis)(data, progress=_relay_bar(relay), **options)
        self.worker.returned.connect(self._finish)
        self.worker.finished.connect(self._done)
        self._relay = relay  # kept alive while the worker runs
        self.worker.start()
        return self.worker

    def _show_progress(self, n, total, desc):
        """The worker's bar, drawn by napari in the main thread (one bar per stage: a new ``desc`` or total)."""
        from napari.utils import progress

        bar = self._bar
        if bar is None or bar.desc != desc or bar.total != total:
            if bar is not None:
                bar.close()
            bar = self._bar = progress(total=total or None, desc=desc)
        bar.update(n - bar.n)

    def _done(self):
        if self._bar is not None:
            self._bar.close()
            self._bar = None
        self._relay = None
        self.run.enabled = True

    def _finish(self, result):
        from napari.layers import Layer

        from .legend import show_legend

        layers, error = result
        if error is not None:
            self.status.value = f"error: {error}"
            return
        src = self._input
        labels = None if _is_default_axis_labels(src.axis_labels) else src.axis_labels
        for data, kwargs, kind in aligned(layers, src.scale, src.translate, src.units, labels):
            self.viewer.add_layer(Layer.create(data, kwargs, kind))
        show_legend(self.viewer)
        self.status.value = f"added {len(layers)} layers"


def _checked_analysis(labels, **options):
    """``(layers, None)``, or ``(None, message)`` for bad input: an InputError is the user's to fix and goes to
    the status line; any other exception is a bug and reaches napari's error notification (with its traceback)."""
    try:
        return run_analysis(labels, **options), None
    except InputError as exc:
        return None, str(exc)


def _relay_class():
    from qtpy.QtCore import QObject, Signal

    class Relay(QObject):
        """Carries a worker bar's (n, total, desc) to the main thread (queued: the object lives there)."""
        step = Signal(int, int, str)

    return Relay


def _relay_bar(relay):
    """A tqdm class for :func:`hexatissue.analyze` in a worker thread: it draws nothing itself and emits each
    refresh as ``relay.step(n, total, desc)``."""
    import io

    from tqdm import tqdm

    class RelayBar(tqdm):
        def __init__(self, *args, **kwargs):
            kwargs.update(file=io.StringIO(), mininterval=0, disable=False)
            super().__init__(*args, **kwargs)

        def display(self, msg=None, pos=None):
            relay.step.emit(int(self.n), int(self.total or 0), str(self.desc))
            return True

    return RelayBar
