"""Label images of every convention -> touching integer labels.

Three conventions are accepted (``kind``):

``"touching"``
    Cells share borders directly (Cellpose masks, watershed output); 0 is
    background outside the tissue.  0-valued pockets smaller than
    ``POCKET_AREA`` px (holes, gaps at triple junctions of segmented phase
    fields) are filled from their neighbours.
``"membrane"``
    Cells are separated by 0-valued junction lines 1-2 px wide (Tissue
    Analyzer, EpySeg, EpiCure).  Zero pixels within ``membrane_width`` px of
    a cell are given to the neighbouring cells (majority of the 4
    neighbours), so each cell's area includes its share of the membrane;
    wider background stays 0.
``"skeleton"``
    A binary image whose nonzero pixels are junction lines; the cells are the
    4-connected regions enclosed by the lines, numbered 1..n,
    then handled as ``"membrane"``.

``"auto"`` picks ``"skeleton"`` for a binary image whose foreground is thin
lines, ``"membrane"`` when more 0-pixels lie between two different cells (in
a 1-2 px gap along a row or column) than there are direct cell-cell
contacts, and ``"touching"`` otherwise.  The kind is detected on the input
as given.

Outside and background (all become 0, so the cells next to them are border
cells, ``is_border``), in this order:

1. ``background``: label ids that are outside (a rim label of hand-labelled
   data).  For skeletons the ids are those of the enclosed regions (the cell
   ids of the output).
2. ``mask``: pixels outside a region of interest (a 2-D bool image).  They
   are 0 in the final labels too: membranes are not shared out across the
   mask's edge.
3. ``min_area``: smaller regions are membrane.
4. ``outside="auto"`` (open images): a region that touches the image edge
   and is larger than ``OUTSIDE_FACTOR`` (20) times the median region area
   (of the regions of at least ``min_area`` px) is the outside: of a masked
   skeleton, or the outside label of a hand-labelled tissue whose
   background is not 0 (labels of the other kinds: only a label holding at
   least a tenth of the image edge, and with a warning).  Wherever it is,
   edge or not, a region that encloses the tissue (its holes hold at least
   ``ENCLOSED_SHARE`` of the other regions' pixels: a rim label around a
   hand-labelled tissue, the outside of a skeleton drawn along the image
   edge) is the outside too (with a warning, except for skeletons).
   ``"none"`` keeps them as cells.
5. Membranes are shared out (kinds ``"membrane"``, ``"skeleton"``).
6. ``fill_holes``: 0-valued 4-connected pockets smaller than this many px
   that do not touch the edge of an open image are holes between touching
   cells and are filled from their neighbours (all kinds; 0 disables).
   Default ``POCKET_AREA`` (16 px): gaps at triple junctions.
"""
from __future__ import annotations

import warnings

import numpy as np
from scipy import ndimage

from .._components import components
from .._dispatch import Kernels
from ..errors import FrameWarning, HexatissueWarning, InputError, is_real
from ..options import KINDS, OUTSIDE_RULES, POCKET_AREA, check_background
from . import _kernels

K = Kernels(_kernels, "hexatissue.mesh._reference")

OUTSIDE_FACTOR = 20  # a region touching the image edge and > 20 x the median region area is the outside
OUTSIDE_EDGE_SHARE = 0.1  # a label holding this share of the image edge's pixels may be the outside (any kind)
ENCLOSED_SHARE = 0.9  # a region whose holes hold this share of the other regions' pixels encloses the tissue
SKELETON_MIN_AREA = 4  # px: smaller regions enclosed by skeleton lines are specks, not cells


def validate_labels(labels, name="labels") -> np.ndarray:
    """Check a 2-D label image and return it as a non-negative integer array."""
    return checked_labels(labels, name)[0]


def checked_labels(labels, name="labels", kind="auto"):
    """:func:`validate_labels`, and the smallest and largest id of the image it returns (found on the way).

    The ids are None for a bool image (not summarised).  ``kind``: the
    label convention the analysis was told (``"skeleton"``: regions that are
    lines are expected, so the test for drawings of lines is skipped).
    """
    arr = np.asarray(labels)
    if arr.ndim != 2:
        hint = " (for a T x Y x X stack use hexatissue.analyze)" if arr.ndim == 3 else ""
        raise InputError(f"{name} must be a 2-D image indexed [row, col]; got an array of shape {arr.shape}{hint}")
    if arr.size == 0 or min(arr.shape) < 2:
        raise InputError(f"{name} must be at least 2 x 2 pixels; got shape {arr.shape}")
    if arr.dtype == bool:  # not summarised (skeletons and masks): ids unknown
        return arr.astype(np.uint8), None, None
    if arr.dtype.kind == "f":
        if not np.all(np.isfinite(arr)):
            raise InputError(f"{name} contains NaN or infinite values; expected integer cell ids")
        if not np.array_equal(arr, np.round(arr)):
            raise InputError(f"{name} has non-integer float values (dtype {arr.dtype}); expected integer cell ids "
                             f"(for a membrane probability map: --kind membrane-map segments it)")
        if float(arr.max()) >= 2**31:  # 2**31 as float16 would overflow (inf): compared as a Python float
            raise InputError(f"{name} has float ids up to {arr.max()}; expected ids below 2**31")
        arr = arr.astype(np.int64)
    elif arr.dtype.kind not in "iu":
        raise InputError(f"{name} must hold integer cell ids; got dtype {arr.dtype}")
    if not arr.dtype.isnative:  # big-endian TIFF data: the kernel needs the machine's byte order
        arr = arr.astype(arr.dtype.newbyteorder("="))
    lo, hi, nonzero, same_h, same_v = K.label_summary(arr)  # one pass instead of one per check
    if arr.dtype.kind == "u" and arr.dtype.itemsize == 8 and hi > np.iinfo(np.int64).max:
        raise InputError(f"{name} has ids up to {hi} (uint64); expected ids below 2**63 (cell ids are "
                         f"int64 in the tables): relabel the image")
    if arr.dtype.kind == "i" and lo < 0:
        raise InputError(f"{name} has negative ids (min {lo}); expected 0 = background and positive cell ids")
    if not nonzero:
        raise InputError(f"{name} is all zeros: there are no cells")
    _check_label_like(arr, name, same_h, same_v)
    if kind != "skeleton":
        _check_regions_are_areas(arr, name, int(lo), int(hi))
    return arr, int(lo), int(hi)


#: A label image has most pixels inside cells, so most pairs of neighbouring pixels share a label:
#: 0.88-0.97 in every real segmentation we hold (labels, membranes, skeletons), against 0.003-0.51
#: in raw microscopy images (intensities vary from pixel to pixel).
MIN_SAME_NEIGHBOUR = 0.7
LABEL_CHECK_PIXELS = 4096  # smaller images (hand-made test cases) are not checked


def _check_label_like(arr, name, same_h, same_v):
    """Refuse images whose neighbouring pixels rarely share a value: intensities, not cell labels.

    ``same_h`` and ``same_v`` count the horizontal and vertical pairs of neighbours with equal values.
    """
    if arr.size < LABEL_CHECK_PIXELS:
        return
    h, w = arr.shape
    same = (same_h / (h * (w - 1)) + same_v / ((h - 1) * w)) / 2
    if same < MIN_SAME_NEIGHBOUR:
        raise InputError(f"{name} does not look like a label image: only {same:.0%} of neighbouring pixels share a "
                         f"value (a label image has most pixels inside cells, >= {MIN_SAME_NEIGHBOUR:.0%}); is it a "
                         f"raw microscopy image? Segment it first (e.g. Cellpose, EpySeg) and analyse the labels, or give a "
                         f"membrane channel with --kind membrane-map (a baseline watershed)")


#: In a segmentation most pixels of a cell lie inside it: at most 0.33 of the non-zero pixels of every
#: real label image we hold touch another value (4-neighbours), against 0.44-0.70 in dim raw planes
#: (few grey values) and 0.99-1.0 in drawings of coloured junction lines (benchmarks/input_corpus.py).
MAX_EDGE_SHARE = 0.4
#: A region image whose values each come in this many separate pieces on average or more is intensities.
SPECKS_PER_VALUE = 3
#: Side (px) of the central window whose regions are counted for :data:`SPECKS_PER_VALUE`.
PIECES_WINDOW = 512
#: Above this edge share, with most pixels 0, the regions are lines drawn on a black ground.
LINE_EDGE_SHARE = 0.9


def _check_regions_are_areas(arr, name, lo, hi):
    """Refuse images whose regions are lines or specks: coloured junction drawings and dim raw planes.

    Binary images (skeletons, masks) are not tested: their lines are meant.
    """
    if arr.size < LABEL_CHECK_PIXELS or min(arr.shape) < 3:
        return
    c = arr[1:-1, 1:-1]
    n_nonzero = int(np.count_nonzero(c))
    if not n_nonzero:
        return
    inner = c != 0  # in place from here: at most two bool images at a time (frames are read with little memory)
    for other in (arr[:-2, 1:-1], arr[2:, 1:-1], arr[1:-1, :-2], arr[1:-1, 2:]):
        inner &= c == other
    share = 1 - np.count_nonzero(inner) / n_nonzero
    del inner
    if share < MAX_EDGE_SHARE:
        return
    if np.count_nonzero((arr == lo) | (arr == hi)) == arr.size:  # two values: a skeleton or a mask
        return
    values = np.unique(arr)
    values = values[values != 0]
    zero = 1 - np.count_nonzero(arr) / arr.size
    if share >= LINE_EDGE_SHARE and zero >= 0.5:  # lines on a black ground (4-connected pieces: any number)
        raise InputError(
            f"{name} does not look like a segmentation: its {len(values)} values are lines on a black ground, not "
            f"cell areas ({share:.0%} of its non-zero pixels touch another value, a cell is mostly inside; "
            f"{zero:.0%} of the pixels are 0). Is it a drawing of the junctions in colour (one colour per junction, as "
            f"vertex-extraction tools draw them)? Give the label image it was drawn from, or analyse the lines as "
            f"a skeleton with --kind skeleton (kind='skeleton')")
    # counted on a central window of at most PIECES_WINDOW px a side: bounded time and memory on any frame
    r0, c0 = max(0, (arr.shape[0] - PIECES_WINDOW) // 2), max(0, (arr.shape[1] - PIECES_WINDOW) // 2)
    window = arr[r0:r0 + PIECES_WINDOW, c0:c0 + PIECES_WINDOW]
    in_window = np.unique(window)
    pieces = _pieces(window) / max(1, np.count_nonzero(in_window))
    if pieces >= SPECKS_PER_VALUE:
        raise InputError(
            f"{name} does not look like a segmentation: it holds {len(values)} values ({lo}-{hi}), each scattered "
            f"over {pieces:.0f} separate specks on average ({share:.0%} of its non-zero pixels touch another "
            f"value; a cell is one region, mostly inside). Is it a dim raw image (a plane of a stack with few grey "
            f"values)? Segment it first (e.g. Cellpose, EpySeg) and analyse the labels, or give a membrane channel "
            f"with --kind membrane-map (a baseline watershed)")


def _pieces(arr):
    """Number of 4-connected regions of equal non-zero value (each region counted once)."""

    index = np.arange(arr.size).reshape(arr.shape)
    a, b = [], []
    for same, first, second in ((arr[:, 1:] == arr[:, :-1], index[:, 1:], index[:, :-1]),
                                (arr[1:] == arr[:-1], index[1:], index[:-1])):
        a.append(first[same])
        b.append(second[same])
    comp = components(arr.size, np.concatenate(a), np.concatenate(b))
    return len(np.unique(comp[(arr != 0).ravel()]))


def _direct_and_separating(lab):
    """Counts of direct cell-cell contacts and of 0-pixels lying between two different cells.

    A 0-pixel separates when, along a row or a column, the nearest pixels on
    either side within a 1-2 px gap of zeros belong to two different cells.
    """
    direct = separating = 0
    for axis in (0, 1):
        before = np.roll(lab, 1, axis)
        after1 = np.roll(lab, -1, axis)
        after2 = np.roll(lab, -2, axis)
        cells = (lab != 0) & (before != 0)
        direct += int(np.count_nonzero(cells & (lab != before)))
        zero = lab == 0
        one_gap = zero & (before != 0) & (after1 != 0) & (before != after1)
        two_gap = zero & (after1 == 0) & (before != 0) & (after2 != 0) & (before != after2)
        separating += int(np.count_nonzero(one_gap | two_gap))
    return direct, separating


def detect_kind(lab, periodic=False, lowest=None) -> str:
    """Guess the convention of a validated label image (see module docstring).

    ``lowest``: ``lab.min()`` if the caller knows it already (saves a pass over the image).
    """
    # a contiguous copy (of ~256 x 256 px): the kernel then has one layout, compiled by mesh.warm_up
    sample = np.ascontiguousarray(lab[:: max(1, lab.shape[0] // 256), :: max(1, lab.shape[1] // 256)])
    if K.at_most_two_values(sample) and len(np.unique(lab)) == 2:
        fg = lab != 0
        interior = ndimage.binary_erosion(fg, border_value=1)
        if fg.mean() < 0.5 and interior.sum() < 0.2 * fg.sum():
            return "skeleton"
    if (lab.min() if lowest is None else lowest) > 0:  # no 0 pixel
        return "touching"
    direct, separating = _direct_and_separating(lab)
    return "membrane" if separating > direct else "touching"


def label_skeleton(skeleton, periodic=False) -> np.ndarray:
    """Number the 4-connected regions enclosed by the nonzero lines of ``skeleton`` 1..n."""
    return _regions(skeleton == 0, periodic).astype(np.int32)


def _regions(foreground, periodic):
    """4-connected regions of a bool image numbered 1..n (0 elsewhere); on a torus, across the box edges too."""
    cells, n = ndimage.label(foreground)
    if periodic and n > 1:
        # regions touching across the box edges are one region
        a = np.r_[cells[:, 0], cells[0, :]]
        b = np.r_[cells[:, -1], cells[-1, :]]
        keep = (a > 0) & (b > 0)
        comp = components(n + 1, a[keep], b[keep])
        new_id = np.zeros(n + 1, np.int64)
        new_id[1:] = np.unique(comp[1:], return_inverse=True)[1] + 1
        cells = new_id[cells]
    return cells


def normalize_labels(labels, kind="auto", periodic=False, membrane_width=3, min_area=None, *, background=(),
                     fill_holes=POCKET_AREA, outside="auto", mask=None):
    """Touching integer labels from any convention (see the module docstring for the rules).

    Returns
    -------
    labels : (rows, cols) integer array
        Cells touch directly; 0 only where background is wider than
        ``membrane_width``, outside the mask and for the outside regions.
    membrane : (rows, cols) bool array
        Pixels that were junction lines and were given to a cell.
    """
    lab = validate_labels(labels)
    return normalize_valid(lab, kind, periodic, membrane_width, min_area, background=background,
                           fill_holes=fill_holes, outside=outside, mask=check_mask(mask, lab.shape))


def check_mask(mask, shape, name="mask"):
    """A region-of-interest mask as a bool array of ``shape`` (None stays None); nonzero = inside."""
    if mask is None:
        return None
    arr = np.asarray(mask)
    if arr.dtype.kind not in "biuf":
        raise InputError(f"{name} must be a 2-D bool or integer image (nonzero = inside); got dtype {arr.dtype}")
    if arr.shape != tuple(shape):
        raise InputError(f"{name} must have the shape of the labels {tuple(shape)}; got {arr.shape}")
    if arr.dtype.kind == "f" and not np.all(np.isfinite(arr)):
        raise InputError(f"{name} contains NaN or infinite values")
    inside = arr != 0
    if not inside.any():
        raise InputError(f"{name} is all zeros: no pixel is inside the region of interest")
    return inside




def normalize_valid(lab, kind="auto", periodic=False, membrane_width=3, min_area=None, *, background=(),
                    fill_holes=POCKET_AREA, outside="auto", mask=None, lowest=None):
    """:func:`normalize_labels` of labels already checked by :func:`validate_labels` (and ``mask`` by
    :func:`check_mask`).

    ``lowest``: ``lab.min()`` if the caller knows it already (:func:`checked_labels`).  The labels
    come back as the same array object exactly when they are unchanged.
    """
    if kind not in KINDS:
        raise InputError(f"kind must be one of {KINDS}; got {kind!r}")
    if outside not in OUTSIDE_RULES:
        raise InputError(f"outside must be one of {OUTSIDE_RULES}; got {outside!r}")
    if not (isinstance(membrane_width, (int, np.integer)) and membrane_width >= 0):
        raise InputError(f"membrane_width must be a non-negative whole number of px; got {membrane_width!r}")
    if not (isinstance(fill_holes, (int, np.integer)) and not isinstance(fill_holes, bool) and fill_holes >= 0):
        raise InputError(f"fill_holes must be a non-negative whole number of px; got {fill_holes!r}")
    if min_area is not None and not (is_real(min_area) and min_area >= 0):
        raise InputError(f"min_area must be a non-negative number of px (or None: the kind's default); "
                         f"got {min_area!r}")
    background = check_background(background)
    if kind != "skeleton":
        _refuse_white_membranes(lab, background)
    given = lab
    if kind == "membrane-map":  # segmented already (Source.checked_frame, mesh_from_labels): touching labels
        kind = "touching"
    if kind == "auto":
        kind = detect_kind(lab, periodic, lowest)
    if kind == "skeleton":
        lab = label_skeleton(lab, periodic)
        if lab.max() == 0:
            raise InputError("labels: the skeleton encloses no region; expected junction lines around cells")
    if background:
        lab = np.where(np.isin(lab, background), 0, lab)
    if mask is not None:
        lab = np.where(mask, lab, 0)
    if min_area is None:
        min_area = SKELETON_MIN_AREA if kind == "skeleton" else 0
    dropped = min_area > 0
    if dropped:
        lab = _drop_small(lab, min_area)
    if kind == "skeleton" and outside == "auto" and not periodic:  # region ids 1..n: a bincount is small
        lab = _drop_outer_regions(lab, np.bincount(lab.ravel()))
        lab = _drop_enclosing(lab, warn=False)
    elif outside == "auto" and not periodic:
        lab = _drop_enclosing(_drop_outside_label(lab), warn=True)
    # no 0 pixel (ids are non-negative): a min does not build a mask
    positive = (lab.min() if lowest is None or lab is not given else lowest) > 0
    if not positive and not lab.any():
        removed = ["the background", "the outside", "the pixels outside the mask"] + \
            ([f"the regions smaller than min_area = {min_area:g} px"] if dropped else [])
        raise InputError(f"labels: no cell is left after removing {', '.join(removed[:-1])} and {removed[-1]}")
    membrane = np.zeros(lab.shape, bool)
    if positive:
        return lab, membrane
    zero = lab == 0
    dtype = np.int32 if lab.max() < 2**31 else np.int64
    lab = np.ascontiguousarray(lab, dtype=dtype)
    if kind in ("membrane", "skeleton") and membrane_width > 0:
        lab = K.fill_gaps(lab, int(membrane_width), bool(periodic))
        if mask is not None:
            lab[~mask] = 0
        membrane = zero & (lab != 0)
    lab, left = _fill_pockets(lab, fill_holes, periodic, mask)
    if mask is not None:
        lab[~mask] = 0
    if len(left):
        _hole_hint(lab, left, fill_holes)
    return lab, membrane


def mesh_labels(labels, box, mesh, mask=None, lowest=None):
    """The touching labels the mesh (and the tracker) of :func:`hexatissue.analyze` use for one validated frame.

    The one door from a label image to the cells of an analysis: exporters
    and scorers that must match the ``cells`` table of a results folder
    (``hexatissue export --to ctc``, :func:`hexatissue.benchmark.score.score`)
    call this with the analysis's own options and mask.

    Parameters
    ----------
    labels : (rows, cols) integer array
        One frame, checked by :func:`validate_labels` (as
        :meth:`hexatissue.Source.frame` gives it).
    box : Box or None
        The periodic box (only whether there is one matters), None for an
        open image.
    mesh : MeshOptions
        ``kind``, ``membrane_width``, ``min_area``, ``background``,
        ``fill_holes`` and ``outside`` of the analysis.
    mask : (rows, cols) bool array, optional
        Region of interest, checked by :func:`check_mask` (e.g. from
        :func:`hexatissue.source.read_mask`).
    lowest : int, optional
        ``labels.min()`` if the caller knows it already.

    Returns
    -------
    labels : (rows, cols) integer array
        The normalised labels (see :func:`normalize_labels`): membranes
        shared out, background, small regions and the outside 0; the same
        array object when unchanged.
    membrane : (rows, cols) bool array
        The pixels that were membrane.
    """
    return normalize_valid(labels, mesh.kind, box is not None, mesh.membrane_width, mesh.min_area,
                           background=mesh.background, fill_holes=mesh.fill_holes, outside=mesh.outside, mask=mask,
                           lowest=lowest)


def relabel(lab, ids, values, others=None):
    """``lab`` with each id of ``ids`` (sorted, unique) replaced by the matching entry of ``values``.

    Pixels holding any other value keep it (``others`` None) or become ``others``.
    """
    ids, values = np.asarray(ids, np.int64), np.asarray(values, np.int64)
    if not len(ids):
        return lab.copy() if others is None else np.full(lab.shape, others, np.int64)
    key = np.minimum(np.searchsorted(ids, lab), len(ids) - 1)
    return np.where(ids[key] == lab, values[key], lab if others is None else others)


def outer_regions(lab, counts=None):
    """Ids of the regions touching the image edge with more than ``OUTSIDE_FACTOR`` x the median region area.

    The rule for the outside of a masked skeleton (an open image): its one
    large region around the tissue.  ``counts`` are the pixel counts per id
    (``np.bincount(lab.ravel())``).
    """
    if counts is None:
        counts = np.bincount(lab.ravel())
    areas = counts[1:][counts[1:] > 0]
    if len(areas) < 2:
        return np.zeros(0, np.int64)
    edge = np.unique(np.r_[lab[0], lab[-1], lab[:, 0], lab[:, -1]])
    edge = edge[edge > 0]
    return edge[counts[edge] > OUTSIDE_FACTOR * np.median(areas)]


#: A label whose pixels border this fraction of all cells or more is a line network, not a cell.
WHITE_LINE_FRACTION = 0.5


def _refuse_white_membranes(lab, background):
    """Membranes drawn with the dtype's largest value (white lines) instead of 0 would be one giant cell."""
    if lab.dtype.kind != "u" or lab.dtype.itemsize > 2:
        return
    white = np.iinfo(lab.dtype).max
    if white in background or not (lab == white).any():
        return
    beside = np.r_[lab[:, 1:][lab[:, :-1] == white], lab[:, :-1][lab[:, 1:] == white],
                   lab[1:][lab[:-1] == white], lab[:-1][lab[1:] == white]]
    touched = np.unique(beside[(beside != white) & (beside != 0)])
    present = np.bincount(lab.ravel()) > 0  # ids below 65536: a bincount, not a sort
    n_cells = int(present[1:white].sum())
    if n_cells >= 10 and len(touched) >= WHITE_LINE_FRACTION * n_cells:
        raise InputError(f"label {white} (the largest {lab.dtype} value) borders {len(touched)} of {n_cells} cells: "
                         f"it looks like membranes drawn in white, not a cell. Set them to 0 first "
                         f"(labels[labels == {white}] = 0), or pass background=({white},) with kind='membrane' "
                         f"(--background {white} --kind membrane)")


def _drop_small(lab, min_area):
    """Regions of fewer than ``min_area`` px set to 0 (counted on compact ids: any id range)."""
    compact, _ = compact_labels(lab)
    counts = np.bincount(compact.ravel())
    small = counts < min_area
    small[0] = False
    return np.where(small[compact], 0, lab) if small.any() else lab


def _drop_outer_regions(lab, counts):
    outer = outer_regions(lab, counts)
    return np.where(np.isin(lab, outer), 0, lab) if len(outer) else lab


def _drop_outside_label(lab):
    """Labels with the outside label of a hand-labelled tissue (a label around it, not 0) set to 0, with a warning.

    The rule of a skeleton's outside (:func:`outer_regions`), for any labels: a label touching the image
    edge with more than ``OUTSIDE_FACTOR`` x the median cell area.  Only a label holding at least
    ``OUTSIDE_EDGE_SHARE`` of the image edge is a candidate, so ordinary frames cost one pass over their edge.
    """
    edge = np.r_[lab[0], lab[-1], lab[:, 0], lab[:, -1]]
    edge = edge[edge != 0]
    if not len(edge):
        return lab
    values, counts = np.unique(edge, return_counts=True)
    if counts.max() < OUTSIDE_EDGE_SHARE * (2 * sum(lab.shape)):
        return lab
    ids, areas = np.unique(lab, return_counts=True)
    areas = areas[ids != 0]
    ids = ids[ids != 0]
    if len(ids) < 3:
        return lab
    candidates = values[counts >= OUTSIDE_EDGE_SHARE * (2 * sum(lab.shape))]
    area_of = dict(zip(ids.tolist(), areas.tolist()))
    outer = [v for v in candidates.tolist() if area_of[v] > OUTSIDE_FACTOR * np.median(areas)]
    if not outer:
        return lab
    warnings.warn(f"label {', '.join(map(str, outer))} touches the image edge and covers more than "
                  f"{OUTSIDE_FACTOR} x the median cell area: it is taken as the outside of the tissue (like 0; the "
                  f"cells next to it are border cells). --outside none keeps it as a cell; --background LABEL names "
                  f"outside labels yourself", HexatissueWarning, stacklevel=2)
    return np.where(np.isin(lab, outer), 0, lab)


def enclosing_label(lab) -> tuple[int, float]:
    """``(id, share)`` of the region that encloses the others (0, 0.0 if none): the outside wherever it is.

    Its candidate is the first nonzero label met walking in from the middle
    of each of the four image edges (one pass over a row and a column, so an
    ordinary frame costs nothing more); it encloses the tissue when the
    holes of its region (the pixels it cuts off from the image edge) hold at
    least ``ENCLOSED_SHARE`` of the other regions' pixels, and there are at
    least two other regions.  ``share`` is that fraction.
    """
    rows, cols = lab.shape
    if rows < 3 or cols < 3:
        return 0, 0.0
    rays = (lab[rows // 2, :], lab[rows // 2, ::-1], lab[:, cols // 2], lab[::-1, cols // 2])
    first = set()
    for ray in rays:
        hit = np.flatnonzero(ray)
        if not len(hit):
            return 0, 0.0
        first.add(int(ray[hit[0]]))
    if len(first) != 1:
        return 0, 0.0
    candidate = first.pop()
    region = lab == candidate
    others = (lab != 0) & ~region
    n_others = int(others.sum())
    if not n_others:
        return 0, 0.0
    cut_off, _ = ndimage.label(~region)
    edge = np.unique(np.r_[cut_off[0], cut_off[-1], cut_off[:, 0], cut_off[:, -1]])
    inside = ~np.isin(cut_off, edge) & others
    share = float(inside.sum()) / n_others
    if share < ENCLOSED_SHARE or len(np.unique(lab[inside])) < 2:
        return 0, 0.0
    return candidate, share


def _drop_enclosing(lab, warn):
    """Labels with the region that encloses the tissue (:func:`enclosing_label`) set to 0; a warning if ``warn``."""
    outer, share = enclosing_label(lab)
    if not outer:
        return lab
    if warn:
        warnings.warn(f"label {outer} encloses the tissue (its holes hold {100 * share:.0f}% of the other cells' "
                      f"pixels): it is taken as the outside of the tissue (like 0; the cells next to it are border "
                      f"cells). --outside none keeps it as a cell; --background LABEL names outside labels yourself",
                      HexatissueWarning, stacklevel=2)
    return np.where(lab == outer, 0, lab)


def compact_labels(lab, top=None):
    """Labels renumbered 0..n in the order of their ids (0 stays 0 = background), as int32.

    ``top``: ``lab.max()`` if the caller knows it already.

    Returns
    -------
    compact : (rows, cols) int32 array
    ids : (n + 1,) int array
        Original id of each compact id; ``ids[0] == 0`` whether or not 0 occurs.
    """
    top = int(lab.max()) if top is None else top
    if top < 2**24 and top <= 4 * lab.size:
        present = K.present_ids(lab, top)  # no int64 copy of the image, unlike np.bincount
        present[0] = True
        ids = np.flatnonzero(present)
        if len(ids) == top + 1:
            return lab.astype(np.int32, copy=False), ids
        new = np.zeros(top + 1, np.int32)
        new[ids] = np.arange(len(ids), dtype=np.int32)
        return new[lab], ids
    ids, inv = np.unique(np.r_[0, lab.ravel()], return_inverse=True)
    return inv[1:].reshape(lab.shape).astype(np.int32), ids


def touches_outside(lab, periodic=False):
    """Sorted ids of the cells touching background 0 or, on an open image, the image edge.

    The same border rule as the mesh's ``is_border`` (a junction with cell 0,
    the edge of an open image counting as 0), for touching labels.
    """
    zero = lab == 0
    near = np.zeros(lab.shape, bool)
    if zero.any():
        for axis in (0, 1):
            for step in (1, -1):
                shifted = np.roll(zero, step, axis=axis)
                if not periodic:  # np.roll wraps; an open image has no neighbour across the edge
                    edge = (0 if step == 1 else -1)
                    index = [slice(None), slice(None)]
                    index[axis] = edge
                    shifted[tuple(index)] = False
                near |= shifted
    if not periodic:
        near[0, :] = near[-1, :] = near[:, 0] = near[:, -1] = True
    ids = np.unique(lab[near & ~zero])
    return ids[ids > 0]


def fill_pockets(lab, fill_holes=POCKET_AREA, periodic=False):
    """Labels with their 0-valued holes filled from the neighbouring cells (majority of 4 neighbours).

    A hole is a 4-connected 0-region smaller than ``fill_holes`` px that does
    not touch the edge of an open image; larger 0-regions are background and
    stay 0.  ``fill_holes=0`` fills nothing.
    """
    return _fill_pockets(lab, fill_holes, periodic)[0]


def _fill_pockets(lab, fill_holes, periodic, mask=None):
    """:func:`fill_pockets`, and the sizes (px) of the 0-regions left inside the tissue.

    Those are the pockets of ``fill_holes`` px or more that touch neither
    the edge of an open image nor the outside of ``mask``: holes in the
    tissue that stay background (empty with ``fill_holes=0``: nothing was
    asked).
    """
    zero = lab == 0
    if fill_holes <= 0 or not zero.any():
        return lab, np.zeros(0, np.int64)
    pockets = _regions(zero, periodic)
    sizes = np.bincount(pockets.ravel())
    small = sizes < fill_holes
    small[0] = False
    inner = np.ones(len(sizes), bool)
    inner[0] = False
    if not periodic:
        inner[np.r_[pockets[0], pockets[-1], pockets[:, 0], pockets[:, -1]]] = False
    if mask is not None:
        inner[pockets[~mask]] = False
    small &= inner
    left = sizes[inner & ~small]
    if not small.any():
        return lab, left
    holes = small[pockets]
    # one pass fills one layer: as many passes as the deepest hole pixel is far from a cell (4-connected)
    passes = int(ndimage.distance_transform_cdt(holes, metric="taxicab").max())
    filled = K.fill_gaps(np.ascontiguousarray(lab), passes, bool(periodic))
    filled[zero & ~holes] = 0
    return filled, left


def _hole_hint(lab, sizes, fill_holes):
    """A :class:`FrameWarning` naming ``--fill-holes`` for the holes the size of a cell or smaller left in the tissue.

    Larger 0-regions inside the tissue (more than ``OUTSIDE_FACTOR`` x the
    median cell area: a wound, a lumen, the inside of a ring of cells) are
    taken as meant and not reported.
    """
    areas = np.bincount(compact_labels(lab)[0].ravel())[1:]
    median = float(np.median(areas)) if len(areas) else 0.0
    sizes = np.sort(sizes[sizes <= OUTSIDE_FACTOR * median])[::-1]
    if not len(sizes):
        return
    shown = ", ".join(str(int(v)) for v in sizes[:4]) + (", ..." if len(sizes) > 4 else "")
    warnings.warn(FrameWarning(
        f"holes of background 0 inside the tissue (not touching the image edge) larger than fill_holes = "
        f"{fill_holes} px stay background: the cells around them count as border cells, not interior. If they are "
        f"gaps in the segmentation, --fill-holes AREA (fill_holes=AREA) fills those smaller than AREA px",
        f"{len(sizes)} hole(s): {shown} px; median cell {median:.0f} px"), stacklevel=3)
