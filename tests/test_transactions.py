"""A detection's output directory is one transaction: SIGINT, SIGTERM and SIGKILL at the moment
its temporary directory appears leave the complete earlier result; a second run into the same
directory at once refuses; a directory holding other files is never replaced."""

from __future__ import annotations

import hashlib
import os
import signal
import subprocess
import sys
import time
from pathlib import Path

import pytest

import interaction_tensor as it
import interaction_tensor.geometry.files as io_mod
from interaction_tensor.cli.main import main
from interaction_tensor.geometry.files import _signals_deferred, atomic_dir, write_mesh

from support import corner_example


@pytest.fixture(scope="module")
def inputs(tmp_path_factory):
    d = tmp_path_factory.mktemp("tx")
    query, scene_object = corner_example()
    write_mesh(d / "scene.ply", scene_object.vertices, scene_object.faces)
    it.InteractionTensor.fit(query, scene_object, "corner",
                             it.TrainSettings(query_points=800, seed=1)).save(d / "c.npz")
    return d


def _digest(folder: Path) -> dict:
    return {str(p.relative_to(folder)): hashlib.sha1(p.read_bytes()).hexdigest()
            for p in sorted(folder.rglob("*")) if p.is_file()}


def _detect_argv(inputs, out, *extra):
    return ["detect", str(inputs / "scene.ply"), str(inputs / "c.npz"), "-o", str(out),
            "--sample-fraction", "0.3", "--quiet", *extra]


def _default_sigint():
    signal.signal(signal.SIGINT, signal.SIG_DFL)


@pytest.mark.parametrize("sig,code", [(signal.SIGINT, 130), (signal.SIGTERM, 143),
                                      (signal.SIGKILL, -9)])
def test_a_signal_mid_write_leaves_the_earlier_result(inputs, tmp_path, sig, code):
    out = tmp_path / "out"
    assert main(_detect_argv(inputs, out, "--top-k", "3")) == 0
    before = _digest(out)
    assert "predictions.json" in before and "predictions.glb" in before
    # a slower rerun (render.png too) into the same directory, stopped as soon as its
    # temporary directory appears
    # the child starts with SIGINT at its default, as a command typed at a terminal does: a
    # test run started in the background (`pytest &` in a script) has SIGINT ignored, which
    # its children inherit, and Python then leaves it ignored (exit 0, nothing on stderr)
    run = subprocess.Popen([sys.executable, "-m", "interaction_tensor.cli.main",
                            *_detect_argv(inputs, out, "--top-k", "5", "--render")],
                           stderr=subprocess.PIPE, text=True, preexec_fn=_default_sigint)
    deadline = time.time() + 300
    while time.time() < deadline and run.poll() is None:
        if list(tmp_path.glob(".out.*.part")):
            break
        time.sleep(0.005)
    assert run.poll() is None, "the run finished before it could be interrupted"
    run.send_signal(sig)
    err = run.communicate(timeout=120)[1]
    assert run.returncode == code, err
    if sig != signal.SIGKILL:
        assert "Traceback" not in err and err.strip().count("\n") == 0, err
        assert not list(tmp_path.glob(".out.*")), "temporary files left behind"
    assert _digest(out) == before                      # the complete earlier result
    # the next run cleans up what a killed run left, and completes
    assert main(_detect_argv(inputs, out, "--top-k", "2")) == 0
    assert not list(tmp_path.glob(".out.*"))
    assert _digest(out) != before and (out / "predictions.json").is_file()


def test_a_second_run_into_the_same_directory_refuses(tmp_path):
    target = tmp_path / "res"
    with atomic_dir(target, "marker.json") as tmp:
        (tmp / "marker.json").write_text("{}")
        with pytest.raises(it.InputError, match="another itensor run is writing"):
            with atomic_dir(target, "marker.json"):
                pass
    assert (target / "marker.json").is_file()
    with atomic_dir(target, "marker.json") as tmp:        # the lock is free again
        (tmp / "marker.json").write_text("{}")


def test_a_directory_with_other_files_is_never_replaced(inputs, tmp_path, capsys):
    out = tmp_path / "mine"
    out.mkdir()
    (out / "notes.txt").write_text("my notes")
    assert main(_detect_argv(inputs, out)) == 2
    assert "not an earlier output" in capsys.readouterr().err
    assert (out / "notes.txt").read_text() == "my notes"
    # an earlier result with a foreign file added is not swapped away either
    good = tmp_path / "good"
    assert main(_detect_argv(inputs, good)) == 0
    (good / "notes.txt").write_text("mine")
    assert main(_detect_argv(inputs, good)) == 2
    err = capsys.readouterr().err
    assert "notes.txt" in err and "would be lost" in err
    assert (good / "notes.txt").read_text() == "mine"


def test_signals_wait_while_a_temporary_is_made_or_swapped():
    """SIGTERM arriving between making a temporary and entering the block that removes it
    left .part files behind under load (1 run in the full suite): it is now held back over
    those few lines and raised right after them."""

    class Stop(Exception):
        pass

    def raise_stop(*_):
        raise Stop

    previous = signal.signal(signal.SIGTERM, raise_stop)
    steps = []
    # another thread that masks nothing (as Numba's and tqdm's): the kernel may hand it the
    # signal, so a per-thread mask in the main thread would not hold it back
    import threading
    import time
    other = threading.Thread(target=time.sleep, args=(0.5,), daemon=True)
    other.start()
    try:
        with pytest.raises(Stop):
            with _signals_deferred():
                os.kill(os.getpid(), signal.SIGTERM)
                steps.append("made")                   # still runs: the signal waits
            steps.append("after")                      # never: it is raised on leaving
    finally:
        signal.signal(signal.SIGTERM, previous)
    assert steps == ["made"]


def test_a_signal_held_while_the_temporary_is_made_still_removes_it(tmp_path, monkeypatch):
    """The signal held back while the temporary is made is raised as that block ends, inside
    the block that removes the temporary: no .part directory is left behind."""
    import tempfile


    class Stop(Exception):
        pass

    def raise_stop(*_):
        raise Stop

    real = tempfile.mkdtemp

    def mkdtemp_then_signal(*args, **kwargs):
        made = real(*args, **kwargs)
        os.kill(os.getpid(), signal.SIGTERM)          # arrives just after the directory exists
        return made

    monkeypatch.setattr(io_mod.tempfile, "mkdtemp", mkdtemp_then_signal)
    previous = signal.signal(signal.SIGTERM, raise_stop)
    try:
        with pytest.raises(Stop):
            with atomic_dir(tmp_path / "out", "run.json") as tmp:
                (tmp / "run.json").write_text("{}")   # never: the signal is raised first
    finally:
        signal.signal(signal.SIGTERM, previous)
    assert not (tmp_path / "out").exists()
    assert sorted(p.name for p in tmp_path.iterdir()) == [], list(tmp_path.iterdir())
