"""Files: writing and reading tables, atomic files and folders, OME-TIFF writing, zarr helpers.

Tables are written atomically: to a temporary name in the same folder, then
renamed.  Label images are read by :func:`hexatissue.open_source` and
:func:`hexatissue.read_labels` (:mod:`hexatissue.source`).
"""
from __future__ import annotations

import os
import tempfile
from pathlib import Path

import numpy as np
import pandas as pd

from .errors import InputError
from .units import Calibration

__all__ = ["write_table", "write_tables", "read_table", "read_units", "atomic_path", "atomic_dir", "check_replaceable",
           "check_output_folder", "check_zarr_chunks", "read_zarr", "write_tiff"]


def _current_umask() -> int:
    mask = os.umask(0)
    os.umask(mask)
    return mask


_UMASK = _current_umask()


def atomic_path(path):
    """A context manager yielding a temporary path next to ``path``; renamed onto ``path`` on success.

    Nothing is left half-written: on error the temporary file is removed.
    """
    from contextlib import contextmanager

    @contextmanager
    def _ctx():
        target = Path(path)
        target.parent.mkdir(parents=True, exist_ok=True)
        fd, tmp = tempfile.mkstemp(prefix=f".{target.name}.", suffix=".tmp", dir=target.parent)
        os.close(fd)
        os.chmod(tmp, 0o666 & ~_UMASK)  # mkstemp makes 0600 files; results are ordinary files
        try:
            yield Path(tmp)
            os.replace(tmp, target)
        except BaseException:
            if os.path.exists(tmp):
                os.remove(tmp)
            raise

    return _ctx()


def check_replaceable(path, owned=None, *, name="path", overwrite=False) -> Path:
    """``path`` as a Path if a writer may put its output there; else InputError, before any work.

    Allowed: a path that does not exist, an empty folder, or an earlier
    output of the same writer (``owned(path)`` is true: the writer
    recognises its own format and mark).  Anything else (a file, a folder
    of other files, another tool's store) is replaced only with
    ``overwrite``.  A results folder of ``hexatissue analyze`` (it holds
    ``metadata.json``) is never replaced, ``overwrite`` or not.
    """
    path = Path(path)
    if not path.exists() and not path.is_symlink():
        return path
    if path.is_dir() and (path / "metadata.json").is_file():
        raise InputError(f"{name} {str(path)!r} is a results folder of 'hexatissue analyze' (it holds metadata.json); "
                         f"it is never replaced: write the export to another path")
    if path.is_dir() and not any(path.iterdir()):
        return path
    if owned is not None and owned(path):
        return path
    if overwrite:
        return path
    what = "a file" if not path.is_dir() else f"a folder, {sum(1 for _ in path.iterdir())} entries"
    raise InputError(f"{name} {str(path)!r} already exists ({what}) and is not an earlier output of this writer; "
                     f"writing there would replace what it holds: choose another path, or pass --overwrite "
                     f"(overwrite=True) to replace it")


def zarr_attributes(folder) -> dict:
    """The attributes of the zarr group ``folder`` (v3 ``zarr.json`` or v2 ``.zattrs``); {} if it has none.

    Read as plain JSON (no zarr import), for writers recognising their own
    earlier output before they replace it.
    """
    import json

    folder = Path(folder)
    for name, key in (("zarr.json", "attributes"), (".zattrs", None)):
        try:
            data = json.loads((folder / name).read_text())
        except (OSError, ValueError):
            continue
        if isinstance(data, dict):
            attrs = data.get(key, {}) if key else data
            return attrs if isinstance(attrs, dict) else {}
    return {}


def atomic_dir(path, *, owned=None, overwrite=False, name="path"):
    """A context manager yielding a temporary folder next to ``path``; it replaces ``path`` on success.

    For stores that are folders (zarr, GEFF): readers never see one half
    written.  ``path`` is first checked by :func:`check_replaceable`
    (``owned``, ``overwrite``, ``name``): only an absent path, an empty
    folder or an earlier output of the writer (or, with ``overwrite``,
    anything but a results folder) is replaced, so nothing the writer did
    not make is deleted.  An existing ``path`` is moved aside, the new
    folder renamed onto it, then the old one deleted; on error the
    temporary folder is removed and ``path`` is left as it was.
    """
    import shutil
    from contextlib import contextmanager

    @contextmanager
    def _ctx():
        target = check_replaceable(path, owned, name=name, overwrite=overwrite)
        target.parent.mkdir(parents=True, exist_ok=True)
        tmp = Path(tempfile.mkdtemp(prefix=f".{target.name}.", suffix=".tmp", dir=target.parent))
        os.chmod(tmp, 0o777 & ~_UMASK)
        try:
            yield tmp
            old = None
            if target.exists() or target.is_symlink():
                old = Path(tempfile.mkdtemp(prefix=f".{target.name}.", suffix=".old", dir=target.parent))
                os.replace(target, old / target.name)
            os.replace(tmp, target)
            if old is not None:
                shutil.rmtree(old)
        except BaseException:
            shutil.rmtree(tmp, ignore_errors=True)
            raise

    return _ctx()


# OME's spellings of the calibration's units (frames and simulation iterations have no OME unit)
_OME_LENGTH = {"um": "µm", "nm": "nm", "mm": "mm", "cm": "cm", "m": "m"}
_OME_TIME = {"ms": "ms", "s": "s", "min": "min", "h": "h"}


def write_tiff(path, array, calibration=None) -> Path:
    """Write a 2-D image or a ``T x rows x cols`` stack as an OME-TIFF with its calibration, atomically.

    The pixel size and frame interval go to OME's ``PhysicalSizeX/Y`` and
    ``TimeIncrement`` (read back by :func:`hexatissue.open_source`; Fiji
    reads them with Bio-Formats).  Any integer or float dtype is kept
    (uint32 labels included).  Returns the path.
    """
    import tifffile


    array = np.asarray(array)
    if array.ndim not in (2, 3):
        raise InputError(f"array must be a 2-D image or a T x rows x cols stack; got shape {array.shape}")
    cal = calibration or Calibration()
    meta = {"axes": "YX" if array.ndim == 2 else "TYX"}
    if cal.length_unit in _OME_LENGTH:
        unit = _OME_LENGTH[cal.length_unit]
        meta.update(PhysicalSizeX=cal.pixel_size, PhysicalSizeY=cal.pixel_size, PhysicalSizeXUnit=unit,
                    PhysicalSizeYUnit=unit)
    if array.ndim == 3 and cal.time_unit in _OME_TIME:
        meta.update(TimeIncrement=cal.frame_interval, TimeIncrementUnit=_OME_TIME[cal.time_unit])
    with atomic_path(path) as tmp:
        tifffile.imwrite(tmp, array, ome=True, metadata=meta)
    return Path(path)


def check_output_folder(path, name="out") -> Path:
    """``path`` as a Path if a folder can be written there (it exists as a folder, or can be made); else InputError.

    Nothing is created: the nearest existing ancestor must be a folder in
    which a file can be made (tried with a temporary file, so read-only
    file systems are caught too).  Call it before a long computation.
    """
    if not isinstance(path, (str, os.PathLike)) or not str(path):
        raise InputError(f"{name} must be a folder path (str or Path); got {path!r}")
    path = Path(path)
    if path.exists() and not path.is_dir():
        raise InputError(f"{name} {str(path)!r} is a file; expected a folder (or a path where one can be made)")
    ancestor = path
    while not ancestor.exists():
        ancestor = ancestor.parent
    if not ancestor.is_dir():
        raise InputError(f"{name} {str(path)!r} lies below the file {str(ancestor)!r}; expected a folder path")
    try:
        with tempfile.TemporaryFile(dir=ancestor):
            pass
    except OSError as exc:
        raise InputError(f"{name} {str(path)!r} cannot be written: {str(ancestor)!r} is not writable "
                         f"({exc.strerror or exc})") from None
    return path


#: The folder locks this process holds: lock file (resolved) -> [its open file, holders in this process].
_HELD = {}


class FolderLock:
    """A folder's exclusive lock held by this process (:func:`lock_folder`); :meth:`close` lets go of it, and the
    last holder in the process releases it."""

    def __init__(self, path):
        self.path = path

    def close(self):
        if self.path is None:
            return
        held = _HELD[self.path]
        held[1] -= 1
        if not held[1]:
            held[0].close()  # closing the file releases the flock
            del _HELD[self.path]
        self.path = None


def lock_folder(folder, filename, what):
    """Take the exclusive lock of ``folder`` (the file ``filename`` in it, fcntl); InputError when another process
    holds it.

    Returns a :class:`FolderLock` (its ``close`` releases the lock; so does
    the end of the process), or None where fcntl is missing (Windows:
    nothing is locked).  Within one process the lock is taken again by the
    same holder, not refused: ``hexatissue analyze`` holds its ``--out``
    folder and :func:`hexatissue.analyze` takes it again for the tables it
    streams there.  ``what`` names the folder in the message (``"--out
    folder"``).  The folder is made if it does not exist.
    """
    try:
        import fcntl
    except ImportError:
        return None
    folder = Path(folder)
    folder.mkdir(parents=True, exist_ok=True)
    path = (folder / filename).resolve()
    if path in _HELD:
        _HELD[path][1] += 1
        return FolderLock(path)
    handle = open(path, "a+")
    try:
        fcntl.flock(handle.fileno(), fcntl.LOCK_EX | fcntl.LOCK_NB)
    except OSError:
        handle.close()
        raise InputError(f"{what} {str(folder)!r} is in use by another running analysis (its {filename} is held); "
                         f"wait for it to finish or use another folder") from None
    handle.seek(0)
    handle.truncate()
    handle.write(f"{os.getpid()}\n")
    handle.flush()
    _HELD[path] = [handle, 1]
    return FolderLock(path)


#: Rows per Parquet row group: the writer holds one group's encoded columns at a time.
PARQUET_ROW_GROUP = 65536


#: The keys of a Parquet column's field metadata that hold its unit and meaning (from :mod:`hexatissue.schema`).
UNIT_KEY, DESCRIPTION_KEY = b"unit", b"description"


def write_table(df: pd.DataFrame, path, schema=None) -> Path:
    """Write ``df`` to ``path`` (``.parquet`` or ``.csv``) atomically; returns the path.

    ``schema``: the name of the table in :data:`hexatissue.schema.TABLES`;
    in a Parquet file, each of its columns then carries its ``unit`` and
    ``description`` in the field's metadata (read them with
    ``pyarrow.parquet.read_schema(path).field(column).metadata``, or
    :func:`read_units`), so other tools see them.  A unit of ``""`` is a
    count, an id, a flag or a dimensionless number.
    """
    path = Path(path)
    suffix = path.suffix.lower()
    if suffix not in (".parquet", ".csv"):
        raise InputError(f"table path {str(path)!r} must end in .parquet or .csv")
    with atomic_path(path) as tmp:
        if suffix == ".parquet":
            _write_parquet(df, tmp, schema)
        else:
            df.to_csv(tmp, index=False)
    return path


def _write_parquet(df, path, schema):
    import pyarrow as pa
    import pyarrow.parquet as pq

    from .schema import column_units

    table = pa.Table.from_pandas(df, preserve_index=False)
    if schema is not None:
        units = column_units(schema, table.column_names)
        fields = [f.with_metadata({UNIT_KEY: units[f.name][0].encode(), DESCRIPTION_KEY: units[f.name][1].encode()})
                  if f.name in units else f for f in table.schema]
        table = pa.Table.from_arrays(table.columns, schema=pa.schema(fields, metadata=table.schema.metadata))
    # row groups bound the writer's buffers (one whole-table group: +7% of the table); dictionary encoding only
    # for the columns that repeat (frames, ids, flags, labels): on floats it halved the write speed for files 8 %
    # larger (a 240-frame, 4,800-cell movie's parts: 4.1 against 2.0 CPU-s, 447 against 415 MB)
    repeating = [f.name for f in table.schema if not pa.types.is_floating(f.type)]
    pq.write_table(table, path, row_group_size=PARQUET_ROW_GROUP, use_dictionary=repeating)


def read_units(path) -> dict[str, tuple[str, str]]:
    """``{column: (unit, description)}`` from a Parquet file's field metadata (:func:`write_table`).

    Columns without them (files of other tools, columns outside the
    schema) are left out; a CSV file has none: ``{}``.
    """
    path = Path(path)
    if path.suffix.lower() != ".parquet":
        return {}
    import pyarrow.parquet as pq

    try:
        fields = pq.read_schema(path)
    except (OSError, ValueError) as exc:
        raise InputError(f"table {str(path)!r} cannot be read ({exc}); it is damaged or not a parquet file") from exc
    return {f.name: (f.metadata[UNIT_KEY].decode(), f.metadata.get(DESCRIPTION_KEY, b"").decode())
            for f in fields if f.metadata and UNIT_KEY in f.metadata}


def write_tables(tables: dict, directory, formats=("parquet",)) -> list[Path]:
    """Write ``{name: DataFrame}`` to ``directory/<name>.<fmt>`` for each format in ``formats``."""
    bad = set(formats) - {"parquet", "csv"}
    if bad:
        raise InputError(f"formats must be 'parquet' and/or 'csv'; got {sorted(bad)}")
    directory = Path(directory)
    return [write_table(df, directory / f"{name}.{fmt}") for name, df in tables.items() for fmt in formats]


def read_table(path) -> pd.DataFrame:
    """Read a table written by :func:`write_table`."""
    path = Path(path)
    if not path.exists():
        raise InputError(f"table {str(path)!r} does not exist")
    suffix = path.suffix.lower()
    if suffix not in (".parquet", ".csv"):
        raise InputError(f"table path {str(path)!r} must end in .parquet or .csv")
    try:
        return pd.read_parquet(path) if suffix == ".parquet" else pd.read_csv(path)
    except (OSError, ValueError, pd.errors.ParserError, UnicodeDecodeError) as exc:
        detail = str(exc).splitlines()[0] if str(exc) else type(exc).__name__
        raise InputError(f"table {str(path)!r} cannot be read ({detail}); it is damaged or not a "
                         f"{suffix[1:]} file") from exc


def check_zarr_chunks(arr, n_rows, what) -> None:
    """InputError when a chunk of the first ``n_rows`` rows of the zarr array ``arr`` is missing from its store.

    zarr reads a missing chunk as its fill value (zeros), so a deleted chunk
    would pass for data.  zarr also skips writing chunks that are all fill
    value, so check only arrays whose chunks never are (label images, cell
    areas, fields).  Stores this check cannot inspect are not checked.
    """
    import math

    try:
        from zarr.core.sync import sync

        path = arr.store_path
        prefix = f"{path.path}/" if path.path else ""
        if n_rows <= 0 or 0 in arr.shape:
            return
        rows = range(math.ceil(min(n_rows, arr.shape[0]) / arr.chunks[0]))
        rest = [range(math.ceil(n / c)) for n, c in zip(arr.shape[1:], arr.chunks[1:])]
        from itertools import product

        missing = [c for c in product(rows, *rest)
                   if not sync(path.store.exists(prefix + arr.metadata.encode_chunk_key(c)))]
    except (AttributeError, ImportError, TypeError):  # another zarr version or store: nothing to check
        return
    if missing:
        raise InputError(f"{what}: {len(missing)} chunk(s) of array {arr.name!r} are missing from the store "
                         f"(first at chunk {missing[0]}); the store is damaged: write it again")


def read_zarr(arr, what, index=Ellipsis):
    """``np.asarray(arr[index])``; a damaged (truncated, garbled) chunk becomes an InputError naming ``what``."""
    try:
        return np.asarray(arr[index])
    except Exception as exc:
        detail = str(exc).splitlines()[0] if str(exc) else type(exc).__name__
        raise InputError(f"{what}: array {getattr(arr, 'name', '?')!r} cannot be read ({type(exc).__name__}: "
                         f"{detail}); the store is damaged: write it again") from exc
