"""Running an MPF simulation into a zarr store, with checkpoints, resume and Ctrl-C safety."""
from __future__ import annotations

import math
import signal
import threading
import time
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from ..errors import InputError, is_real
from .model import ThreadTuner, initial_state, set_threads
from .params import Params
from .segment import segment
from .store import RunStore

__all__ = ["run_simulation", "RunSummary"]


@dataclass
class RunSummary:
    """What :func:`run_simulation` did.

    Attributes
    ----------
    path : Path
    frames : int
        Frames in the store.
    step : int
        Global step reached (0 = end of relaxation).
    steps_done : int
        Steps computed in this call (relaxation included).
    seconds : float
        Wall time of the stepping in this call.
    area_error : float
        Largest ``|area / (pi R^2) - 1|`` over cells at the end.
    leak : float
        Largest fraction of a cell's ``int phi^2`` seen next to its patch rim.
    threads : int
    interrupted : bool
    """

    path: Path
    frames: int
    step: int
    steps_done: int
    seconds: float
    area_error: float
    leak: float
    threads: int
    interrupted: bool = False

    @property
    def steps_per_second(self) -> float:
        return self.steps_done / self.seconds if self.seconds > 0 else math.nan

    def __str__(self):
        state = "interrupted" if self.interrupted else "done"
        return (f"{state}: {self.path} step {self.step}, {self.frames} frames; {self.steps_done} steps in "
                f"{self.seconds:.1f} s ({self.steps_per_second:.0f} steps/s, {self.threads} thread(s)); "
                f"max area error {100 * self.area_error:.2f} %, patch-rim leak {self.leak:.1e}")


class _CtrlC:
    """First Ctrl-C sets a flag (the run checkpoints and stops at the next chunk); a second one aborts."""

    def __init__(self):
        self.flag = False
        self._old = None

    def _handler(self, signum, frame):
        if self.flag:
            raise KeyboardInterrupt
        self.flag = True

    def __enter__(self):
        if threading.current_thread() is threading.main_thread():
            self._old = signal.signal(signal.SIGINT, self._handler)
        return self

    def __exit__(self, *exc):
        if self._old is not None:
            signal.signal(signal.SIGINT, self._old)
        return False


def _check_int(name, value, minimum):
    if isinstance(value, bool) or not isinstance(value, (int, np.integer)) or value < minimum:
        raise InputError(f"{name} must be an integer >= {minimum}; got {value!r}")
    return int(value)


def run_simulation(out, params: Params | None = None, *, steps: int | None = None, save_every: int = 100,
                   relax: int = 10_000, seed=0, patches_every: int = 0, threads: int | str | None = None,
                   labels=None, resume: bool = False, overwrite: bool = False,
                   checkpoint_seconds: float = 60.0, progress: bool = True, callback=None) -> RunSummary:
    """Run the MPF model and write it frame by frame to the zarr store ``out``.

    The run starts from :func:`~hexatissue.simulate.initial_state` (jittered
    lattice, or ``labels``), relaxes passively (v0 = 0, theta frozen) for
    ``relax`` steps (global steps ``-relax .. 0``), then runs ``steps`` active
    steps.  Frame ``k`` is the state at global step ``k * save_every`` (frame
    0 = the relaxed state).  Nothing but the current state is held in memory.

    Parameters
    ----------
    out : str or Path
        The ``.zarr`` directory to write (see :mod:`hexatissue.simulate.store`).
    params : Params, optional
        Model parameters (default: the paper's).  Ignored on resume (read from the store).
    steps : int or None
        Active steps.  On resume, ``None`` keeps the stored value; a larger
        value extends the run.
    save_every : int
        Steps between saved frames.
    relax : int
        Passive relaxation steps before the active run.
    seed : int
        Seeds the initial lattice jitter, the polarities and the rotational noise.
    patches_every : int
        Save the full patch fields every this many frames (0 = never).
    threads : int or "auto", optional
        numba threads (default: keep numba's current setting; "auto": the
        cores left idle by the current load for the first chunk, then the
        fastest of that count, 1 and all threads, measured on chunks of the
        run; a count not in use is timed again after 30 s, the wait doubling
        (up to 8 min) each time it loses: :class:`~hexatissue.simulate.model.ThreadTuner`).
        Results do not depend on it.
    labels : (Ly, Lx) int array, optional
        Initial segmentation instead of the jittered lattice.
    resume : bool
        Continue ``out`` from its last checkpoint; frames written after that
        checkpoint are discarded and recomputed, so the store ends up exactly
        as after an uninterrupted run.
    overwrite : bool
        Replace an existing ``out`` (without resume).
    checkpoint_seconds : float
        Minimum wall time between checkpoints (taken at frame boundaries; a
        last one is always written at the end or on Ctrl-C).  0 = at every chunk.
    progress : bool
        Show a tqdm progress bar (steps/s).
    callback : callable, optional
        ``callback(frame, sim)`` after each saved frame.

    Returns
    -------
    RunSummary

    Raises
    ------
    KeyboardInterrupt
        After Ctrl-C, once the current chunk finished and a checkpoint was
        written (resume with ``resume=True``).  A second Ctrl-C aborts at
        once; the previous checkpoint then stays the valid one.
    """
    out = Path(out)
    save_every = _check_int("save_every", save_every, 1)
    if not (is_real(checkpoint_seconds) and checkpoint_seconds >= 0):
        raise InputError(f"checkpoint_seconds must be a finite number of seconds >= 0; got {checkpoint_seconds!r}")
    if resume:
        store = RunStore.open(out)
        sim, n_frames, n_patch = store.read_checkpoint()
        store.truncate(n_frames, n_patch)
        attrs = store.attrs
        save_every, relax = int(attrs["save_every"]), int(attrs["relax"])
        patches_every = int(attrs["patches_every"])
        steps = int(attrs["steps"]) if steps is None else _check_int("steps", steps, 0)
        if steps < sim.step:
            raise InputError(f"steps = {steps} is before the checkpoint at step {sim.step}; expected steps >= {sim.step}")
        store.attrs["steps"] = steps
    else:
        params = Params() if params is None else params
        if not isinstance(params, Params):
            raise InputError(f"params must be a hexatissue.simulate.Params; got {type(params).__name__}")
        steps = _check_int("steps", 10_000 if steps is None else steps, 0)
        relax = _check_int("relax", relax, 0)
        patches_every = _check_int("patches_every", patches_every, 0)
        seed = _check_int("seed", seed, 0)
        sim = initial_state(params, seed=seed, labels=labels)
        sim.step = -relax
        store = RunStore.create(out, params, seed, relax, steps, save_every, patches_every, overwrite=overwrite)
        if labels is not None:
            store.g.create_array("init_labels", data=np.asarray(labels))
    n_frames_total = steps // save_every + 1
    store.reserve(n_frames_total, (n_frames_total - 1) // patches_every + 1 if patches_every else 0)
    n_threads = set_threads(threads)
    # "auto": the load-based count for the first chunk (it includes compiling), then measured counts
    tuner = ThreadTuner.for_machine(n_threads) if isinstance(threads, str) and threads == "auto" else None
    first_chunk = True

    bar = None
    if progress:
        from ..progress import progress as progress_bar

        bar = progress_bar(total=relax + steps, initial=sim.step + relax, unit="step", dynamic_ncols=True,
                           desc=f"MPF {sim.params.n_cells} cells")
    done, seconds, last_ckpt, interrupted = 0, 0.0, time.monotonic(), False
    n_saved = int(store.attrs["n_frames"])
    writer = _Writer()
    try:
        with _CtrlC() as ctrl:
            while True:
                s = sim.step
                if s >= 0 and s % save_every == 0 and n_saved == s // save_every:
                    _save_frame(writer, store, sim, n_saved, patches_every)
                    n_saved += 1
                    if callback is not None:
                        callback(s // save_every, sim)
                if s >= steps:
                    break
                if ctrl.flag:
                    interrupted = True
                    break
                if time.monotonic() - last_ckpt >= checkpoint_seconds:
                    writer.drain()
                    store.write_checkpoint(sim)
                    last_ckpt = time.monotonic()
                n = min(save_every, -s) if s < 0 else min(save_every - s % save_every, steps - s)
                if tuner is not None and not first_chunk:
                    n_threads = set_threads(tuner.choose(time.monotonic()))
                t0 = time.perf_counter()
                sim.advance(n, active=s >= 0)
                dt = time.perf_counter() - t0
                seconds += dt
                if tuner is not None and not first_chunk:
                    tuner.record(n_threads, n / max(dt, 1e-9), time.monotonic())
                first_chunk = False
                done += n
                if bar is not None:
                    bar.update(n)
    finally:
        writer.close()
        if bar is not None:
            bar.close()
    # not in `finally`: a second Ctrl-C may land between a kernel call and the step counter update
    store.write_checkpoint(sim)
    sim.check_leak()
    area = sim.moments()[:, 0]
    summary = RunSummary(out, int(store.attrs["n_frames"]), sim.step, done, seconds,
                         float(np.max(np.abs(area / (math.pi * sim.params.R**2) - 1))), float(sim.leak.max()),
                         n_threads, interrupted)
    if interrupted:
        raise KeyboardInterrupt(str(summary))
    return summary


class _Writer:
    """One background thread that appends frames to the store in order while the kernels run (they release the GIL).

    At most ``depth`` frames wait in memory; errors surface in the main thread
    at the next submit or drain.
    """

    def __init__(self, depth=2):
        from collections import deque
        from concurrent.futures import ThreadPoolExecutor

        self._pool = ThreadPoolExecutor(max_workers=1, thread_name_prefix="mpf-writer")
        self._pending = deque()
        self._depth = depth

    def submit(self, fn, *args):
        self._pending.append(self._pool.submit(fn, *args))
        while len(self._pending) > self._depth:
            self._pending.popleft().result()

    def drain(self):
        while self._pending:
            self._pending.popleft().result()

    def close(self):
        try:
            self.drain()
        finally:
            self._pool.shutdown(wait=True)


def _save_frame(writer: _Writer, store: RunStore, sim, frame: int, patches_every: int):
    # everything taken from the state is computed or copied now; only the store I/O is deferred
    writer.submit(store.append_frame, segment(sim), sim.step, sim.moments(), sim.theta.copy())
    if patches_every and frame % patches_every == 0:
        writer.submit(store.append_patches, frame, sim.phi.copy(), sim.ox.copy(), sim.oy.copy())
