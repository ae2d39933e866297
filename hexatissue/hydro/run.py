"""Running the solver with diagnostics, zarr output and checkpoint / resume.

Store layout (zarr group ``RUN.zarr``):

- ``attrs``: ``params`` (HydroParams as dict), ``n``, ``meta`` (experiment info);
- ``time``, ``free_energy``, ``kinetic_energy``, ``n_defects``: one entry per
  diagnostic step (float64 / int64);
- ``field_time``; ``psi_re``, ``psi_im``, ``vx``, ``vy``: ``(frames, n, n)``
  float32 fields (node ``[i, j]`` at x = j dx, y = i dx), one frame every
  ``field_every`` diagnostics;
- ``defects/{frame,x,y,charge}``: all defects, ``frame`` indexing ``time``;
- ``checkpoint.npz`` beside the arrays: the full solver state at the last
  flush (diagnostics are buffered and flushed with every stored field, and at
  the end), written atomically.  Resuming truncates the arrays to the
  checkpoint and continues; the result is identical to an uninterrupted run.
"""
from __future__ import annotations

from dataclasses import dataclass, field
from pathlib import Path

import numpy as np
import pandas as pd

from ..box import Box
from ..defects import defects_from_field
from ..errors import InputError
from ..io import atomic_path, check_output_folder, check_zarr_chunks
from ..progress import progress as progress_bar
from .params import HydroParams
from .solver import State

__all__ = ["HydroResult", "integrate", "open_run"]

SCALARS = {"time": "f8", "free_energy": "f8", "kinetic_energy": "f8", "n_defects": "i8"}
FIELDS = ("psi_re", "psi_im", "vx", "vy")
DEFECT_COLS = {"frame": "i8", "x": "f8", "y": "f8", "charge": "f8"}


@dataclass
class HydroResult:
    """Outcome of a run.

    Attributes
    ----------
    diagnostics : DataFrame
        ``frame``, ``time``, ``free_energy``, ``kinetic_energy`` (energy units,
        summed over the grid times dx^2), ``n_defects``.
    defects : DataFrame
        ``frame``, ``time``, ``defect`` (trajectory id; per-frame id if
        untracked), ``x``, ``y`` (x = column * dx, y = row * dx), ``charge``
        (+-1/6), ``p`` (6).
    annihilation_time : float or None
        First diagnostic time with no defect left (None if never).
    psi, velocity : ndarray
        Final Psi6 and ``v_x + i v_y`` on the grid.
    params : HydroParams
    meta : dict
    path : Path or None
    """

    diagnostics: pd.DataFrame
    defects: pd.DataFrame
    annihilation_time: float | None
    psi: np.ndarray
    velocity: np.ndarray
    params: HydroParams
    meta: dict = field(default_factory=dict)
    path: Path | None = None


def _diagnose(solver, state):
    psi = solver.psi(state)
    n = solver.n
    d = defects_from_field(psi, 6, spacing=solver.params.dx, periodic=True,
                           box=Box(n * solver.params.dx, n * solver.params.dx))
    scal = {"time": state.time, "free_energy": solver.free_energy(state),
            "kinetic_energy": solver.kinetic_energy(state), "n_defects": len(d)}
    return scal, d, psi


class _Memory:
    """Diagnostics kept in memory (also the in-memory mirror of a zarr run)."""

    def __init__(self):
        self.scal = {k: [] for k in SCALARS}
        self.defects = []

    def add(self, scal, d, frame):
        for k in SCALARS:
            self.scal[k].append(scal[k])
        if len(d):
            d = d.assign(frame=frame)
            self.defects.append(d)

    def tables(self):
        diag = pd.DataFrame({k: np.asarray(v, dtype=SCALARS[k]) for k, v in self.scal.items()})
        diag.insert(0, "frame", np.arange(len(diag), dtype=np.int64))
        if self.defects:
            d = pd.concat(self.defects, ignore_index=True)
        else:
            d = pd.DataFrame({c: np.zeros(0, t) for c, t in DEFECT_COLS.items()})
        d = d.assign(time=diag["time"].to_numpy()[d["frame"].to_numpy()] if len(d) else np.zeros(0))
        d["p"] = 6
        return diag, d[["frame", "time", "x", "y", "charge", "p"]].reset_index(drop=True)


class _Store:
    """Frame-by-frame zarr writer with checkpoint."""

    def __init__(self, path, solver, meta, resume):
        import zarr

        self.path = Path(path)
        self.ckpt = self.path / "checkpoint.npz"
        n = solver.n
        if resume and self.ckpt.exists():
            try:
                self.group = zarr.open_group(str(self.path), mode="r+")
                saved = self.group.attrs["params"]
            except Exception as exc:
                raise InputError(f"cannot resume {str(self.path)!r}: it is not a readable hydro run store "
                                 f"({type(exc).__name__}: {exc})") from None
            if saved != solver.params.to_dict() or self.group.attrs["n"] != n:
                raise InputError(f"cannot resume {self.path}: it was run with other parameters ({saved}, n={self.group.attrs['n']})")
        else:
            if self.path.exists() and not self.path.is_dir():
                raise InputError(f"out {str(self.path)!r} is a file; expected a folder for the zarr store")

            check_output_folder(self.path, "out")
            self.group = zarr.open_group(str(self.path), mode="w")
            self.group.attrs.update({"params": solver.params.to_dict(), "n": n, "meta": meta})
            for k, t in SCALARS.items():
                self.group.create_array(k, shape=(0,), chunks=(4096,), dtype=t)
            self.group.create_array("field_time", shape=(0,), chunks=(4096,), dtype="f8")
            for k in FIELDS:
                self.group.create_array(k, shape=(0, n, n), chunks=(1, n, n), dtype="f4")
            for k, t in DEFECT_COLS.items():
                self.group.create_array(f"defects/{k}", shape=(0,), chunks=(65536,), dtype=t)

    def load(self, solver):
        """(state, memory, n_frames, n_fields) from the checkpoint, arrays truncated to it."""

        try:
            with np.load(self.ckpt) as z:
                prev = {k[5:]: z[k] for k in z.files if k.startswith("prev_")}
                state = State(z["psi_hat"], z["omega_hat"], float(z["time"]), int(z["step"]), prev)
                frames, fields, ndef = int(z["frames"]), int(z["fields"]), int(z["defects"])
        except Exception as exc:  # truncated or garbled npz (zipfile, pickle, key and value errors)
            raise InputError(f"cannot resume {str(self.path)!r}: its checkpoint.npz cannot be read "
                             f"({type(exc).__name__}: {exc}); the store is damaged: run it again") from None
        g = self.group
        what = f"cannot resume {str(self.path)!r}"
        try:
            # arrays never all zero in a chunk (zarr does not store such chunks): energies, defect charges
            for k, rows in (("free_energy", frames), ("defects/charge", ndef)):
                check_zarr_chunks(g[k], rows, what)
            for k in list(SCALARS) + [f"defects/{c}" for c in DEFECT_COLS]:
                g[k]  # noqa: B018 -- every array must be there
        except KeyError as exc:
            raise InputError(f"{what}: array {exc} is missing; the store is damaged: run it again") from None
        for k in SCALARS:
            g[k].resize((frames,))
        g["field_time"].resize((fields,))
        for k in FIELDS:
            g[k].resize((fields, solver.n, solver.n))
        for k in DEFECT_COLS:
            g[f"defects/{k}"].resize((ndef,))
        mem = _Memory()
        for k in SCALARS:
            mem.scal[k] = list(g[k][:])
        if ndef:
            mem.defects = [pd.DataFrame({k: g[f"defects/{k}"][:] for k in DEFECT_COLS})]
        return state, mem, frames, fields

    def write(self, pending, psi=None, vel=None, time=None):
        """Append buffered diagnostics [(scal, defects, frame), ...] and optionally one field frame."""
        g = self.group
        if pending:
            m = g["time"].shape[0]
            for k in SCALARS:
                g[k].resize((m + len(pending),))
                g[k][m:] = np.array([p[0][k] for p in pending], dtype=SCALARS[k])
            tables = [p[1].assign(frame=p[2]) for p in pending if len(p[1])]
            if tables:
                d = pd.concat(tables, ignore_index=True)
                m = g["defects/x"].shape[0]
                for k in DEFECT_COLS:
                    g[f"defects/{k}"].resize((m + len(d),))
                    g[f"defects/{k}"][m:] = d[k].to_numpy(DEFECT_COLS[k])
        if psi is not None:
            m = g["field_time"].shape[0]
            g["field_time"].resize((m + 1,))
            g["field_time"][m] = time
            for k, v in zip(FIELDS, (psi.real, psi.imag, vel.real, vel.imag)):
                g[k].resize((m + 1,) + v.shape)
                g[k][m] = v.astype("f4")

    def checkpoint(self, state, frames):
        extra = {f"prev_{k}": v for k, v in state.prev.items()}
        with atomic_path(self.ckpt) as tmp:
            with open(tmp, "wb") as f:
                np.savez(f, psi_hat=state.psi_hat, omega_hat=state.omega_hat, time=state.time,
                         step=state.step, frames=frames, fields=self.group["field_time"].shape[0],
                         defects=self.group["defects/x"].shape[0], **extra)


def integrate(solver, state, steps=None, max_time=None, save_every=10, field_every=20, out=None,
              resume=False, stop=None, meta=None, progress=True):
    """Step ``solver`` from ``state``, recording diagnostics every ``save_every`` steps.

    Parameters
    ----------
    solver : Solver
    state : State
        Initial state (ignored when resuming from a checkpoint in ``out``).
    steps : int, optional
        Number of steps; None: until ``stop`` says so or ``max_time``.
    max_time : float, optional
        Safety cap on the simulated time (required when ``steps`` is None).
    save_every : int
        Steps between diagnostics (free and kinetic energy, defects).
    field_every : int
        Diagnostics between stored fields (Psi6 and velocity).
    out : path, optional
        zarr store written frame by frame, with checkpoints.
    resume : bool
        Continue from the checkpoint in ``out`` if there is one.
    stop : callable(diagnostics dict, defects DataFrame) -> bool, optional
        Checked at every diagnostic step.
    meta : dict, optional
        Stored in the zarr attributes.
    progress : bool
        Show a tqdm progress bar.

    Returns
    -------
    HydroResult (``defects`` untracked: ``defect`` is the per-frame index)
    """

    if steps is None and max_time is None:
        raise InputError("give steps or max_time (a safety cap when running until a stop condition)")
    if steps is not None and (isinstance(steps, bool) or not isinstance(steps, (int, np.integer)) or steps < 1):
        raise InputError(f"steps must be a positive integer number of time steps (or None); got {steps!r}")
    if save_every < 1 or field_every < 1:
        raise InputError(f"save_every and field_every must be >= 1; got {save_every}, {field_every}")
    dt = solver.params.dt
    last_step = steps if steps is not None else int(np.ceil(max_time / dt))
    store = _Store(out, solver, meta or {}, resume) if out is not None else None
    if store is not None and resume and store.ckpt.exists():
        state, mem, frame, _ = store.load(solver)
    else:
        state = state.copy()
        mem, frame = _Memory(), 0
    bar = progress_bar(total=last_step, initial=state.step, enabled=progress, unit="step", leave=False)
    pending = []
    done = False
    if frame > 0 and stop is not None:  # resumed: the run may already have met its stop condition
        last = {k: v[-1] for k, v in mem.scal.items()}
        d = pd.concat(mem.defects, ignore_index=True) if mem.defects else pd.DataFrame(columns=list(DEFECT_COLS))
        done = bool(stop(last, d[d["frame"] == frame - 1]))
    if frame == 0:
        done = _record(solver, state, mem, store, pending, 0, field_every, stop, last=False)
        frame = 1
    while not done and state.step < last_step:
        n = min(save_every, last_step - state.step)
        for _ in range(n):
            solver.step(state)
        bar.update(n)
        if not np.all(np.isfinite(state.psi_hat)):
            bar.close()
            raise InputError(f"dt = {dt:g} is too large: the run became unstable (non-finite fields) by "
                             f"t = {state.time:g}; lower dt (--dt; default 0.05)")
        done = _record(solver, state, mem, store, pending, frame, field_every, stop, state.step >= last_step)
        frame += 1
    bar.close()
    diag, d = mem.tables()
    d.insert(2, "defect", d.groupby("frame").cumcount().astype(np.int64))
    zero = diag.loc[diag["n_defects"] == 0, "time"]
    t_ann = float(zero.iloc[0]) if len(zero) and diag["n_defects"].iloc[0] > 0 else None
    return HydroResult(diag, d, t_ann, solver.psi(state), solver.velocity(state), solver.params,
                       meta or {}, None if out is None else Path(out))


def _record(solver, state, mem, store, pending, frame, field_every, stop, last):
    """Diagnose, buffer; flush to the store (with a checkpoint) on field frames and at the end."""
    scal, d, psi = _diagnose(solver, state)
    mem.add(scal, d, frame)
    done = not np.isfinite(scal["free_energy"]) or (stop is not None and bool(stop(scal, d)))
    if store is not None:
        pending.append((scal, d, frame))
        with_field = frame % field_every == 0
        if with_field or done or last:
            vel = solver.velocity(state) if with_field else None
            store.write(pending, psi if with_field else None, vel, state.time)
            store.checkpoint(state, frame + 1)
            pending.clear()
    return done


def open_run(path):
    """Read a run written by :func:`integrate`: (diagnostics, defects, fields dict, attrs)."""
    import zarr

    g = zarr.open_group(str(path), mode="r")
    diag = pd.DataFrame({k: g[k][:] for k in SCALARS})
    diag.insert(0, "frame", np.arange(len(diag), dtype=np.int64))
    d = pd.DataFrame({k: g[f"defects/{k}"][:] for k in DEFECT_COLS})
    d["time"] = diag["time"].to_numpy()[d["frame"].to_numpy()] if len(d) else []
    fields = {k: g[k] for k in FIELDS}
    fields["time"] = g["field_time"][:]
    return diag, d, fields, dict(g.attrs)
