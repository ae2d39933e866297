"""Interrupts and kills: a run stops within 2 s of SIGINT, its workers included, also while it compiles its kernels,
and leaves no folder that reads as complete (subprocesses on the real command)."""
import os
import signal
import subprocess
import sys
import time
from pathlib import Path

import numpy as np
import pytest
import tifffile

from hexatissue.cli import _interrupted
from hexatissue.synthetic import jittered_seeds, voronoi_labels

ROOT = Path(__file__).resolve().parents[1]


def _env():
    return dict(os.environ, PYTHONPATH=str(ROOT) + os.pathsep + os.environ.get("PYTHONPATH", ""))


def _session(pid):
    """The live processes of session ``pid`` (zombies waiting for init are not counted)."""
    out = subprocess.run(["ps", "-o", "pid=,stat=", "-s", str(pid)], capture_output=True, text=True).stdout
    return [line.split()[0] for line in out.splitlines() if line.split() and not line.split()[1].startswith("Z")]


def test_ctrl_c_inside_compiled_code_is_an_interrupt():
    try:
        try:
            raise KeyboardInterrupt
        except KeyboardInterrupt as inner:
            raise SystemError("CPUDispatcher(...) returned a result with an exception set") from inner
    except SystemError as outer:
        try:
            raise SystemError("_numba_unpickle returned a result with an exception set") from outer
        except SystemError as chained:
            assert _interrupted(chained)
    assert not _interrupted(SystemError("something else")) and _interrupted(KeyboardInterrupt())


@pytest.mark.slow
def test_sigint_stops_a_run_and_its_workers_within_two_seconds(tmp_path):
    frames = [voronoi_labels(jittered_seeds((1024, 1024), 14, seed=s), (1024, 1024)).astype(np.uint16)
              for s in range(4)]
    tifffile.imwrite(tmp_path / "big.tif", np.stack([frames[k % 4] for k in range(96)]), imagej=True,
                     metadata={"axes": "TYX"})
    for delay in (6.0, 9.0):  # in the frames' pool, then (on this machine) in the movie stages
        out = tmp_path / f"o{delay:g}"
        # started as a shell without job control starts a background command: SIGINT ignored
        run = subprocess.Popen([sys.executable, "-m", "hexatissue.cli", "analyze", str(tmp_path / "big.tif"),
                                "--out", str(out), "--workers", "2"], env=_env(), stdout=subprocess.PIPE,
                               stderr=subprocess.PIPE, start_new_session=True,
                               preexec_fn=lambda: signal.signal(signal.SIGINT, signal.SIG_IGN))
        time.sleep(delay)
        if run.poll() is not None:
            pytest.skip("the run ended before the interrupt (a faster machine): nothing to interrupt")
        start = time.monotonic()
        os.kill(run.pid, signal.SIGINT)
        _, err = run.communicate(timeout=30)
        took = time.monotonic() - start
        assert run.returncode == 130 and "interrupted" in err.decode(), err.decode()[-2000:]
        assert took < 2.0, took
        time.sleep(0.5)
        assert _session(run.pid) == []  # the workers are gone too
        assert not (out / "metadata.json").exists()  # nothing reads as complete


@pytest.mark.slow
def test_sigint_while_the_first_run_compiles_stops_it_at_once(tmp_path):
    """An empty numba cache and an input above REFERENCE_PIXELS: the run compiles the kernels and says so; SIGINT
    then stops it within 2 s with the interrupted message and code (no traceback, no destructor noise) and leaves
    no process behind."""
    from hexatissue.pipeline import REFERENCE_PIXELS

    side = int(np.sqrt(REFERENCE_PIXELS)) + 64
    np.save(tmp_path / "large.npy", voronoi_labels(jittered_seeds((side, side), 40, seed=1), (side, side)))
    env = dict(_env(), NUMBA_CACHE_DIR=str(tmp_path / "cache"), HEXATISSUE_PROGRESS="0")
    run = subprocess.Popen([sys.executable, "-m", "hexatissue.cli", "analyze", str(tmp_path / "large.npy"), "--out",
                            str(tmp_path / "o")], env=env, stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True,
                           start_new_session=True)
    try:
        assert "compiling the kernels" in run.stderr.readline()
        time.sleep(2.0)  # inside numba's compiler by now (the mesh's kernels take tens of seconds)
        assert run.poll() is None
        start = time.monotonic()
        os.kill(run.pid, signal.SIGINT)
        _, err = run.communicate(timeout=30)
        took = time.monotonic() - start
    finally:
        if run.poll() is None:
            run.kill()
    assert run.returncode == 130 and err.strip() == "hexatissue analyze: interrupted; files already written are " \
        "complete", err[-2000:]
    assert took < 2.0, took
    time.sleep(0.5)
    assert _session(run.pid) == []


def test_a_failed_figure_leaves_a_folder_that_does_not_read_as_complete(tmp_path, monkeypatch, capsys):
    import errno

    from hexatissue import read_results
    from hexatissue.cli import main
    from hexatissue.errors import InputError
    from hexatissue.workflows import figures

    labels = voronoi_labels(jittered_seeds((96, 120), 14, seed=1), (96, 120)).astype(np.uint16)
    np.save(tmp_path / "l.npy", np.stack([labels, labels]))
    assert main(["analyze", str(tmp_path / "l.npy"), "--out", str(tmp_path / "o")]) == 0  # a complete folder

    def full(*args, **kwargs):
        raise OSError(errno.ENOSPC, "No space left on device")

    monkeypatch.setattr(figures, "save_movie_figures", full)
    assert main(["analyze", str(tmp_path / "l.npy"), "--out", str(tmp_path / "o"), "--figures"]) == 2
    assert "No space left on device" in capsys.readouterr().err
    assert not (tmp_path / "o" / "metadata.json").exists()
    with pytest.raises(InputError, match="metadata.json"):
        read_results(tmp_path / "o")


def test_an_interrupt_swallowed_by_compiled_code_still_ends_the_command():
    """numba's compiler runs LLVM through ctypes callbacks, which print a KeyboardInterrupt raised in them and go on:
    the command must still end, with its message and code 130, within the grace period."""
    script = """
import os, signal, sys, time
from hexatissue.cli import _Interrupt
signal.signal(signal.SIGINT, _Interrupt("analyze"))
try:
    os.kill(os.getpid(), signal.SIGINT)
    time.sleep(0.1)
except KeyboardInterrupt:
    pass  # swallowed, as a ctypes callback does
time.sleep(30)
"""
    start = time.monotonic()
    run = subprocess.run([sys.executable, "-c", script], env=_env(), capture_output=True, text=True, timeout=60)
    assert run.returncode == 130 and time.monotonic() - start < 10
    assert run.stderr.strip() == "hexatissue analyze: interrupted; files already written are complete"


def test_an_error_after_an_interrupt_is_the_interrupt(tmp_path, monkeypatch, capsys):
    """An interrupt inside numba's compiler can surface as an unrelated error (its cache: "no compiled object
    yet"): after Ctrl-C, the command says it was interrupted, with code 130, not a traceback."""
    from hexatissue import cli

    def interrupted_compile(args, source, options):
        try:
            os.kill(os.getpid(), signal.SIGINT)
            time.sleep(0.1)
        except KeyboardInterrupt:
            pass
        raise RuntimeError("no compiled object yet for <Library 'merge_clusters'>")

    monkeypatch.setattr(cli, "_analyze_into", interrupted_compile)
    np.save(tmp_path / "l.npy", voronoi_labels(jittered_seeds((64, 64), 14, seed=1), (64, 64)))
    assert cli.main(["analyze", str(tmp_path / "l.npy"), "--out", str(tmp_path / "o")]) == 130
    assert capsys.readouterr().err.strip() == "hexatissue analyze: interrupted; files already written are complete"
    time.sleep(cli.INTERRUPT_GRACE + 0.5)  # the grace timer was cancelled: this process is still here
