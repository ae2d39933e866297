"""The movie's tables filled frame by frame (:class:`Rows`), for the spine."""
from __future__ import annotations

import numpy as np
import pandas as pd

from ._system import reserve
from .schema import empty_table, validate

__all__ = ["Rows"]


class Rows:
    """One table of the movie, filled frame by frame into one growing buffer per column.

    What ``pd.concat`` of the per-frame tables gives, without keeping them:
    each frame's table is copied into the buffers on arrival and dropped, so
    its memory is reused by the next frame, and :meth:`table` wraps the
    buffers without a copy.  (Keeping thousands of small per-frame tables,
    then concatenating them, holds the movie twice at the end, and the C
    heap keeps the freed parts resident.)  Buffers are reserved for the
    expected number of rows and doubled when full; the reserved tail is
    never written, so it costs address space, not memory
    (:func:`~hexatissue._system.reserve`).  Frames whose
    columns or dtypes differ from the first one's (or non-NumPy dtypes) fall
    back to ``pd.concat``.
    """

    def __init__(self, expected_frames=1):
        self.expected_frames = max(int(expected_frames), 1)
        self.n = 0
        self.names = self.dtypes = self.buffers = None
        self.parts = None  # the pd.concat fallback

    def append(self, df, frames=1):
        """Add the rows of ``df`` (the table of ``frames`` frames, used to size the buffers).

        ``df`` is a dict of numpy columns, as the frame job returns every
        table (reading those is free; ``df[name]`` is not), or a DataFrame
        (a checkpoint's rows).
        """
        if isinstance(df, dict):
            names, dtypes, n_rows = list(df), [a.dtype for a in df.values()], len(next(iter(df.values())))
            column = df.__getitem__
        else:
            names, dtypes, n_rows = list(df.columns), list(df.dtypes), len(df)
            column = lambda name: df[name].to_numpy()  # noqa: E731
        if self.parts is not None:
            self.parts.append(pd.DataFrame(df))
            return
        if self.buffers is None:
            if not all(isinstance(dt, np.dtype) for dt in dtypes):
                self.parts = [pd.DataFrame(df)]
                return
            self.names, self.dtypes = names, dtypes
            capacity = int(1.1 * max(n_rows, 1) / max(frames, 1) * self.expected_frames) + 16
            self.buffers = [reserve(capacity, dt) for dt in self.dtypes]
        elif names != self.names or dtypes != self.dtypes:
            self.parts = [self.table(), pd.DataFrame(df)]
            self.names = self.dtypes = self.buffers = None
            return
        end = self.n + n_rows
        if end > len(self.buffers[0]):
            capacity = max(end, 2 * len(self.buffers[0]))
            for k, old in enumerate(self.buffers):  # one column at a time
                new = reserve(capacity, old.dtype)
                new[:self.n] = old[:self.n]
                self.buffers[k] = new
                del old, new
        for buf, name in zip(self.buffers, self.names):
            buf[self.n:end] = column(name)
        self.n = end

    @property
    def nbytes(self) -> int:
        """Bytes of the rows held."""
        if self.parts is not None:
            return int(sum(part.memory_usage().sum() for part in self.parts))
        return 0 if self.buffers is None else sum(self.n * buf.dtype.itemsize for buf in self.buffers)

    def table(self, name=None, orders=None, start=0) -> pd.DataFrame:
        """The rows from ``start`` on (views of the buffers); ``empty_table(name, orders)`` if nothing came."""
        if self.parts is not None:
            out = pd.concat(self.parts, ignore_index=True)
            return out.iloc[start:].reset_index(drop=True) if start else out
        if self.buffers is None:
            return empty_table(name, orders)
        out = pd.DataFrame({n: buf[start:self.n] for n, buf in zip(self.names, self.buffers)}, copy=False)
        return validate(out, name) if name is not None else out  # the frame job's columns are checked here
