"""A whole analysis (:class:`Movie`) and the folder it is saved in.

A Movie holds its tables by name (``movie.tables["cells"]``, also
``movie.cells``), each a table of :data:`hexatissue.schema.TABLES`, plus the
metadata needed to read them: box, shape, number of frames, calibration,
the options used, the source's description, the version and what the
analysis decided (``summary``).  Every table has a ``frame`` column (0 for a
single image) except the per-event and per-track ones.  Positions are in
pixels, ``x`` = column and ``y`` = row, origin at the centre of pixel
(0, 0); times in frames.  The physical units travel in
:class:`~hexatissue.units.Calibration`.

A results folder is a saved Movie: :func:`write_results` (:meth:`Movie.write`)
and :func:`read_results` round-trip every table that has a schema, and
``metadata.json``.  A table computed outside :func:`hexatissue.analyze`
lives in the same folder once it has a schema entry.
"""
from __future__ import annotations

import json
from pathlib import Path

import numpy as np
import pandas as pd

from ._system import release_freed_memory
from .box import Box
from .errors import InputError
from .frame import MESH_TABLES, Frame, Tables
from .io import atomic_path, check_output_folder, read_table, read_units, write_table
from .options import OPTION_CLASSES
from .schema import TABLES as SCHEMAS, coerce, column_units, validate
from .stored import PART_PATTERN, StoredTable
from .units import Calibration

__all__ = ["Movie", "write_results", "read_results", "check_replaceable_tables", "FORMATS", "METADATA", "RUN_LOCK"]

FORMATS = ("parquet", "csv")
METADATA = "metadata.json"
#: Everything a Movie holds besides its tables, with its default.
_ATTRIBUTES = {"box": None, "shape": (), "n_frames": 0, "calibration": None, "options": None, "source": None,
               "version": "", "summary": None}


def _check_table(name, table):
    if name not in SCHEMAS:
        raise InputError(f"a Movie holds tables that have a schema; {name!r} has none (tables: {list(SCHEMAS)}; "
                         f"add an entry to hexatissue.schema.TABLES)")
    if not isinstance(table, (pd.DataFrame, StoredTable)):
        raise InputError(f"table {name!r} must be a pandas DataFrame (or a StoredTable); got {type(table).__name__}")
    return table


class Movie:
    """Every table of an analysis, concatenated over frames, plus the metadata to read it.

    Parameters
    ----------
    cells, vertices, edges, cell_vertices, ... : pandas.DataFrame or None
        The tables, by their schema name (:data:`hexatissue.schema.TABLES`):
        the junction networks (``cells``, ``vertices``, ``edges``,
        ``cell_vertices``, required; ``cells`` has ``track`` and
        ``gamma{p}`` columns after :func:`hexatissue.analyze`), ``grid``
        (coarse-grained fields Gamma_p), ``defects`` (with defect
        ``track``), ``defect_events`` (pair creation / annihilation),
        ``events`` (T1 quartets), ``neighbour_events`` (the paper's per-cell
        definition), ``lineage``, ``cell_events`` (per-cell T1 statistics),
        and any other table with a schema.  None: the table is absent.
    box : Box or None
        Periodic box, or None for open images.
    shape : tuple of int
        ``(rows, cols)`` of the frames.
    n_frames : int
        Frames analysed (also those without cells); default: from ``cells``.
    calibration : Calibration
        Pixel size and frame interval with their units.
    options : dict
        The options objects used, by stage name (``mesh``, ``order``, ...).
    source : dict
        Description of the input (see :class:`hexatissue.Source`).
    version : str
        hexatissue version that produced the tables.
    summary : dict
        What :func:`hexatissue.analyze` decided from the data: ``tracking``
        (mode requested and used, why, id consistency, rows whose track
        differs from the cell id, divisions) and ``events`` (censoring
        window used and its rule, events classified).

    Attributes
    ----------
    tables : dict
        The tables present, by name, in the schema's order.  Each is also an
        attribute (``movie.cells``); a table with a schema that is absent
        reads as None.
    """

    def __init__(self, cells, vertices, edges, cell_vertices, *, box=None, shape=(), n_frames=0, calibration=None,
                 options=None, source=None, version="", summary=None, **tables):
        given = dict(cells=cells, vertices=vertices, edges=edges, cell_vertices=cell_vertices, **tables)
        given = {name: _check_table(name, table) for name, table in given.items() if table is not None}
        object.__setattr__(self, "tables", Tables((name, given[name]) for name in SCHEMAS if name in given))
        self.box = box
        self.shape = shape
        self.calibration = Calibration() if calibration is None else calibration
        self.options = {} if options is None else options
        self.source = {} if source is None else source
        self.version = version
        self.summary = {} if summary is None else summary
        if not n_frames:
            n_frames = int(self.cells["frame"].max()) + 1 if len(self.cells) else 0
        self.n_frames = n_frames

    def __getattr__(self, name):
        # only reached for names that are not ordinary attributes: the tables
        if name in SCHEMAS:
            return self.__dict__.get("tables", {}).get(name)
        raise AttributeError(f"'Movie' object has no attribute {name!r}")

    def __setattr__(self, name, value):
        if name not in SCHEMAS:
            object.__setattr__(self, name, value)
            return
        if value is None:
            self.tables.pop(name, None)
            return
        self.tables[name] = _check_table(name, value)
        order = {n: k for k, n in enumerate(SCHEMAS)}
        if list(self.tables) != sorted(self.tables, key=order.get):
            kept = sorted(self.tables.items(), key=lambda item: order[item[0]])
            self.tables.clear()
            self.tables.update(kept)

    def __repr__(self):
        shown = ", ".join(f"{name}: {len(table)} rows" for name, table in self.tables.items())
        return f"Movie({self.n_frames} frames, {shown})"

    def __getstate__(self):
        return self.__dict__

    def __setstate__(self, state):
        object.__setattr__(self, "__dict__", state)

    @classmethod
    def from_frames(cls, frames) -> "Movie":
        """Concatenate :class:`Frame` objects (their ``frame`` attribute is the frame index)."""
        frames = list(frames)
        if not frames:
            raise InputError("frames must contain at least one Frame; got an empty sequence")
        tables = {}
        for name in MESH_TABLES:
            parts = [getattr(f, name).assign(frame=np.int64(f.frame)) for f in frames]
            tables[name] = pd.concat(parts, ignore_index=True)
        first = frames[0]
        n = max(int(f.frame) for f in frames) + 1
        return cls(**tables, box=first.box, shape=first.shape, n_frames=n, calibration=first.calibration)

    @property
    def frames(self) -> np.ndarray:
        """Sorted frame indices present in the cells table."""
        return np.unique(self.cells["frame"].to_numpy())

    def __len__(self) -> int:
        return int(self.n_frames)

    def frame(self, t: int) -> Frame:
        """The :class:`Frame` at time point ``t`` (its four mesh tables; ``cells`` keeps every column)."""
        if not 0 <= t < self.n_frames:
            raise InputError(f"frame {t} is not in this movie; it has frames 0..{self.n_frames - 1}")
        parts = {name: self.table_at(name, t) for name in MESH_TABLES}
        return Frame(**parts, frame=int(t), box=self.box, shape=self.shape, calibration=self.calibration)

    def table_at(self, name: str, t: int) -> pd.DataFrame:
        """Rows of table ``name`` at frame ``t`` (index reset)."""
        table = self.tables.get(name)
        if table is None:
            raise InputError(f"this movie has no {name!r} table; it has {sorted(self.tables)}")
        if isinstance(table, StoredTable):
            return table.read(frames=(t, t))
        return table[table["frame"].to_numpy() == t].reset_index(drop=True)

    def polygons(self, t: int) -> dict[int, np.ndarray]:
        """Cell polygons of frame ``t`` (see :meth:`Frame.polygons`)."""
        return self.frame(t).polygons()

    def replace(self, **changes) -> "Movie":
        """A copy with some tables or attributes replaced (a table set to None is dropped).

        A name that is neither an attribute nor a table with a schema raises
        :class:`InputError`.
        """
        kept = {name: getattr(self, name) for name in _ATTRIBUTES}
        return Movie(**{**self.tables, **kept, **changes})

    def metadata(self) -> dict:
        """What ``metadata.json`` holds: box, shape, frames, calibration, options, summary, source, version."""
        return {
            "hexatissue_version": self.version,
            "n_frames": int(self.n_frames),
            "shape": [int(s) for s in self.shape],
            "box": None if self.box is None else self.box.to_list(),
            "calibration": self.calibration.to_dict(),
            "options": {name: opts.to_dict() for name, opts in self.options.items()},
            "summary": self.summary,
            "source": self.source,
            "tables": {name: int(len(table)) for name, table in self.tables.items()},
        }

    def write(self, directory, formats=("parquet",)) -> list[Path]:
        """Write every table to ``directory/<table>.<fmt>`` and ``metadata.json`` (last); returns the paths.

        See :func:`write_results`.
        """
        return write_results(self, directory, formats)


def write_results(movie, directory, formats=("parquet",), release=False) -> list[Path]:
    """Write every table of ``movie`` to ``directory/<table>.<fmt>`` and ``metadata.json`` (last).

    ``metadata.json`` records each input file (the labels, the mask, the
    images) by its absolute path (:func:`hexatissue.open_source`) with its
    path relative to ``directory`` beside it (``relative_path``).
    Each Parquet column carries its unit and meaning from
    :data:`hexatissue.schema.TABLES` in its field metadata (keys ``unit``
    and ``description``; :func:`hexatissue.io.read_units`).
    Files are written to temporary names and renamed, so a folder is never
    left with half a table; ``metadata.json`` is written last, so a folder
    that has it is complete.  Rewriting an existing results folder first
    removes its ``metadata.json`` (a write interrupted half-way leaves a
    folder that :func:`read_results` refuses, never old and new tables
    passing for one result), then the tables of this Movie are written
    and the old tables it does not have are removed.  A folder that holds
    files named like tables but is not a results folder is refused before
    anything is written (:func:`check_replaceable_tables`): they are not
    this package's to replace.

    Parameters
    ----------
    movie : Movie
    directory : str or Path
    formats : str or sequence of {"parquet", "csv"}
    release : bool
        Drop each table from ``movie`` once written, smallest first: for a
        caller that does not use the tables afterwards (``hexatissue
        analyze``).  The Parquet writer's buffers then come on top of the
        tables not yet written, not of all of them (the largest is written
        last, when the others are freed).  The files are the same either way.

    Returns
    -------
    list of Path
        The files written, ``metadata.json`` last.
    """
    formats = tuple(formats) if isinstance(formats, (list, tuple)) else (formats,)
    bad = [f for f in formats if f not in FORMATS]
    if bad or not formats:
        raise InputError(f"formats must be one or more of {FORMATS}; got {list(formats)}")
    directory = check_output_folder(directory, "directory")
    check_replaceable_tables(directory)
    meta = dict(movie.metadata(), formats=list(formats))  # before any table is released
    meta["source"] = _with_relative_paths(meta["source"], directory)
    previous = _listed_tables(directory / METADATA)
    (directory / METADATA).unlink(missing_ok=True)  # the folder is incomplete from here until the end
    tables = dict(movie.tables)
    names = sorted(tables, key=lambda n: _memory(tables[n])) if release else list(tables)
    written = []
    for name in names:
        if release:  # the previous table's pages (and what the caller freed last), before this table's buffers
            release_freed_memory()
        if isinstance(tables[name], StoredTable):
            written += _write_stored(tables[name], directory, formats)
        else:
            written += [write_table(tables[name], directory / f"{name}.{fmt}", schema=name) for fmt in formats]
        if release:
            del tables[name]
            setattr(movie, name, None)
    for name in dict.fromkeys([*SCHEMAS, *previous]):  # the tables of a previous result too, schema or not
        for fmt in FORMATS:
            stale = directory / f"{name}.{fmt}"
            if stale not in written:
                stale.unlink(missing_ok=True)
        parts = directory / name
        if parts.is_dir() and not any(p.parent == parts for p in written):
            _remove_parts(parts)
    with atomic_path(directory / METADATA) as tmp:
        tmp.write_text(json.dumps(meta, indent=2))
    return written + [directory / METADATA]


def _memory(table):
    """Bytes a table holds in memory (0 for one on disk)."""
    return 0 if isinstance(table, StoredTable) else int(table.memory_usage().sum())


def _remove_parts(folder):
    """Remove a table's part files, then its folder if nothing else is in it."""
    for path in folder.iterdir():
        if PART_PATTERN.fullmatch(path.name):
            path.unlink()
    if not any(folder.iterdir()):
        folder.rmdir()


def _write_stored(table, directory, formats):
    """Write a :class:`~hexatissue.stored.StoredTable` part by part: as a Parquet dataset ``directory/<name>/``
    (its own parts are finished in place) and, for ``"csv"``, as one CSV file; returns the files written."""
    written = []
    for fmt in formats:
        if fmt == "csv":
            path = directory / f"{table.name}.csv"
            with atomic_path(path) as tmp:
                for k, (_, part) in enumerate(table.iter_parts()):
                    part.to_csv(tmp, index=False, header=k == 0, mode="w" if k == 0 else "a")
            written.append(path)
            continue
        target = directory / table.name
        if target.resolve() == table.folder.resolve():
            table.finish()
        else:
            if target.is_dir():
                _remove_parts(target)
            copy = StoredTable(target, table.name, table.orders)
            for (first, last), part in table.iter_parts():
                copy.append(part, first, last)
        written += [target / path.name for _, _, _, path in table.parts]
    return written


def _path_entries(source):
    """The source description and each of its entries (mask, images of the image stages) that records a file."""
    entries = [source] + [v for v in source.values() if isinstance(v, dict)] if isinstance(source, dict) else []
    return [e for e in entries if isinstance(e.get("path"), str) and e["path"]]


def _with_relative_paths(source, directory):
    """``source`` with each recorded file's path relative to the results folder beside its absolute path.

    The absolute path finds the file from any working folder; the relative
    one finds it when the results folder and the data were moved together.
    """
    import copy
    import os

    source = copy.deepcopy(source)
    for entry in _path_entries(source):
        if os.path.isabs(entry["path"]):
            try:
                entry["relative_path"] = os.path.relpath(entry["path"], Path(directory).resolve())
            except ValueError:  # another drive (Windows): no relative path
                entry.pop("relative_path", None)
    return source


def _found_paths(source, folder):
    """``source`` with a recorded path that no longer exists replaced by its ``relative_path`` from ``folder``, if
    that exists (the results folder moved together with its data)."""
    for entry in _path_entries(source):
        moved = entry.get("relative_path")
        if not Path(entry["path"]).exists() and isinstance(moved, str) and (folder / moved).exists():
            entry["path"] = str((folder / moved).resolve())
    return source


#: The file ``hexatissue analyze`` locks in its ``--out`` folder: a folder holding it was written by a run.
RUN_LOCK = ".hexatissue.lock"


def check_replaceable_tables(directory, name="directory"):
    """InputError when ``directory`` holds files named like tables but is not a results folder.

    Writing results replaces ``<table>.parquet`` / ``<table>.csv`` and
    removes the ones the new result does not have; in a folder that is not
    an earlier result (no ``metadata.json``, and no :data:`RUN_LOCK` of an
    interrupted run) such files are someone else's, and nothing is written.
    """
    directory = Path(directory)
    if not directory.is_dir() or (directory / METADATA).exists() or (directory / RUN_LOCK).exists():
        return
    theirs = sorted(f"{table}.{fmt}" for table in SCHEMAS for fmt in FORMATS
                    if (directory / f"{table}.{fmt}").exists())
    if theirs:
        raise InputError(f"{name} {str(directory)!r} holds {', '.join(theirs[:5])}{' ...' if len(theirs) > 5 else ''} "
                         f"but is not a results folder (no {METADATA}): writing the results would replace or remove "
                         f"them; write to another folder, or move those files")


def _listed_tables(path) -> list:
    """The table names a results folder's ``metadata.json`` lists ([] when it is missing or unreadable)."""
    try:
        listed = json.loads(path.read_text()).get("tables", {})
    except (OSError, ValueError, AttributeError):
        return []
    return [name for name in listed if isinstance(name, str) and "/" not in name and "\\" not in name]


def _check_units(path, name):
    """InputError when a column's unit in the file (Parquet field metadata) is not the schema's."""
    found = read_units(path)
    expected = column_units(name, found)
    wrong = [c for c, (unit, _) in found.items() if c in expected and unit != expected[c][0]]
    if wrong:
        c = wrong[0]
        raise InputError(f"column {c!r} is in {found[c][0]!r} in the file; expected {expected[c][0]!r} (tables stay "
                         f"in px and frames; the calibration converts them): written by another tool or version")


#: Bytes on disk of a results folder's tables split in parts above which :func:`read_results` (``lazy="auto"``)
#: leaves them on disk: Parquet packs the tables 3-5 times, so 2 GB of parts are 6-10 GB in memory.
LAZY_BYTES = 2 * 1024 ** 3


def read_results(directory, lazy="auto") -> Movie:
    """A results folder (:meth:`Movie.write`, ``hexatissue analyze``) read back as a :class:`Movie`.

    Parameters
    ----------
    directory : str or Path
        Folder holding ``metadata.json`` and the tables (Parquet preferred
        over CSV when both exist): each a file ``<table>.parquet`` or, for
        the large tables of a streamed analysis (``analyze(out=...)``), a
        folder ``<table>/`` of Parquet parts by chunk of frames.
    lazy : bool or "auto"
        Tables in parts as :class:`~hexatissue.stored.StoredTable` (read by
        column and frame range on demand: ``movie.cells.read(["x", "y"],
        frames=(0, 9))``, ``movie.table_at("cells", 3)``,
        ``.to_pandas()``, ``.dataset()`` for pyarrow or dask) instead of
        DataFrames.  ``"auto"`` (default): when their parts hold more than
        :data:`LAZY_BYTES` on disk.  Tables in single files are always read.

    Returns
    -------
    Movie
        Every table found that has a schema, with box, shape, number of
        frames, calibration, options, summary, source and version from
        ``metadata.json``.  The units a Parquet file gives its columns (field
        metadata, see :func:`write_results`) are checked against the schema.
        A recorded input file (``source["path"]``, the mask's, the images')
        that is no longer at its absolute path but at its ``relative_path``
        from the folder (results and data moved together) gets that path.
    """
    folder = Path(directory)
    if not folder.is_dir():
        raise InputError(f"results folder {str(folder)!r} does not exist or is not a folder; expected the output "
                         f"of hexatissue analyze")
    meta_path = folder / METADATA
    if not meta_path.exists():
        raise InputError(f"results folder {str(folder)!r} has no {METADATA}: it is not a complete hexatissue "
                         f"results folder (analyze writes metadata.json last)")
    try:
        meta = json.loads(meta_path.read_text())
        if not isinstance(meta, dict):
            raise ValueError("not a JSON object")
    except (OSError, ValueError) as exc:
        raise InputError(f"results folder {str(folder)!r}: {METADATA} cannot be read ({exc}); the folder is "
                         f"damaged: write it again") from None
    if lazy not in (True, False, "auto"):
        raise InputError(f"lazy must be True, False or 'auto'; got {lazy!r}")
    stored = {name: StoredTable.open(folder / name, name) for name in SCHEMAS
              if (folder / name).is_dir() and any(PART_PATTERN.fullmatch(p.name) for p in (folder / name).iterdir())}
    if lazy == "auto":
        lazy = sum(path.stat().st_size for t in stored.values() for _, _, _, path in t.parts) > LAZY_BYTES
    tables = {}
    for name, table in stored.items():
        try:
            validate(table.head(), name)
            _check_units(table.parts[0][3], name)
            tables[name] = table if lazy else validate(table.read(), name)
        except InputError as exc:
            raise InputError(f"results folder {str(folder)!r}: {name}/: {exc}") from None
    for name in SCHEMAS:
        if name in tables:
            continue
        for fmt in FORMATS:
            path = folder / f"{name}.{fmt}"
            if path.exists():
                table = read_table(path)
                table = coerce(table, name) if fmt == "csv" else table
                try:  # a table edited by hand or by another tool: every schema column, of its kind and unit
                    tables[name] = validate(table, name)
                    _check_units(path, name)
                except InputError as exc:
                    raise InputError(f"results folder {str(folder)!r}: {path.name}: {exc}") from None
                break
    # metadata.json is the manifest: every table it lists must be there, with the row count it gives
    listed = meta.get("tables", {})
    wrong = [name for name, rows in listed.items() if name in SCHEMAS
             and (name not in tables or len(tables[name]) != int(rows))]
    if wrong:
        raise InputError(f"results folder {str(folder)!r} does not match its {METADATA}: table(s) {wrong} are "
                         f"missing or have other row counts; the folder is damaged or was partly overwritten")
    missing = [name for name in MESH_TABLES if name not in tables]
    if missing:
        raise InputError(f"results folder {str(folder)!r} is missing table(s) {missing}")
    try:
        options = {name: OPTION_CLASSES[name].from_dict(value) for name, value in meta.get("options", {}).items()}
    except (InputError, KeyError) as exc:
        raise InputError(f"results folder {str(folder)!r} was written by hexatissue "
                         f"{meta.get('hexatissue_version', '?')} with options this version cannot read ({exc}); "
                         f"analyse the data again") from None
    return Movie(**tables, box=None if meta.get("box") is None else Box(*meta["box"]),
                 shape=tuple(meta.get("shape", ())), n_frames=int(meta.get("n_frames", 0)),
                 calibration=Calibration.from_dict(meta.get("calibration", {})), options=options,
                 source=_found_paths(meta.get("source", {}), folder), version=meta.get("hexatissue_version", ""),
                 summary=meta.get("summary", {}))
