"""Many scenes x many descriptors, on Dask: one laptop or the cluster you already have.

One task per scene: a worker loads and indexes the scene once and runs every descriptor on it
in one pass (:func:`~interaction_tensor.detection.search.detect_many`, one pass per descriptor spacing).
Each (scene, descriptor) result is a folder ``OUT/<scene>/<descriptor>/`` built aside and
swapped in, so a folder holding ``predictions.json`` is always complete: a crashed or killed
batch loses no finished result, and running the same batch again skips what is done.
``OUT/summary.csv``, ``summary.json`` and ``index.html`` (every render linked) describe the
whole batch.

The workers write the result folders themselves: with a remote cluster (``scheduler``),
``OUT``, the scenes and the descriptors must be on a file system every worker sees, under
the same paths.
"""

from __future__ import annotations

import csv
import glob
import hashlib
import html
import json
import os
import time
from dataclasses import dataclass
from pathlib import Path

from interaction_tensor.api import CLEANING_OPTIONS, load_scene, load_tensor
from interaction_tensor.descriptor.tensor import InteractionTensor
from interaction_tensor.detection.search import detect_many
from interaction_tensor.errors import InputError, ItensorError, SettingsError
from interaction_tensor.geometry.files import atomic_path, output_path, write_json
from interaction_tensor.settings import DetectSettings

#: columns of summary.csv
COLUMNS = ["scene", "descriptor", "affordance", "status", "predictions", "best_score",
           "pairs", "pairs_scored", "pairs_accepted", "seconds", "output", "message"]
MARKER = "predictions.json"


# --------------------------------------------------------------------------- inputs
def expand_paths(items, what: str, suffixes=None) -> list[Path]:
    """Paths from paths, globs and manifest files (one path per line, ``#`` comments; or a
    JSON list, or a JSON object with a ``"scenes"``/``"descriptors"``/``"paths"`` list),
    relative paths in a manifest taken from its directory. Order kept, duplicates dropped."""
    out: list[Path] = []
    for item in items:
        item = str(item)
        if any(c in item for c in "*?["):
            matches = sorted(glob.glob(item, recursive=True))
            if not matches:
                raise InputError(item, f"no {what} match this pattern")
            out += [Path(m) for m in matches]
            continue
        path = Path(item)
        if not path.exists():
            raise InputError(path, f"no such {what[:-1] if what.endswith('s') else what} file")
        if path.is_file() and (suffixes is None or path.suffix.lower() not in suffixes) \
                and path.suffix.lower() in (".txt", ".json", ".list", ""):
            out += _manifest(path, what)
        else:
            out.append(path)
    seen, unique = set(), []
    for p in out:
        key = os.path.abspath(p)
        if key not in seen:
            seen.add(key)
            unique.append(p)
    if not unique:
        raise InputError(None, f"no {what} given")
    return unique


def _manifest(path: Path, what: str) -> list[Path]:
    text = path.read_text(errors="replace")
    if path.suffix.lower() == ".json":
        try:
            doc = json.loads(text)
        except ValueError as exc:
            raise InputError(path, f"manifest is not JSON ({exc})") from None
        if isinstance(doc, dict):
            doc = next((doc[k] for k in (what, "paths") if isinstance(doc.get(k), list)), None)
        if not isinstance(doc, list) or not all(isinstance(v, str) for v in doc):
            raise InputError(path, f"manifest must be a list of paths (or {{\"{what}\": [...]}})")
        entries = doc
    else:
        entries = [ln.strip() for ln in text.splitlines()
                   if ln.strip() and not ln.lstrip().startswith("#")]
    paths = [p if p.is_absolute() else path.parent / p for p in map(Path, entries)]
    missing = [str(p) for p in paths if not p.exists()]
    if missing:
        raise InputError(path, f"manifest lists {len(missing)} missing file(s), e.g. "
                               f"{missing[0]}")
    return paths


def unique_names(paths: list[Path]) -> list[str]:
    """Folder names: each file's stem, with a short hash of its path where stems repeat."""
    stems = [p.stem if p.is_file() else p.name for p in paths]
    counts = {s: stems.count(s) for s in stems}
    return [s if counts[s] == 1 else
            f"{s}-{hashlib.sha1(os.path.abspath(p).encode()).hexdigest()[:6]}"
            for s, p in zip(stems, paths)]


def is_done(folder: Path) -> bool:
    """A result folder is finished when its marker exists (folders are swapped in whole)."""
    return (folder / MARKER).is_file()


# --------------------------------------------------------------------------- one scene
def run_scene(job: dict) -> list[dict]:
    """Run every descriptor of ``job`` on one scene; write one folder per descriptor.

    Runs on a Dask worker (or in this process). ``job``: scene, scene_id, descriptors
    [(name, path)], outdir, settings (DetectSettings fields), scene_options, render,
    threads. Returns one summary row per descriptor.
    """

    if job.get("threads"):
        try:
            import numba

            numba.set_num_threads(max(1, min(int(job["threads"]), numba.config.NUMBA_NUM_THREADS)))
        except ImportError:
            pass
    scene_dir = Path(job["outdir"]) / job["scene_id"]
    rows, todo = [], []
    for name, path in job["descriptors"]:
        folder = scene_dir / name
        if is_done(folder):
            rows.append(_row_from_folder(job, name, folder, "skipped"))
        else:
            todo.append((name, path))
    if not todo:
        return rows
    settings = DetectSettings(**job["settings"])
    try:
        tensors = [(name, path, load_tensor(path)) for name, path in todo]
        groups: dict[float, list] = {}
        for item in tensors:
            spacing = settings.scene_spacing or item[2].scene_spacing
            groups.setdefault(spacing, []).append(item)
        for spacing, items in groups.items():
            t0 = time.perf_counter()
            scene = load_scene(job["scene"], spacing, seed=settings.seed,
                               pairs_per_point=(settings.sample_fraction
                                                * settings.n_orientations * len(items)),
                               **job["scene_options"])
            t_prep = time.perf_counter() - t0
            dets = detect_many(scene, [t for _, _, t in items], settings)
            for (name, path, _), det in zip(items, dets):
                det.stats["seconds"]["scene_preparation"] = round(t_prep, 4)
                folder = scene_dir / name
                det.save(folder, render=job["render"], scene_name=str(job["scene"]),
                         descriptor_name=str(path))       # built aside, swapped in whole
                rows.append(_row(job, name, det, folder,
                                 det.stats["seconds"].get("total", 0.0) + t_prep))
    except ItensorError as exc:
        done = {r["descriptor"] for r in rows}
        rows += [_failed(job, name, str(exc)) for name, _ in todo if name not in done]
    return rows


def _row(job, name, det, folder, seconds) -> dict:
    st = det.stats
    return {"scene": job["scene_id"], "descriptor": name, "affordance": det.tensor.affordance,
            "status": "done", "predictions": len(det.predictions),
            "best_score": round(det.predictions[0].score, 6) if det.predictions else None,
            "pairs": st["pairs"], "pairs_scored": st["pairs_scored"],
            "pairs_accepted": st["pairs_accepted"],
            "seconds": round(seconds, 3), "output": str(folder), "message": ""}


def _row_from_folder(job, name, folder, status) -> dict:
    try:
        doc = json.loads((folder / MARKER).read_text())
        preds = doc.get("predictions", [])
        st = doc.get("stats", {})
        return {"scene": job["scene_id"], "descriptor": name,
                "affordance": doc.get("affordance"), "status": status,
                "predictions": len(preds), "best_score": preds[0]["score"] if preds else None,
                "pairs": st.get("pairs"), "pairs_scored": st.get("pairs_scored"),
                "pairs_accepted": st.get("pairs_accepted"),
                "seconds": st.get("seconds", {}).get("total"), "output": str(folder),
                "message": "done by an earlier run"}
    except (OSError, ValueError, KeyError, TypeError, IndexError) as exc:
        return _failed(job, name, f"earlier result unreadable: {exc}")


def _failed(job, name, message) -> dict:
    return {"scene": job["scene_id"], "descriptor": name, "affordance": None,
            "status": "failed", "predictions": 0, "best_score": None, "pairs": None,
            "pairs_scored": None,
            "pairs_accepted": None, "seconds": None, "output": "", "message": message}


# --------------------------------------------------------------------------- the batch
@dataclass
class BatchResult:
    """What a batch did: one row per (scene, descriptor); ``failed`` counts failures."""

    rows: list
    outdir: Path
    seconds: float
    workers: int
    scheduler: str

    @property
    def failed(self) -> int:
        return sum(r["status"] == "failed" for r in self.rows)

    def summary(self) -> dict:
        counts = {s: sum(r["status"] == s for r in self.rows) for s in ("done", "skipped",
                                                                         "failed")}
        return {"output": str(self.outdir), "seconds": round(self.seconds, 3),
                "workers": self.workers, "scheduler": self.scheduler, **counts,
                "results": len(self.rows)}

    def __repr__(self) -> str:
        s = self.summary()
        return (f"<BatchResult {s['results']} results in {self.outdir}: {s['done']} done, "
                f"{s['skipped']} skipped, {s['failed']} failed, {self.seconds:.1f} s>")


def batch(scenes, tensors, outdir, settings: DetectSettings | None = None, *, client=None,
          scheduler: str | None = None, workers: int | None = None, render: bool = True,
          progress: bool = False, **options) -> BatchResult:
    """Detect every descriptor in every scene; one result folder per pair, plus a summary.

    Parameters
    ----------
    scenes : scene paths, globs or manifest files (see :func:`expand_paths`)
    tensors : descriptor paths, globs or manifests, or InteractionTensor objects (saved into
        ``outdir/descriptors/`` first, so that workers can load them)
    outdir : output directory (created; earlier results in it are kept and skipped)
    settings : DetectSettings (defaults as ``itensor detect``); ``options``: its fields and
        :func:`~interaction_tensor.api.load_scene` options (``scan``, ``scale``, ``up``, ...)
    client : a ``dask.distributed.Client`` to use as it is
    scheduler : address of a running Dask scheduler (``tcp://host:8786``)
    workers : local cluster size (default: the machine's cores, at most one per scene);
        0 runs in this process without Dask
    render : draw ``render.png`` per result (linked from ``index.html``)
    """
    from dataclasses import fields, replace


    t0 = time.perf_counter()
    outdir = output_path(outdir, "output directory")
    if outdir.exists() and not outdir.is_dir():
        raise InputError(outdir, "exists and is not a directory")
    names = {f.name for f in fields(DetectSettings)}
    overrides = {k: options.pop(k) for k in list(options) if k in names}
    settings = replace(settings or DetectSettings(), **overrides)
    scene_paths = expand_paths(scenes, "scenes")
    if isinstance(tensors, (str, os.PathLike, InteractionTensor)):
        tensors = [tensors]
    desc_paths = []
    for t in tensors:
        if isinstance(t, InteractionTensor):
            path = outdir / "descriptors" / f"{_safe(t.affordance)}.npz"
            desc_paths.append(t.save(path))
        else:
            desc_paths += expand_paths([t], "descriptors", suffixes=(".npz",))
    for p in desc_paths:        # refuse a bad descriptor now, not on every worker
        InteractionTensor.load(p)

    allowed = {"scan", "normals", "color", "depth", "intrinsics", "depth_scale", "depth_trunc",
               "scale", "up", *CLEANING_OPTIONS}
    unknown = sorted(set(options) - allowed)
    if unknown:
        raise SettingsError(f"unknown option{'s' if len(unknown) > 1 else ''} "
                            f"{', '.join(unknown)}")
    if workers is not None and workers < 0:
        raise SettingsError(f"workers must be 0 (this process) or more, got {workers}")
    outdir.mkdir(parents=True, exist_ok=True)
    scene_ids, desc_names = unique_names(scene_paths), unique_names(desc_paths)
    jobs = [{"scene": os.path.abspath(s), "scene_id": sid,
             "descriptors": [(n, os.path.abspath(d)) for n, d in zip(desc_names, desc_paths)],
             "outdir": os.path.abspath(outdir), "settings": settings.to_dict(),
             "scene_options": options, "render": render, "threads": None}
            for s, sid in zip(scene_paths, scene_ids)]
    rows, n_workers, where = _run(jobs, client, scheduler, workers, progress)
    order = {sid: i for i, sid in enumerate(scene_ids)}
    dorder = {n: i for i, n in enumerate(desc_names)}
    rows.sort(key=lambda r: (order.get(r["scene"], 0), dorder.get(r["descriptor"], 0)))
    result = BatchResult(rows, outdir, time.perf_counter() - t0, n_workers, where)
    write_summary(result)
    return result


def _safe(name: str) -> str:
    """A file name from a descriptor's affordance name (text from a file): letters, digits,
    ``-_.`` only, no leading dot (no hidden files, no ``..``), at most 64 characters."""
    safe = "".join(c if c.isalnum() or c in "-_." else "_" for c in name)[:64].lstrip(".")
    return safe or "descriptor"


def _run(jobs, client, scheduler, workers, progress):
    """Run the jobs: in this process (workers=0), on ``client``, on ``scheduler``, or on a
    local cluster. Returns (rows, workers, where)."""
    bar = _progress(len(jobs), progress)
    if workers == 0 and client is None and scheduler is None:
        rows = []
        for job in jobs:
            rows += _rows_of(job, lambda: run_scene(job))
            bar.update(1)
        bar.close()
        return rows, 0, "this process"
    try:
        from dask.distributed import Client, LocalCluster, as_completed
    except ImportError:
        raise SettingsError("batches on Dask need dask.distributed: pip install "
                            "'interaction-tensor[dask]' (or workers=0 / --workers 0 to run "
                            "in this process)") from None
    own, cluster = None, None
    try:
        if client is None:
            if scheduler is not None:
                try:
                    own = Client(scheduler, timeout="20s")
                except (OSError, TimeoutError) as exc:
                    raise InputError(None, f"scheduler {scheduler}: cannot connect ({exc})") \
                        from None
                where = scheduler
            else:
                cores = os.cpu_count() or 1
                n = max(1, min(workers or cores, len(jobs)))
                cluster = LocalCluster(n_workers=n, threads_per_worker=1, processes=True,
                                       dashboard_address=None)
                own = Client(cluster)
                for job in jobs:        # share the cores between the worker processes
                    job["threads"] = max(1, cores // n)
                where = "local cluster"
            client = own
        else:
            where = str(getattr(client, "scheduler", "client"))
        n_workers = len(client.scheduler_info().get("workers", {}))
        futures = {client.submit(run_scene, job, pure=False,
                                 key=f"itensor-{job['scene_id']}-{time.time_ns()}"): job
                   for job in jobs}
        rows = []
        for future in as_completed(futures):
            rows += _rows_of(futures[future], future.result)
            bar.update(1)
        return rows, n_workers, where
    finally:
        bar.close()
        if own is not None:
            own.close()
        if cluster is not None:
            cluster.close()


def _rows_of(job, get) -> list[dict]:
    """The rows of one scene's task; a task that failed outright (a worker lost too often, an
    unexpected error) gives a failed row per descriptor, so the batch goes on."""
    try:
        return get()
    except (KeyboardInterrupt, SystemExit):
        raise
    except Exception as exc:  # noqa: BLE001 - reported per row, the batch goes on
        return [_failed(job, name, f"{type(exc).__name__}: {exc}") for name, _ in
                job["descriptors"]]


def _progress(total: int, show: bool):
    from tqdm import tqdm

    return tqdm(total=total, unit="scene", desc="batch", disable=not show)


# --------------------------------------------------------------------------- summary
def write_summary(result: BatchResult) -> None:
    """``summary.csv``, ``summary.json`` and ``index.html`` in the batch's directory."""

    out = result.outdir
    with atomic_path(out / "summary.csv") as tmp:
        with open(tmp, "w", newline="") as fh:
            w = csv.DictWriter(fh, COLUMNS)
            w.writeheader()
            for r in result.rows:
                w.writerow({k: ("" if r.get(k) is None else r.get(k)) for k in COLUMNS})
    write_json(out / "summary.json", {**result.summary(), "rows": result.rows})
    with atomic_path(out / "index.html") as tmp:
        tmp.write_text(index_html(result))


def index_html(result: BatchResult) -> str:
    """A self-contained page: the summary table, each result's render and files linked."""
    out = result.outdir
    s = result.summary()
    lines = [
        "<!doctype html><html><head><meta charset='utf-8'><title>itensor batch</title>",
        "<style>body{font-family:sans-serif;margin:1.5em}table{border-collapse:collapse}"
        "td,th{border:1px solid #ccc;padding:4px 8px;text-align:left;vertical-align:top}"
        "img{width:320px}.failed{background:#fdd}</style></head><body>",
        f"<h1>itensor batch: {s['results']} results</h1>",
        f"<p>{s['done']} done, {s['skipped']} skipped (done before), {s['failed']} failed, in "
        f"{s['seconds']} s on {html.escape(str(s['scheduler']))} ({s['workers']} workers). "
        "<a href='summary.csv'>summary.csv</a></p>",
        "<table><tr><th>scene</th><th>descriptor</th><th>status</th><th>predictions</th>"
        "<th>best score</th><th>render</th><th>files</th></tr>"]
    for r in result.rows:
        rel = os.path.relpath(r["output"], out) if r["output"] else ""
        render = Path(r["output"]) / "render.png" if r["output"] else None
        img = (f"<a href='{html.escape(rel)}/render.png'><img src='{html.escape(rel)}/render.png'"
               " loading='lazy'></a>" if render is not None and render.is_file() else "")
        files = " ".join(f"<a href='{html.escape(rel)}/{f}'>{f}</a>"
                         for f in ("predictions.json", "heatmap.ply", "predictions.glb")
                         if rel and (Path(r["output"]) / f).is_file())
        best = "" if r["best_score"] is None else f"{float(r['best_score']):.3f}"
        cls = " class='failed'" if r["status"] == "failed" else ""
        status = html.escape(r["status"] + (f": {r['message']}" if r["status"] == "failed" else ""))
        lines.append(f"<tr{cls}><td>{html.escape(r['scene'])}</td>"
                     f"<td>{html.escape(r['descriptor'])}</td><td>{status}</td>"
                     f"<td>{r['predictions']}</td><td>{best}</td><td>{img}</td>"
                     f"<td>{files}</td></tr>")
    lines.append("</table></body></html>")
    return "\n".join(lines) + "\n"
