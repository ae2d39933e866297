"""Tables kept on disk as they are made: a Parquet dataset per table, one part per chunk of frames.

A long movie's tables do not fit in memory (about 1.3 kB per cell and frame
with the default stages: 13 GB at 10^7 cell-frames).  A :class:`StoredTable`
holds one of them as ``<folder>/<name>/part-<first>-<last>.parquet`` files
(frames ``first`` to ``last``, in frame order), written as the frames finish,
and reads back only the columns and frames asked for.  Columns that the
movie stages add (a cell's ``track``, its velocity) are kept on disk too,
one ``.npy`` file each in the table's folder (hidden from Parquet readers of
the folder), until :meth:`StoredTable.finish` writes them into the parts.  The
folder reads as one table with ``pandas.read_parquet(folder)`` or
``pyarrow.dataset.dataset(folder)``; every column carries its unit in the
Parquet field metadata, as :func:`hexatissue.io.write_table` writes.
"""
from __future__ import annotations

import re
from pathlib import Path

import numpy as np
import pandas as pd

from .errors import InputError
from .io import write_table
from .schema import empty_table

__all__ = ["StoredTable", "ColumnWriter", "PART_PATTERN", "ADDED_PREFIX"]

#: File name of one part: the frames it holds, first and last.
PART_PATTERN = re.compile(r"part-(\d{8})-(\d{8})\.parquet")

#: File name prefix of an added column (``.added-<column>.npy``): a leading dot, so that pyarrow and pandas
#: readers of the table's folder skip it.
ADDED_PREFIX = ".added-"


class StoredTable:
    """One table of a movie as Parquet parts by chunk of frames, read by column and frame range.

    Parameters
    ----------
    folder : str or Path
        The table's folder (``<results>/<name>``); created when the first part is written.
    name : str
        The table's schema name (:data:`hexatissue.schema.TABLES`).
    orders : sequence of int, optional
        The p of the gamma columns, for the empty table's columns.

    Notes
    -----
    Parts are written whole and atomically (:func:`hexatissue.io.write_table`),
    so a part on disk is complete.  Added columns are ``.npy`` files beside
    the parts, one array over all rows in part order, read a slice at a time,
    until :meth:`finish`: a stage that adds a column part by part
    (:meth:`column_writer`) holds no more than a part of it in memory.
    """

    def __init__(self, folder, name, orders=None):
        self.folder = Path(folder)
        self.name = name
        self.orders = orders
        self.parts = []  # (first frame, last frame, rows, path), in frame order
        self.added = []  # (column, its .npy file over all rows, insert after this column or None)
        self._columns = None

    @classmethod
    def open(cls, folder, name):
        """The table written in ``folder`` (its parts, found by name); InputError when it holds none."""
        folder = Path(folder)
        table = cls(folder, name)
        files = sorted(p for p in folder.iterdir() if PART_PATTERN.fullmatch(p.name)) if folder.is_dir() else []
        if not files:
            raise InputError(f"table folder {str(folder)!r} holds no part-<first>-<last>.parquet files")
        import pyarrow.parquet as pq

        for path in files:
            first, last = map(int, PART_PATTERN.fullmatch(path.name).groups())
            table.parts.append((first, last, pq.ParquetFile(path).metadata.num_rows, path))
        return table

    # -- writing ---------------------------------------------------------------------------------------------

    def append(self, table, first, last):
        """Write the rows of frames ``first`` to ``last`` (a DataFrame) as the next part."""
        if self.parts and first <= self.parts[-1][1]:
            raise ValueError(f"{self.name}: part of frames {first}-{last} does not follow frame {self.parts[-1][1]}")
        self.folder.mkdir(parents=True, exist_ok=True)
        path = self.folder / f"part-{first:08d}-{last:08d}.parquet"
        write_table(table, path, schema=self.name)
        if self._columns is None:
            self._columns = list(table.columns)
        self.parts.append((int(first), int(last), len(table), path))

    def add_column(self, column, values, after=None):
        """Add (or replace) ``column``, ``values`` over every row in order, as pandas would.

        ``after``: the column to insert it after (an existing ``column`` is
        dropped first); None: replaced in place, or appended at the end.
        """
        writer = self.column_writer(column, np.asarray(values).dtype, after)
        writer.write(values)
        writer.close()

    def column_writer(self, column, dtype, after=None) -> "ColumnWriter":
        """A :class:`ColumnWriter` that adds ``column`` (of ``dtype``) from its values part by part, in row order;
        ``after`` as for :meth:`add_column`."""
        return ColumnWriter(self, column, dtype, after)

    def _added_column(self, column, path, after):
        """Register the finished file of an added ``column`` (replacing an earlier one of that name, whose place it
        keeps when ``after`` is None)."""
        earlier = [a for c, _, a in self.added if c == column]
        if earlier and after is None:
            after = earlier[-1]
        self.added = [entry for entry in self.added if entry[0] != column]
        target = self.folder / f"{ADDED_PREFIX}{column}.npy"
        path.replace(target)
        self.added.append((column, target, after))

    def finish(self):
        """Write the added columns into the parts (each rewritten atomically), then remove their files; a no-op
        without added columns."""
        if not self.added:
            return
        for (_, _, _, path), (_, part) in zip(self.parts, self.iter_parts()):
            write_table(part, path, schema=self.name)
        self._columns = list(self.head().columns) if self.parts else None  # the parts' columns now
        for _, path, _ in self.added:
            path.unlink(missing_ok=True)
        self.added = []

    # -- reading ---------------------------------------------------------------------------------------------

    def __len__(self):
        return sum(rows for _, _, rows, _ in self.parts)

    @property
    def columns(self) -> list:
        """The table's columns, added ones included, in order."""
        return list(self.head().columns)

    @property
    def frame_chunks(self) -> list:
        """``(first, last)`` frames of every part."""
        return [(first, last) for first, last, _, _ in self.parts]

    def head(self) -> pd.DataFrame:
        """The columns of the table with no rows."""
        return self._part(0, empty=True) if self.parts else empty_table(self.name, self.orders)

    def _offsets(self):
        return np.concatenate([[0], np.cumsum([rows for _, _, rows, _ in self.parts])]).astype(np.int64)

    def _part(self, k, columns=None, empty=False):
        """Part ``k`` with the added columns (only ``columns`` when given; none of its rows when ``empty``)."""
        stored = None if columns is None else [c for c in columns if c in self._stored_columns()]
        if empty:
            import pyarrow.parquet as pq

            schema = pq.read_schema(self.parts[k][3])
            df = schema.empty_table().select(stored or schema.names).to_pandas()
        else:
            df = self._arrow_read([k], stored).to_pandas(split_blocks=True, self_destruct=True)
        start = self._offsets()[k]
        df = self._with_added(df, slice(start, start + len(df)), columns)
        return df if columns is None else df[[c for c in columns if c in df.columns]]

    def _with_added(self, df, rows, columns):
        """``df`` (the table's ``rows``, a slice) with the added columns (only those in ``columns`` when given),
        each set or inserted as :meth:`add_column` says."""
        for column, path, after in self.added:
            if columns is not None and column not in columns:
                continue
            values = np.array(np.load(path, mmap_mode="r")[rows])  # the slice alone is read
            if after is not None:
                if column in df.columns:
                    del df[column]
                df.insert(df.columns.get_loc(after) + 1 if after in df.columns else len(df.columns), column,
                          values)
            else:
                df[column] = values
        return df

    def _stored_columns(self):
        if self._columns is None and self.parts:
            import pyarrow.parquet as pq

            self._columns = list(pq.read_schema(self.parts[0][3]).names)
        return self._columns or []

    def read(self, columns=None, frames=None) -> pd.DataFrame:
        """The table (only ``columns`` that it has, when given; only the parts overlapping ``frames`` =
        ``(first, last)`` and, of those, the rows of these frames) as one DataFrame.

        The parts are read as one Arrow table and converted column by
        column, each Arrow buffer freed once converted (not a DataFrame per
        part, then their concatenation: twice the memory).
        """
        import pyarrow as pa

        keep = [k for k, (first, last, _, _) in enumerate(self.parts)
                if frames is None or (last >= frames[0] and first <= frames[1])]
        if not keep:
            head = self.head()
            return head if columns is None else head[[c for c in columns if c in head.columns]]
        on_disk = self._stored_columns()
        stored = list(on_disk) if columns is None else [c for c in columns if c in on_disk]
        # the frame column selects the rows, also when it is not asked for
        selecting = frames is not None and "frame" not in stored
        table = self._arrow_read(keep, stored + (["frame"] if selecting else []))
        out = table.to_pandas(split_blocks=True, self_destruct=True)
        del table
        pa.default_memory_pool().release_unused()
        offsets = self._offsets()
        out = self._with_added(out, slice(offsets[keep[0]], offsets[keep[-1] + 1]), columns)  # consecutive parts
        if frames is not None:
            f = out["frame"].to_numpy()
            inside = (f >= frames[0]) & (f <= frames[1])
            if not inside.all():
                out = out[inside].reset_index(drop=True)
            if selecting:
                del out["frame"]
        return out if columns is None else out[[c for c in columns if c in out.columns]]

    def _arrow_read(self, keep, columns):
        """Parts ``keep`` (consecutive), only ``columns``, as one Arrow table."""
        import pyarrow.dataset as ds

        return ds.dataset([str(self.parts[k][3]) for k in keep], format="parquet").to_table(columns=columns)

    def iter_parts(self):
        """``((first, last), DataFrame)`` of every part in frame order, the added columns included."""
        for k, (first, last, _, _) in enumerate(self.parts):
            yield (first, last), self._part(k)

    def frames_reader(self, columns):
        """``read(first, last)``: the ``columns`` of the rows of frames ``first`` to ``last``, for ranges that move
        forward through the movie; each part is read once while the ranges stay in it."""
        held = {"parts": None, "table": None}
        wanted = [c for c in columns if c in self.columns]
        with_frame = wanted if "frame" in wanted else [*wanted, "frame"]  # the rows are found by their frame

        def read(first, last):
            keep = tuple(k for k, (lo, hi, _, _) in enumerate(self.parts) if hi >= first and lo <= last)
            if not keep:
                return self.head()[wanted]
            if held["parts"] != keep:
                held["table"] = None  # the previous parts' memory, before these are read
                table = self.read(with_frame, frames=(self.parts[keep[0]][0], self.parts[keep[-1]][1]))
                f = table["frame"].to_numpy()
                held.update(parts=keep, table=table, frame=f,
                            ordered=len(f) < 2 or bool(np.all(f[1:] >= f[:-1])))  # analyze writes frame order
            table, f = held["table"], held["frame"]
            if not held["ordered"]:
                return table.loc[(f >= first) & (f <= last), wanted]
            lo, hi = np.searchsorted(f, first, "left"), np.searchsorted(f, last, "right")
            return table.iloc[lo:hi][wanted]

        return read

    def __getitem__(self, column) -> pd.Series:
        """One column over every row (a pandas Series)."""
        if column not in self.columns:
            raise KeyError(column)
        return self.read([column])[column]

    def to_pandas(self) -> pd.DataFrame:
        """The whole table in memory."""
        return self.read()

    def dataset(self):
        """The parts as a ``pyarrow.dataset.Dataset`` (added columns not yet finished are not in it)."""
        import pyarrow.dataset as ds

        return ds.dataset([str(p) for _, _, _, p in self.parts], format="parquet")

    def to_dask(self, columns=None):
        """The parts as a ``dask.dataframe.DataFrame``, one partition per part (only ``columns`` when given; added
        columns not yet finished are not in it)."""
        import dask.dataframe as dd

        return dd.read_parquet([str(p) for _, _, _, p in self.parts], columns=columns)

    def __repr__(self):
        return f"StoredTable({self.name!r}, {len(self)} rows in {len(self.parts)} part(s) at {str(self.folder)!r})"


class ColumnWriter:
    """A column added to a :class:`StoredTable` from its values part by part (:meth:`StoredTable.column_writer`).

    :meth:`write` appends the next rows' values (in row order) to a ``.npy``
    file in the table's folder; :meth:`close` checks that every row has one
    and adds the column.  Only the values given to one :meth:`write` are in
    memory.
    """

    def __init__(self, table, column, dtype, after=None):
        self.table, self.column, self.after = table, column, after
        self.dtype = np.dtype(dtype)
        if self.dtype.hasobject:
            raise ValueError(f"{table.name}.{column}: an added column must be numeric or bool, not {self.dtype}")
        table.folder.mkdir(parents=True, exist_ok=True)
        self.path = table.folder / f"{ADDED_PREFIX}{column}.npy.tmp"
        self._file = open(self.path, "wb")
        self._header = {"descr": np.lib.format.dtype_to_descr(self.dtype), "fortran_order": False,
                        "shape": (len(table),)}
        np.lib.format.write_array_header_1_0(self._file, self._header)
        self.rows = 0

    def write(self, values):
        """Append ``values`` (the next rows', in row order)."""
        values = np.ascontiguousarray(values, dtype=self.dtype)
        if self.rows + len(values) > self._header["shape"][0]:
            self._abort()
            raise ValueError(f"{self.table.name}.{self.column}: more values than the table's {len(self.table)} rows")
        self._file.write(values.tobytes())
        self.rows += len(values)

    def close(self):
        """Add the column to the table; ValueError (and nothing added) unless every row has its value."""
        self._file.close()
        if self.rows != self._header["shape"][0]:
            self.path.unlink(missing_ok=True)
            raise ValueError(f"{self.table.name}.{self.column}: {self.rows} values for {len(self.table)} rows")
        self.table._added_column(self.column, self.path, self.after)

    def _abort(self):
        self._file.close()
        self.path.unlink(missing_ok=True)
