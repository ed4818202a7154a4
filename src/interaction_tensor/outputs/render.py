"""``render.png`` for a detection directory and a figure-2 style picture of a descriptor.

Both are drawn by :mod:`.raster` (software z-buffer, no OpenGL) and laid out with Pillow.
"""

from __future__ import annotations

import json
import time
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from interaction_tensor.descriptor.tensor import InteractionTensor
from interaction_tensor.errors import InputError
from interaction_tensor.geometry.core import Geometry
from interaction_tensor.geometry.files import atomic_path, output_path
from interaction_tensor.geometry.load import load_geometry
from interaction_tensor.geometry.readers import read_ply
from interaction_tensor.geometry.sampling import (
    estimate_normals,
    mean_spacing,
    mesh_area,
    sample_mesh,
)
from interaction_tensor.outputs.export import colormap
from interaction_tensor.outputs.raster import Canvas, frame_points

OBJECT_COLOR = (230, 60, 40)
#: The outline of each predicted place (the box round its accepted test points).
PLACE_COLOR = (15, 15, 15)
#: A box's 8 corners (True: the high end on that axis) and its 12 edges (corners one axis
#: apart).
_CORNERS = np.array([[x, y, z] for x in (0, 1) for y in (0, 1) for z in (0, 1)], bool)
_BOX_EDGES = np.array([(i, j) for i in range(8) for j in range(i + 1, 8)
                       if (_CORNERS[i] != _CORNERS[j]).sum() == 1])
PANEL = (640, 480)
#: A posed object counts as in sight in a panel when this share of its samples is.
IN_SIGHT = 0.01


# --------------------------------------------------------------------------- reading
def read_ply_vertices(path) -> dict:
    """Vertex properties of a PLY file as ``name -> (N,) array`` (the library's PLY reader)."""

    path = Path(path)
    if not path.is_file():
        raise InputError(path, "not found")
    return read_ply(path)["vertex"]


@dataclass
class Outdir:
    """What a detection directory holds, loaded for drawing.

    points (N, 3), score (N,), threshold, predictions (list of dicts, rank order),
    objects: list of Geometry or None per prediction (the posed query objects),
    doc: predictions.json as a dict.
    """

    path: Path
    doc: dict
    points: np.ndarray
    score: np.ndarray
    threshold: float
    predictions: list
    objects: list

    @property
    def title(self) -> str:
        scene = Path(str(self.doc.get("scene", "scene"))).name
        n = len(self.predictions)
        best = f", best score {self.predictions[0]['score']:.2f}" if n else ", none accepted"
        places = self.doc.get("stats", {}).get("places")
        found = f" of {places} places" if places is not None else ""
        return (f"{self.doc.get('affordance', 'interaction')} in {scene}: {n} "
                f"predictions{found}{best}")

    def place_boxes(self, lift: float = 0.0) -> tuple[np.ndarray, np.ndarray]:
        """The 12 edges of the box round the place of each prediction (``predictions.json``'s
        places), its top raised by ``lift`` m (above the surface drawn), as (E, 3) starts and
        ends; none for a result without places."""
        places = {p["index"]: p for p in self.doc.get("places", [])}
        starts, ends = [], []
        for pred in self.predictions:
            place = places.get(pred.get("place", -1))
            if place is None:
                continue
            lo, hi = np.asarray(place["lo"], float), np.asarray(place["hi"], float)
            hi[2] += lift
            corner = np.where(_CORNERS, hi, lo)
            starts.append(corner[_BOX_EDGES[:, 0]])
            ends.append(corner[_BOX_EDGES[:, 1]])
        if not starts:
            return np.zeros((0, 3)), np.zeros((0, 3))
        return np.vstack(starts), np.vstack(ends)


def load_outdir(outdir, top_k: int | None = None) -> Outdir:
    """Read ``predictions.json``, ``heatmap.ply`` and ``top/`` of a detection directory."""

    outdir = Path(outdir)
    if not outdir.is_dir():
        raise InputError(outdir, "not a directory (expected the output of 'itensor detect')")
    pj = outdir / "predictions.json"
    if not pj.is_file():
        raise InputError(outdir, "has no predictions.json (run 'itensor detect -o' into it)")
    try:
        doc = json.loads(pj.read_text())
        preds = list(doc["predictions"])
    except (ValueError, KeyError, TypeError) as exc:
        raise InputError(pj, f"not a predictions file ({exc})") from None
    props = read_ply_vertices(outdir / "heatmap.ply")
    try:
        points = np.column_stack([props["x"], props["y"], props["z"]]).astype(float)
    except KeyError:
        raise InputError(outdir / "heatmap.ply", "has no x, y, z vertex properties") from None
    if len(points) == 0 or not np.isfinite(points).all():
        raise InputError(outdir / "heatmap.ply", "is empty or has NaN coordinates")
    score = next((np.asarray(props[k], float) for k in ("quality", "scalar_score", "score")
                  if k in props), np.zeros(len(points)))
    threshold = float(doc.get("parameters", {}).get("threshold_used")
                      or doc.get("stats", {}).get("threshold") or 0.0)
    if top_k is not None:
        preds = preds[:top_k]
    objects = []
    for rank in range(1, len(preds) + 1):
        f = outdir / "top" / f"top_{rank:02d}.ply"
        objects.append(load_geometry(f) if f.is_file() else None)
    return Outdir(outdir, doc, points, score, threshold if threshold < 1 else 0.0, preds,
                  objects)


# --------------------------------------------------------------------------- helpers
def _surface_samples(geometry, spacing: float, seed: int = 0):
    """Points (N, 3) and normals (N, 3) covering a mesh about every ``spacing`` m (at most
    150k), or a cloud's own points with PCA normals."""

    if geometry.is_mesh:
        n = int(np.clip(mesh_area(geometry) / spacing ** 2, 500, 150_000))
        return sample_mesh(geometry, n, seed)
    pts = np.asarray(geometry.vertices, float)
    nrm = geometry.normals if geometry.normals is not None else estimate_normals(pts, k=10)
    return pts, nrm


def _spacing(points: np.ndarray) -> float:

    return max(mean_spacing(points, sample=5000), 1e-4)


def _font(size: int):
    from PIL import ImageFont

    try:
        return ImageFont.load_default(size=size)
    except TypeError:  # Pillow < 10.1: fixed-size bitmap font
        return ImageFont.load_default()


def _colorbar(height: int, vmin: float, vmax: float, label: str, grey_label: str | None):
    """A vertical colour bar (Pillow image) with ticks, using the heat-map ramp."""
    from PIL import Image, ImageDraw

    bar_h = int(height * 0.6)
    img = Image.new("RGB", (135, height), (255, 255, 255))
    draw = ImageDraw.Draw(img)
    top = (height - bar_h) // 2
    t = np.linspace(1, 0, bar_h)
    vals = vmin + t * (vmax - vmin)
    cols = colormap(np.maximum(vals, 1e-9), vmin, vmax)
    strip = np.repeat(cols[:, None, :], 22, axis=1)
    img.paste(Image.fromarray(strip), (14, top))
    draw.rectangle([13, top - 1, 36, top + bar_h], outline=(60, 60, 60))
    font = _font(13)
    for v in np.linspace(vmin, vmax, 5):
        y = top + int(round((vmax - v) / max(vmax - vmin, 1e-12) * (bar_h - 1)))
        draw.line([36, y, 41, y], fill=(60, 60, 60))
        draw.text((44, y - 7), f"{v:.2f}", fill=(30, 30, 30), font=font)
    draw.text((10, top - 26), label, fill=(30, 30, 30), font=_font(15))
    if grey_label:
        y = top + bar_h + 14
        draw.rectangle([14, y, 36, y + 14], fill=(170, 170, 170), outline=(60, 60, 60))
        draw.text((44, y), grey_label, fill=(30, 30, 30), font=font)
    return img


def _compose(panels, captions, title: str, colorbar, labels=None):
    """Lay panels (H, W, 3 uint8) out in a grid with captions, a title and a colour bar."""
    from PIL import Image, ImageDraw

    n = len(panels)
    cols = 1 if n == 1 else 2
    rows = (n + cols - 1) // cols
    ph, pw = panels[0].shape[:2]
    title_h, gap = 34, 6
    width = cols * pw + (cols - 1) * gap + colorbar.width
    height = title_h + rows * ph + (rows - 1) * gap
    img = Image.new("RGB", (width, height), (255, 255, 255))
    draw = ImageDraw.Draw(img)
    draw.text((10, 8), title, fill=(20, 20, 20), font=_font(18))
    font, small = _font(14), _font(13)
    for i, (panel, caption) in enumerate(zip(panels, captions)):
        x0 = (i % cols) * (pw + gap)
        y0 = title_h + (i // cols) * (ph + gap)
        img.paste(Image.fromarray(panel), (x0, y0))
        draw.rectangle([x0, y0, x0 + pw - 1, y0 + ph - 1], outline=(200, 200, 200))
        box = draw.textbbox((x0 + 8, y0 + 6), caption, font=font)
        draw.rectangle([box[0] - 4, box[1] - 3, box[2] + 4, box[3] + 3], fill=(255, 255, 255))
        draw.text((x0 + 8, y0 + 6), caption, fill=(20, 20, 20), font=font)
        for text, (x, y) in (labels[i] if labels else []):
            if 0 <= x < pw - 20 and 12 <= y < ph:
                box = draw.textbbox((x0 + x, y0 + y), text, font=small, anchor="mb")
                draw.rectangle([box[0] - 2, box[1] - 1, box[2] + 2, box[3] + 1],
                               fill=(255, 255, 255), outline=OBJECT_COLOR)
                draw.text((x0 + x, y0 + y), text, fill=(20, 20, 20), font=small, anchor="mb")
    cb = colorbar.resize((colorbar.width, height)) if colorbar.height != height else colorbar
    img.paste(colorbar if colorbar.height == height else cb, (width - colorbar.width, 0))
    return img


def _save_png(img, out_png) -> Path:
    out_png = Path(out_png)
    with atomic_path(out_png) as tmp:
        img.save(tmp, format="PNG", compress_level=6)   # "optimize": 4x the time, 1.5 % smaller
    return out_png


def _clusters(positions: np.ndarray, radius: float, limit: int) -> list[list[int]]:
    """Greedy leader clustering in rank order: lists of prediction indices."""
    groups: list[list[int]] = []
    leaders: list[np.ndarray] = []
    for i, p in enumerate(positions):
        for g, lead in zip(groups, leaders):
            if np.linalg.norm(p - lead) <= radius:
                g.append(i)
                break
        else:
            groups.append([i])
            leaders.append(p)
    return groups[:limit]


def _best_view(scene_pts, scene_size, frame, targets, azimuths, elevations, near_cut, tol):
    """The view among ``elevations`` x ``azimuths`` from which most ``targets`` are visible
    (low-res depth test of the scene), ties to the first (elevations before azimuths);
    returns the Camera framed at panel size."""
    best, best_view = -1, None
    for el, az in ((el, az) for el in elevations for az in azimuths):
        cam = frame_points(frame, az, el, 160, 120, near_cut=near_cut)
        canvas = Canvas(cam, supersample=1)
        canvas.points(scene_pts, (0, 0, 0), size=scene_size, lit=False)
        seen = int(canvas.visible(targets, tol).sum())
        if seen > best:
            best, best_view = seen, (az, el)
        if best == len(targets):            # every one in sight: no view does better
            break
    return frame_points(frame, *best_view, *PANEL, near_cut=near_cut)


# --------------------------------------------------------------------------- render.png
def render_outdir(outdir, out_png=None, top_k: int | None = None, max_closeups: int = 3,
                  supersample: int = 2, verbose: bool = False,
                  normals: np.ndarray | None = None, spacing: float | None = None) -> Path:
    """Draw a detection directory into ``render.png`` (or ``out_png``) and return its path.

    Panels: an overview of the whole scene from above (points higher than the predictions'
    surroundings are hidden so ceilings and wall cabinets do not cover them), then up to
    ``max_closeups`` close-ups, one per group of nearby predictions, each from the azimuth
    (and, where the usual elevation does not see them all, a lower one: under a shelf) that
    sees most of them, cutting away what stands between the camera and the group. The
    scene is coloured by the heat map (grey: not accepted) with a colour bar; the query
    object is drawn at each of the ``top_k`` predictions and labelled with its rank, and
    the place it stands for is outlined (the box round the place's accepted test points);
    one out of sight in a panel is named in its caption instead.
    ``normals``: the heat map's points' normals (the scene's, in ``heatmap.ply``'s order),
    which shade them, and ``spacing`` (m), theirs: estimated from the points when not given
    (:meth:`Detection.save` gives the scene's).
    """
    t0 = time.perf_counter()
    out_png = None if out_png is None else output_path(out_png, "picture (PNG)")
    od = load_outdir(outdir, top_k)
    out_png = out_png or od.path / "render.png"
    pts, score = od.points, od.score
    colors = colormap(score, vmin=od.threshold, vmax=1.0)

    spacing = _spacing(pts) if spacing is None else max(float(spacing), 1e-4)
    size = 2.2 * spacing
    positions = np.array([p["position"] for p in od.predictions], float).reshape(-1, 3)
    objs = [o for o in od.objects if o is not None]
    diag = max((float(np.linalg.norm(np.ptp(o.vertices, axis=0))) for o in objs),
               default=10 * spacing)
    obj_samples = []
    for rank, o in enumerate(od.objects, 1):
        if o is not None:
            p, n = _surface_samples(o, max(diag / 150, 1e-4), seed=rank)
            obj_samples.append((rank, p, n, o.vertices))

    # hide what is well above the predictions (ceilings, wall cabinets)
    zmin, zmax = pts[:, 2].min(), pts[:, 2].max()
    ref = positions[:, 2].max() if len(positions) else zmin + 0.9
    zcut = max(ref + max(0.6, 2.5 * diag), zmin + 0.5)
    low = pts[:, 2] <= zcut
    if low.sum() < 100:
        low[:] = True
    cut_note = f", z > {zcut:.2f} m hidden" if zcut < zmax - 0.02 else ""
    if normals is not None and np.shape(normals) == pts.shape:
        normals = np.asarray(normals, float)
    else:
        # PCA normals of the drawn points only (the costly step on large scenes)
        normals = np.zeros_like(pts)
        normals[low] = estimate_normals(pts[low], k=10)
    # the points drawn, their colours and normals, taken out once for every panel
    shown, shown_colors, shown_normals = pts[low], colors[low], normals[low]
    rng = np.random.default_rng(0)
    frame = shown[rng.choice(len(shown), min(len(shown), 4000), replace=False)]
    # coarse copy of the scene for the visibility tests
    coarse = shown[rng.choice(len(shown), min(len(shown), 60_000), replace=False)]
    coarse_size = 1.7 * spacing * np.sqrt(len(shown) / max(len(coarse), 1))

    views = []  # (camera, caption, ranks shown)
    azimuths = (-60, -120, -30, -150, 30, 60, 120, 150)
    if len(positions):
        cam = _best_view(coarse, coarse_size, frame, positions, azimuths, (50,), None, 0.1)
    else:
        cam = frame_points(frame, -60, 50, *PANEL)
    views.append((cam, f"overview{cut_note}", list(range(1, len(positions) + 1))))
    radius = max(0.6, 3 * diag)
    for group in _clusters(positions, radius, max_closeups):
        members = [obj_samples[j][3] for j in range(len(obj_samples))
                   if obj_samples[j][0] - 1 in group]
        box = np.vstack(members + [positions[group]]) if members else positions[group]
        lo, hi = box.min(axis=0) - diag, box.max(axis=0) + diag
        nearby = shown[np.all((shown >= lo - [0, 0, 10]) & (shown <= hi), axis=1)]
        fr = np.vstack([box, lo, hi])
        cam = _best_view(nearby if len(nearby) else coarse, size, fr, positions[group],
                         azimuths, (35, 12), 0.5 * diag + 0.05, max(0.03, diag / 4))
        ranks = [i + 1 for i in group]
        views.append((cam, "close-up: " + ", ".join(f"#{r}" for r in ranks), ranks))

    box_a, box_b = od.place_boxes(lift=0.5 * spacing)
    panels, captions, labels = [], [], []
    for cam, caption, ranks in views:
        canvas = Canvas(cam, supersample)
        canvas.points(shown, shown_colors, shown_normals, size=size)
        canvas.lines(box_a, box_b, PLACE_COLOR, width_px=supersample)
        for rank, p, n, verts in obj_samples:
            canvas.points(p, OBJECT_COLOR, n, size=1.7 * diag / 150)
        panels.append(canvas.image())
        lab, unseen = [], []
        for rank, p, n, verts in obj_samples:
            if rank not in ranks:
                continue
            # a label marks an object in sight; one hidden (under a shelf, behind a
            # cabinet) is named in the caption instead of labelled over what hides it
            if canvas.visible(p, max(0.005, diag / 30)).mean() < IN_SIGHT:
                unseen.append(f"#{rank}")
                continue
            topp = verts.mean(axis=0)
            topp[2] = verts[:, 2].max() + 0.01
            x, y, z = canvas.project(topp[None])
            if z[0] > cam.near:
                lab.append((f"#{rank}", (float(x[0]), float(y[0]) - 4)))
        captions.append(caption + (f"; {', '.join(unseen)} out of sight" if unseen else ""))
        labels.append(lab)
    bar = _colorbar(PANEL[1], od.threshold, 1.0, "score", "not accepted")
    img = _compose(panels, captions, od.title, bar, labels)
    path = _save_png(img, out_png)
    if verbose:
        print(f"rendered {len(panels)} views in {time.perf_counter() - t0:.1f} s -> {path}")
    return path


# --------------------------------------------------------------------------- figure 2
def render_tensor(descriptor, out_png, supersample: int = 2) -> Path:
    """Draw a descriptor like the paper's figure 2 and return the PNG path.

    Left: the example (query object in blue, scene-object samples in tan) with the weighted
    keypoints. Right: the tensor from the side, objects as faint dots so that the bisector
    surface points (coloured by weight) and the provenance vectors of the keypoints (from
    each keypoint to the scene-object, coloured by weight) show through.
    ``descriptor``: an InteractionTensor or the path of its ``.npz``.
    """

    out_png = output_path(out_png, "picture (PNG)")
    tensor = descriptor if isinstance(descriptor, InteractionTensor) \
        else InteractionTensor.load(descriptor)
    centre = np.asarray(tensor.query_centroid, float)
    d_o = float(tensor.radius)
    q = Geometry(np.asarray(tensor.query_vertices, float),
                 tensor.query_faces if tensor.query_is_mesh else None)
    qp, qn = _surface_samples(q, max(d_o / 200, 1e-4))
    sp = np.asarray(tensor.scene_points, float)
    sp = sp[np.linalg.norm(sp - centre, axis=1) <= 1.3 * d_o]
    sn = estimate_normals(sp, k=10) if len(sp) >= 10 else np.tile([0, 0, 1.0], (len(sp), 1))
    bis, w = np.asarray(tensor.bisector_points, float), np.asarray(tensor.weights, float)
    kp = tensor.weighted
    wcol = colormap(np.maximum(w, 1e-9), 0, 1)
    kcol = colormap(np.maximum(kp.weights, 1e-9), 0, 1)
    frame = np.vstack([qp, bis, kp.points + kp.provenance])

    panels = []
    cam = frame_points(np.vstack([frame, sp]) if len(sp) else frame, -60, 30, *PANEL)
    canvas = Canvas(cam, supersample)
    canvas.points(qp, (120, 150, 210), qn, size=1.7 * d_o / 200)
    canvas.points(sp, (205, 185, 150), sn, radius_px=2)
    canvas.points(kp.points, kcol, radius_px=2, lit=False)
    panels.append(canvas.image())

    cam = frame_points(frame, -90, 12, *PANEL)
    canvas = Canvas(cam, supersample)
    pick = np.random.default_rng(0).choice(len(qp), min(len(qp), 4000), replace=False)
    canvas.points(qp[pick], (120, 150, 210), radius_px=0, lit=False)
    canvas.points(sp, (170, 150, 120), radius_px=1, lit=False)
    canvas.points(bis, wcol, radius_px=1, lit=False)
    order = np.argsort(kp.weights)  # heavy vectors drawn last, on top
    canvas.lines(kp.points[order], (kp.points + kp.provenance)[order], kcol[order])
    canvas.points(kp.points, kcol, radius_px=2, lit=False)
    panels.append(canvas.image())

    title = (f"Interaction tensor '{tensor.affordance}': {len(bis)} bisector points, "
             f"{len(kp.points)} keypoints with provenance vectors")
    captions = ["example: query (blue), scene-object (tan), keypoints",
                "side view: bisector points and provenance vectors"]
    bar = _colorbar(PANEL[1], 0.0, 1.0, "weight", None)
    return _save_png(_compose(panels, captions, title, bar), out_png)
