"""Cell Tracking Challenge (CTC) folders read as tracked movies: masks whose ids are tracks, plus a track file.

The layout (celltrackingchallenge.net, "Naming and file content
conventions"; written by :func:`hexatissue.exchange.ctc.write_ctc`): one
16-bit label image per frame whose pixel values are track ids, and a text
file with one line ``L B E P`` per track (id, first and last frame, parent;
0 = none).  A result is ``maskTTT.tif`` + ``res_track.txt`` in one folder,
a ground truth ``TRA/man_trackTTT.tif`` + ``TRA/man_track.txt``; ``TTT``
has 3 digits (4 beyond 1000 frames).  The format has no gaps: an object
missing for some frames and coming back is a new track whose parent is the
part before the gap; :func:`gap_links` tells these continuations (a parent
with one child) from divisions (two or more).  Checking a whole folder is
:func:`hexatissue.exchange.ctc.check_ctc`.
"""
from __future__ import annotations

import re
from pathlib import Path

import numpy as np
import pandas as pd

from ..errors import InputError
from ..mesh.labels import relabel
from ..schema import require_columns
from ..track import lineage_roots
from .base import Opened, refuse
from .folder import FilesReader

__all__ = ["RESULT", "TRUTH", "TRACK_COLUMNS", "mask_digits", "mask_files", "ctc_layout", "is_ctc_folder",
           "read_track_file", "numbered_masks", "gap_links", "CtcReader", "open_ctc"]

RESULT = ("mask", "res_track.txt")  # (mask file prefix, track file) of a result
TRUTH = ("man_track", "man_track.txt")  # of a ground truth (in TRA/)
TRACK_COLUMNS = ("track", "frame_start", "frame_end", "parent")


def mask_digits(n_frames: int) -> int:
    """Digits of the frame number in the mask file names: 3, or 4 beyond 1000 frames."""
    return 4 if n_frames > 1000 else 3


def mask_files(folder: Path, prefix: str) -> list[Path]:
    """The files ``<prefix>TTT.tif`` (or ``.tiff``, any number of digits) in ``folder``, unordered."""
    pattern = re.compile(rf"^{prefix}(\d+)\.tiff?$", re.IGNORECASE)
    return [p for p in folder.iterdir() if p.is_file() and pattern.match(p.name)] if folder.is_dir() else []


def ctc_layout(folder) -> tuple[Path, Path, str, str]:
    """``(mask folder, track file, mask prefix, layout name)`` of a CTC folder; InputError if it is not one.

    A folder holding a result (``res_track.txt``) and a ``TRA`` folder is read as the result.
    """
    folder = Path(folder)
    if not folder.is_dir():
        raise InputError(f"CTC folder {str(folder)!r} does not exist or is not a folder")
    for where, (prefix, name), layout in ((folder, RESULT, "result"), (folder / "TRA", TRUTH, "truth"),
                                          (folder, TRUTH, "truth")):
        if (where / name).is_file():
            return where, where / name, prefix, layout
    raise InputError(f"{str(folder)!r} is not a Cell Tracking Challenge folder: expected res_track.txt with "
                     f"maskTTT.tif files, or TRA/man_track.txt with TRA/man_trackTTT.tif files")


def is_ctc_folder(path) -> bool:
    """True when ``path`` is a folder in a CTC layout (a track file with its masks next to it)."""
    try:
        where, _, prefix, _ = ctc_layout(path)
    except InputError:
        return False
    return bool(mask_files(where, prefix))


def read_track_file(path: Path, problems: list) -> pd.DataFrame:
    """The lines of a track file as ``track, frame_start, frame_end, parent``; malformed lines go to ``problems``."""
    rows = []
    for k, line in enumerate(path.read_text().splitlines(), 1):
        if not line.strip():
            continue
        parts = line.split()
        try:
            values = [int(v) for v in parts]
        except ValueError:
            values = []
        if len(values) != 4 or min(values) < 0:
            problems.append(f"{path.name} line {k} is {line.strip()!r}; expected four non-negative integers L B E P")
            continue
        rows.append(values)
    return pd.DataFrame(rows or np.zeros((0, 4), np.int64), columns=list(TRACK_COLUMNS)).astype(np.int64)


def numbered_masks(files, prefix, problems) -> dict[int, Path]:
    """``{frame: mask file}``; numbering problems (not 0..T-1, mixed widths) appended to ``problems``."""
    found = {}
    widths = set()
    for p in sorted(files):
        digits = re.match(rf"^{prefix}(\d+)", p.name, re.IGNORECASE).group(1)
        widths.add(len(digits))
        if int(digits) in found:
            problems.append(f"frame {int(digits)} has two mask files: {found[int(digits)].name}, {p.name}")
        found[int(digits)] = p
    if not found:
        problems.append(f"no {prefix}TTT.tif mask files")
        return {}
    n = max(found) + 1
    gaps = sorted(set(range(n)) - set(found))
    if gaps:
        problems.append(f"mask files must be numbered 0..{n - 1}; missing {gaps[:20]}")
    if widths != {mask_digits(n)}:
        problems.append(f"mask file numbers have {sorted(widths)} digits; expected {mask_digits(n)} for {n} frames")
    return dict(sorted(found.items()))


def gap_links(tracks) -> tuple[dict[int, int], dict[int, int]]:
    """Tell gap continuations from divisions in CTC track lines.

    Parameters
    ----------
    tracks : pandas.DataFrame
        ``track`` and ``parent`` columns (e.g. from :func:`hexatissue.exchange.ctc.read_ctc`).

    Returns
    -------
    same : dict
        ``{track: earlier track}`` for the only child of its parent: the same
        cell after a gap, mapped to the first track of its chain.
    parents : dict
        ``{daughter: mother}`` for the children of parents with two or more
        children (divisions), in the ids after applying ``same``.
    """
    require_columns(tracks, ("track", "parent"), "tracks")
    child_of = {int(l): int(p) for l, p in zip(tracks["track"], tracks["parent"]) if p}
    counts = pd.Series(list(child_of.values()), dtype=np.int64).value_counts().to_dict()

    single = {c: p for c, p in child_of.items() if counts[p] == 1}
    root = lineage_roots(single, set(single) | set(child_of) | set(child_of.values()))
    same = {c: root[c] for c in single}
    parents = {root[c]: root[p] for c, p in child_of.items() if counts[p] > 1}
    return same, parents


class CtcReader:
    """Frames of a CTC folder for :func:`hexatissue.open_source`: ids are tracks, gaps merged back.

    The masks are read lazily, one file per frame; the track file is read
    when opened (InputError on a malformed line).  Tracks continuing one
    another across a gap (a parent with a single child) are given the first
    id of their chain, so each cell is one id over time; :attr:`parents`
    holds the divisions.  :func:`hexatissue.exchange.ctc.check_ctc` checks a whole folder.
    """

    def __init__(self, folder):
        where, track_file, prefix, self.layout = ctc_layout(folder)
        problems: list[str] = []
        tracks = read_track_file(track_file, problems)
        paths = numbered_masks(mask_files(where, prefix), prefix, problems)
        if problems:
            raise InputError(f"CTC folder {str(folder)!r}: " + "; ".join(problems[:10]))
        self.same, self.parents = gap_links(tracks)
        self._old = np.array(sorted(self.same), np.int64)
        self._new = np.array([self.same[i] for i in self._old.tolist()], np.int64)
        self._files = FilesReader(list(paths.values()), None, f"CTC folder {str(folder)!r}")
        self.n_frames, self.shape, self.calibration = self._files.n_frames, self._files.shape, self._files.calibration
        # the first frame's ids must have their track lines (an empty or foreign track file loses every
        # division); hexatissue.exchange.check_ctc checks every frame
        ids = np.unique(self._files.read(0))
        unlisted = np.setdiff1d(ids[ids > 0], tracks["track"].to_numpy(np.int64))
        if len(unlisted):
            raise InputError(f"CTC folder {str(folder)!r}: {track_file.name} has no line for {len(unlisted)} id(s) of "
                             f"frame 0 (e.g. {unlisted[:5].tolist()}); a CTC track file lists every id of the masks "
                             f"as 'L B E P' (hexatissue.exchange.check_ctc checks the whole folder)")

    def describe(self) -> dict:
        return self._files.describe()

    def read(self, t) -> np.ndarray:
        arr = self._files.read(t)
        return relabel(arr, self._old, self._new) if len(self._old) else arr


def open_ctc(path: Path, key=None, channel=None, level=None) -> Opened:
    """A Cell Tracking Challenge folder: masks whose ids are tracks (consistent), divisions from its track file."""
    refuse("a Cell Tracking Challenge folder", key=key, channel=channel, level=level)
    reader = CtcReader(path)
    desc = {"kind": "ctc", "path": str(path), "layout": reader.layout, "gaps_merged": len(reader.same)}
    return Opened(reader, desc, reader.calibration, ids_consistent=True, parents=reader.parents)
