"""``index.html``: a self-contained interactive 3D page for a detection directory.

The page inlines its data (base64 typed arrays in a JSON block) and the viewer script shipped
in ``outputs/static/viewer.js`` (a small WebGL viewer with a Canvas 2D fallback), so it opens
from disk with no network access.
"""

from __future__ import annotations

import base64
import html
import json
from importlib import resources
from pathlib import Path

import numpy as np

from interaction_tensor.descriptor.tensor import InteractionTensor
from interaction_tensor.errors import InputError
from interaction_tensor.geometry.files import atomic_path, output_path
from interaction_tensor.geometry.sampling import mean_spacing
from interaction_tensor.outputs.export import colormap
from interaction_tensor.outputs.render import load_outdir

MAX_POINTS = 200_000
#: The fewest scene points the page may be asked to keep.
MIN_POINTS = 1000


def _b64(array, dtype) -> str:
    return base64.b64encode(np.ascontiguousarray(array, dtype=dtype).tobytes()).decode("ascii")


def _quantised(points: np.ndarray) -> dict:
    """(N, 3) positions as uint16 steps from the minimum corner (about 0.1 mm for 6 m)."""
    lo = points.min(axis=0)
    step = np.maximum(np.ptp(points, axis=0) / 65535.0, 1e-9)
    q = np.rint((points - lo) / step).clip(0, 65535)
    return {"origin": lo.tolist(), "step": step.tolist(), "data": _b64(q, "<u2")}


def _mesh(vertices, faces, size=None) -> dict:
    faces = np.zeros((0, 3)) if faces is None else np.asarray(faces)
    return {"vertices": _b64(vertices, "<f4"), "faces": _b64(faces.reshape(-1), "<u4"),
            "size": size}


def _find_descriptor(doc: dict, outdir: Path):
    """The descriptor a detection used, if it can still be found: the copy the result
    carries, the path as written, then relative to the output directory, then its file name
    inside it."""
    copy = doc.get("descriptor_file")
    if copy and (outdir / Path(str(copy)).name).is_file():
        return outdir / Path(str(copy)).name
    name = doc.get("descriptor")
    if not name:
        return None
    p = Path(str(name))
    for cand in (p, outdir / p, outdir / p.name):
        if cand.suffix == ".npz" and cand.is_file():
            return cand
    return None


def _example(tensor, max_bisector: int = 20_000, seed: int = 0) -> dict:
    centre = np.asarray(tensor.query_centroid, float)
    sp = np.asarray(tensor.scene_points, float)
    sp = sp[np.linalg.norm(sp - centre, axis=1) <= 1.3 * float(tensor.radius)]
    bis, w = np.asarray(tensor.bisector_points, float), np.asarray(tensor.weights, float)
    if len(bis) > max_bisector:
        keep = np.random.default_rng(seed).choice(len(bis), max_bisector, replace=False)
        bis, w = bis[keep], w[keep]
    kp = tensor.weighted
    kcol = colormap(np.maximum(kp.weights, 1e-9), 0, 1)
    vectors = np.stack([kp.points, kp.points + kp.provenance], axis=1).reshape(-1, 3)
    return {
        "query": _mesh(tensor.query_vertices,
                       tensor.query_faces if tensor.query_is_mesh else None,
                       float(tensor.radius) / 150),
        "scene_object": _b64(sp, "<f4"),
        "scene_spacing": float(tensor.scene_spacing),
        "bisector": _b64(bis, "<f4"),
        "bisector_colors": _b64(colormap(np.maximum(w, 1e-9), 0, 1), "u1"),
        "keypoints": _b64(kp.points, "<f4"),
        "keypoint_colors": _b64(kcol, "u1"),
        "vectors": _b64(vectors, "<f4"),
        "vector_colors": _b64(np.repeat(kcol, 2, axis=0), "u1"),
        "counts": {"bisector": int(len(tensor.bisector_points)), "keypoints": int(len(kp.points))},
    }


def build_data(outdir, max_points: int = MAX_POINTS, seed: int = 0) -> dict:
    """Everything the page shows, as a JSON-ready dict (see :func:`write_viewer`)."""

    od = load_outdir(outdir)
    pts, score = od.points, od.score
    n = len(pts)
    note = None
    if n > max_points:
        # keep the heat (accepted points) first, then fill with a random subset
        rng = np.random.default_rng(seed)
        hot = np.flatnonzero(score > 0)
        cold = np.flatnonzero(score <= 0)
        hot = rng.choice(hot, min(len(hot), max_points // 2), replace=False)
        cold = rng.choice(cold, min(len(cold), max_points - len(hot)), replace=False)
        keep = np.sort(np.concatenate([hot, cold]))
        note = (f"The scene was down-sampled for the browser: {len(keep):,} of {n:,} points "
                f"are shown (accepted points first). Open heatmap.ply for all of them.")
    else:
        keep = np.arange(n)
    spacing = mean_spacing(pts, sample=5000) * np.sqrt(n / max(len(keep), 1))
    colors = colormap(score[keep], vmin=od.threshold, vmax=1.0)

    tensor, desc_note = None, None
    desc = _find_descriptor(od.doc, od.path)
    if desc is not None:
        try:
            tensor = InteractionTensor.load(desc)
        except Exception as exc:  # noqa: BLE001 - the page still works without it
            desc_note = f"descriptor {desc} could not be read: {exc}"
    else:
        desc_note = f"descriptor {od.doc.get('descriptor')!r} not found"

    predictions, meshes = [], []
    places = {p["index"]: p for p in od.doc.get("places", [])}
    if tensor is not None:
        meshes.append(_mesh(tensor.query_vertices,
                            tensor.query_faces if tensor.query_is_mesh else None,
                            float(tensor.radius) / 150))
        size = float(np.linalg.norm(np.ptp(tensor.query_vertices, axis=0)))
    else:
        size = 0.1
    for rank, p in enumerate(od.predictions, 1):
        entry = {"rank": rank, "score": float(p["score"]), "position": list(p["position"]),
                 "angle": float(p.get("angle", 0.0)),
                 "orientation_index": int(p.get("orientation_index", 0))}
        place = places.get(p.get("place", -1))
        if place is not None:
            entry["place"] = {k: place[k] for k in ("index", "pairs", "lo", "hi")}
        obj = od.objects[rank - 1]
        if tensor is not None:
            entry.update(mesh=0, pose=np.asarray(p["pose"], float).tolist())
        elif obj is not None:  # no descriptor: the posed copies from top/
            meshes.append(_mesh(obj.vertices, obj.faces if obj.is_mesh else None))
            entry.update(mesh=len(meshes) - 1, pose=np.eye(4).tolist())
            size = float(np.linalg.norm(np.ptp(obj.vertices, axis=0)))
        else:
            continue
        predictions.append(entry)

    ramp = colormap(np.linspace(max(od.threshold, 1e-9), 1.0, 9), od.threshold, 1.0)
    return {
        "title": od.title,
        "scene_name": str(od.doc.get("scene")),
        "affordance": od.doc.get("affordance"),
        "threshold": od.threshold,
        "note": note,
        "descriptor_note": desc_note,
        "scene": {"positions": _quantised(pts[keep]), "colors": _b64(colors, "u1"),
                  "count": int(len(keep)), "total": int(n), "point_size": float(1.5 * spacing)},
        "meshes": meshes,
        "object_size": size,
        "predictions": predictions,
        "example": _example(tensor) if tensor is not None else None,
        "colorbar": {"vmin": od.threshold, "vmax": 1.0,
                     "stops": [f"rgb({r},{g},{b})" for r, g, b in ramp.tolist()]},
    }


_ERROR_HOOK = """(function(){var n=0;function mark(m){n++;
document.documentElement.setAttribute('data-errors',String(n));
var e=document.getElementById('errors');if(e){e.hidden=false;e.textContent+=m+'\\n';}}
window.addEventListener('error',function(e){mark('error: '+e.message);});
window.addEventListener('unhandledrejection',function(e){mark('rejection: '+e.reason);});
var ce=console.error;console.error=function(){mark(Array.prototype.join.call(arguments,' '));
return ce.apply(console,arguments);};
document.documentElement.setAttribute('data-errors','0');})();"""

_CSS = """
*{box-sizing:border-box} body{margin:0;font:14px/1.4 system-ui,sans-serif;color:#222;background:#f4f4f4}
header{padding:8px 14px;background:#fff;border-bottom:1px solid #ddd}
header h1{font-size:17px;margin:0} .note{background:#fff6d5;border:1px solid #e6c65a;padding:4px 8px;margin-top:6px;border-radius:4px}
main{display:grid;grid-template-columns:1fr 300px;gap:10px;padding:10px;height:calc(100vh - 70px);min-height:560px}
.panels{display:grid;grid-template-rows:3fr 2fr;gap:10px;min-height:0}
.panel{position:relative;background:#fff;border:1px solid #ddd;border-radius:4px;min-height:0;display:flex;flex-direction:column}
.panel h2{font-size:14px;margin:0;padding:5px 10px;border-bottom:1px solid #eee}
.panel canvas{flex:1;width:100%;min-height:0;display:block;cursor:grab}
.panel.missing canvas{display:none} .panel .missing-note{display:none;padding:10px}
.panel.missing .missing-note{display:block}
.legend{position:absolute;right:10px;top:36px;background:rgba(255,255,255,.85);padding:6px;border-radius:4px;font-size:12px}
.legend .bar{width:16px;height:140px;display:inline-block;vertical-align:top;border:1px solid #666}
.legend .ticks{display:inline-flex;flex-direction:column;justify-content:space-between;height:140px;margin-left:4px}
.legend .grey{display:inline-block;width:16px;height:10px;background:#aaa;border:1px solid #666}
aside{background:#fff;border:1px solid #ddd;border-radius:4px;overflow:auto;padding:8px}
aside h2{font-size:14px;margin:4px 0 8px} ol{list-style:none;padding:0;margin:0}
li.prediction{padding:5px 8px;border:1px solid #eee;border-radius:4px;margin-bottom:4px;cursor:pointer}
li.prediction:hover{background:#f3f0ff} li.prediction.selected{background:#ffe3fa;border-color:#e040c0}
.score{float:right;font-variant-numeric:tabular-nums} .where,.place{color:#666;font-size:12px}
.controls{font-size:12px;padding:4px 10px;color:#555} button{font-size:12px}
#errors{white-space:pre-wrap;color:#b00;font-size:12px}
"""


def write_viewer(outdir, max_points: int = MAX_POINTS, out_html=None, seed: int = 0) -> Path:
    """Write ``OUTDIR/index.html`` (or ``out_html``) and return its path.

    The page shows the scene coloured by the heat map (down-sampled to ``max_points``, with a
    note when it is), the query object posed at every top prediction, a list of predictions
    (click one to highlight it and fly to it) and, when the descriptor named in
    ``predictions.json`` can be found, the training example with the bisector points and the
    keypoints' provenance vectors coloured by weight. ``it.view`` and ``itensor view``.
    """
    if not max_points >= MIN_POINTS:
        raise InputError(None, f"max_points (--max-points) must be at least {MIN_POINTS}, "
                               f"got {max_points}")
    outdir = Path(outdir)
    out = outdir / "index.html" if out_html is None else output_path(out_html, "page (HTML)")
    data = build_data(outdir, max_points, seed)
    script = resources.files("interaction_tensor.outputs").joinpath("static/viewer.js").read_text()
    payload = json.dumps(data, separators=(",", ":")).replace("</", "<\\/")
    esc = html.escape
    cb = data["colorbar"]
    notes = "".join(f'<div class="note">{esc(n)}</div>' for n in (data["note"],) if n)
    ex = data["example"]
    ex_title = ("Training example: query, scene-object, bisector points and the provenance "
                f"vectors of {ex['counts']['keypoints']} keypoints, coloured by weight"
                if ex else "Training example")
    doc = f"""<!DOCTYPE html>
<html lang="en"><head><meta charset="utf-8">
<meta name="viewport" content="width=device-width, initial-scale=1">
<title>{esc(data['title'])}</title>
<script>{_ERROR_HOOK}</script>
<style>{_CSS}</style></head>
<body>
<header><h1>{esc(data['title'])}</h1>{notes}<pre id="errors" hidden></pre></header>
<main>
 <div class="panels">
  <section class="panel" id="scene-panel">
   <h2>Scene coloured by score, query object at the top {len(data['predictions'])} predictions</h2>
   <canvas id="scene-canvas" aria-label="3D view of the scene"></canvas>
   <div class="legend"><div>score</div><span class="bar" style="background:linear-gradient(to top,{','.join(cb['stops'])})"></span><span class="ticks"><span>{cb['vmax']:.2f}</span><span>{(cb['vmin'] + cb['vmax']) / 2:.2f}</span><span>{cb['vmin']:.2f}</span></span><div><span class="grey"></span> not accepted</div></div>
   <div class="controls">drag: orbit &middot; right-drag or shift-drag: pan &middot; wheel: zoom &middot; double-click: reset
    <label><input type="checkbox" id="show-objects" checked> objects</label> <button id="reset">overview</button></div>
  </section>
  <section class="panel" id="example-panel">
   <h2>{esc(ex_title)}</h2>
   <canvas id="example-canvas" aria-label="3D view of the training example"></canvas>
   <div class="missing-note">{esc(data['descriptor_note'] or '')}</div>
   <div class="controls"><label><input type="checkbox" id="show-query" checked> query object</label>
    <label><input type="checkbox" id="show-bisector" checked> all bisector points</label></div>
  </section>
 </div>
 <aside><h2>Predictions ({len(data['predictions'])})</h2><ol id="predictions"></ol>
  <p class="where">{esc(data['scene_name'])}: {data['scene']['total']:,} points, threshold {data['threshold']:.3f}</p></aside>
</main>
<script type="application/json" id="itensor-data">{payload}</script>
<script>{script}</script>
</body></html>
"""
    with atomic_path(out) as tmp:
        tmp.write_text(doc, encoding="utf-8")
    return out
