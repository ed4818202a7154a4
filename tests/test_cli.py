"""The command line through its real entry point (the installed ``itensor`` script)."""

import json
import os
import shutil
import subprocess
import sys

import numpy as np
import pytest

import interaction_tensor as it
from interaction_tensor.cli.main import build_parser, main
from interaction_tensor.geometry.files import write_mesh, write_ply_points

from support import corner_example

ITENSOR = shutil.which("itensor") or None


def run(*args, check=None):
    cmd = [ITENSOR] if ITENSOR else [sys.executable, "-m", "interaction_tensor.cli.main"]
    proc = subprocess.run(cmd + [str(a) for a in args], capture_output=True, text=True,
                          timeout=600, env={**os.environ, "PYTHONWARNINGS": "ignore"})
    if check is not None:
        assert proc.returncode == check, proc.stderr
    return proc


@pytest.fixture(scope="module")
def files(tmp_path_factory):
    d = tmp_path_factory.mktemp("cli")
    q, s = corner_example()
    write_mesh(d / "box.ply", q.vertices, q.faces)
    write_mesh(d / "corner.ply", s.vertices, s.faces)
    return d


@pytest.fixture(scope="module")
def descriptor(files):
    out = files / "corner.npz"
    run("train", files / "box.ply", files / "corner.ply", "--affordance", "corner-box",
        "-o", out, "--query-points", 3000, check=0)
    return out


def test_train_info_detect(files, descriptor):
    info = run("info", descriptor, check=0)
    assert "corner-box" in info.stdout and "weighted keypoints" in info.stdout
    js = json.loads(run("info", descriptor, "--json", check=0).stdout)
    assert js["keypoints"]["weighted"]["count"] == 512
    out = files / "det"
    proc = run("detect", files / "corner.ply", descriptor, "-o", out, "--top-k", 3,
               "--sample-fraction", 0.2, "--seed", 4, check=0)
    assert "after the normal filter" in proc.stdout
    doc = json.loads((out / "predictions.json").read_text())
    assert doc["affordance"] == "corner-box"
    assert 1 <= len(doc["predictions"]) <= 3
    p = doc["predictions"][0]
    assert set(p) >= {"position", "orientation_index", "angle", "score", "pose"}
    assert np.asarray(p["pose"]).shape == (4, 4)
    for key in ("scene_points", "test_points_sampled", "candidates_after_normal_filter",
                "keypoint_comparisons", "seconds"):
        assert key in doc["stats"]
    assert doc["accepted"]["file"] == "accepted.npz"
    with np.load(out / "accepted.npz", allow_pickle=False) as acc:
        assert sorted(acc.files) == sorted(doc["accepted"]["columns"])
        assert doc["accepted"]["count"] == len(acc["score"]) == len(acc["point_index"]) > 0
        assert all(1 <= c <= 512 for c in acc["comparisons_to_decision"])
        assert np.all(acc["score"] >= doc["parameters"]["threshold_used"] - 1e-6)
        assert acc["point_index"].max() < doc["stats"]["scene_points"]
    assert doc["stats"]["mean_comparisons_to_accept"] <= 512
    assert (out / "heatmap.ply").stat().st_size > 0
    header = (out / "heatmap.ply").read_bytes()[:400].decode("ascii", "replace")
    assert "property float quality" in header and "property float scalar_score" in header
    assert "property uchar red" in header and (out / "predictions.glb").stat().st_size > 0
    tops = sorted((out / "top").glob("top_*.ply"))
    assert len(tops) == len(doc["predictions"])
    # no temporary files left behind
    assert not [f for f in out.rglob("*") if ".part" in f.name]
    # the picture by default, and no picture when asked
    assert (out / "render.png").read_bytes()[:8] == b"\x89PNG\r\n\x1a\n"
    assert "place 0" in proc.stdout and "places found" in proc.stdout
    bare = files / "det-bare"
    run("detect", files / "corner.ply", descriptor, "-o", bare, "--top-k", 3,
        "--sample-fraction", 0.2, "--seed", 4, "--no-render", "-q", check=0)
    assert not (bare / "render.png").exists()
    assert (bare / "predictions.json").read_text() != ""


def _one_line_error(proc, *words):
    assert proc.returncode == 2, (proc.returncode, proc.stdout, proc.stderr)
    err = proc.stderr.strip()
    assert "Traceback" not in proc.stderr
    assert len(err.splitlines()) == 1, err
    for w in words:
        assert w in err, err


def test_bad_inputs_give_one_line_errors(files, descriptor, tmp_path):
    _one_line_error(run("train", tmp_path / "nope.ply", files / "corner.ply",
                        "--affordance", "x", "-o", tmp_path / "x.npz"), "nope.ply", "no such file")
    _one_line_error(run("train", tmp_path, files / "corner.ply", "--affordance", "x",
                        "-o", tmp_path / "x.npz"), "is a directory")
    empty = tmp_path / "empty.ply"
    empty.write_bytes(b"")
    _one_line_error(run("train", empty, files / "corner.ply", "--affordance", "x",
                        "-o", tmp_path / "x.npz"), "empty.ply", "empty")
    nan = tmp_path / "nan.ply"
    pts = np.random.default_rng(0).random((20, 3))
    pts[3] = np.nan
    write_ply_points(nan, pts)
    _one_line_error(run("detect", nan, descriptor, "-o", tmp_path / "o"), "nan.ply", "NaN")
    # objects that do not touch: the query 3 m above the scene-object
    far = tmp_path / "far.ply"
    q, _ = corner_example()
    write_mesh(far, q.vertices + [0, 0, 3.0], q.faces)
    _one_line_error(run("train", far, files / "corner.ply", "--affordance", "x",
                        "-o", tmp_path / "far.npz"), "do not")
    not_descriptor = tmp_path / "fake.npz"
    not_descriptor.write_bytes(b"PK not really")
    _one_line_error(run("detect", files / "corner.ply", not_descriptor, "-o", tmp_path / "o"),
                    "fake.npz")
    _one_line_error(run("info", tmp_path / "missing.npz"), "missing.npz")
    # nothing half-written: no descriptor and no output directory contents after failures
    assert not (tmp_path / "x.npz").exists() and not (tmp_path / "far.npz").exists()
    assert not list(tmp_path.glob("*.part*"))
    assert not (tmp_path / "o").exists() or not any((tmp_path / "o").iterdir())


def test_usage_errors_exit_non_zero():
    proc = run("detect")
    assert proc.returncode == 2 and "usage" not in proc.stderr
    assert proc.stderr.strip().count("\n") == 0 and "the following arguments are required" \
        in proc.stderr and "'itensor detect --help'" in proc.stderr
    for option in (["--top-k", "-3"], ["--top-k", "0"], ["--sample-fraction", "2"]):
        proc = run("detect", "scene.ply", "d.npz", "-o", "out", *option)
        assert proc.returncode == 2 and proc.stderr.strip().count("\n") == 0, proc.stderr
        assert f"argument {option[0]}" in proc.stderr and "--help" in proc.stderr
    assert run("--version", check=0).stdout.startswith("itensor ")


def test_detect_on_an_rgbd_frame_directory(files, descriptor, tmp_path):
    from support import shared_file
    frame = shared_file("rgbd/tum_desk/intrinsics.json").parent
    out = tmp_path / "tum"
    proc = run("detect", frame, descriptor, "-o", out, "--sample-fraction", 0.05,
               "--voxel-size", 0.02, "--quiet")
    assert proc.returncode == 0, proc.stderr
    doc = json.loads((out / "predictions.json").read_text())
    assert doc["parameters"]["criterion"] == "gaussian"       # the default for captured data
    assert "real_scene" in doc
    assert (out / "predictions_input_frame.json").exists()
    assert (out / "heatmap_input_frame.ply").exists()
    _one_line_error(run("detect", descriptor, "-o", tmp_path / "x",
                        "--depth", frame / "color.png", "--intrinsics", frame / "intrinsics.json"),
                    "color.png")


# ----------------------------------------------------------------------------- polish
def _all_actions():
    import argparse


    def walk(parser, name):
        for a in parser._actions:
            if isinstance(a, argparse._SubParsersAction):
                for n, sp in a.choices.items():
                    yield from walk(sp, f"{name} {n}")
            elif not isinstance(a, (argparse._HelpAction, argparse._VersionAction)):
                yield name, parser, a

    yield from walk(build_parser(), "itensor")


def test_every_option_has_help_and_shows_its_default():
    actions = list(_all_actions())
    assert len(actions) > 100
    for name, parser, action in actions:
        assert action.help, f"{name} {action.option_strings or action.dest} has no help"
        default = action.default
        if action.option_strings and default not in (None, False) and not isinstance(default, bool):
            text = parser.formatter_class(prog="x")._get_help_string(action)
            assert "default" in text.lower(), f"{name} {action.option_strings}: {text}"


def test_detect_json_summary_and_unwritable_outputs(tmp_path, capsys):

    from support import corner_example

    query, scene_object = corner_example()
    write_mesh(tmp_path / "q.ply", query.vertices, query.faces)
    write_mesh(tmp_path / "s.ply", scene_object.vertices, scene_object.faces)
    assert main(["train", str(tmp_path / "q.ply"), str(tmp_path / "s.ply"), "--affordance",
                 "corner", "-o", str(tmp_path / "c.npz"), "--json"]) == 0
    doc = json.loads(capsys.readouterr().out)
    assert doc["affordance"] == "corner" and doc["descriptor"].endswith("c.npz")
    assert main(["detect", str(tmp_path / "s.ply"), str(tmp_path / "c.npz"), "-o",
                 str(tmp_path / "out"), "--json", "--sample-fraction", "0.2"]) == 0
    out = capsys.readouterr().out.strip().splitlines()
    assert len(out) == 1
    summary = json.loads(out[0])
    assert summary["pairs_scored"] > 0 and summary["output"] == str(tmp_path / "out")
    assert len(summary["predictions"]) >= 1
    assert summary["pairs_tested"] == summary["pairs"] >= summary["pairs_scored"]
    # an unknown placement test is one line and status 2
    with pytest.raises(SystemExit) as exc:
        main(["detect", str(tmp_path / "s.ply"), str(tmp_path / "c.npz"), "-o",
              str(tmp_path / "out3"), "--skip-test", "clearence"])
    assert exc.value.code == 2
    err = capsys.readouterr().err
    assert "unknown placement test clearence" in err and "Traceback" not in err
    # unwritable outputs: one line naming the path, status 2, no traceback
    (tmp_path / "file").write_text("x")
    for target in (str(tmp_path / "file" / "c.npz"), str(tmp_path / "out"), ""):
        code = main(["train", str(tmp_path / "q.ply"), str(tmp_path / "s.ply"), "--affordance",
                     "corner", "-o", target])
        err = capsys.readouterr().err
        assert code == 2 and err.count("\n") == 1 and "Traceback" not in err, (target, err)
    assert main(["detect", str(tmp_path / "s.ply"), str(tmp_path / "c.npz"), "-o", ""]) == 2
    assert "output is empty" in capsys.readouterr().err


def test_a_closed_pipe_ends_quietly(tmp_path):
    """``itensor info --json X | head -c 10``: no traceback when the reader goes away."""
    import subprocess
    import sys

    from support import corner_example

    query, scene_object = corner_example()
    t = it.InteractionTensor.fit(query, scene_object, "corner", it.TrainSettings(query_points=500))
    t.save(tmp_path / "c.npz")
    # the reader closes its end before itensor writes a byte: EPIPE on the first write
    run = subprocess.Popen([sys.executable, "-m", "interaction_tensor.cli.main", "info", "--json",
                            str(tmp_path / "c.npz")], stdout=subprocess.PIPE,
                           stderr=subprocess.PIPE, text=True)
    run.stdout.close()
    err = run.stderr.read()
    assert run.wait(timeout=120) == 141, err
    assert "Traceback" not in err and "BrokenPipe" not in err and "Exception" not in err, err
