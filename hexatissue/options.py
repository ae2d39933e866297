"""Options of the analysis stages, as frozen and validated dataclasses.

Each stage of :func:`hexatissue.analyze` takes one options object; the field
names are the keyword names of the stage's own function
(:func:`hexatissue.mesh_from_labels`, :func:`hexatissue.coarse_grain`,
:class:`hexatissue.Tracker`, :func:`hexatissue.detect_t1`).  An invalid field
raises :class:`~hexatissue.InputError` naming it when the object is built,
so nothing fails half-way through a movie.  Lengths are in px, times in
frames.
"""
from __future__ import annotations

import os
import re
from dataclasses import asdict, dataclass, field, fields, replace

import numpy as np

from .errors import InputError, check_orders, check_positive, is_real

__all__ = ["MeshOptions", "OrderOptions", "TrackOptions", "EventOptions", "IntensityOptions", "SurfaceOptions",
           "DeformationOptions", "FlowOptions", "MechanicsOptions", "OPTION_CLASSES",
           "cli_field", "add_flags", "from_flags", "flag_text"]

# The vocabulary of the options: the stages read it from here (options sit on the data floor, below them).
#: Label conventions of :func:`hexatissue.mesh_from_labels`.
KINDS = ("auto", "touching", "membrane", "skeleton", "membrane-map")
#: Rules for a skeleton's outside region (see ``MeshOptions.outside``).
OUTSIDE_RULES = ("auto", "none")
POCKET_AREA = 16  # px: smaller 0-valued pockets in touching labels are holes (e.g. at triple junctions)
#: Cell centres of the shape function (:func:`hexatissue.shape_order`).
CENTERS = ("vertex_mean", "area_centroid")
#: Node-validity rules of :func:`hexatissue.coarse_grain` (see its docstring and docs/order.md).
VALIDITY = ("tissue", "occupied", "all")
#: Tracking modes (see :class:`TrackOptions`).
TRACK_MODES = ("auto", "always", "never", "off")
#: How overlap tracking links frames (``TrackOptions.follow``, :class:`hexatissue.track.Tracker`).
FOLLOW_MODES = ("flow", "none")
#: Tables that name the kind of a T1 in the deformation budget (see :class:`DeformationOptions`).
T1_SOURCES = ("quartets", "neighbours")
#: Estimators of force inference (see :class:`MechanicsOptions`).
FORCE_METHODS = ("bayes", "lsq")
#: Junction models of force inference (see :class:`MechanicsOptions`).
JUNCTION_MODELS = ("auto", "straight", "curved")


def check_background(background, name="background"):
    """Label ids that are outside, as a sorted tuple of non-negative ints."""
    values = (background,) if np.isscalar(background) else background
    try:
        ids = tuple(values)
    except TypeError:
        raise InputError(f"{name} must be a sequence of label ids; got {background!r}") from None
    for v in ids:
        if isinstance(v, (bool, np.bool_)) or not isinstance(v, (int, np.integer)) or v < 0:
            raise InputError(f"{name} must hold non-negative integer label ids; got {v!r}")
    return tuple(sorted({int(v) for v in ids}))


def check_pair(value, name, integer):
    """``origin`` (two finite numbers, px) or ``shape`` (two positive ints) as a tuple, or None."""
    if value is None:
        return None
    try:
        pair = tuple(value)
    except TypeError:
        pair = ()
    what = "(rows, cols), two positive integers" if integer else "(x, y), two finite numbers in px"
    if len(pair) != 2:
        raise InputError(f"{name} must be {what}; got {value!r}")
    if integer:
        return tuple(check_positive(v, name, integer=True) for v in pair)
    ok = all(not isinstance(v, bool) and np.isscalar(v) and np.isfinite(v) for v in pair)
    if not ok:
        raise InputError(f"{name} must be {what}; got {value!r}")
    return float(pair[0]), float(pair[1])


def _fail(cls, name, value, expected):
    raise InputError(f"{cls.__name__}.{name} must be {expected}; got {value!r}")


def cli_field(default, flag, help, **argparse):
    """A dataclass field that ``hexatissue analyze`` (and the napari widget) offer as ``flag``.

    ``help`` is the text shown, without the default (added from ``default``);
    ``argparse`` holds what the default does not say (``type`` when the
    default is None or a tuple, ``metavar``, ``choices``, ``nargs``,
    ``action="store_false"`` for a ``--no-...`` flag).
    Fields made without it are options of the Python API only.
    """
    return field(default=default, metadata={"flag": flag, "help": help, "argparse": argparse})


#: the type a flag parses, from its field's annotation (``int | None`` -> int)
_ANNOTATION_TYPES = {"int": int, "float": float, "str": str, "bool": bool}


def _annotation(f) -> str:
    """A dataclass field's annotation as written (a string under ``from __future__ import annotations``)."""
    return f.type if isinstance(f.type, str) else getattr(f.type, "__name__", str(f.type))


def add_flags(parser, cls, prefix=""):
    """Add a group of command-line flags to ``parser``: one per field of ``cls`` made with :func:`cli_field`.

    The group is titled ``cls.title``; each flag's destination is
    ``prefix + field name`` and its default the field's, shown in its help.
    :func:`from_flags` builds the options object back.
    """
    group = None
    for f in fields(cls):
        if "flag" not in f.metadata:
            continue
        group = group or parser.add_argument_group(cls.title)
        extra = dict(f.metadata["argparse"])
        text = f.metadata["help"]
        if extra.get("action") is None:
            if "type" not in extra:
                extra["type"] = _ANNOTATION_TYPES[_annotation(f).split(" |")[0]]
            if "choices" not in extra:
                extra.setdefault("metavar", f.metadata["flag"].lstrip("-").replace("-", "_").upper())
            if f.default is not None and f.default != ():
                shown = " ".join(map(str, f.default)) if isinstance(f.default, tuple) else f.default
                text += f" (default: {shown})"
        group.add_argument(f.metadata["flag"], dest=prefix + f.name, default=f.default, help=text, **extra)
    return group


def from_flags(args, cls, prefix=""):
    """The ``cls`` options object from the flags of :func:`add_flags` (fields without a flag keep their defaults)."""
    given = {f.name: getattr(args, prefix + f.name) for f in fields(cls) if "flag" in f.metadata}
    return cls(**{k: tuple(v) if isinstance(v, list) else v for k, v in given.items()})


def flag_text(text, classes) -> str:
    """An error text with ``SomeOptions.field`` replaced by the flag that sets it, for the options ``classes``."""
    flags = {f"{cls.__name__}.{f.name}": f.metadata["flag"] for cls in classes for f in fields(cls)
             if "flag" in f.metadata}
    return re.sub(r"\b[A-Z]\w*Options\.\w+", lambda m: flags.get(m.group(0), m.group(0)), text)


#: Options class of each stage, by the name used in ``metadata.json``, checkpoints and as the keyword of
#: :func:`hexatissue.analyze`: every subclass of ``_Options`` declares it (``class X(_Options, stage="x")``).
OPTION_CLASSES: dict[str, type] = {}


class _Options:
    """Shared behaviour: validation helpers, ``to_dict`` / ``from_dict`` for ``metadata.json``.

    A subclass that is the options of a stage of :func:`hexatissue.analyze`
    names it; every subclass may title its group of command-line flags
    (:func:`add_flags`): ``class MeshOptions(_Options, stage="mesh", title="junction network")``.
    """

    stage: str = ""
    title: str = ""

    def __init_subclass__(cls, *, stage=None, title="", **kwargs):
        super().__init_subclass__(**kwargs)
        cls.title = title
        if stage is None:  # options of something that is not a stage of analyze (e.g. the benchmark's rendering)
            return
        if stage in OPTION_CLASSES:
            raise TypeError(f"two options classes for stage {stage!r}: {OPTION_CLASSES[stage].__name__} and "
                            f"{cls.__name__}")
        cls.stage = stage
        OPTION_CLASSES[stage] = cls

    def _number(self, name, low=0.0, allow_none=False, integer=False, strict=False, high=None):
        value = getattr(self, name)
        if value is None and allow_none:
            return
        ok = is_real(value) and (value > low if strict else value >= low)
        ok = ok and (high is None or value <= high) and (not integer or float(value) == int(value))
        if not ok:
            what = "an integer" if integer else "a finite number"
            bound = f"> {low}" if strict else f">= {low}"
            bound += f" and <= {high}" if high is not None else ""
            _fail(type(self), name, value, f"{what} {bound}" + (" or None" if allow_none else ""))
        object.__setattr__(self, name, int(value) if integer else float(value))

    def _flags(self, *names):
        """Check that the fields ``names`` are True or False (a switch given as 1 or "yes" is refused)."""
        for name in names:
            if not isinstance(getattr(self, name), bool):
                _fail(type(self), name, getattr(self, name), "True or False")

    def to_dict(self) -> dict:
        """Plain dict (tuples as lists) for JSON."""
        return {k: list(v) if isinstance(v, tuple) else v for k, v in asdict(self).items()}

    @classmethod
    def from_dict(cls, data):
        """Inverse of :meth:`to_dict`; unknown fields raise :class:`InputError`."""
        if not isinstance(data, dict):
            raise InputError(f"{cls.__name__} options must be a dict; got {type(data).__name__}")
        known = {f.name for f in fields(cls)}
        unknown = set(data) - known
        if unknown:
            raise InputError(f"{cls.__name__} has no field(s) {sorted(unknown)}; its fields are {sorted(known)}")
        return cls(**data)

    def replace(self, **changes):
        """A copy with some fields changed (validated again)."""
        return replace(self, **changes)


@dataclass(frozen=True)
class MeshOptions(_Options, stage="mesh", title="junction network"):
    """Junction network extraction (:func:`hexatissue.mesh_from_labels`).

    Parameters
    ----------
    kind : {"auto", "touching", "membrane", "skeleton"}
        Label convention (detected by default).
    merge_distance : float
        Junctions shorter than this (px) are contracted: four-fold vertices.
    membrane_width : int
        0-valued junction pixels within this many px of a cell are shared out.
    min_area : int, optional
        Regions with fewer pixels are membrane (default: 4 for skeletons, else 0).
    background : tuple of int
        Label ids that are outside (set to 0 first; cells touching them are border cells).
    fill_holes : int
        0-valued pockets smaller than this many px between cells are filled;
        0 disables (default 16 px: gaps at triple junctions).
    outside : {"auto", "none"}
        ``"auto"``: a region touching the image edge and more than 20 x the
        median region area is outside (a masked skeleton's outside region, or
        a hand-labelled tissue's background label that is not 0; for labels
        other than skeletons with a warning); ``"none"``: it is a cell.

    A region-of-interest mask is per image: ``hexatissue.analyze(..., mask=)``.
    """

    kind: str = cli_field("auto", "--kind", "label convention (default: detected); membrane-map: the "
                          "input is a membrane image or probability map, segmented first (threshold-free "
                          "watershed baseline, docs/input.md)", choices=KINDS)
    merge_distance: float = cli_field(2.0, "--merge-distance", "junctions shorter than this (px) become four-fold "
                                      "vertices")
    membrane_width: int = cli_field(3, "--membrane-width", "0-valued junction pixels within this many px of a "
                                    "cell are shared out")
    min_area: int | None = cli_field(None, "--min-area", "regions smaller than this (px) are membrane "
                                     "(default: 4 for skeletons, else 0)")
    background: tuple = cli_field((), "--background", "label ids that are outside, like 0 (e.g. a rim label); "
                                  "their neighbours are border cells", nargs="+", type=int, metavar="LABEL")
    fill_holes: int = cli_field(POCKET_AREA, "--fill-holes", "0-valued pockets smaller than AREA px between cells "
                                "are filled; 0 disables", metavar="AREA")
    outside: str = cli_field("auto", "--outside", "auto: a region touching the image edge and > 20 x the median "
                             "region area is outside, not a cell (a masked skeleton's outside, a background label "
                             "that is not 0); none: keep it", choices=OUTSIDE_RULES)

    def __post_init__(self):
        if self.kind not in KINDS:
            _fail(type(self), "kind", self.kind, f"one of {KINDS}")
        self._number("merge_distance")
        self._number("membrane_width", integer=True)
        self._number("min_area", integer=True, allow_none=True)
        self._number("fill_holes", integer=True)
        if self.outside not in OUTSIDE_RULES:
            _fail(type(self), "outside", self.outside, f"one of {OUTSIDE_RULES}")
        try:
            object.__setattr__(self, "background", check_background(self.background))
        except InputError:
            _fail(type(self), "background", self.background, "a sequence of non-negative integer label ids")


@dataclass(frozen=True)
class OrderOptions(_Options, stage="order", title="shape order"):
    """Shape order: gamma_p per cell, the coarse-grained field Gamma_p and its defects.

    Parameters
    ----------
    p : sequence of int
        Symmetry orders (2 nematic, 6 hexatic); every one gets ``gamma{p}``
        columns in ``cells``, a ``Gamma{p}`` field in ``grid`` and defects.
    center : {"vertex_mean", "area_centroid"}
        Cell centre of the shape function.
    fields : bool
        Compute the coarse-grained field and defects (False: gamma_p only).
    radius, spacing : float, optional
        Coarse-graining disk radius and grid spacing, px (default 1.5 R_cell
        and R_cell of each frame, see :func:`hexatissue.coarse_grain`).
    min_coverage : float
        Open images: fraction of a node's disk that must lie on interior cells.
    r_cell : float, optional
        R_cell, px, for every frame (default: each frame's own).
    origin : (float, float), optional
        Position (x, y), px, of the first grid node.
    shape : (int, int), optional
        Grid nodes (rows, cols) on open images.
    validity : {"tissue", "occupied", "all"}
        Node-validity rule (see :func:`hexatissue.coarse_grain`).
    defect_max_distance : float, optional
        Largest displacement of a defect between frames when defects are
        tracked, px (default: 1.5 grid spacings).
    """

    p: tuple = cli_field((6, 2), "--p", "symmetry orders of gamma_p, Gamma_p and defects", nargs="+", type=int,
                          metavar="P")
    center: str = cli_field("vertex_mean", "--center", "cell centre of the shape function", choices=CENTERS)
    fields: bool = cli_field(True, "--no-fields", "only gamma_p per cell: no coarse-grained field or defects",
                             action="store_false")
    radius: float | None = cli_field(None, "--radius", "coarse-graining radius, px (default 1.5 R_cell)")
    spacing: float | None = cli_field(None, "--spacing", "coarse-graining grid spacing, px (default R_cell)")
    min_coverage: float = 1.0
    r_cell: float | None = None
    origin: tuple | None = None
    shape: tuple | None = None
    validity: str = "tissue"
    defect_max_distance: float | None = None

    def __post_init__(self):
        try:
            object.__setattr__(self, "p", check_orders(self.p, "OrderOptions.p"))
        except TypeError:
            _fail(type(self), "p", self.p, "one or more positive integer symmetry orders")
        if self.center not in CENTERS:
            _fail(type(self), "center", self.center, f"one of {CENTERS}")
        self._flags("fields")
        for name in ("radius", "spacing", "r_cell", "defect_max_distance"):
            self._number(name, strict=True, allow_none=True)
        self._number("min_coverage", high=1.0)
        for name, integer in (("origin", False), ("shape", True)):
            try:
                object.__setattr__(self, name, check_pair(getattr(self, name), name, integer))
            except InputError:
                _fail(type(self), name, getattr(self, name),
                      "(rows, cols), two positive integers, or None" if integer
                      else "(x, y), two finite numbers in px, or None")
        if self.validity not in VALIDITY:
            _fail(type(self), "validity", self.validity, f"one of {VALIDITY}")
        if self.validity != "tissue" and self.min_coverage != 1.0:
            _fail(type(self), "min_coverage", self.min_coverage, "1.0 unless validity is 'tissue'")


@dataclass(frozen=True)
class TrackOptions(_Options, stage="track", title="tracking"):
    """Cell tracking (:class:`hexatissue.track.MovieTracker`).

    Parameters
    ----------
    mode : {"auto", "always", "never", "off"}
        ``"never"``: the label ids are the tracks (``track == cell``, a cell
        missing for some frames keeps its track); divisions are still read
        from them (a mother id ending while two new ids appear inside it).
        ``"always"``: link cells by overlap (:class:`hexatissue.Tracker`).
        ``"off"``: no tracking, every cell of every frame is its own track
        (frames that are unrelated images).
        ``"auto"`` (default): ``"off"`` for sources of independent images (a
        folder of polygon files), ``"never"`` for sources with consistent ids
        (MPF runs, polygon tables) and for movies whose ids are measured to be consistent
        (at least :data:`hexatissue.track.ID_CONSISTENCY` of the cells that
        overlap a cell of the next frame overlap their own id), else
        ``"always"``.  :func:`hexatissue.analyze` records the resolved mode.
    min_iou : float
        Smallest intersection over union of a link, in (0, 1].
    max_gap : int
        Overlap tracking: frames a cell may be missing and still continue its track.
    follow : {"flow", "none"}
        Overlap tracking: follow the tissue's motion (default; see
        :class:`hexatissue.track.Tracker`) or overlap the frames as they are.
    child_fraction, mother_fraction : float
        Division detection thresholds (see :func:`hexatissue.track.match_frames`).
    division_min_frames, division_min_cycle, division_area_tolerance
        Division plausibility (:func:`hexatissue.track.check_divisions`): a
        daughter must last ``division_min_frames`` frames (3: a split of one or
        two frames is a segmentation flicker); a cell may not divide within
        ``division_min_cycle`` frames of its birth (5: epithelial cell cycles
        last hours, hundreds of frames at the usual minutes per frame; the
        EpiTools wing disc's overlap tracks 101 and 103 divided 1-2 frames after
        their own birth); the daughters' first-frame areas must sum to the
        mother's last-frame area within ``division_area_tolerance`` of it (0.4:
        the curated EpiCure division 73 -> 477 + 490 gives 0.95; mitotic
        rounding enlarges the mother's apical area before it splits).
        Implausible divisions are kept, flagged in ``lineage.division_suspect``.
    """

    mode: str = cli_field("auto", "--track", "never: the label ids are the tracks (divisions still read from "
                          "them); always: link cells by overlap; off: no tracking (unrelated images); auto: keep the "
                          "ids when they are consistent over time (off for a folder of polygon files)",
                          choices=TRACK_MODES)
    min_iou: float = 0.2
    max_gap: int = cli_field(0, "--max-gap", "overlap tracking: link cells missing for up to this many frames")
    follow: str = cli_field("flow", "--track-follow", "overlap tracking: flow: carry each frame's cells along the "
                            "tissue's measured motion before overlapping them with the next frame's; none: overlap "
                            "the frames as they are (cells moving half a diameter or more per frame are lost)",
                            choices=FOLLOW_MODES)
    child_fraction: float = 0.6
    mother_fraction: float = 0.2
    division_min_frames: int = cli_field(3, "--division-min-frames", "a division whose daughter lasts fewer "
                                         "frames is flagged suspect")
    division_min_cycle: int = cli_field(5, "--division-min-cycle", "a division within this many frames of the "
                                        "mother's own birth is flagged suspect")
    division_area_tolerance: float = cli_field(0.4, "--division-area-tolerance", "a division whose daughters' "
                                               "areas sum to the mother's off by more than this fraction is "
                                               "flagged suspect")

    def __post_init__(self):
        if not isinstance(self.mode, str) or self.mode not in TRACK_MODES:
            _fail(type(self), "mode", self.mode, f"one of {TRACK_MODES}")
        if not isinstance(self.follow, str) or self.follow not in FOLLOW_MODES:
            _fail(type(self), "follow", self.follow, f"one of {FOLLOW_MODES}")
        for name in ("min_iou", "child_fraction", "mother_fraction"):
            self._number(name, strict=True, high=1.0)
        self._number("max_gap", integer=True)
        self._number("division_min_frames", integer=True)
        self._number("division_min_cycle", integer=True)
        self._number("division_area_tolerance")


@dataclass(frozen=True)
class EventOptions(_Options, stage="events", title="T1 events"):
    """T1 detection and classification (:func:`hexatissue.detect_t1`).

    Parameters
    ----------
    min_length : float
        Junctions shorter than this (px) count as four-fold vertices.
    censor : int, optional
        T1s starting within this many frames of the end are ``unresolved``.
        None (default): from the movie, :func:`hexatissue.events.default_censor`
        (``min(10, max(1, n_frames // 5))``); :func:`hexatissue.analyze`
        records the value used.
    """

    min_length: float = cli_field(0.0, "--min-length", "contacts shorter than this (px) count as four-fold "
                                  "vertices in T1 detection")
    censor: int | None = cli_field(None, "--censor", "T1s within this many frames of the end are 'unresolved' "
                                   "(default: min(10, max(1, frames // 5)))")

    def __post_init__(self):
        self._number("min_length")
        self._number("censor", integer=True, allow_none=True)


@dataclass(frozen=True)
class IntensityOptions(_Options, stage="intensity", title="raw channel intensities"):
    """Intensities of a raw channel on the junction network (:func:`hexatissue.intensity.measure_intensity`).

    Parameters
    ----------
    image : str, Path, array or Source, optional
        The raw channel (e.g. E-cadherin, myosin), of the labels' shape, with
        one frame per frame of the labels or one frame for all (read with
        :func:`hexatissue.open_source`).  None (default): the stage does not run.
        ``metadata.json`` records a path as given and other images by their
        description (``source["intensity"]``).
    channel : int, optional
        Channel of a multi-channel ``image`` file (0-based).
    step : float
        Distance between samples along a junction, px.
    """

    image: object = cli_field(None, "--intensity", "a raw channel (e.g. E-cadherin) of the labels' shape: junction "
                              "and cell intensities, junction polarity", type=str, metavar="FILE")
    channel: int | None = cli_field(None, "--intensity-channel", "channel of a multi-channel --intensity file")
    step: float = cli_field(0.5, "--intensity-step", "distance between samples along a junction, px")

    def __post_init__(self):
        self._number("channel", integer=True, allow_none=True)
        self._number("step", strict=True)
        if self.channel is not None and self.image is None:
            raise InputError(f"IntensityOptions.channel selects a channel of IntensityOptions.image, which is not "
                             f"given; got channel={self.channel!r}")

    @property
    def enabled(self) -> bool:
        """Whether the stage runs (an image is given)."""
        return self.image is not None

    def to_dict(self) -> dict:
        """Plain dict for JSON; an image that is not a path is recorded as None (its description is in
        ``source["intensity"]``)."""
        image = self.image
        return {"image": os.fspath(image) if isinstance(image, (str, os.PathLike)) else None, "channel": self.channel,
                "step": self.step}


@dataclass(frozen=True)
class SurfaceOptions(_Options, stage="surface", title="curved tissue: cells on a height map"):
    """Cells measured on the curved surface a height map describes (:func:`hexatissue.surface.surface_arrays`).

    Every cell polygon's vertices are lifted onto the height map (bilinear
    at the sub-pixel vertex), and each cell is measured in its tangent plane:
    its area and perimeter in 3-D, its unit normal and its shape functions
    gamma_p (the orders of the order stage) in a tangent frame whose first
    axis is the image x axis projected on the plane (docs/surface.md).

    Parameters
    ----------
    image : str, Path, array or Source, optional
        The height map: z of the tissue's surface at every pixel, of the
        labels' shape, one frame per frame of the labels or one frame for all
        (read with :func:`hexatissue.open_source`), as surface projections
        (LocalZProjector, SurfCut, PreMosa, MorphoGraphX) write it; finite
        everywhere.  None (default): the stage does not run.
        ``metadata.json`` records a path as given and other images by their
        description (``source["surface"]``).
    channel : int, optional
        Channel of a multi-channel ``image`` file (0-based).
    pixel_size : float, optional
        The height map's unit: None (default) when the heights are in px
        (the lateral pixel's length); else the length of a pixel in the
        heights' calibrated unit (e.g. 0.2 for heights in µm at 0.2 µm/px).
    z_step : float
        Length of one unit of the height map, in px or (with ``pixel_size``)
        in the calibrated unit: the slice spacing for a height map of slice
        indices (default 1).  Heights are converted to px as
        ``z = height * z_step / pixel_size``.
    center : {"vertex_mean", "area_centroid"}
        Cell centre of the surface shape functions, in the tangent plane.
    """

    image: object = cli_field(None, "--surface", "a height map of the labels' shape (z of the tissue's surface per "
                              "pixel, from a surface projection): cell areas, perimeters, normals and gamma_p on the "
                              "surface", type=str, metavar="FILE")
    channel: int | None = cli_field(None, "--surface-channel", "channel of a multi-channel --surface file")
    pixel_size: float | None = cli_field(None, "--surface-pixel-size", "the heights are in a calibrated unit (e.g. "
                                         "um) in which a pixel is this long (default: heights in px)", type=float)
    z_step: float = cli_field(1.0, "--surface-z-step", "length of one unit of the height map, in px or in the unit of "
                              "--surface-pixel-size (the slice spacing for heights given as slice indices)")
    center: str = "vertex_mean"

    def __post_init__(self):
        self._number("channel", integer=True, allow_none=True)
        self._number("pixel_size", strict=True, allow_none=True)
        self._number("z_step", strict=True)
        if self.center not in CENTERS:
            _fail(type(self), "center", self.center, f"one of {CENTERS}")
        if self.channel is not None and self.image is None:
            raise InputError(f"SurfaceOptions.channel selects a channel of SurfaceOptions.image, which is not "
                             f"given; got channel={self.channel!r}")
        image = self.image
        if image is None or isinstance(image, (str, os.PathLike)) or hasattr(image, "image"):
            return  # a file or a Source: read (and checked) frame by frame
        try:
            heights = np.asarray(image, dtype=float)
        except (TypeError, ValueError):
            _fail(type(self), "image", f"<{type(image).__name__}>", "the surface's height map: a path, a Source or a 2-D or "
                  "3-D (frames, rows, cols) array of numbers")
        if heights.ndim not in (2, 3):
            _fail(type(self), "image", f"<array of shape {heights.shape}>", "a 2-D or 3-D (frames, rows, cols) "
                  "array of heights")
        if not np.isfinite(heights).all():
            raise InputError(f"SurfaceOptions.image holds {int((~np.isfinite(heights)).sum())} NaN or infinite "
                             f"height(s); fill the pixels with no surface (e.g. with their neighbours' heights)")

    @property
    def enabled(self) -> bool:
        """Whether the stage runs (a height map is given)."""
        return self.image is not None

    @property
    def scale(self) -> float:
        """px per unit of the height map: ``z_step / pixel_size`` (``z_step`` when the heights are in px)."""
        return self.z_step / (1.0 if self.pixel_size is None else self.pixel_size)

    def to_dict(self) -> dict:
        """Plain dict for JSON; a height map that is not a path is recorded as None (its description is in
        ``source["surface"]``)."""
        out = {f.name: getattr(self, f.name) for f in fields(self)}  # (asdict would deep-copy an array)
        out["image"] = os.fspath(self.image) if isinstance(self.image, (str, os.PathLike)) else None
        return out


@dataclass(frozen=True)
class DeformationOptions(_Options, stage="deformation", title="deformation budget"):
    """The tissue's deformation budget (:func:`hexatissue.deformation.deformation_budget`).

    Parameters
    ----------
    enabled : bool
        Run the stage (off by default).  It needs cell tracks.
    t1_events : {"quartets", "neighbours"}
        The table that names each T1's kind: the quartet ``events`` or the
        per-cell ``neighbour_events``.
    grid : bool
        Also a budget per region of the Gamma_p grid (when the order fields
        run).
    roi : str, Path or array, optional
        Regions of interest: a label image (or a bool mask) drawn on frame
        ``roi_frame``; each region follows its cells (and their daughters).
        ``metadata.json`` records a path as given, an array as None.
    roi_frame : int
        The frame ``roi`` is drawn on.
    """

    enabled: bool = cli_field(False, "--deformation", "the tissue's deformation budget: shear and growth split into "
                              "cell shape change, T1 cycles, intercalations, divisions, extrusions (needs tracks)",
                              action="store_true")
    t1_events: str = cli_field("quartets", "--deformation-t1", "the table naming each T1's kind",
                               choices=T1_SOURCES)
    grid: bool = cli_field(True, "--no-deformation-grid", "no budget per region of the Gamma_p grid",
                           action="store_false")
    roi: object = cli_field(None, "--deformation-roi", "a label image of regions of interest drawn on "
                            "--deformation-roi-frame; each follows its cells", type=str, metavar="FILE")
    roi_frame: int = cli_field(0, "--deformation-roi-frame", "the frame the regions of interest are drawn on")

    def __post_init__(self):
        self._flags("enabled", "grid")
        if self.t1_events not in T1_SOURCES:
            _fail(type(self), "t1_events", self.t1_events, f"one of {T1_SOURCES}")
        self._number("roi_frame", integer=True)
        roi = self.roi
        if isinstance(roi, (str, os.PathLike)):  # checked now, so a movie is not analysed for nothing
            if os.path.splitext(os.fspath(roi))[1].lower() not in (".npy", ".tif", ".tiff", ".png"):
                _fail(type(self), "roi", roi, "a .npy, .tif or .png label image")
            if not os.path.isfile(roi):
                _fail(type(self), "roi", roi, "an existing file")
        elif roi is not None:
            shape = np.shape(roi)
            kind = np.asarray(roi).dtype.kind
            if len(shape) != 2 or kind not in "biu":
                _fail(type(self), "roi", f"<{np.asarray(roi).dtype} array of shape {shape}>",
                      "a 2-D label image (ints, or a bool mask)")

    def to_dict(self) -> dict:
        """Plain dict for JSON; a region image that is not a path is recorded as None."""
        out = super().to_dict()
        out["roi"] = os.fspath(self.roi) if isinstance(self.roi, (str, os.PathLike)) else None
        return out


@dataclass(frozen=True)
class FlowOptions(_Options, stage="flow", title="tissue flow"):
    """Tissue flow: cell velocities and velocity-gradient fields on the Gamma_p grid (:mod:`hexatissue.flow`).

    Parameters
    ----------
    enabled : bool
        Compute ``cells.vx``, ``cells.vy`` and, with the order fields, the
        ``flow`` table.
    radius_factor : float
        Disk radius of each node's affine fit in units of the order field's
        radius (:func:`hexatissue.flow.flow_fields`; default 2: ~9 cells).
    min_cells : int
        Fewest cells a fit takes (at least 3).
    piv : bool
        With a raw channel (``IntensityOptions.image``) and the flow fields:
        its PIV velocity at every node (:func:`hexatissue.flow.piv.piv_fields`;
        ``flow.piv_vx``, ``piv_vy``, ``piv_peak``).
    """

    enabled: bool = cli_field(True, "--no-flow", "no cell velocities or flow fields", action="store_false")
    radius_factor: float = cli_field(2.0, "--flow-radius-factor", "disk radius of the flow fields' fits, in units "
                                     "of the order field's radius")
    min_cells: int = cli_field(3, "--flow-min-cells", "fewest cells in a flow field's fit (at least 3)")
    piv: bool = cli_field(True, "--no-piv", "no PIV of the --intensity channel on the flow grid",
                          action="store_false")

    def __post_init__(self):
        self._flags("enabled", "piv")
        self._number("radius_factor", strict=True)
        self._number("min_cells", low=3, integer=True)


@dataclass(frozen=True)
class MechanicsOptions(_Options, stage="mechanics", title="force inference"):
    """Junction tensions, cell pressures and stress from force balance (:func:`hexatissue.mechanics.infer_forces`).

    Parameters
    ----------
    enabled : bool
        Run the stage (off by default).
    method : {"bayes", "lsq"}
        Bayesian MAP with the prior's weight chosen by ABIC, or least squares
        (determined only in periodic boxes; NaN where the balance leaves an
        unknown free).
    mu : float, optional
        Fixed prior weight for ``bayes`` (default: ABIC).
    sd : bool
        Posterior standard deviations (``bayes``; one solve per unknown).
    junctions : {"auto", "straight", "curved"}
        The junction model.  ``"auto"``: per junction, an arc (Young-Laplace:
        balanced by its end tangents, its curvature setting the pressure
        difference across it) where its own pixels show a curvature beyond
        pixel noise, else straight, its direction the line fitted to its
        pixels (:func:`hexatissue.mechanics.frame_forces`).  ``"straight"``:
        every junction straight along its chord, the pressures pushing on
        the vertices (the vertex model's balance).  ``"curved"``: every
        junction an arc.  Polygon input (no pixels) is always straight.
    curved : bool, optional
        The former switch (``--straight-junctions`` sets it False):
        False means ``junctions="straight"``, True ``"curved"``; None leaves
        ``junctions`` as given.
    """

    enabled: bool = cli_field(False, "--mechanics", "force inference: junction tensions, cell pressures and the "
                              "Batchelor stress, per cell and on the Gamma_p grid", action="store_true")
    method: str = cli_field("bayes", "--mechanics-method", "estimator: Bayesian with ABIC, or least squares",
                            choices=FORCE_METHODS)
    mu: float | None = cli_field(None, "--mechanics-mu", "fixed prior weight of the Bayesian estimator "
                                 "(default: chosen by ABIC)", type=float)
    sd: bool = cli_field(True, "--no-mechanics-sd", "no posterior standard deviations (faster on large frames)",
                         action="store_false")
    junctions: str = cli_field("auto", "--junctions", "junction model: an arc where the junction's pixels show a "
                               "curvature beyond pixel noise, else its fitted line (auto); all straight; all arcs",
                               choices=JUNCTION_MODELS)
    curved: bool | None = cli_field(None, "--straight-junctions", "the same as --junctions straight",
                                    action="store_const", const=False)

    def __post_init__(self):
        self._flags("enabled", "sd")
        if self.curved is not None:
            if not isinstance(self.curved, bool):
                _fail(type(self), "curved", self.curved, "True, False or None")
            object.__setattr__(self, "junctions", "curved" if self.curved else "straight")
            object.__setattr__(self, "curved", None)
        if self.junctions not in JUNCTION_MODELS:
            _fail(type(self), "junctions", self.junctions, f"one of {JUNCTION_MODELS}")
        if self.method not in FORCE_METHODS:
            _fail(type(self), "method", self.method, f"one of {FORCE_METHODS}")
        if self.mu is not None and not (is_real(self.mu) and self.mu > 0):
            _fail(type(self), "mu", self.mu, "a positive finite number or None")
        if self.mu is not None:
            object.__setattr__(self, "mu", float(self.mu))


def check_options(value, name):
    """``value`` if it is an instance of the options class of stage ``name``; else :class:`InputError`."""
    cls = OPTION_CLASSES[name]
    if not isinstance(value, cls):
        raise InputError(f"{name} must be a hexatissue.{cls.__name__}; got {type(value).__name__}")
    return value

