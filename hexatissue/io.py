"""Reading label images and stacks; writing and reading tables.

Label images are integer arrays indexed ``[row, col]`` (``[t, row, col]``
for stacks) with 0 = background or membrane.  Tables are written atomically:
to a temporary name in the same folder, then renamed.
"""
from __future__ import annotations

import os
import tempfile
from pathlib import Path

import numpy as np
import pandas as pd

from .errors import InputError

__all__ = ["read_labels", "write_table", "write_tables", "read_table", "atomic_path"]

LABEL_SUFFIXES = (".tif", ".tiff", ".png", ".npy", ".npz")


def _current_umask() -> int:
    mask = os.umask(0)
    os.umask(mask)
    return mask


_UMASK = _current_umask()


def _collapse_rgb(arr: np.ndarray, path) -> np.ndarray:
    """RGB(A) images whose colour channels are equal (skeletons saved as RGB) become one channel."""
    if arr.ndim >= 3 and arr.shape[-1] in (3, 4):
        rgb = arr[..., :3]
        if np.array_equal(rgb[..., 0], rgb[..., 1]) and np.array_equal(rgb[..., 0], rgb[..., 2]):
            return rgb[..., 0]
        # distinct colours: encode each colour as one integer label
        rgb = rgb.astype(np.int64)
        return (rgb[..., 0] << 16) | (rgb[..., 1] << 8) | rgb[..., 2]
    return arr


def read_labels(path, key: str | None = None) -> np.ndarray:
    """Read a 2-D label image or a T x Y x X label stack.

    Parameters
    ----------
    path : str or Path
        ``.tif``/``.tiff`` (tifffile), ``.png``, ``.npy``, a Cellpose
        ``*_seg.npy`` (its ``masks``), or ``.npz`` (array ``key``, by default
        ``labels`` or the only array in the file).
    key : str, optional
        Array name inside an ``.npz`` or a Cellpose ``_seg.npy`` file.

    Returns
    -------
    numpy.ndarray
        Indexed ``[row, col]`` or ``[t, row, col]``.  RGB images with equal
        channels (skeletons saved as RGB) are reduced to one channel.

    Raises
    ------
    InputError
        The file is missing, has an unknown suffix or cannot be read.
    """
    path = Path(path)
    if not path.exists():
        raise InputError(f"path {str(path)!r} does not exist; expected a label image file")
    suffix = path.suffix.lower()
    try:
        if suffix in (".tif", ".tiff"):
            import tifffile

            arr = tifffile.imread(path)
        elif suffix == ".png":
            import imageio.v3 as iio

            arr = iio.imread(path)
        elif suffix == ".npy":
            if path.name.endswith("_seg.npy"):
                # Cellpose saves a pickled dict; only files of that name are unpickled.
                arr = np.asarray(np.load(path, allow_pickle=True).item()[key or "masks"])
            else:
                arr = np.load(path, allow_pickle=False)
        elif suffix == ".npz":
            with np.load(path, allow_pickle=False) as data:
                names = list(data.keys())
                if key is None:
                    key = "labels" if "labels" in names else (names[0] if len(names) == 1 else None)
                if key not in names:
                    raise InputError(f"{path.name}: choose an array with key=; it holds {names}")
                arr = data[key]
        else:
            raise InputError(f"path {str(path)!r} has unknown suffix {suffix!r}; expected one of {LABEL_SUFFIXES}")
    except InputError:
        raise
    except Exception as exc:  # any reader failure becomes a clear InputError
        raise InputError(f"could not read label image {str(path)!r}: {type(exc).__name__}: {exc}") from exc
    return _collapse_rgb(np.asarray(arr), path)


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


def write_table(df: pd.DataFrame, path) -> Path:
    """Write ``df`` to ``path`` (``.parquet`` or ``.csv``) atomically; returns the path."""
    path = Path(path)
    suffix = path.suffix.lower()
    if suffix not in (".parquet", ".csv"):
        raise InputError(f"table path {str(path)!r} must end in .parquet or .csv")
    with atomic_path(path) as tmp:
        if suffix == ".parquet":
            df.to_parquet(tmp, index=False)
        else:
            df.to_csv(tmp, index=False)
    return path


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
    if path.suffix.lower() == ".parquet":
        return pd.read_parquet(path)
    if path.suffix.lower() == ".csv":
        return pd.read_csv(path)
    raise InputError(f"table path {str(path)!r} must end in .parquet or .csv")
