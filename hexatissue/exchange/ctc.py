"""Cell Tracking Challenge (CTC) folders: tracked masks plus a track file.

The CTC layout (celltrackingchallenge.net, "Naming and file content
conventions"): one 16-bit label image per frame whose pixel values are track
ids (0 = background), and a text file with one line ``L B E P`` per track:
its id ``L``, first and last frame ``B`` and ``E`` (0-based), and the id of
its parent track ``P`` (0 = none).  A track is present in every frame from
``B`` to ``E`` and in no other; a parent ends before its children begin.
Two layouts hold the same content:

- a result: ``maskTTT.tif`` and ``res_track.txt`` in one folder;
- a ground truth: ``TRA/man_trackTTT.tif`` and ``TRA/man_track.txt``, and
  the reference segmentation ``SEG/man_segTTT.tif`` (what the SEG measure,
  ``ctc_evaluate --seg``, compares a result's masks with): a label image
  per annotated frame whose ids need not match the tracks; the export
  annotates every frame, with the same masks as ``TRA``.

``TTT`` is the frame index with 3 digits (4 when there are more than 1000
frames).  The format has no gaps: an object missing for some frames and
coming back is a new track whose parent is the part before the gap.
:func:`write_ctc` splits tracks that way, and
:func:`hexatissue.readers.ctc.gap_links` tells the continuations apart from
divisions when reading (a parent with one child is the same cell after a
gap; a parent with two or more children divided).

Reading a CTC folder as a tracked movie (:func:`hexatissue.open_source`) is
:mod:`hexatissue.readers.ctc`; this module writes the format and checks a
folder against it.
"""
from __future__ import annotations

import re
from pathlib import Path

import numpy as np
import pandas as pd

from ..errors import InputError
from ..io import atomic_path, check_output_folder, check_replaceable
from ..mesh.labels import relabel
from ..readers.ctc import RESULT, TRUTH, ctc_layout, mask_digits, mask_files, numbered_masks, read_track_file
from ..schema import require_columns
from ..source import open_source

__all__ = ["write_ctc", "is_ctc_export", "MARK", "check_ctc", "read_ctc", "MAX_ID", "SEG_PREFIX"]

MAX_ID = 2**16 - 1  # CTC masks are 16-bit
MAX_LISTED = 50  # violations spelled out by check_ctc before it only counts the rest
#: The reference segmentation's file prefix in a ground truth's ``SEG`` folder (``SEG/man_segTTT.tif``, 2-D frames).
SEG_PREFIX = "man_seg"


# ---------------------------------------------------------------------------------------------------------
# writing
# ---------------------------------------------------------------------------------------------------------
def _mask_frames(masks) -> list[np.ndarray]:
    """The frames of ``masks`` as 2-D non-negative integer arrays of one shape, ids <= MAX_ID."""
    if isinstance(masks, np.ndarray) and masks.ndim == 3:
        frames = list(masks)
    elif isinstance(masks, (list, tuple)) and len(masks) and all(np.ndim(f) == 2 for f in masks):
        frames = [np.asarray(f) for f in masks]
    else:
        raise InputError(f"masks must be a T x Y x X integer array or a non-empty sequence of 2-D frames; got "
                         f"{type(masks).__name__} of shape {np.shape(masks) if hasattr(masks, 'shape') else '?'}")
    out = []
    for t, f in enumerate(frames):
        if f.shape != frames[0].shape:
            raise InputError(f"masks: frame {t} is {f.shape}; expected {frames[0].shape} like frame 0")
        if f.dtype.kind == "f" and not (np.isfinite(f).all() and np.array_equal(f, np.round(f))):
            raise InputError(f"masks: frame {t} has non-integer values; expected integer track ids")
        if f.dtype.kind not in "iuf":
            raise InputError(f"masks: frame {t} has dtype {f.dtype}; expected integer track ids")
        if f.size and (f.min() < 0 or f.max() > MAX_ID):
            raise InputError(f"masks: frame {t} has ids from {f.min()} to {f.max()}; CTC masks are 16-bit: "
                             f"expected 0 (background) to {MAX_ID}")
        out.append(f.astype(np.int64, copy=False))
    return out


def _presence(frames) -> dict[int, np.ndarray]:
    """``{id: sorted frames where it has pixels}`` (0 left out) of a list or a ``{frame: mask}`` dict."""
    seen: dict[int, list[int]] = {}
    for t, f in (frames.items() if isinstance(frames, dict) else enumerate(frames)):
        for i in np.unique(f).tolist():
            if i:
                seen.setdefault(int(i), []).append(t)
    return {i: np.asarray(ts, np.int64) for i, ts in sorted(seen.items())}


def _ctc_tracks(presence, parents, first_new):
    """Tracks without gaps: ``(rows [L, B, E, P], {frame: {old id: new id}})``.

    The first run of frames of an id keeps the id; every later run gets the
    next free id with the run before it as parent.  A daughter's parent is
    the last run of its mother that ends before the daughter begins.
    """
    runs = {}  # id -> [(new id, start, end)]
    renamed = {}
    next_id = first_new
    for i, ts in presence.items():
        cuts = np.flatnonzero(np.diff(ts) > 1) + 1
        pieces = np.split(ts, cuts)
        runs[i] = []
        for k, piece in enumerate(pieces):
            new = i if k == 0 else next_id
            next_id += k > 0
            runs[i].append((new, int(piece[0]), int(piece[-1])))
            if new != i:
                for t in piece.tolist():
                    renamed.setdefault(t, {})[i] = new
    rows = []
    for i, pieces in runs.items():
        mother = parents.get(i, 0)
        for k, (new, start, end) in enumerate(pieces):
            if k:
                parent = pieces[k - 1][0]
            elif mother in runs:
                before = [r for r in runs[mother] if r[2] < start]
                parent = before[-1][0] if before else 0
            else:
                parent = 0
            rows.append((new, start, end, parent))
    return sorted(rows), renamed


#: The file that marks a CTC folder as written by :func:`write_ctc` (CTC tools read only the masks and track file).
MARK = ".hexatissue-ctc"


def is_ctc_export(folder) -> bool:
    """Whether ``folder`` (the one holding the masks) was written by :func:`write_ctc` (it holds :data:`MARK`)."""
    return (Path(folder) / MARK).is_file()


def write_ctc(masks, lineage, out, *, truth=False, overwrite=False) -> Path:
    """Write tracked masks and their lineage as a Cell Tracking Challenge folder.

    Parameters
    ----------
    masks : T x Y x X integer array or sequence of 2-D arrays
        Label images (indexed ``[row, col]``) whose ids are *track* ids;
        0 = background.  Ids must fit in 16 bits (1..65535).
    lineage : pandas.DataFrame
        A hexatissue lineage table (:func:`hexatissue.track.lineage_table`):
        at least ``track`` and ``parent`` (0 = no parent).  Every id of the
        masks must have a row.  The frames a track spans are read from the
        masks, not from the table.
    out : str or Path
        Output folder (made if needed).
    truth : bool
        False: the result layout, ``out/maskTTT.tif`` and
        ``out/res_track.txt``; True: the ground-truth layout,
        ``out/TRA/man_trackTTT.tif`` and ``out/TRA/man_track.txt``, plus
        the reference segmentation of every frame,
        ``out/SEG/man_segTTT.tif`` (the same masks).
    overwrite : bool
        Write into a mask folder (``out``, or ``out/TRA`` and ``out/SEG``)
        that holds files and is not an earlier export; without it such a
        folder is refused before anything is written, so no one else's
        masks are replaced or removed.

    Returns
    -------
    Path
        The folder holding the masks and the track file (``out``, or
        ``out/TRA`` with ``truth``).

    Notes
    -----
    A track missing from some frames is split at each gap: the part after a
    gap gets a new id (above every id in use) whose parent is the part
    before it, as the format requires.  A parent that never appears in the
    masks, or has no part ending before its daughter begins, is written as
    0.  Files are written under temporary names and
    renamed; mask files of an earlier export that this one does not write
    are removed.  The mask folder gets a hidden mark file (:data:`MARK`) by
    which a later export knows it may replace it.

    Raises
    ------
    InputError
        Masks that are not integer label images of one shape, ids outside
        0..65535, a lineage without ``track``/``parent`` or missing a
        track of the masks, ``out`` not writable, or a mask folder of
        other files (without ``overwrite``) or a results folder.
    """
    import tifffile


    frames = _mask_frames(masks)
    require_columns(lineage, ("track", "parent"), "lineage")
    presence = _presence(frames)
    known = set(lineage["track"].astype(np.int64).tolist())
    missing = sorted(set(presence) - known)
    if missing:
        raise InputError(f"lineage has no row for track(s) {missing[:20]}{' ...' if len(missing) > 20 else ''} "
                         f"of the masks; expected one row per track id in the masks")
    parents = {int(t): int(p) for t, p in zip(lineage["track"], lineage["parent"]) if p}
    biggest = max([0, *presence, *known])
    rows, renamed = _ctc_tracks(presence, parents, biggest + 1)
    if rows and max(r[0] for r in rows) > MAX_ID:  # the ids given to tracks continuing after a gap
        raise InputError(f"splitting tracks at their gaps needs ids up to {max(r[0] for r in rows)}; CTC masks are "
                         f"16-bit (ids up to {MAX_ID}): relabel the tracks to smaller ids first")
    prefix, track_name = TRUTH if truth else RESULT
    root = check_output_folder(out, "out")
    folder = root / "TRA" if truth else root
    targets = [(folder, prefix)] + ([(root / "SEG", SEG_PREFIX)] if truth else [])
    for where, _ in targets:
        check_replaceable(where, is_ctc_export, name="out", overwrite=overwrite)
    for where, _ in targets:
        where.mkdir(parents=True, exist_ok=True)
        # marked first, so that an export interrupted halfway can be written again
        (where / MARK).write_text(f"Cell Tracking Challenge {'ground truth' if truth else 'result'} written by "
                                  f"hexatissue.exchange.ctc.write_ctc\n")
    digits = mask_digits(len(frames))
    written = set()
    for t, f in enumerate(frames):
        if t in renamed:  # the ids of the parts after a gap
            old = sorted(renamed[t])
            f = relabel(f, old, [renamed[t][i] for i in old])
        for where, name in targets:
            path = where / f"{name}{t:0{digits}d}.tif"
            with atomic_path(path) as tmp:
                tifffile.imwrite(tmp, f.astype(np.uint16), photometric="minisblack")
            written.add(path)
    for where, name in targets:
        for stale in mask_files(where, name):
            if stale not in written:
                stale.unlink()
    with atomic_path(folder / track_name) as tmp:
        tmp.write_text("".join(f"{l} {b} {e} {p}\n" for l, b, e, p in rows))
    return folder


# ---------------------------------------------------------------------------------------------------------
# reading and checking
# ---------------------------------------------------------------------------------------------------------
def _check_tracks(tracks, presence, problems):
    ids = tracks["track"].to_numpy()
    dup = sorted(set(ids[pd.Series(ids).duplicated().to_numpy()].tolist()))
    if dup:
        problems.append(f"track id(s) {dup[:20]} have several lines; ids must be unique")
    if (ids == 0).any():
        problems.append("a line has track id 0, which is the background; ids start at 1")
    span = {int(l): (int(b), int(e)) for l, b, e in tracks[["track", "frame_start", "frame_end"]].to_numpy()}
    for l, b, e, p in tracks.to_numpy().tolist():
        if b > e:
            problems.append(f"track {l}: begins at frame {b} after it ends ({e})")
        if p == l:
            problems.append(f"track {l} is its own parent")
        elif p and p not in span:
            problems.append(f"track {l}: parent {p} has no line")
        elif p and span[p][1] >= b:
            problems.append(f"track {l}: parent {p} ends at frame {span[p][1]}, not before its child begins ({b})")
        frames = presence.get(l)
        if frames is None:
            problems.append(f"track {l}: its line says frames {b}..{e} but no mask holds it")
        elif not np.array_equal(frames, np.arange(b, e + 1)):
            want = set(range(b, e + 1))
            absent, outside = sorted(want - set(frames.tolist())), sorted(set(frames.tolist()) - want)
            problems.append(f"track {l}: its line says frames {b}..{e}; "
                            + "; ".join(s for s in (f"absent from frame(s) {absent[:10]}" if absent else "",
                                                    f"present in frame(s) {outside[:10]}" if outside else "") if s))
    unlisted = sorted(set(presence) - set(span))
    if unlisted:
        problems.append(f"mask id(s) {unlisted[:20]} have no line in the track file")


def _read_masks(paths, problems) -> dict[int, np.ndarray]:
    """``{frame: mask}`` of the files that are single 2-D non-negative integer images of one shape."""

    frames = {}
    for t, path in paths.items():
        try:
            src = open_source(path)
            if src.n_frames != 1:
                raise InputError(f"it holds {src.n_frames} images; expected one")
            f = src.raw_frame(0)
            if f.dtype.kind not in "iu" or (f.size and f.min() < 0):
                raise InputError(f"it has dtype {f.dtype}; expected non-negative integer (16-bit) labels")
        except InputError as exc:
            problems.append(f"{path.name}: {exc}")
            continue
        shape = next(iter(frames.values())).shape if frames else f.shape
        if f.shape != shape:
            problems.append(f"{path.name} is {f.shape}; expected {shape} like the first mask")
            continue
        frames[t] = f
    return frames


def _check_seg(seg, n_frames, shape, problems):
    """A ground truth's ``SEG`` folder: ``man_segTTT.tif`` of frames among the TRA masks' (TTT digits as theirs),
    single 2-D integer images of their shape."""
    pattern = re.compile(rf"^{SEG_PREFIX}(\d+)\.tiff?$", re.IGNORECASE)
    files = {}
    for path in sorted(p for p in seg.iterdir() if p.is_file() and p.suffix.lower() in (".tif", ".tiff")):
        match = pattern.match(path.name)
        if match is None:  # 3-D annotations (man_seg_TTT_SSS.tif) are not written or read here
            problems.append(f"SEG/{path.name}: expected {SEG_PREFIX}TTT.tif (2-D reference segmentation of frame TTT)")
        elif len(match.group(1)) != mask_digits(n_frames) or int(match.group(1)) >= n_frames:
            problems.append(f"SEG/{path.name}: expected a frame number of {mask_digits(n_frames)} digits below "
                            f"{n_frames} (the TRA masks' frames)")
        else:
            files[int(match.group(1))] = path
    if not files and not problems:
        problems.append("SEG holds no man_segTTT.tif file")
    found: list[str] = []
    frames = _read_masks(files, found)
    problems.extend(f"SEG/{p}" for p in found)
    for t, f in frames.items():
        if shape is not None and f.shape != shape:
            problems.append(f"SEG/{files[t].name} is {f.shape}; expected {shape} like the TRA masks")


def _inspect(folder):
    """``(masks by frame, tracks, problems, layout)`` of a CTC folder (a ground truth's SEG folder checked too)."""
    where, track_file, prefix, layout = ctc_layout(folder)
    problems: list[str] = []
    tracks = read_track_file(track_file, problems)
    paths = numbered_masks(mask_files(where, prefix), prefix, problems)
    frames = _read_masks(paths, problems)
    if frames and len(frames) == len(paths):
        _check_tracks(tracks, _presence(frames), problems)
    seg = where.parent / "SEG" if where.name == "TRA" else where / "SEG"
    if layout == "truth" and seg.is_dir() and paths:
        _check_seg(seg, len(paths), next(iter(frames.values())).shape if frames else None, problems)
    return frames, tracks, problems, layout


def check_ctc(folder) -> None:
    """Check a Cell Tracking Challenge folder (either layout); InputError listing every violation.

    Checked: the mask files are numbered ``0..T-1`` with 3 digits (4 beyond
    1000 frames), are single 2-D integer images of one shape (in a ground
    truth with a ``SEG`` folder, its ``man_segTTT.tif`` files too: frames
    among ``0..T-1``, the same digits and shape); every line of
    the track file is ``L B E P`` (non-negative integers); ids are unique
    and not 0; every mask id has a line and is present in exactly the
    frames ``B..E`` of it; every parent has a line and ends before its
    child begins.

    Raises
    ------
    InputError
        The folder is not in a CTC layout, or one message with every
        violation found (the first 50 spelled out, the rest counted).
    """
    _, _, problems, _ = _inspect(folder)
    if problems:
        listed = "\n  ".join(problems[:MAX_LISTED])
        more = f"\n  ... and {len(problems) - MAX_LISTED} more" if len(problems) > MAX_LISTED else ""
        raise InputError(f"CTC folder {str(folder)!r} breaks the format ({len(problems)} violation(s)):\n  "
                         f"{listed}{more}")


def read_ctc(folder) -> tuple[np.ndarray, pd.DataFrame]:
    """The masks and track lines of a Cell Tracking Challenge folder (either layout), as stored.

    Returns
    -------
    masks : (T, rows, cols) integer array
        Frame ``t`` is ``maskTTT.tif`` (``man_trackTTT.tif``); ids are track
        ids, 0 = background.
    tracks : pandas.DataFrame
        One row per line of the track file: ``track`` (L), ``frame_start``
        (B), ``frame_end`` (E, frames, inclusive), ``parent`` (P, 0 = none).

    Raises
    ------
    InputError
        The folder breaks the format (see :func:`check_ctc`).
    """
    frames, tracks, problems, _ = _inspect(folder)
    if problems:
        check_ctc(folder)  # raises with the full list
    return np.stack(list(frames.values())), tracks.sort_values("track", kind="stable").reset_index(drop=True)
