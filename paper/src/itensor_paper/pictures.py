"""Close-up pictures of judged poses: what a person checks a number against.

One panel per pose: the scene cut to a box around the posed query object, seen from the side
that shows most of the object; when no side shows half of it, everything more than ``cut``
(5 cm) nearer to the camera than the object is clipped away (a cabinet front or a wall), the
object drawn green when the judge found it valid and red when not, with its rank, score and
the judge's first reason. Drawn with the project's software renderer (:mod:`~interaction_tensor.outputs.raster`):
no display or OpenGL needed.
"""

from __future__ import annotations

from pathlib import Path

import numpy as np

from interaction_tensor.geometry.files import atomic_path
from interaction_tensor.geometry.sampling import (
    estimate_normals,
    mesh_area,
    sample_mesh,
)
from interaction_tensor.outputs.raster import Canvas, frame_points
from interaction_tensor.outputs.render import _font

VALID = (40, 170, 70)
INVALID = (215, 50, 40)
SCENE = (150, 150, 160)
PANEL = (360, 300)
#: Height (px) of a sheet's title, above its first row of panels.
TITLE = 30
#: Height (px) of the caption under each panel, and panels per row of a sheet.
CAPTION = 34
PER_ROW = 5


def panel_origin(i: int, count: int) -> tuple:
    """(x, y) of the top left of panel ``i`` of a :func:`sheet` of ``count`` panels."""
    cols = min(PER_ROW, count)
    return (i % cols) * PANEL[0], TITLE + (i // cols) * (PANEL[1] + CAPTION)


def _samples(geometry, spacing: float, seed: int = 0, limit: int = 2_500_000):
    """Area samples of a mesh about ``spacing`` apart (at most ``limit``) and their normals."""

    if not geometry.is_mesh:
        pts = np.asarray(geometry.vertices, float)
        return pts, (geometry.normals if geometry.normals is not None else estimate_normals(pts))
    n = int(np.clip(mesh_area(geometry) / spacing ** 2, 500, limit))
    return sample_mesh(geometry, n, seed)


def closeup(scene_points, scene_normals, query_points, query_normals, pose, colour,
            margin: float | None = None, size=PANEL, azimuths=(210, 300, 30, 120),
            elevation: float = 22.0, spacing: float = 0.01, cut: float = 0.05,
            touch: float = 0.03, see_through: bool = True,
            to_floor: bool = False) -> np.ndarray:
    """(H, W, 3) uint8: the posed query object and the scene within ``margin`` (m; default
    the object's size, at least 0.3 m, and 0.4 m above it: a tap over a mug) of it, from
    the side that sees most of it. With ``see_through``, the scene points that would still
    hide it (a cabinet door, a panel more than ``touch`` m in front of it) are left out;
    without, the scene hides what it hides (a body sunk into a floor shows no legs), as a
    person looking at the place would see it. With ``to_floor``, the box goes down to the
    lowest scene point under it, so that the floor shows how high the object is."""

    rot, t = pose[:3, :3], pose[:3, 3]
    q = query_points @ rot.T + t
    qn = query_normals @ rot.T
    if margin is None:
        margin = max(0.3, float(np.ptp(q, axis=0).max()))
    lo, hi = q.min(axis=0) - margin, q.max(axis=0) + margin
    hi[2] = max(hi[2], q[:, 2].max() + 0.4)
    if to_floor:
        lo[2] = min(lo[2], floor_under(scene_points, lo, hi))
    keep = np.all((scene_points >= lo) & (scene_points <= hi), axis=1)
    sp, sn = scene_points[keep], scene_normals[keep]
    frame = np.vstack([q, [lo, hi]])

    sub = q[:: max(1, len(q) // 400)]

    def camera(az, w, h, cut_away):
        cam = frame_points(frame, az, elevation, w, h)
        if cut_away:
            cam.near = max(cam.near, float(cam.project(q)[2].min()) - cut)
        return cam

    def best_view(cut_away):            # the view that sees most of the object
        seen = []
        for az in azimuths:
            cv = Canvas(camera(az, 120, 100, cut_away), supersample=1)
            cv.points(sp, (0, 0, 0), size=spacing, lit=False)
            seen.append(int(cv.visible(sub, 0.02).sum()))
        i = int(np.argmax(seen))
        return azimuths[i], seen[i] / len(sub)

    # the whole scene when some view shows at least half of the object, else the cut-away
    best_az, frac = best_view(False)
    cut_away = see_through and frac < 0.5
    if cut_away:
        best_az, _ = best_view(True)
    cam = camera(best_az, *size, cut_away)
    qs = max(float(np.sqrt(np.ptp(q, axis=0).prod() ** (2 / 3) / max(len(q), 1)) * 1.6), 0.004)
    front = (_in_front(cam, sp, q, qs, touch) if see_through
             else np.zeros(len(sp), bool))
    cv = Canvas(cam, supersample=2)
    cv.points(sp[~front], SCENE, sn[~front], size=spacing * 1.6)
    cv.points(q, colour, qn, size=qs)
    return cv.image()


def floor_under(scene_points, lo, hi) -> float:
    """The lowest scene point over the plan of the box ``lo``-``hi`` (its bottom without
    any)."""
    over = np.all((scene_points[:, :2] >= lo[:2]) & (scene_points[:, :2] <= hi[:2]), axis=1)
    return float(scene_points[over, 2].min()) if over.any() else float(lo[2])


def _in_front(cam, scene_points, q, q_size: float, touch: float, halo_px: int = 4) -> np.ndarray:
    """(N,) bool: the scene points that would hide the posed object ``q`` from ``cam``: over
    its silhouette (widened by ``halo_px`` pixels) and more than ``touch`` m nearer than it
    there. What touches the object (a rail through a hook, a seat under a person) lies
    within ``touch`` and stays."""
    from scipy.ndimage import minimum_filter


    obj = Canvas(cam, supersample=1)
    obj.points(q, (0, 0, 0), size=q_size, lit=False)
    depth = minimum_filter(obj.depth.reshape(obj.h, obj.w), size=2 * halo_px + 1,
                           mode="constant", cval=np.inf)
    px, py, z = cam.project(scene_points)
    ix, iy = np.rint(px).astype(np.int64), np.rint(py).astype(np.int64)
    inside = (ix >= 0) & (ix < obj.w) & (iy >= 0) & (iy < obj.h)
    out = np.zeros(len(z), bool)
    d = depth[iy[inside], ix[inside]]             # inf off the silhouette
    hit = np.isfinite(d)
    out[np.flatnonzero(inside)[hit]] = z[inside][hit] < d[hit] - touch
    return out


def sheet(path, scene_geometry, query_geometry, poses, valid, captions, title: str,
          scene_spacing: float = 0.01) -> Path:
    """One PNG with a close-up per pose (up to 5 per row) under a title."""
    from PIL import Image, ImageDraw


    sp, sn = _samples(scene_geometry, scene_spacing)
    qp, qn = _samples(query_geometry, 0.004)
    panels = [closeup(sp, sn, qp, qn, np.asarray(p, float), VALID if v else INVALID,
                      spacing=scene_spacing) for p, v in zip(poses, valid)]
    if not panels:
        panels = [np.full((PANEL[1], PANEL[0], 3), 255, np.uint8)]
        captions = ["no prediction"]
    cols = min(PER_ROW, len(panels))
    rows = (len(panels) + cols - 1) // cols
    w, h = PANEL
    img = Image.new("RGB", (cols * w, TITLE + rows * (h + CAPTION)), (255, 255, 255))
    draw = ImageDraw.Draw(img)
    draw.text((8, 7), title, fill=(20, 20, 20), font=_font(16))
    for i, (panel, cap) in enumerate(zip(panels, captions)):
        x, y = panel_origin(i, len(panels))
        img.paste(Image.fromarray(panel), (x, y))
        draw.rectangle([x, y, x + w - 1, y + h - 1], outline=(210, 210, 210))
        for k, line in enumerate(str(cap).split("\n")[:2]):
            draw.text((x + 6, y + h + 2 + 15 * k), line[:52], fill=(20, 20, 20), font=_font(12))
    path = Path(path)
    path.parent.mkdir(parents=True, exist_ok=True)
    with atomic_path(path) as tmp:
        img.save(tmp, format="PNG", optimize=True)
    return path


def run_sheet(path, scene_geometry, query_geometry, rows: list, example: str, scene: str,
              method: str = "iT-weighted") -> Path:
    """The picture of one (example, scene) run: its judged top poses (``rows`` of the
    evaluation's judgements, each with ``_pose``, ``rank``, ``score``, ``accepted``, ``valid``
    and ``reasons``)."""
    return sheet(path, scene_geometry, query_geometry, [r["_pose"] for r in rows],
                 [r["valid"] for r in rows],
                 [f"#{r['rank']} score {r['score']:.3f} "
                  f"{'accepted' if r['accepted'] else 'rejected'}\n"
                  + ("valid" if r["valid"] else "invalid: " + r["reasons"]) for r in rows],
                 f"{example} in {scene}: {method} top {len(rows)} "
                 "(green: judged valid, red: invalid)")


