"""Checkpoints of a running analysis: the finished frames' tables and the stages' frame states (the tracker), saved
every few frames."""
from __future__ import annotations

import json

import pandas as pd

from .errors import InputError, check_positive
from .io import atomic_path, check_output_folder, lock_folder, read_table

__all__ = ["Checkpoint"]


class Checkpoint:
    """Frame tables (``tables``, by name) and the stages' frame states (by stage name, as bytes: the tracker's
    pickle, :class:`hexatissue.stages.FrameState`) saved every ``every`` frames in ``directory``.

    ``key`` (JSON-able) says what is analysed and how: a folder holding
    another key is refused, not resumed.
    """

    def __init__(self, directory, key, every, tables):
        self.tables = tuple(tables)
        self.every = check_positive(every, "checkpoint_every", integer=True)
        self.dir = check_output_folder(directory, "checkpoint")
        self.key = json.loads(json.dumps(key))  # as it reads back from JSON
        self.state_path = self.dir / "checkpoint.json"
        self._lock = None

    def lock(self):
        """Take the folder's exclusive lock (``checkpoint.lock``, :func:`hexatissue.io.lock_folder`); InputError
        when another run holds it.  Released by :meth:`unlock`, or by the OS when the process ends."""
        self._lock = lock_folder(self.dir, "checkpoint.lock", "checkpoint folder")

    def unlock(self):
        """Release the lock taken by :meth:`lock`."""
        if self._lock is not None:
            self._lock.close()  # closing the file releases the flock
            self._lock = None

    def _damaged(self, what):
        return InputError(f"checkpoint folder {str(self.dir)!r} is damaged ({what}); delete it (or use another "
                          f"folder) to start again")

    def due(self, start, n_frames):
        """Frame counts after which a checkpoint is written."""
        return set(range(start + self.every, n_frames + 1, self.every)) | {n_frames}

    def _state(self):
        if not self.state_path.exists():
            return None
        try:
            state = json.loads(self.state_path.read_text())
            if not (isinstance(state, dict) and {"key", "done", "files"} <= set(state)
                    and isinstance(state["files"], dict) and ("states" in state or "tracker" in state)):
                raise ValueError("not a checkpoint state")
            if "states" not in state:  # written before the stages kept their own states: the tracker's alone
                state["states"] = {"track": state.pop("tracker")} if state["tracker"] else {}
        except (OSError, ValueError) as exc:
            raise self._damaged(f"checkpoint.json cannot be read: {exc}") from None
        return state

    def load(self, loaders):
        """(frames done, tables, frame states by stage name) from the last checkpoint, or (0, None, None).

        ``loaders``: by stage name, the function that makes a state of its bytes (``FrameState.load``).
        """
        state = self._state()
        if state is None:
            return 0, None, None
        if state["key"] != self.key:
            raise InputError(f"checkpoint folder {str(self.dir)!r} holds another movie or other options; "
                             f"use a new folder or delete it")
        try:
            parts = {name: [read_table(self.dir / f) for f in state["files"].get(name, [])]
                     for name in self.tables}
        except InputError as exc:
            raise self._damaged(str(exc)) from None
        states = {}
        for name, load in loaders.items():
            fname = state["states"].get(name)
            if fname is None:
                raise self._damaged(f"no {name} state")
            try:
                states[name] = load((self.dir / fname).read_bytes())
            except Exception as exc:  # missing or truncated pickle
                raise self._damaged(f"{name} state {fname!r}: {type(exc).__name__}: {exc}") from None
        return int(state["done"]), parts, states

    def save(self, done, new_parts, states):
        """Add the tables of the frames finished since the last checkpoint and the frame ``states`` (bytes by stage
        name); ``done`` frames in all.

        Parts are packed as they come (:meth:`_pack`): a table of a long movie is held in a few files, not one
        per checkpoint (65,536 frames saved every 100 made 2,627 files).
        """
        state = self._state() or {"key": self.key, "done": 0, "files": {name: [] for name in self.tables},
                                  "states": {}}
        superseded = []
        for name, tables in new_parts.items():
            if not tables:
                continue
            fname = f"{name}_{done:08d}.parquet"
            with atomic_path(self.dir / fname) as tmp:
                pd.concat(tables, ignore_index=True).to_parquet(tmp, index=False)
            state["files"][name].append(fname)
            superseded += self._pack(state["files"][name], name)
        for name, data in states.items():
            fname = f"{name}_state_{done:08d}.pkl"
            with atomic_path(self.dir / fname) as tmp:
                tmp.write_bytes(data)
            if name in state["states"]:
                superseded.append(state["states"][name])
            state["states"][name] = fname
        state["done"] = int(done)
        # the state file is written last: a crash before this line leaves the previous checkpoint valid
        with atomic_path(self.state_path) as tmp:
            tmp.write_text(json.dumps(state))
        for fname in superseded:  # only now no state names them
            (self.dir / fname).unlink(missing_ok=True)

    def _pack(self, files, name):
        """Merge the newest parts of one table while the last spans at least as many frames as the one before.

        A binary counter: each frame is rewritten about log2(frames / every) times, and a table keeps about that
        many files.  A part's last frame is in its name (``name_00000400.parquet``, or ``name_00000100-00000400``
        for a merged part), so the spans need no bookkeeping.  Returns the files merged away.
        """
        def ends():
            return [0] + [int(f[-16:-8]) for f in files]  # frames done before each part, then after each

        merged_away = []
        while len(files) >= 2:
            e = ends()
            if e[-1] - e[-2] < e[-2] - e[-3]:
                break
            fname = f"{name}_{e[-3]:08d}-{e[-1]:08d}.parquet"
            parts = [read_table(self.dir / f) for f in files[-2:]]
            with atomic_path(self.dir / fname) as tmp:
                pd.concat(parts, ignore_index=True).to_parquet(tmp, index=False)
            merged_away += files[-2:]
            files[-2:] = [fname]
        return merged_away
