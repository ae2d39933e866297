"""The zarr store of an MPF run: written frame by frame, read back lazily.

Layout of ``RUN.zarr`` (zarr v3 group)::

    attrs: format, format_version, params (a store without params.advection
           was advected with central differences and reads back so), seed, relax, steps, save_every,
           patches_every, hexatissue_version, n_frames, n_patch_frames,
           checkpoint ("a", "b" or null), leak_max
    labels         (T, Ly, Lx) int16/int32   label = cell index + 1, 0 = background
    step           (T,)        int64         global step of each frame (0 = end of relaxation)
    x, y           (T, N)      float64       unwrapped phi^2-weighted centroids, px (x = column, y = row)
    theta          (T, N)      float64       polarity angle, rad, atan2(dy, dx)
    area           (T, N)      float64       int phi^2 dA / phi0^2, px^2
    patches/phi    (K, N, P, P)              full patch fields every ``patches_every`` frames
    patches/ox, oy (K, N)      int64         unwrapped patch origins (node (i, j) at row oy + i, col ox + j)
    patches/frame  (K,)        int64         frame index of each patch snapshot
    checkpoint/a, checkpoint/b               two checkpoint slots (phi, ox, oy, theta, leak; attrs:
                                             step, n_frames, n_patch_frames, rng state); ``attrs.checkpoint``
                                             names the last complete one

Frames are appended one at a time and ``attrs.n_frames`` is raised only
after every array of the frame is written, so readers never see half a frame.
A checkpoint goes to the slot not named in ``attrs.checkpoint`` and the
pointer flips only when it is complete, so a crash while checkpointing
leaves the previous checkpoint intact.
"""
from __future__ import annotations

import json
from dataclasses import dataclass
from pathlib import Path

import numpy as np
import pandas as pd

from .._version import __version__
from ..box import Box
from ..errors import InputError
from ..io import check_output_folder, check_zarr_chunks, read_zarr
from .params import Params

__all__ = ["RunStore", "MPFRun", "read_run"]

FORMAT = "hexatissue-mpf"
FORMAT_VERSION = 1
PER_CELL = ("x", "y", "theta", "area")


def _version() -> str:
    try:

        return str(__version__)
    except Exception:  # the package root is owned elsewhere; never fail a run over a version string
        return "unknown"


def _label_dtype(n_cells):
    return "int16" if n_cells < np.iinfo(np.int16).max else "int32"


class RunStore:
    """Writer for the store of one run (see the module docstring for the layout)."""

    def __init__(self, group):
        self.g = group

    # -- creation / opening ---------------------------------------------------------
    @classmethod
    def create(cls, path, params: Params, seed: int, relax: int, steps: int, save_every: int,
               patches_every: int, overwrite: bool = False) -> "RunStore":
        import zarr

        path = Path(path)
        if path.exists() and not overwrite:
            raise InputError(f"out: {str(path)!r} already exists; pass overwrite=True (--overwrite) or resume=True (--resume)")
        if path.exists() and not path.is_dir():
            raise InputError(f"out: {str(path)!r} is a file, not a run store; overwrite replaces run stores "
                             f"(folders) only: remove the file or choose another --out")

        check_output_folder(path, "out")
        g = zarr.open_group(str(path), mode="w")
        N, (Ly, Lx), P = params.n_cells, params.shape, params.patch
        g.create_array("labels", shape=(0, Ly, Lx), chunks=(1, Ly, Lx), dtype=_label_dtype(N), fill_value=0)
        g.create_array("step", shape=(0,), chunks=(256,), dtype="int64", fill_value=0)
        # small row blocks: appending a frame rewrites one chunk of each per-cell array
        rows = max(1, min(16, 2**16 // (8 * N)))
        for name in PER_CELL:
            g.create_array(name, shape=(0, N), chunks=(rows, N), dtype="float64", fill_value=0.0)
        pg = g.require_group("patches")
        pg.create_array("phi", shape=(0, N, P, P), chunks=(1, N, P, P), dtype=params.dtype, fill_value=0.0)
        pg.create_array("ox", shape=(0, N), chunks=(1, N), dtype="int64", fill_value=0)
        pg.create_array("oy", shape=(0, N), chunks=(1, N), dtype="int64", fill_value=0)
        pg.create_array("frame", shape=(0,), chunks=(256,), dtype="int64", fill_value=0)
        g.attrs.update(
            {
                "format": FORMAT,
                "format_version": FORMAT_VERSION,
                "params": params.to_dict(),
                "seed": int(seed),
                "relax": int(relax),
                "steps": int(steps),
                "save_every": int(save_every),
                "patches_every": int(patches_every),
                "hexatissue_version": _version(),
                "n_frames": 0,
                "n_patch_frames": 0,
                "checkpoint": None,
                "leak_max": 0.0,
            }
        )
        return cls(g)

    @classmethod
    def open(cls, path, mode="r+") -> "RunStore":
        import zarr

        path = Path(path)
        if not path.exists():
            raise InputError(f"path {str(path)!r} does not exist; expected an MPF run store (.zarr)")
        try:
            g = zarr.open_group(str(path), mode=mode)
        except Exception as exc:
            raise InputError(f"path {str(path)!r} is not a zarr group: {type(exc).__name__}: {exc}") from exc
        if g.attrs.get("format") != FORMAT:
            raise InputError(f"path {str(path)!r} is not an MPF run store (attrs.format != {FORMAT!r})")
        return cls(g)

    @property
    def attrs(self):
        return self.g.attrs

    @property
    def params(self) -> Params:
        d = dict(self.g.attrs["params"])
        # stores written before Params.advection existed were advected with central differences
        d.setdefault("advection", "central")
        return Params.from_dict(d)

    # -- frames -----------------------------------------------------------------------
    def append_frame(self, labels, step, moments, theta):
        """Append one frame; ``moments`` is ``Simulation.moments()`` (area, x, y)."""
        t = int(self.g.attrs["n_frames"])
        values = {"x": moments[:, 1], "y": moments[:, 2], "theta": theta, "area": moments[:, 0]}
        self._put("labels", t, labels)
        self._put("step", t, step)
        for name, v in values.items():
            self._put(name, t, v)
        self.g.attrs["n_frames"] = t + 1

    def append_patches(self, frame, phi, ox, oy):
        k = int(self.g.attrs["n_patch_frames"])
        self._put("patches/phi", k, phi)
        self._put("patches/ox", k, ox)
        self._put("patches/oy", k, oy)
        self._put("patches/frame", k, frame)
        self.g.attrs["n_patch_frames"] = k + 1

    def reserve(self, n_frames, n_patch_frames):
        """Grow the arrays to hold ``n_frames`` frames and ``n_patch_frames`` patch snapshots.

        Done once per run, not per frame: resizing rewrites array metadata.
        Entries beyond ``attrs.n_frames`` are not part of the run.
        """
        for names, n in ((("labels", "step") + PER_CELL, n_frames),
                         (("patches/phi", "patches/ox", "patches/oy", "patches/frame"), n_patch_frames)):
            for name in names:
                a = self.g[name]
                if a.shape[0] < n:
                    a.resize((n,) + a.shape[1:])

    def _put(self, name, t, value):
        a = self.g[name]
        if a.shape[0] <= t:
            a.resize((t + 1,) + a.shape[1:])
        a[t] = value

    def truncate(self, n_frames, n_patch_frames):
        """Forget frames beyond the given counts (those written after the last checkpoint)."""
        self.g.attrs.update({"n_frames": int(n_frames), "n_patch_frames": int(n_patch_frames)})

    # -- checkpoints --------------------------------------------------------------------
    def write_checkpoint(self, sim):
        """Save the full state of ``sim`` to the free slot, then point ``attrs.checkpoint`` at it."""
        current = self.g.attrs.get("checkpoint")
        slot = "b" if current == "a" else "a"
        cg = self.g.require_group(f"checkpoint/{slot}")
        for key in ("phi", "ox", "oy", "theta", "leak"):
            arr = np.ascontiguousarray(getattr(sim, key))
            if key in cg and cg[key].shape == arr.shape and cg[key].dtype == arr.dtype:
                cg[key][...] = arr  # the slot is reused: overwrite in place
            else:
                cg.create_array(key, data=arr, chunks=arr.shape, overwrite=True)
        cg.attrs.update(
            {
                "step": int(sim.step),
                "n_frames": int(self.g.attrs["n_frames"]),
                "n_patch_frames": int(self.g.attrs["n_patch_frames"]),
                # JSON numbers cannot hold 128-bit integers portably: keep the RNG state as text
                "rng_state": json.dumps(sim.rng.bit_generator.state),
            }
        )
        self.g.attrs.update({"checkpoint": slot, "leak_max": float(max(self.g.attrs.get("leak_max", 0.0), sim.leak.max(initial=0.0)))})

    def read_checkpoint(self):
        """``(Simulation, n_frames, n_patch_frames)`` from the last complete checkpoint."""
        from .model import Simulation


        slot = self.g.attrs.get("checkpoint")
        if slot is None:
            raise InputError("resume: the store has no checkpoint yet; start the run again without resume")
        what = f"resume: the checkpoint of {str(self.g.store_path)!r}"
        try:
            cg = self.g[f"checkpoint/{slot}"]
            arrays = {key: cg[key] for key in ("phi", "ox", "oy", "theta", "leak")}
            state = json.loads(cg.attrs["rng_state"])
            bitgen = getattr(np.random, state["bit_generator"])()
            bitgen.state = state
            step, n_frames, n_patch = int(cg.attrs["step"]), int(cg.attrs["n_frames"]), int(cg.attrs["n_patch_frames"])
        except (KeyError, ValueError, TypeError, AttributeError) as exc:
            raise InputError(f"{what} is incomplete or garbled ({type(exc).__name__}: {exc}); the store is "
                             f"damaged: start the run again with --overwrite") from None
        values = {}
        check_zarr_chunks(arrays["phi"], arrays["phi"].shape[0], what)  # leak, ox, oy may be all zero: unchecked
        for key, arr in arrays.items():
            values[key] = read_zarr(arr, what)
        sim = Simulation(self.params, values["phi"], values["ox"], values["oy"], values["theta"],
                         np.random.Generator(bitgen), step=step, leak=values["leak"])
        return sim, n_frames, n_patch


@dataclass
class Patches:
    """Saved patch snapshots: ``phi`` (K, N, P, P) zarr array, origins ``ox, oy`` (K, N), ``frame`` (K,)."""

    phi: object
    ox: np.ndarray
    oy: np.ndarray
    frame: np.ndarray


class MPFRun:
    """A finished (or running) MPF run read from its zarr store.

    Attributes
    ----------
    labels : zarr array view, (T, Ly, Lx)
        Label images read lazily on indexing (``run.labels[t]``); label = cell
        index + 1, consistent over time; 0 = background.
    cells : pandas.DataFrame
        One row per frame and cell: ``frame``, ``cell`` (label id), ``x``, ``y``
        (px; centroid folded into the box, x = column, y = row, origin at the
        centre of pixel (0, 0)), ``x_unwrapped``, ``y_unwrapped`` (px; continuous
        trajectories across the periodic box), ``theta`` (rad, polarity angle,
        atan2(dy, dx)), ``area`` (px^2, ``int phi^2 dA / phi0^2``: the field area,
        target pi R^2).
    params : Params
    box : hexatissue.box.Box
        The periodic simulation box ``Box(Lx, Ly)``.
    step : (T,) int64 array
        Global step of each frame (0 = end of the passive relaxation).
    time : (T,) float64 array
        ``step * dt`` in simulation time units.
    patches : Patches or None
        Full patch fields saved every ``patches_every`` frames.
    seed : int
    attrs : dict
        All store attributes (run settings, package version).
    """

    def __init__(self, path):
        store = RunStore.open(path, mode="r")
        g = store.g
        self.path = Path(path)
        self.attrs = dict(g.attrs)
        self.params = store.params
        self.seed = int(self.attrs["seed"])
        T = int(self.attrs["n_frames"])
        self.n_frames = T
        self._g = g

        self.box = Box(float(self.params.Lx), float(self.params.Ly))

        what = f"MPF run {str(path)!r}"
        try:
            arrays = [g[name] for name in ("labels", "step") + PER_CELL]
        except KeyError as exc:
            raise InputError(f"{what} has no array {exc}; the store is damaged: run it again") from None
        for arr in arrays:
            if arr.basename in ("labels", "x", "y", "area"):  # never all zero in a chunk (zarr skips those)
                check_zarr_chunks(arr, T, what)
        self.step = read_zarr(g["step"], what, slice(0, T))
        self.time = self.step * self.params.dt
        self._cells = None
        K = int(self.attrs.get("n_patch_frames", 0))
        if K:
            pg = g["patches"]
            self.patches = Patches(_Head(pg["phi"], K), pg["ox"][:K], pg["oy"][:K], pg["frame"][:K])
        else:
            self.patches = None

    @property
    def labels(self):
        return _Head(self._g["labels"], self.n_frames)

    @property
    def cells(self) -> pd.DataFrame:
        if self._cells is None:
            T, N = self.n_frames, self.params.n_cells

            cols = {k: read_zarr(self._g[k], f"MPF run {str(self.path)!r}", slice(0, T)) for k in PER_CELL}
            xw = np.mod(cols["x"], self.params.Lx)
            yw = np.mod(cols["y"], self.params.Ly)
            self._cells = pd.DataFrame(
                {
                    "frame": np.repeat(np.arange(T, dtype=np.int64), N),
                    "cell": np.tile(np.arange(1, N + 1, dtype=np.int64), T),
                    "x": xw.ravel(),
                    "y": yw.ravel(),
                    "x_unwrapped": cols["x"].ravel(),
                    "y_unwrapped": cols["y"].ravel(),
                    "theta": cols["theta"].ravel(),
                    "area": cols["area"].ravel(),
                }
            )
        return self._cells.copy()

    def __len__(self):
        return self.n_frames

    def __repr__(self):
        p = self.params
        return (f"MPFRun({str(self.path)!r}: {self.n_frames} frames, {p.n_cells} cells, "
                f"box {p.Lx} x {p.Ly}, D_r={p.D_r:g}, v0={p.v0:g}, seed={self.seed})")


class _Head:
    """Lazy view of the first ``n`` entries along axis 0 of a zarr array (frames beyond are not committed)."""

    def __init__(self, arr, n):
        self._arr = arr
        self.shape = (int(n),) + tuple(arr.shape[1:])
        self.dtype = arr.dtype
        self.ndim = len(self.shape)

    def __len__(self):
        return self.shape[0]

    def __getitem__(self, key):
        if not isinstance(key, tuple):
            key = (key,)
        first, rest = key[0], key[1:]
        if isinstance(first, (int, np.integer)):
            t = int(first) + (self.shape[0] if first < 0 else 0)
            if not 0 <= t < self.shape[0]:
                raise IndexError(f"frame {first} out of range for {self.shape[0]} frames")
            return self._arr[(t,) + rest]
        if isinstance(first, slice):
            return self._arr[(slice(*first.indices(self.shape[0])),) + rest]
        idx = np.arange(self.shape[0])[first]
        return np.stack([self._arr[(int(t),) + rest] for t in np.atleast_1d(idx)])

    def __array__(self, dtype=None, copy=None):
        out = np.asarray(self[:])
        return out if dtype is None else out.astype(dtype)

    def __iter__(self):
        for t in range(self.shape[0]):
            yield self[t]


def read_run(path) -> MPFRun:
    """Open the zarr store of an MPF run written by :func:`~hexatissue.simulate.run_simulation`.

    Returns
    -------
    MPFRun
        With ``.labels`` (T x Ly x Lx, lazy), ``.cells`` (frame, cell, x, y,
        x_unwrapped, y_unwrapped, theta, area), ``.params``, ``.box``, ``.step``,
        ``.time`` and ``.patches``; see :class:`MPFRun`.
    """
    return MPFRun(path)
