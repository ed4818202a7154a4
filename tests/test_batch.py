"""itensor batch: many scenes x many descriptors, resumable, on a real Dask cluster."""

from __future__ import annotations

import csv
import json
import os
import signal
import subprocess
import sys
import time
from pathlib import Path

import numpy as np
import pytest

import interaction_tensor as it
from interaction_tensor.batch import batch, expand_paths, unique_names
from interaction_tensor.cli.main import main
from interaction_tensor.examples import demo
from interaction_tensor.examples.procedural import box_part, parts_mesh
from interaction_tensor.geometry.files import write_mesh

HEIGHTS = (0.55, 0.7, 0.85, 1.0)
FAST = ["--sample-fraction", "0.1", "--top-k", "3"]


@pytest.fixture(scope="module")
def data(tmp_path_factory):
    """Four small scenes (a floor and a table top at HEIGHTS) and two descriptors."""
    d = tmp_path_factory.mktemp("batch")
    for i, h in enumerate(HEIGHTS):
        g = parts_mesh([box_part("floor", (0, 0, -0.01), (1.0, 1.0, 0.02)),
                        box_part("top", (0.1, 0.1, h - 0.015), (0.5, 0.4, 0.03))])
        write_mesh(d / f"room{i}.ply", g.vertices, g.faces)
    ex = demo.build()
    it.train(ex.query, ex.scene_object, "placing-bowl", spacing=0.02).save(d / "bowl.npz")
    it.train(ex.query, ex.scene_object, "placing-loose", spacing=0.02,
             acceptance="sitting").save(d / "loose.npz")
    return d


def _rows(out: Path) -> list[dict]:
    with open(out / "summary.csv") as fh:
        return list(csv.DictReader(fh))


def test_in_process_batch_writes_every_pair_and_resumes(data, tmp_path):
    out = tmp_path / "out"
    scenes = [data / "room0.ply", data / "room1.ply"]
    res = batch(scenes, [data / "bowl.npz", data / "loose.npz"], out, workers=0,
                sample_fraction=0.1, top_k=3)
    assert res.failed == 0 and len(res.rows) == 4
    for scene, h in (("room0", HEIGHTS[0]), ("room1", HEIGHTS[1])):
        for desc in ("bowl", "loose"):
            folder = out / scene / desc
            doc = json.loads((folder / "predictions.json").read_text())
            z = np.array([p["position"][2] for p in doc["predictions"]])
            assert len(z) >= 1 and np.any(np.abs(z - h) < 0.02), (scene, desc, z)
            assert (folder / "render.png").is_file() and (folder / "heatmap.ply").is_file()
    rows = _rows(out)
    assert [(r["scene"], r["descriptor"], r["status"]) for r in rows] == [
        ("room0", "bowl", "done"), ("room0", "loose", "done"),
        ("room1", "bowl", "done"), ("room1", "loose", "done")]
    # pairs decided, and of them scored (those that passed the placement tests)
    assert all(int(r["pairs"]) >= int(r["pairs_scored"]) > 0 for r in rows)
    page = (out / "index.html").read_text()
    assert page.count("render.png'><img") == 4 and "summary.csv" in page
    # a rerun skips everything; a removed result is made again, the others are left alone
    kept = (out / "room0" / "bowl" / "predictions.json").stat().st_ino
    import shutil

    shutil.rmtree(out / "room1" / "loose")
    again = batch(scenes, [data / "bowl.npz", data / "loose.npz"], out, workers=0,
                  sample_fraction=0.1, top_k=3)
    assert [r["status"] for r in again.rows] == ["skipped", "skipped", "skipped", "done"]
    assert [r["pairs"] for r in again.rows] == [int(r["pairs"]) for r in rows]
    assert (out / "room0" / "bowl" / "predictions.json").stat().st_ino == kept
    assert (out / "room1" / "loose" / "predictions.json").is_file()


def test_inputs_from_globs_and_manifests(data, tmp_path):
    (tmp_path / "scenes.txt").write_text(f"# two rooms\n{data / 'room2.ply'}\n\nroom3.ply\n")
    (tmp_path / "room3.ply").write_bytes((data / "room3.ply").read_bytes())
    paths = expand_paths([str(data / "room[01].ply"), tmp_path / "scenes.txt"], "scenes")
    assert [p.name for p in paths] == ["room0.ply", "room1.ply", "room2.ply", "room3.ply"]
    (tmp_path / "list.json").write_text(json.dumps({"scenes": [str(data / "room1.ply")]}))
    assert expand_paths([tmp_path / "list.json"], "scenes") == [data / "room1.ply"]
    names = unique_names([data / "room0.ply", tmp_path / "room3.ply", data / "room3.ply"])
    assert names[0] == "room0" and names[1] != names[2] and names[1].startswith("room3-")
    (tmp_path / "bad.txt").write_text("missing.ply\n")
    with pytest.raises(it.InputError, match="bad.txt: manifest lists 1 missing"):
        expand_paths([tmp_path / "bad.txt"], "scenes")
    with pytest.raises(it.InputError, match="no scenes match"):
        expand_paths([str(tmp_path / "*.nothing")], "scenes")


def test_failures_are_rows_and_bad_descriptors_are_refused_first(data, tmp_path, capsys):
    broken = tmp_path / "broken.ply"
    broken.write_text("ply\nformat ascii 1.0\nelement vertex 9\nproperty float x\nend_header\n1\n")
    code = main(["batch", "--scenes", str(data / "room0.ply"), str(broken), "--descriptors",
                 str(data / "bowl.npz"), "-o", str(tmp_path / "out"), "--workers", "0",
                 "--no-render", "--quiet", *FAST])
    assert code == 1
    rows = _rows(tmp_path / "out")
    assert [r["status"] for r in rows] == ["done", "failed"]
    assert "broken.ply" in rows[1]["message"] and "header" in rows[1]["message"]
    assert "broken.ply" in capsys.readouterr().err
    (tmp_path / "fake.npz").write_bytes(b"not a descriptor")
    code = main(["batch", "--scenes", str(data / "room0.ply"), "--descriptors",
                 str(tmp_path / "fake.npz"), "-o", str(tmp_path / "out2"), "--workers", "0"])
    assert code == 2 and not (tmp_path / "out2" / "summary.csv").exists()


# ----------------------------------------------------------------------------- Dask
def _start(args, log):
    return subprocess.Popen([sys.executable, "-m", *args], stdout=log, stderr=log,
                            start_new_session=True)


@pytest.fixture
def dask_cluster(tmp_path):
    """A real scheduler and two single-threaded workers (no nannies) on localhost."""
    pytest.importorskip("dask.distributed")
    sched_file = tmp_path / "scheduler.json"
    log = open(tmp_path / "dask.log", "w")
    procs = [_start(["distributed.cli.dask_scheduler", "--scheduler-file", str(sched_file),
                     "--port", "0", "--no-dashboard", "--host", "127.0.0.1"], log)]
    deadline = time.time() + 60
    while not sched_file.exists() and time.time() < deadline:
        time.sleep(0.2)
    assert sched_file.exists(), (tmp_path / "dask.log").read_text()
    address = json.loads(sched_file.read_text())["address"]
    env = {**os.environ, "NUMBA_NUM_THREADS": "1"}
    for _ in range(2):
        procs.append(subprocess.Popen(
            [sys.executable, "-m", "distributed.cli.dask_worker", address, "--nthreads", "1",
             "--no-nanny", "--no-dashboard", "--host", "127.0.0.1", "--memory-limit", "0"],
            stdout=log, stderr=log, start_new_session=True, env=env))
    from dask.distributed import Client

    with Client(address, timeout="30s") as client:
        client.wait_for_workers(2, timeout=60)
    yield address, procs[1:]
    for p in procs:
        if p.poll() is None:
            os.killpg(p.pid, signal.SIGTERM)
    for p in procs:
        try:
            p.wait(timeout=20)
        except subprocess.TimeoutExpired:
            os.killpg(p.pid, signal.SIGKILL)
    log.close()


def test_batch_on_a_dask_scheduler_survives_a_killed_worker(data, tmp_path, dask_cluster):
    address, workers = dask_cluster
    out = tmp_path / "out"
    argv = ["interaction_tensor.cli.main", "batch", "--scenes", str(data / "room*.ply"),
            "--descriptors", str(data / "bowl.npz"), str(data / "loose.npz"), "-o", str(out),
            "--scheduler", address, "--no-render", "--quiet", "--json", *FAST]
    run = subprocess.Popen([sys.executable, "-m", *argv], stdout=subprocess.PIPE,
                           stderr=subprocess.PIPE, text=True)
    # kill one worker as soon as the first result is finished
    deadline = time.time() + 300
    first = None
    while time.time() < deadline and run.poll() is None:
        # a finished result's folder (a result being written is a hidden ".part" one)
        done = sorted(p for p in out.glob("*/*/predictions.json")
                      if not p.parent.name.startswith("."))
        if done:
            first = done[0]
            break
        time.sleep(0.1)
    assert first is not None, run.communicate()
    first_inode = first.stat().st_ino
    workers[0].send_signal(signal.SIGKILL)
    stdout, stderr = run.communicate(timeout=600)
    if run.returncode != 0:
        # the batch may give up on tasks the dead worker held; a rerun completes the rest
        assert run.returncode == 1, stderr
        rerun = subprocess.run([sys.executable, "-m", *argv], capture_output=True, text=True,
                               timeout=600)
        assert rerun.returncode == 0, rerun.stderr
        stdout = rerun.stdout
    summary = json.loads(stdout.strip().splitlines()[-1])
    assert summary["failed"] == 0 and summary["results"] == 8
    assert first.stat().st_ino == first_inode          # the finished result was not redone
    rows = _rows(out)
    assert len(rows) == 8 and all(r["status"] in ("done", "skipped") for r in rows)
    for i, h in enumerate(HEIGHTS):
        doc = json.loads((out / f"room{i}" / "bowl" / "predictions.json").read_text())
        assert any(abs(p["position"][2] - h) < 0.02 for p in doc["predictions"])
    assert not list(out.rglob("*.part"))               # no half-written folders left
