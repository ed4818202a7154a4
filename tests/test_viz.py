"""Pictures and the HTML viewer: render.png, the figure-2 picture, index.html in Chromium."""

from __future__ import annotations

import os
import re
import shutil
import subprocess
import sys
import tempfile
from pathlib import Path

import numpy as np
import pytest

from interaction_tensor.cli.main import main
from interaction_tensor.errors import InputError
from interaction_tensor.examples.procedural import box_part, parts_mesh
from interaction_tensor.geometry.files import write_json, write_mesh, write_ply_points
from interaction_tensor.outputs import render_outdir, render_tensor, write_viewer
from interaction_tensor.outputs.export import colormap
from interaction_tensor.outputs.html import build_data

PIL = pytest.importorskip("PIL")
from PIL import Image  # noqa: E402

THRESHOLD = 0.8


def _grid(x0, x1, y0, y1, z, step):
    xs, ys = np.meshgrid(np.arange(x0, x1, step), np.arange(y0, y1, step))
    return np.column_stack([xs.ravel(), ys.ravel(), np.full(xs.size, z)])


def make_outdir(path: Path, tensor=None, n_predictions: int = 4) -> Path:
    """A small detection directory: a 2 x 2 m floor and a 0.6 m table top at 0.7 m, the
    table top hot, a 10 cm box posed at the predictions (3 on the table, 1 on the floor)."""
    floor = _grid(-1, 1, -1, 1, 0.0, 0.02)
    top = _grid(0.2, 0.8, 0.2, 0.8, 0.7, 0.02)
    pts = np.vstack([floor, top])
    score = np.zeros(len(pts))
    score[len(floor):] = 0.85 + 0.15 * np.clip(1 - np.linalg.norm(top[:, :2] - 0.5, axis=1) / 0.4, 0, 1)
    write_ply_points(path / "heatmap.ply", pts, colors=colormap(score, THRESHOLD, 1.0),
                     score=score, accepted=(score > 0).astype(float))
    box = parts_mesh([box_part("box", (0, 0, 0.05), (0.1, 0.1, 0.1))])
    places = [(0.5, 0.5, 0.7), (0.3, 0.35, 0.7), (0.7, 0.3, 0.7), (-0.6, -0.6, 0.0)]
    preds = []
    for rank, pos in enumerate(places[:n_predictions], 1):
        pose = np.eye(4)
        pose[:3, 3] = pos
        write_mesh(path / "top" / f"top_{rank:02d}.ply", box.vertices + pos, box.faces)
        preds.append({"position": list(pos), "orientation_index": 0, "angle": 0.0,
                      "score": 0.99 - 0.01 * rank, "pose": pose.tolist(), "point_index": -1})
    descriptor = "missing.npz"
    if tensor is not None:
        tensor.save(path / "example.npz")
        descriptor = str(path / "example.npz")
    write_json(path / "predictions.json", {
        "scene": "synthetic room", "descriptor": descriptor, "affordance": "placing-box",
        "parameters": {"threshold_used": THRESHOLD}, "predictions": preds,
        "accepted": {"count": 0}, "stats": {}})
    return path


@pytest.fixture(scope="module")
def outdir(tmp_path_factory, corner_tensor):
    return make_outdir(tmp_path_factory.mktemp("viz"), corner_tensor)


def _pixels(png) -> np.ndarray:
    img = Image.open(png)
    assert img.mode == "RGB"
    return np.asarray(img).astype(int)


def _heat_pixels(a: np.ndarray) -> int:
    """Pixels in the heat-map hues (teal, green, yellow of the ramp; not grey, not red)."""
    r, g = a[..., 0], a[..., 1]
    return int(((g - r > 25) & (g > 60)).sum())


def _red_pixels(a: np.ndarray) -> int:
    r, g, b = a[..., 0], a[..., 1], a[..., 2]
    return int(((r - g > 80) & (r - b > 80)).sum())


def _not_blank(a: np.ndarray) -> None:
    assert a.std() > 20
    assert (a.sum(axis=2) < 720).mean() > 0.15  # more than 15 % of the picture is not white


# --------------------------------------------------------------------------- render.png
def test_render_outdir_draws_heat_map_objects_and_colour_bar(outdir):

    png = render_outdir(outdir)
    assert png == outdir / "render.png"
    a = _pixels(png)
    _not_blank(a)
    assert a.shape[0] >= 480 and a.shape[1] >= 640
    assert _heat_pixels(a) > 2000, "heat-map colours missing"
    assert _red_pixels(a) > 300, "the query objects are not drawn"
    # spread-out predictions: an overview and close-ups (a 2-column grid)
    assert a.shape[1] > 2 * 640
    # the colour bar (right margin) holds the top of the ramp (yellow)
    bar = a[:, -135:]
    assert ((bar[..., 0] > 200) & (bar[..., 1] > 200) & (bar[..., 2] < 90)).sum() > 20


def test_render_needs_no_opengl(outdir, tmp_path, monkeypatch):
    """The software renderer is the only path: it works with OpenGL libraries unimportable."""
    for name in ("OpenGL", "OpenGL.GL", "pyrender", "pyvista", "vtk", "matplotlib"):
        monkeypatch.setitem(sys.modules, name, None)

    a = _pixels(render_outdir(outdir, tmp_path / "no-gl.png", supersample=1))
    _not_blank(a)
    assert _heat_pixels(a) > 1000


def test_render_without_predictions(tmp_path):

    make_outdir(tmp_path, n_predictions=0)
    a = _pixels(render_outdir(tmp_path, supersample=1))
    _not_blank(a)
    assert _red_pixels(a) == 0


def test_render_tensor_like_figure_2(corner_tensor, tmp_path):

    a = _pixels(render_tensor(corner_tensor, tmp_path / "tensor.png"))
    _not_blank(a)
    assert _heat_pixels(a) > 200, "weight colours missing"


def test_bad_outdir_is_an_input_error(tmp_path):

    with pytest.raises(InputError, match="predictions.json"):
        render_outdir(tmp_path)
    (tmp_path / "predictions.json").write_text("{not json")
    with pytest.raises(InputError, match="not a predictions file"):
        write_viewer(tmp_path)


# --------------------------------------------------------------------------- CLI
@pytest.fixture()
def cli():

    return main


def test_cli_view_show_render(cli, outdir, tmp_path, capsys):
    assert cli(["view", str(outdir), "--max-points", "2000"]) == 0
    page = (outdir / "index.html").read_text()
    assert "down-sampled for the browser" in page
    assert cli(["show", str(outdir / "example.npz"), "--render", str(tmp_path / "t.png")]) == 0
    assert (tmp_path / "t.png").stat().st_size > 10_000
    assert cli(["render", str(outdir), "-o", str(tmp_path / "r.png"), "--top-k", "2"]) == 0
    assert cli(["view", str(tmp_path / "nowhere")]) == 2
    assert "nowhere" in capsys.readouterr().err


# --------------------------------------------------------------------------- index.html
def test_page_is_self_contained(outdir):

    page = write_viewer(outdir).read_text()
    assert not re.search(r"<script[^>]+src=", page)
    assert not re.search(r"(src|href)=\"(https?:)?//", page)
    assert "fetch(" not in page and "XMLHttpRequest" not in page
    assert "down-sampled" not in page  # small scene: no note
    assert 'id="example-canvas"' in page and "provenance" in page


def test_page_without_descriptor_uses_posed_objects(tmp_path):

    make_outdir(tmp_path)
    data = build_data(tmp_path)
    assert data["example"] is None and "not found" in data["descriptor_note"]
    assert len(data["predictions"]) == 4 and len(data["meshes"]) == 4


CHROMIUM = shutil.which("chromium") or shutil.which("chromium-browser")
FLAGS = ["--headless", "--no-sandbox", "--disable-gpu", "--disable-quic", "--no-first-run",
         "--disable-background-networking", "--disable-component-update", "--disable-sync",
         "--enable-logging=stderr", "--v=0", "--virtual-time-budget=4000",
         "--enable-unsafe-swiftshader"]


def _chromium(url: str, *extra: str) -> subprocess.CompletedProcess:
    with tempfile.TemporaryDirectory() as profile:
        return subprocess.run([CHROMIUM, *FLAGS, f"--user-data-dir={profile}", *extra, url],
                              capture_output=True, text=True, timeout=120)


def _console_errors(stderr: str) -> list[str]:
    lines = [ln for ln in stderr.splitlines() if "CONSOLE" in ln]
    return [ln for ln in lines if re.search(r"Uncaught|Error|error", ln)
            and "GL Driver Message" not in ln and "software WebGL" not in ln]


@pytest.mark.skipif(CHROMIUM is None, reason="chromium not installed (apt-get install chromium); "
                                             ".ci/run installs it")
@pytest.mark.parametrize("renderer", ["webgl", "canvas2d"])
def test_page_in_headless_chromium(outdir, tmp_path, renderer, record_property):

    page = write_viewer(outdir, out_html=tmp_path / "index.html")
    extra = ["--disable-webgl", "--disable-3d-apis"] if renderer == "canvas2d" else []
    run = _chromium(page.as_uri(), "--dump-dom", *extra)
    dom = run.stdout
    head = re.search(r"<html[^>]*>", dom)
    assert head, f"no DOM dumped: {run.stderr[-2000:]}"
    attrs = dict(re.findall(r'data-([a-z]+)="([^"]*)"', head.group(0)))
    assert attrs.get("ready") == "1", f"viewer did not finish: {attrs}\n{run.stderr[-2000:]}"
    assert attrs.get("errors") == "0", re.search(r'<pre id="errors"[^>]*>(.*?)</pre>', dom, re.S)
    assert attrs.get("renderer") == renderer
    assert int(attrs.get("frames", 0)) >= 1
    assert dom.count('class="prediction') == 4
    assert _console_errors(run.stderr) == []

    # a screenshot of the same page, kept with the test output
    shot = tmp_path / f"viewer-{renderer}.png"
    _chromium(page.as_uri(), f"--screenshot={shot}", "--window-size=1400,900",
              "--hide-scrollbars", *extra)
    a = _pixels(shot)
    assert a.std() > 10, "blank screenshot"
    assert _heat_pixels(a) > 200, "heat map not visible in the page"
    record_property("screenshot", str(shot))
    keep = os.environ.get("ITENSOR_TEST_ARTIFACTS")
    if keep:
        Path(keep).mkdir(parents=True, exist_ok=True)
        shutil.copy(shot, Path(keep) / shot.name)
    print(f"screenshot: {shot}")


def test_the_splat_kernel_fills_the_z_buffer_as_the_numpy_reference():
    """The Numba splat and the NumPy reference give the same depths, colours, normals and
    lighting, pixel for pixel: lit oriented splats of a room, unlit ones over them, fixed
    radii, points behind the camera and off the picture, and ties: points drawn again at
    the same depths take the pixels they won, and, within one call, the later of two
    points at one depth wins."""
    from interaction_tensor.geometry.sampling import sample_mesh
    from interaction_tensor.outputs.raster import Canvas, frame_points

    room = parts_mesh([box_part("floor", (0, 0, -0.01), (3.0, 3.0, 0.02)),
                       box_part("table", (0.3, 0.2, 0.72), (1.0, 0.6, 0.04)),
                       box_part("wall", (0, 1.5, 1.0), (3.0, 0.05, 2.0))])
    pts, nrm = sample_mesh(room, 60_000, 0)
    rng = np.random.default_rng(1)
    colours = (rng.random((len(pts), 3)) * 255).astype(np.uint8)
    cam = frame_points(pts[pts[:, 0] > 0], -60, 35, 320, 240)     # part of it off the picture
    canvases = []
    for reference in (True, False):
        c = Canvas(cam)
        c.points(np.vstack([pts, pts[::3]]), np.vstack([colours, colours[::3] // 2]),
                 np.vstack([nrm, -nrm[::3]]), size=0.015, reference=reference)
        c.points(pts[::7], (90, 90, 250), nrm[::7], size=0.015, reference=reference)
        c.points(pts[::5] + 0.003, (10, 20, 30), size=0.015, lit=False, reference=reference)
        c.points(pts[::40], (200, 0, 0), radius_px=2, lit=False, reference=reference)
        canvases.append(c)
    ref, fast = canvases
    assert np.isfinite(ref.depth).sum() > 1000
    for name in ("depth", "albedo", "normal", "lit"):
        np.testing.assert_array_equal(getattr(ref, name), getattr(fast, name), err_msg=name)
    np.testing.assert_array_equal(np.asarray(ref.image()), np.asarray(fast.image()))


def test_splats_refuse_colours_or_normals_that_do_not_match_the_points():
    """The kernels read colours and normals by point index, so a mismatch is refused
    before any is read."""
    from interaction_tensor.outputs.raster import Canvas, frame_points

    pts = np.random.default_rng(0).random((500, 3))
    canvas = Canvas(frame_points(pts, -60, 35, 80, 60))
    with pytest.raises(ValueError, match="499 colours for 500 points"):
        canvas.points(pts, np.zeros((499, 3), np.uint8))
    with pytest.raises(ValueError, match="normals of shape"):
        canvas.points(pts, (255, 0, 0), np.zeros((20, 3)))
    canvas.points(pts, (255, 0, 0), np.tile([0.0, 0.0, 1.0], (500, 1)))
    assert np.isfinite(canvas.depth).any()


def test_a_close_up_looks_in_under_a_shelf():
    """A prediction under a shelf (a board 9 cm above it) is out of sight from the
    close-ups' usual elevation; the view is then taken from lower down, where the camera
    sees it past the board's edge (frame and cut of a 15 cm object, as the picture's)."""
    from interaction_tensor.outputs.render import _best_view

    g = np.linspace(-1.5, 1.5, 301)
    floor = np.column_stack([a.ravel() for a in np.meshgrid(g, g)] + [np.zeros(g.size ** 2)])
    b = np.linspace(-0.5, 0.5, 101)
    board = np.column_stack([a.ravel() for a in np.meshgrid(b, b)] + [np.full(b.size ** 2, 0.12)])
    scene = np.vstack([floor, board])
    target = np.array([[0.0, 0.0, 0.03]])
    frame = np.vstack([target - 0.15, target + 0.15])
    az = (-60, -120, -30, -150, 30, 60, 120, 150)
    for elevations, expected in (((35,), 35), ((35, 12), 12)):
        cam = _best_view(scene, 0.02, frame, target, az, elevations, 0.125, 0.03)
        d = cam.eye - cam.target
        assert np.degrees(np.arctan2(d[2], np.hypot(d[0], d[1]))) == pytest.approx(expected,
                                                                                   abs=0.5)
    # from above, the board hides it
    from interaction_tensor.outputs.raster import Canvas, frame_points

    canvas = Canvas(frame_points(frame, -60, 35, 160, 120, near_cut=0.125), supersample=1)
    canvas.points(scene, (0, 0, 0), size=0.02, lit=False)
    assert not canvas.visible(target, 0.03).any()
