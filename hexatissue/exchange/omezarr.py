"""Label stacks as OME-Zarr (OME-NGFF 0.5, or 0.4 on request): an image with its labels in ``labels/``.

:func:`write_ome_zarr_labels` writes the standard layout that OME-Zarr
viewers (napari-ome-zarr, ome-zarr-py, ngff-zarr) open as labels over an
image: the root group is a multiscale image (the raw channel when one is
given, else :func:`boundary_image`, the cells' outlines, so that the labels
have something to sit on), and ``labels/cells`` is the multiscale label
image, with ``image-label`` metadata pointing back to it and giving each
label value a colour (``colors``: :func:`label_colors`) and, from an
analysis, its track's properties (``properties``: :func:`track_properties`).
Axes ``t``
(time), ``y``, ``x`` (space) with their units when the calibration has
them; arrays ``0``, ``1``, ... each half the size of the one before, with a
``scale`` coordinate transformation per level (frame interval, pixel size x
2**level); chunk keys nested with "/".  Label levels are made with
:func:`downsample_labels`, the mode of each 2 x 2 block, never a mean (a
mean of two ids is a third id); image levels with the mean.
:func:`hexatissue.open_source` reads the labels with ``key="labels/cells"``
and ``level=``.
"""
from __future__ import annotations

from pathlib import Path

import numpy as np

from ..errors import InputError, check_positive
from ..units import as_calibration
from ..views import columns

__all__ = ["write_ome_zarr_labels", "is_ome_zarr_export", "downsample_labels", "boundary_image", "label_colors",
           "track_properties", "NGFF_LENGTH", "NGFF_TIME", "NGFF_VERSIONS", "LABELS_KEY"]

#: The OME-NGFF versions written: 0.5 (zarr v3, the default) and 0.4 (zarr v2).
NGFF_VERSIONS = ("0.5", "0.4")
#: Where the label image lies in the store (``open_source(path, key=LABELS_KEY)``).
LABELS_KEY = "labels/cells"
#: hexatissue unit names -> OME-NGFF unit names (also GEFF's)
NGFF_LENGTH = {"um": "micrometer", "nm": "nanometer", "mm": "millimeter", "cm": "centimeter", "m": "meter"}
NGFF_TIME = {"ms": "millisecond", "s": "second", "min": "minute", "h": "hour"}
MAX_CHUNK = 1024  # px per chunk side by default
GOLDEN = 0.6180339887498949  # hue step between consecutive groups: neighbouring group numbers get distant hues


def downsample_labels(frame) -> np.ndarray:
    """One label image at half the resolution: the mode of each 2 x 2 block.

    Parameters
    ----------
    frame : (rows, cols) integer array
        Label image indexed ``[row, col]``.

    Returns
    -------
    numpy.ndarray
        ``(ceil(rows / 2), ceil(cols / 2))``, same dtype.  Pixel ``[i, j]``
        is the value held by most of the pixels ``[2i:2i+2, 2j:2j+2]``
        (an odd last row or column is repeated); on a tie between two
        values, or when all four differ, the top-left pixel's value (the
        nearest neighbour).
    """
    f = np.asarray(frame)
    if f.ndim != 2 or f.dtype.kind not in "iu":
        raise InputError(f"frame must be a 2-D integer label image; got {f.dtype} of shape {f.shape}")
    f = np.pad(f, ((0, f.shape[0] % 2), (0, f.shape[1] % 2)), mode="edge")
    a, b, c, d = f[0::2, 0::2], f[0::2, 1::2], f[1::2, 0::2], f[1::2, 1::2]
    # pixels of each block holding a's, b's, c's value; d's value never beats all of them alone: any tie
    # involves a (two pairs, or four distinct values), and d's count equals that of the earlier equal pixel
    na = 1 + (a == b) + (a == c) + (a == d)
    nb = 1 + (b == a) + (b == c) + (b == d)
    nc = 1 + (c == a) + (c == b) + (c == d)
    out = np.where(nb > na, b, a)
    return np.where(nc > np.maximum(na, nb), c, out)


def _downsample_mean(frame) -> np.ndarray:
    """One image at half the resolution: the mean of each 2 x 2 block (an odd last row or column repeated),
    in the image's dtype (rounded for integers)."""
    f = np.pad(frame, ((0, frame.shape[0] % 2), (0, frame.shape[1] % 2)), mode="edge").astype(np.float64)
    mean = (f[0::2, 0::2] + f[0::2, 1::2] + f[1::2, 0::2] + f[1::2, 1::2]) / 4
    return np.rint(mean).astype(frame.dtype) if frame.dtype.kind in "iub" else mean.astype(frame.dtype)


def boundary_image(frame) -> np.ndarray:
    """The outlines of the cells of a label image, to show the labels on when no raw image is given.

    Parameters
    ----------
    frame : (rows, cols) integer array
        Label image indexed ``[row, col]``.

    Returns
    -------
    numpy.ndarray
        ``(rows, cols)`` uint8: 255 on every pixel that has a 4-neighbour
        with another label (so a boundary is 2 px wide, one on each side),
        0 elsewhere.  An image for the eye, not for analysis: analyse the
        labels (``key="labels/cells"``).
    """
    f = np.asarray(frame)
    edge = np.zeros(f.shape, bool)
    across = f[:, 1:] != f[:, :-1]
    edge[:, 1:] |= across
    edge[:, :-1] |= across
    down = f[1:, :] != f[:-1, :]
    edge[1:, :] |= down
    edge[:-1, :] |= down
    return edge.astype(np.uint8) * np.uint8(255)


def label_colors(values, groups=None) -> list[dict]:
    """The NGFF ``image-label`` ``colors`` of label values: one opaque colour per group, background transparent.

    Parameters
    ----------
    values : sequence of int
        Label values (0, the background, may be among them).
    groups : sequence of int, optional
        A group number per value (default: the value itself): values of one
        group share a colour, e.g. the tracks of one lineage.

    Returns
    -------
    list of dict
        ``{"label-value": v, "rgba": [r, g, b, a]}`` (0-255 integers) for
        every value, sorted by value: hue ``frac(group * 0.618...)`` at
        saturation 0.65 and value 0.95, alpha 255; ``[0, 0, 0, 0]`` for 0.
    """
    import colorsys

    values = np.asarray(values, np.int64).ravel()
    groups = values if groups is None else np.asarray(groups, np.int64).ravel()
    if groups.shape != values.shape:
        raise InputError(f"groups must have one number per label value ({len(values)}); got {len(groups)}")
    out = []
    for v, g in sorted(zip(values.tolist(), groups.tolist())):
        if v == 0:
            out.append({"label-value": 0, "rgba": [0, 0, 0, 0]})
            continue
        r, gr, b = colorsys.hsv_to_rgb((g * GOLDEN) % 1.0, 0.65, 0.95)
        out.append({"label-value": int(v), "rgba": [round(r * 255), round(gr * 255), round(b * 255), 255]})
    return out


def track_properties(movie) -> tuple[list[dict], list[dict]]:
    """``(colors, properties)`` of a Movie's tracks for the ``image-label`` of its track-id labels.

    Returns
    -------
    colors : list of dict
        :func:`label_colors` of the background (0, transparent) and of
        every track, one colour per lineage (the daughters of a division
        keep their mother's colour).
    properties : list of dict
        One per track, sorted: ``label-value`` (= ``track``), ``track``,
        ``parent`` (0 = none), ``lineage`` (the first ancestor's track),
        ``frame_start``, ``frame_end`` (frames, inclusive), ``n_frames``
        (frames it is present in), ``area_mean`` (px^2) and
        ``n_sides_mean`` over those frames.
    """
    from ..track import lineage_roots

    cells = columns(movie, "cells", ["track", "frame", "area", "n_sides"])
    by_track = cells.groupby("track", sort=True)
    stats = by_track.agg(frame_start=("frame", "min"), frame_end=("frame", "max"), n_frames=("frame", "size"),
                         area_mean=("area", "mean"), n_sides_mean=("n_sides", "mean"))
    lineage = movie.lineage
    parents = {} if lineage is None else {int(t): int(p) for t, p in zip(lineage["track"], lineage["parent"]) if p}
    tracks = stats.index.to_numpy(np.int64).tolist()
    roots = lineage_roots(parents, tracks)
    properties = [{"label-value": int(t), "track": int(t), "parent": parents.get(int(t), 0),
                   "lineage": int(roots[t]), "frame_start": int(row.frame_start), "frame_end": int(row.frame_end),
                   "n_frames": int(row.n_frames), "area_mean": float(row.area_mean),
                   "n_sides_mean": float(row.n_sides_mean)}
                  for t, row in zip(tracks, stats.itertuples())]
    return label_colors([0, *tracks], [0, *(roots[t] for t in tracks)]), properties


def _frames(stack, name="stack"):
    """(number of frames, read(t), frame shape) of an array, a sequence of 2-D frames or a Source."""
    if hasattr(stack, "frame") and hasattr(stack, "n_frames"):  # a Source (hexatissue.open_source)
        return int(stack.n_frames), stack.frame, tuple(stack.shape)
    if isinstance(stack, (list, tuple)):
        if not stack:
            raise InputError(f"{name} must hold at least one frame; got an empty sequence")
        return len(stack), lambda t: np.asarray(stack[t]), np.asarray(stack[0]).shape
    if not hasattr(stack, "shape") or len(stack.shape) not in (2, 3):
        raise InputError(f"{name} must be a (rows, cols) or (T, rows, cols) array, a sequence of 2-D frames or a "
                         f"Source; got {type(stack).__name__} of shape {getattr(stack, 'shape', '?')}")
    if len(stack.shape) == 2:
        return 1, lambda t: np.asarray(stack), tuple(stack.shape)
    return int(stack.shape[0]), lambda t: np.asarray(stack[t]), tuple(stack.shape[1:])


def _axes(cal):
    axes = [{"name": "t", "type": "time"}, {"name": "y", "type": "space"}, {"name": "x", "type": "space"}]
    if cal.has_time and cal.time_unit in NGFF_TIME:
        axes[0]["unit"] = NGFF_TIME[cal.time_unit]
    if cal.has_length and cal.length_unit in NGFF_LENGTH:
        for a in axes[1:]:
            a["unit"] = NGFF_LENGTH[cal.length_unit]
    return axes


def _ome(attrs, version):
    """Group attributes in the version's place: under ``ome`` (0.5) or at the top with a version (0.4)."""
    if version == "0.5":
        return {"ome": {"version": version, **attrs}}
    if "multiscales" in attrs:
        attrs = dict(attrs, multiscales=[dict(ms, version=version) for ms in attrs["multiscales"]])
    if "image-label" in attrs:
        attrs = dict(attrs, **{"image-label": dict(attrs["image-label"], version=version)})
    return attrs


def _levels(group, n, shape, dtype, levels, chunks, version, fill):
    """The arrays ``0``, ``1``, ... of one multiscale image, each half the size of the one before."""
    arrays, size = [], shape
    v3 = version == "0.5"
    for k in range(levels):
        arrays.append(group.create_array(
            str(k), shape=(n, *size), dtype=dtype, fill_value=fill,
            chunks=(1, min(chunks[1], size[0]), min(chunks[2], size[1])),
            # nested chunk keys ("t/y/x" under c/ in v3, t/y/x in v2), as the NGFF specification asks
            chunk_key_encoding={"name": "default" if v3 else "v2", "separator": "/"},
            **({"dimension_names": ["t", "y", "x"]} if v3 else {})))
        size = ((size[0] + 1) // 2, (size[1] + 1) // 2)
    return arrays


def write_ome_zarr_labels(stack, path, *, image=None, calibration=None, levels=1, chunks=None,
                          version="0.5", colors=None, properties=None, overwrite=False) -> Path:
    """Write a label stack as an OME-Zarr image with its labels (``labels/cells``), atomically.

    Parameters
    ----------
    stack : (T, rows, cols) or (rows, cols) integer array-like, or a sequence of 2-D frames
        Label images indexed ``[t, row, col]``, 0 = background; read one frame
        at a time (zarr, dask and memory maps are fine).
    path : str or Path
        The ``.zarr`` folder to write.  An existing one is replaced only if
        it is an earlier output of this function (or empty); anything else
        is refused unless ``overwrite`` (a results folder always is).
    image : array-like, sequence of 2-D frames or Source, optional
        The raw channel the labels were drawn on: one frame per label frame
        (or one for all), of their shape, any numeric dtype (kept).  Default:
        :func:`boundary_image` of each label frame (uint8 cell outlines).
    calibration : Calibration, dict or None
        Pixel size and frame interval: the ``scale`` of every level is
        ``[frame_interval, pixel_size * 2**level, pixel_size * 2**level]`` and
        the axes carry the units (``micrometer``, ``minute``, ...);
        uncalibrated axes have scale 1 per frame and per level-0 pixel and no
        unit.
    levels : int
        Resolution levels (1: only the full one), the same for image and labels.
    chunks : tuple of int, optional
        Chunk shape ``(1, rows, cols)`` of level 0 (default: one frame,
        at most 1024 x 1024 px); coarser levels use the same, clipped to
        their size.
    version : {"0.5", "0.4"}
        OME-NGFF version: 0.5 (zarr v3, attributes under ``ome``) or 0.4
        (zarr v2, for older readers).
    colors : list of dict, optional
        The ``image-label`` ``colors``: ``{"label-value": v, "rgba": [r, g,
        b, a]}`` (0-255).  Default: :func:`label_colors` of every value in
        the stack (each its own colour, 0 transparent).
    properties : list of dict, optional
        The ``image-label`` ``properties``: one dict per label value with
        its ``label-value`` (:func:`track_properties` for an analysis's
        tracks).  Default: none.
    overwrite : bool
        Replace ``path`` even when it is not an earlier export (a file, a
        folder of other files, another tool's store).

    Returns
    -------
    Path
        ``path``: the image at the root (arrays ``0``, ``1``, ...), the
        labels in ``labels/cells`` (arrays ``0``, ``1``, ...).

    Raises
    ------
    InputError
        ``path`` that exists and is not an earlier export (without
        ``overwrite``) or is a results folder; a stack that is not integer
        labels of one shape, an image of
        another shape or number of frames, ``levels`` < 1 or more levels than
        halvings of the frame, bad ``chunks`` or an unknown ``version``.
    """
    import zarr

    from ..io import atomic_dir

    if version not in NGFF_VERSIONS:
        raise InputError(f"version must be one of {NGFF_VERSIONS}; got {version!r}")
    cal = as_calibration(calibration)
    levels = check_positive(levels, "levels", integer=True)
    n, read, shape = _frames(stack)
    if len(shape) != 2 or min(shape) < 1:
        raise InputError(f"stack frames must be 2-D (rows, cols); got shape {shape}")
    if min(shape) < 2 ** (levels - 1):
        raise InputError(f"levels={levels} halves a {shape[0]} x {shape[1]} frame below 1 px; use at most "
                         f"{int(np.log2(min(shape))) + 1} levels")
    if chunks is None:
        chunks = (1, min(shape[0], MAX_CHUNK), min(shape[1], MAX_CHUNK))
    if len(chunks) != 3 or not all(isinstance(c, (int, np.integer)) and c >= 1 for c in chunks):
        raise InputError(f"chunks must be three positive ints (t, rows, cols); got {chunks!r}")
    first = read(0)
    if first.dtype.kind not in "iu" and first.dtype != bool:
        raise InputError(f"stack must hold integer labels; got dtype {first.dtype}")
    if image is None:
        n_image, read_image, image_dtype = n, lambda t: boundary_image(read(t)), np.dtype(np.uint8)
    else:
        n_image, read_image, image_shape = _frames(image, "image")
        if image_shape != shape or n_image not in (1, n):
            raise InputError(f"image has {n_image} frame(s) of {image_shape}; expected {n} frame(s) (or one) of "
                             f"the labels' shape {shape}")
        image_dtype = np.asarray(read_image(0)).dtype
        if image_dtype.kind not in "iufb":
            raise InputError(f"image must be numeric; got dtype {image_dtype}")
    spacing = cal.pixel_size if cal.has_length else 1.0
    interval = cal.frame_interval if cal.has_time else 1.0
    datasets = [{"path": str(k), "coordinateTransformations": [
        {"type": "scale", "scale": [float(interval), float(spacing * 2**k), float(spacing * 2**k)]}]}
        for k in range(levels)]
    name = Path(path).stem
    with atomic_dir(path, owned=is_ome_zarr_export, overwrite=overwrite) as tmp:
        root = zarr.open_group(str(tmp), mode="w", zarr_format=3 if version == "0.5" else 2)
        pictures = _levels(root, n, shape, image_dtype, levels, chunks, version, 0)
        cells = root.create_group("labels").create_group("cells")
        arrays = _levels(cells, n, shape, first.dtype, levels, chunks, version, 0)
        seen = set()
        for t in range(n):
            frame = first if t == 0 else read(t)
            if frame.shape != shape or frame.dtype.kind not in "iub":
                raise InputError(f"stack frame {t} is {frame.dtype} {frame.shape}; expected integer labels of "
                                 f"{shape} like frame 0")
            if frame.size and frame.min() < 0:
                raise InputError(f"stack frame {t} has negative ids; expected 0 = background and positive ids")
            if colors is None:
                seen.update(np.unique(frame).tolist())
            picture = np.asarray(read_image(t if n_image == n else 0)).astype(image_dtype, copy=False)
            for k, (arr, pic) in enumerate(zip(arrays, pictures)):
                if k:
                    frame, picture = downsample_labels(frame), _downsample_mean(picture)
                arr[t] = frame.astype(first.dtype, copy=False)
                pic[t] = picture
        axes = _axes(cal)
        root.attrs.update(_ome({"multiscales": [{"name": name, "axes": axes, "datasets": datasets, "type": "mean",
                                                 "metadata": {"image": "the raw channel" if image is not None else
                                                              "cell outlines (hexatissue.exchange.omezarr."
                                                              "boundary_image)"}}]}, version))
        root["labels"].attrs.update(_ome({"labels": ["cells"]}, version))
        cells.attrs.update(_ome({
            "multiscales": [{"name": "cells", "axes": axes, "datasets": datasets, "type": "mode",
                             "metadata": {"method": "mode of each 2 x 2 block (hexatissue.exchange.omezarr)"}}],
            "image-label": {"source": {"image": "../../"},
                            "colors": _checked_colors(label_colors(sorted(seen)) if colors is None else colors),
                            **({} if properties is None else {"properties": _checked_properties(properties)})}},
            version))
    return Path(path)


def _checked_colors(colors):
    """``colors`` as JSON-ready NGFF entries; InputError naming what is wrong."""
    out = []
    for k, c in enumerate(colors):
        rgba = c.get("rgba") if isinstance(c, dict) else None
        if (not isinstance(c, dict) or "label-value" not in c or rgba is None or len(rgba) != 4
                or not all(isinstance(x, (int, np.integer)) and 0 <= x <= 255 for x in rgba)):
            raise InputError(f"colors[{k}] must be {{'label-value': int, 'rgba': [r, g, b, a]}} with integers "
                             f"0-255; got {c!r}")
        out.append({"label-value": int(c["label-value"]), "rgba": [int(x) for x in rgba]})
    return out


def _checked_properties(properties):
    """``properties`` as JSON-ready NGFF entries (numpy scalars made Python's); each needs its ``label-value``."""
    out = []
    for k, p in enumerate(properties):
        if not isinstance(p, dict) or "label-value" not in p:
            raise InputError(f"properties[{k}] must be a dict with a 'label-value'; got {p!r}")
        out.append({str(key): value.item() if isinstance(value, np.generic) else value for key, value in p.items()})
    return out


def is_ome_zarr_export(path) -> bool:
    """Whether ``path`` is an OME-Zarr written by :func:`write_ome_zarr_labels` (its labels name this module)."""
    from ..io import zarr_attributes

    attrs = zarr_attributes(Path(path) / "labels" / "cells")
    scales = attrs.get("ome", attrs).get("multiscales") or [{}]
    method = str(((scales[0] if isinstance(scales, list) else {}).get("metadata") or {}).get("method", ""))
    return "hexatissue.exchange.omezarr" in method
