"""Zarr stores: arrays, groups (an array chosen by ``key``), OME-Zarr images (NGFF 0.1 to 0.5), MPF run stores.

OME-Zarr images are calibrated from the ``scale`` of the chosen resolution
level and the axis units.
"""
from __future__ import annotations

from functools import partial
from pathlib import Path

import numpy as np

from ..errors import InputError
from .arrays import ArrayReader
from .base import Opened, optional_int, refuse
from .calibration import metadata_calibration
from .mpf import MPF_FORMAT, open_run_store

__all__ = ["is_zarr_dir", "is_zarr_group", "is_zarr_array", "zarr_node", "ngff_multiscales", "open_zarr_path",
           "open_zarr_group"]


def is_zarr_dir(path: Path) -> bool:
    """True for a folder holding a zarr store (``zarr.json``, ``.zgroup`` or ``.zarray``)."""
    return any((path / name).exists() for name in ("zarr.json", ".zgroup", ".zarray"))


def is_zarr_group(obj) -> bool:
    """True for an open zarr group."""
    return type(obj).__module__.split(".")[0] == "zarr" and hasattr(obj, "array_keys") and hasattr(obj, "attrs")


def zarr_node(path, key=None):
    """The zarr array or group at ``path`` (and ``key`` inside it), opened read-only."""
    import zarr

    node = zarr.open(str(path), mode="r")
    return node if key is None else node[key]


def is_zarr_array(node) -> bool:
    """True for a zarr array (not a group)."""
    return hasattr(node, "shape") and not hasattr(node, "array_keys")


def open_zarr_path(path: Path, key, channel, level, axes=None) -> Opened:
    """A zarr store given as its path: an array, a group, an OME-Zarr image or an MPF run store.

    ``axes`` names the dimensions of a plain zarr array (OME-Zarr images and MPF runs name their own).
    """
    node = zarr_node(path)
    if is_zarr_array(node):
        refuse("a zarr array", key=key, level=level)
        reader = ArrayReader(repr(str(path)), opener=partial(zarr_node, path), channel=channel, axes=axes)
        return Opened(reader, {"kind": "zarr", "path": str(path), "channel": optional_int(channel)})
    return open_zarr_group(node, path, key, channel, level, axes)


def ngff_multiscales(attrs):
    """The first multiscales entry of NGFF 0.4 (``attrs["multiscales"]``) or 0.5 (``attrs["ome"]``), else None."""
    ms = attrs.get("multiscales") or (attrs.get("ome") or {}).get("multiscales")
    return ms[0] if ms else None


def open_zarr_group(group, path, key, channel, level, axes=None) -> Opened:
    """An open zarr group (``path`` None when it was given as an object, not a path); ``axes`` of a plain array."""
    attrs = dict(group.attrs)
    where = repr(str(path)) if path is not None else "the zarr group"
    if attrs.get("format") == MPF_FORMAT:
        refuse("an MPF run store", key=key, channel=channel, level=level, axes=axes)
        if path is None:
            raise InputError("a zarr group holding an MPF run must be given as its path (or as "
                             "hexatissue.simulate.read_run(path))")
        return open_run_store(path)
    node = group
    if key is not None:
        try:
            node = group[key]
        except KeyError:
            raise InputError(f"zarr group {where}: key={key!r} is not in it; it holds arrays "
                             f"{sorted(group.array_keys())} and groups {sorted(group.group_keys())}") from None
        if is_zarr_array(node):
            refuse("a zarr array", level=level)
            opener = partial(zarr_node, path, key) if path is not None else None
            reader = ArrayReader(f"{where} key {key!r}", array=None if opener else node, opener=opener,
                                 channel=channel, axes=axes)
            return Opened(reader, {"kind": "zarr", "path": _str(path), "key": key, "channel": optional_int(channel)})
        attrs = dict(node.attrs)
    ms = ngff_multiscales(attrs)
    if ms is not None:
        refuse("an OME-Zarr image (its metadata names its axes)", axes=axes)
        return _open_ome_zarr(node, ms, path, key, channel, level, where)
    if key is not None:
        raise InputError(f"zarr group {where}: key={key!r} is a group without OME-Zarr multiscales; expected an "
                         f"array or an OME-Zarr image")
    refuse(f"zarr group {where} (not an OME-Zarr image)", level=level)
    names = sorted(group.array_keys())
    chosen = "labels" if "labels" in names else (names[0] if len(names) == 1 else None)
    if chosen is None:
        raise InputError(f"zarr group {where}: choose an array with key= (--key on the command line); it holds arrays {names} and groups "
                         f"{sorted(group.group_keys())}")
    return open_zarr_group(group, path, chosen, channel, level, axes)


def _str(path):
    return None if path is None else str(path)


def _open_ome_zarr(group, ms, path, key, channel, level, where) -> Opened:
    datasets = ms.get("datasets") or []
    level = 0 if level is None else int(level)
    if not level < len(datasets):
        raise InputError(f"level={level} is out of range: OME-Zarr image {where} has {len(datasets)} level(s), "
                         f"0 to {len(datasets) - 1} (paths {[d.get('path') for d in datasets]})")
    dataset = datasets[level]
    ndim = len(group[dataset["path"]].shape)
    # NGFF 0.1/0.2 have no "axes": their images are (t, c, z, y, x); 0.3 names them with strings
    axes = [a if isinstance(a, dict) else {"name": a} for a in ms.get("axes") or "tczyx"[5 - ndim:]]
    names = [str(a.get("name", "")).lower() for a in axes]
    if names[-2:] != ["y", "x"]:
        raise InputError(f"OME-Zarr image {where} has axes {names}; expected the last two to be 'y' and 'x'")

    def letter(a):
        kind = str(a.get("type", "")).lower()
        name = str(a.get("name", "")).lower()
        if kind == "time" or name == "t":
            return "T"
        if kind == "channel" or name == "c":
            return "C"
        return name.upper() if len(name) == 1 else "Q"

    letters = "".join(letter(a) for a in axes[:-2]) + "YX"
    array_key = dataset["path"] if key is None else f"{key}/{dataset['path']}"
    opener = partial(zarr_node, path, array_key) if path is not None else None
    array = None if opener else group[dataset["path"]]
    reader = ArrayReader(f"OME-Zarr image {where} level {level}", array=array, opener=opener,
                         axes=letters, channel=channel)
    scale = _ngff_scale(ms, dataset, len(axes))
    notes = []
    t_axis = letters.find("T")
    calibration = metadata_calibration(notes, scale[-1], scale[-2], axes[-1].get("unit"),
                                       scale[t_axis] if t_axis >= 0 else None,
                                       axes[t_axis].get("unit") if t_axis >= 0 else None)
    if not calibration.has_length and scale[-1] != 1:
        notes.append(f"pixels of level {level} are {scale[-1]:g} base units wide but the x axis has no unit; "
                     f"lengths are in px of this level")
    labels = group.get("labels") if hasattr(group, "get") else None
    desc = {"kind": "ome-zarr", "path": _str(path), "key": key, "channel": optional_int(channel), "level": level,
            "dataset_path": str(dataset["path"]), "n_levels": len(datasets), "scale": [float(s) for s in scale],
            "axis_names": names}
    label_attrs = dict(getattr(labels, "attrs", {})) if labels is not None else {}
    label_names = label_attrs.get("labels") or (label_attrs.get("ome") or {}).get("labels")  # NGFF 0.4 or 0.5
    if label_names:
        desc["ngff_labels"] = [f"labels/{n}" for n in label_names]
    return Opened(reader, desc, calibration, notes=tuple(notes))


def _ngff_scale(ms, dataset, n_axes):
    """Scale per axis of one level: the dataset's scale times the multiscale's own (NGFF coordinateTransformations)."""
    scale = np.ones(n_axes)
    for transforms in (dataset.get("coordinateTransformations"), ms.get("coordinateTransformations")):
        for tr in transforms or []:
            if tr.get("type") == "scale" and "scale" in tr:
                scale = scale * np.asarray(tr["scale"], float)
    return [float(s) for s in scale]
