"""``itensor``: the command line, a thin shell over the Python API.

Each subcommand parses its arguments, calls the library, prints a short report and sets the
exit status: 0 on success, 2 on bad input (one line on stderr, no traceback), 130 when
interrupted.
"""

from __future__ import annotations

import argparse
import json
import os
import signal
import sys
import time
from pathlib import Path

from interaction_tensor import affordances
from interaction_tensor._version import __version__
from interaction_tensor.api import detect, load_tensor, train
from interaction_tensor.batch import batch
from interaction_tensor.cli.common import (  # noqa: F401
    Parser,
    _axis_or_vector,
    _fraction,
    _out_file,
    _out_path,
    _say,
    _show_progress,
    _spacing,
    _vector,
    number,
    quiet_option,
    seed_option,
)
from interaction_tensor.cli.examples import register as register_examples
from interaction_tensor.cli.viz import register as register_viz
from interaction_tensor.descriptor.tensor import InteractionTensor
from interaction_tensor.errors import InputError, ItensorError, SettingsError
from interaction_tensor.examples import demo
from interaction_tensor.geometry.files import write_mesh
from interaction_tensor.settings import (
    BACKENDS,
    CRITERIA,
    KEYPOINT_SETS,
    PLACEMENT_TESTS,
    DetectSettings,
)


def _geometry_options(p: argparse.ArgumentParser) -> None:
    p.add_argument("--scale", type=number(low=0, low_open=True), default=None,
                   help="multiply coordinates by this to get metres (0.001 for mm); default: "
                        "metres, with files larger than a scene (100 m) or, for train, an "
                        "object (10 m) refused as probably mm or cm")
    p.add_argument("--up", choices=("z", "y"), default="z", help="the files' up axis")


def detection_options(p) -> None:
    """The options of :class:`DetectSettings` (``itensor detect`` and ``itensor batch``),
    with its defaults (one place for each: the dataclass)."""
    d = DetectSettings()
    p.add_argument("--top-k", type=number(int, low=1), default=d.top_k,
                   help="predictions kept after suppression")
    p.add_argument("--sample-fraction", type=_fraction, default=d.sample_fraction,
                   help="fraction of scene points used as test points (the paper's 0.3)")
    seed_option(p)
    p.add_argument("--criterion", choices=CRITERIA, default=d.criterion,
                   help="score criterion: paper (default for meshes and clouds) or gaussian "
                        "(the authors' code; default for RGB-D frames and --scan)")
    p.add_argument("--keypoints", choices=KEYPOINT_SETS, default=d.keypoints,
                   help="keypoint set compared: weight-driven (paper) or uniform")
    p.add_argument("--threshold", type=_fraction, default=d.threshold,
                   help="acceptance threshold S_aff on the normalised score (default: the "
                        "descriptor's own)")
    p.add_argument("--spacing", type=_spacing, default=d.scene_spacing,
                   help="mesh sampling spacing in metres (default: the descriptor's)")
    p.add_argument("--orientations", type=number(int, low=1, high=360),
                   default=d.n_orientations,
                   help="orientations of the query object about +Z (the paper's 8)")
    p.add_argument("--normal-tolerance", type=number(low=0, high=180),
                   default=d.normal_tolerance_deg,
                   help="largest angle in degrees between a test normal and N_aff "
                        "(default: the descriptor's, else 15)")
    p.add_argument("--oriented-normals", action="store_true",
                   help="trust the sign of scene normals (default: compare the normal line)")
    p.add_argument("--skip-test", action="append", default=[], metavar="TEST",
                   type=_placement_test,
                   help="a placement test not to run (repeat for more; comma-separated names "
                        f"work too): {', '.join(PLACEMENT_TESTS)}")
    p.add_argument("--backend", choices=("auto",) + BACKENDS[1:], default=d.backend,
                   help="scoring backend; torch runs on a CUDA device when present "
                        "(pip install 'interaction-tensor[torch]')")
    p.add_argument("--device", default=d.device,
                   help="torch device for --backend torch (default: cuda if present, else cpu)")


def _placement_test(text: str) -> tuple:
    names = tuple(t.strip() for t in text.split(",") if t.strip())
    unknown = [t for t in names if t not in PLACEMENT_TESTS]
    if unknown or not names:
        raise argparse.ArgumentTypeError(
            f"unknown placement test {', '.join(unknown) or repr(text)}; known: "
            f"{', '.join(PLACEMENT_TESTS)}")
    return names


# --------------------------------------------------------------------------- real scenes
def real_scene_options(parser) -> None:
    """Add the RGB-D / scan / alignment / cleaning options to the ``itensor detect`` parser.

    If the parser already has ``--up`` (``choices=("z", "y")``, default ``z``), it is widened
    to ``auto``, the other axes and x,y,z, with default ``auto``; otherwise ``--up`` is added
    (default ``auto``). For a plain scene file (no --scan, not a frame) ``auto`` means ``z``,
    the old default, so mesh scenes behave exactly as before.
    """
    g = parser.add_argument_group(
        "real scenes (RGB-D frames, scans)",
        "An RGB-D frame is given with --depth and --intrinsics (and --color), or as a directory "
        "holding color.png, depth.png and intrinsics.json in place of SCENE. --scan treats a "
        "scene file as a captured cloud. Both are cleaned and gravity-aligned.")
    g.add_argument("--color", help="colour image registered to the depth image")
    g.add_argument("--depth", help="depth image (single-channel 16-bit PNG)")
    g.add_argument("--intrinsics", help="JSON with width, height, fx, fy, cx, cy "
                                        "[, depth_scale, depth_trunc]")
    g.add_argument("--depth-scale", type=number(low=0, high=1e6, low_open=True), default=None,
                   help="depth units per metre (overrides the JSON; TUM 5000, mm PNG 1000)")
    g.add_argument("--depth-trunc", type=number(low=0, high=100, low_open=True), default=None,
                   help="ignore depth beyond this many metres (overrides the JSON)")
    g.add_argument("--scan", action="store_true",
                   help="SCENE is a captured point cloud (or scanned mesh): clean and align it")
    g.add_argument("--no-align", action="store_true",
                   help="skip gravity alignment (a frame's camera is then assumed level)")
    g.add_argument("--max-tilt", type=number(low=0, high=90), default=None,
                   help="largest angle (deg) between --up and the supporting plane's normal")
    g.add_argument("--plane-distance", type=number(low=0, high=1, low_open=True), default=0.02,
                   help="RANSAC inlier distance in metres (default 0.02)")
    g.add_argument("--voxel-size", type=number(low=0, high=1), default=None,
                   help="voxel down-sampling edge in metres (default: the descriptor's "
                        "spacing; 0 = none)")
    g.add_argument("--remove-outliers", action=argparse.BooleanOptionalAction, default=True,
                   help="statistical outlier removal (default on)")
    g.add_argument("--outlier-neighbors", type=number(int, low=1, high=1000), default=20,
                   help="neighbours of the statistical outlier removal")
    g.add_argument("--outlier-std", type=number(low=0, low_open=True), default=2.0,
                   help="standard deviations beyond which a point is an outlier")
    g.add_argument("--orient-normals", choices=("camera", "up", "none"), default=None,
                   help="normal orientation (default: camera for a frame, up for a scan)")
    up_help = ("up direction of the input: auto (a frame: camera -Y; a scan: search every "
               "direction), z, y, -y, ... or x,y,z")
    existing = getattr(parser, "_option_string_actions", {}).get("--up")
    if existing is not None:      # widen the detect parser's --up z|y (default z -> auto;
        existing.choices = None   # a plain scene file still reads auto as z)
        existing.type = _axis_or_vector
        existing.default = "auto"
        parser.set_defaults(up="auto")
        existing.help = up_help
    else:
        g.add_argument("--up", type=_axis_or_vector, default="auto", help=up_help)


# --------------------------------------------------------------------------- train
def cmd_train(args) -> int:

    _out_file(args.output, "-o/--output", "the descriptor file to write (.npz)")
    t0 = time.perf_counter()
    tensor = train(args.query, args.scene_object, args.affordance, acceptance=args.acceptance,
                   normal=args.normal, spacing=args.spacing, query_points=args.query_points,
                   vectors=args.vectors, reference_point=args.reference_point, seed=args.seed,
                   scale=args.scale, up=args.up, ground=args.ground)
    out = tensor.save(args.output)
    seconds = time.perf_counter() - t0
    if args.json:
        print(json.dumps({"descriptor": str(out), "affordance": tensor.affordance,
                          "seconds": round(seconds, 3), "threshold": tensor.threshold(),
                          "bisector_points": len(tensor.bisector_points),
                          "keypoints": len(tensor.weighted.points)}))
        return 0
    _say(args, f"trained {tensor.affordance!r} in {seconds:.2f} s: "
               f"{len(tensor.bisector_points)} bisector points, "
               f"{len(tensor.weighted.points)} keypoints, threshold "
               f"{tensor.threshold():.3f} -> {out}")
    return 0


# --------------------------------------------------------------------------- detect
#: DetectSettings field -> ``itensor detect`` option (dest)
_SETTING_OPTIONS = {
    "sample_fraction": "sample_fraction", "top_k": "top_k", "seed": "seed",
    "criterion": "criterion", "keypoints": "keypoints", "threshold": "threshold",
    "scene_spacing": "spacing", "n_orientations": "orientations",
    "normal_tolerance_deg": "normal_tolerance", "oriented_normals": "oriented_normals",
    "backend": "backend", "device": "device"}


def _detect_settings(args) -> DetectSettings:
    skip = tuple(t for names in args.skip_test for t in names)
    return DetectSettings(skip_tests=skip, **{field: getattr(args, dest)
                                              for field, dest in _SETTING_OPTIONS.items()})


def scene_options(args) -> dict:
    """:func:`interaction_tensor.api.load_scene` keyword arguments from ``itensor detect``'s
    options: a scene file, a frame directory, or --depth/--intrinsics[/--color]; --scan."""
    frame = any(getattr(args, k, None) for k in ("color", "depth", "intrinsics"))
    scene = getattr(args, "scene", None)
    options = {"scale": args.scale, "up": args.up}
    if frame:
        options.update(color=args.color, depth=args.depth, intrinsics=args.intrinsics,
                       depth_scale=args.depth_scale, depth_trunc=args.depth_trunc)
    if args.scan:
        options["scan"] = True
    if frame or args.scan or (scene is not None and Path(scene).is_dir()):
        if args.plane_distance is not None and not args.plane_distance > 0:
            raise SettingsError("--plane-distance must be positive (metres)")
        options.update(align=not args.no_align, max_tilt_deg=args.max_tilt,
                       voxel_size=args.voxel_size, remove_outliers=args.remove_outliers,
                       outlier_neighbors=args.outlier_neighbors, outlier_std=args.outlier_std,
                       plane_distance=args.plane_distance,
                       normals_orientation=args.orient_normals)
    elif scene is None:
        raise InputError(None, "give a scene file, an RGB-D frame directory, or --depth and "
                               "--intrinsics (and --color)")
    elif args.up not in ("auto", "z", "y"):
        raise InputError(scene, f"--up {args.up} needs --scan (a plain scene file takes "
                                "--up z or y)")
    return options


def _report(args, result, outdir) -> None:
    st = result.stats
    if getattr(args, "json", False):
        print(json.dumps(summary(result, outdir)))
        return
    for note in st.get("scene_notes", []):
        _say(args, f"note: {note}")
    _say(args, f"scene: {st['scene_points']} points, {st['test_points_sampled']} test points, "
               f"{st['candidates_after_normal_filter']} after the normal filter")
    if st["candidates_after_normal_filter"] == 0:
        _say(args, "no candidate: no test point's normal lies within --normal-tolerance "
                   f"({result.settings.normal_tolerance(result.tensor):g} deg) of the descriptor's "
                   "affordance normal, so nothing was scored")
    rate = st.get("candidates_per_second")
    tests_s = st["seconds"].get("placement_tests", 0)
    _say(args, f"decided {st['pairs']} (point, orientation) pairs in "
               f"{st['deciding_seconds']:.2f} s{f' ({rate:,.0f} candidates/s)' if rate else ''}"
               f": placement tests of all of them in {tests_s:.2f} s, then scored the "
               f"{st['pairs_scored']} that passed them in {st['scoring_seconds']:.2f} s "
               f"({st['backend']}{' on ' + st['device'] if st['backend'] == 'torch' else ''}); "
               f"{st['mean_comparisons_per_decision']:.0f} keypoint comparisons to a "
               f"scored pair's decision")
    of_what = f"{st['pairs_scored']} that passed the placement tests"
    _say(args, f"accepted {st['pairs_accepted']} of the {of_what} (placement tests failed: "
               f"tap {st['pairs_failing_tap']}, clearance "
               f"{st['pairs_failing_clearance']}, contact {st['pairs_failing_contact']}, "
               f"interior {st['pairs_failing_interior']}, ground "
               f"{st['pairs_failing_ground']}, feet {st['pairs_failing_feet']}, straddle "
               f"{st['pairs_failing_straddle']}, mount {st['pairs_failing_mount']}, "
               f"through {st['pairs_failing_through']})")
    ranked = [name for name, key in (("collision", "collision_test"),
                                     ("hanging", "hanging_test"), ("filling", "filling_test"))
              if st.get(key) == "on"]
    if ranked:
        spent = " (the tests allowed are spent: fewer predictions)" \
            if st["collision_tests_exhausted"] else ""
        through = f", {st['pairs_with_nothing_through']} of them with nothing through the " \
            "hook" if st["through_test"] == "on" else ""
        hangs = f", {st['pairs_not_hanging']} not hanging from what passes through it" \
            if "hanging" in ranked else ""
        fills = f", {st['pairs_not_filling']} with no tap, basin or sink" \
            if "filling" in ranked else ""
        which = " and ".join(ranked) + (" tests" if len(ranked) > 1 else " test")
        _say(args, f"{which} of the top predictions: {st['collision_tests']} tested, "
                   f"{st['pairs_failing_collision']} failing{through}{hangs}{fills}{spent} in "
                   f"{st['seconds'].get('collision', 0):.2f} s")
    else:
        _say(args, f"collision test {st['collision_test']}")
    if st["backend"] == "torch" and st["device"] == "cpu":
        print("itensor: note: no CUDA device, so the torch backend ran on the CPU, where the "
              "default Numba backend is much faster", file=sys.stderr)
    places = result.places
    if places:
        _say(args, f"{len(places)} place{'s' if len(places) != 1 else ''} found; the best "
                   f"pose of each of the best {len(result.predictions)}:")
    for rank, p in enumerate(result.predictions[:10], 1):
        x, y, z = p.position
        size = " x ".join(f"{v:.2f}" for v in (places[p.place].hi - places[p.place].lo)[:2]) \
            if 0 <= p.place < len(places) else "?"
        _say(args, f"  #{rank:<2d} score {p.score:.3f} at ({x:.3f}, {y:.3f}, {z:.3f}) m, "
                   f"orientation {p.orientation_index} ({p.angle * 180 / 3.141592653589793:.0f} deg)"
                   f", place {p.place} ({size} m)")
    _say(args, f"wrote {outdir}/predictions.json, heatmap.ply, predictions.glb, top/ "
               f"({len(result.predictions)} posed objects)")


def summary(result, outdir) -> dict:
    """The ``--json`` summary of one detection: counts, seconds, the top predictions."""
    st = result.stats
    return {"output": str(outdir), "scene": result.scene.source,
            "affordance": result.tensor.affordance, "threshold": result.threshold,
            "scene_points": st["scene_points"], "test_points_sampled": st["test_points_sampled"],
            "candidates": st["candidates_after_normal_filter"],
            "pairs": st["pairs"],
            "pairs_scored": st["pairs_scored"], "pairs_tested": st["pairs_tested"],
            "pairs_accepted": st["pairs_accepted"],
            "pairs_accepted_by_score": st["pairs_accepted_by_score"],
            "places": st.get("places", 0),
            **{k: st[k] for k in ("pairs_failing_tap", "pairs_failing_clearance",
                                  "pairs_failing_contact",
                                  "pairs_failing_interior", "pairs_failing_ground", "pairs_failing_feet",
                                  "pairs_failing_straddle", "pairs_failing_mount",
                                  "pairs_failing_through", "collision_test", "collision_tests",
                                  "pairs_failing_collision", "pairs_with_nothing_through",
                                  "hanging_test", "pairs_not_hanging", "filling_test",
                                  "pairs_not_filling")},
            "candidates_per_second": st.get("candidates_per_second"),
            "pairs_per_second": st.get("pairs_per_second"), "seconds": st["seconds"],
            "predictions": [{"score": p.score, "position": p.position.tolist(),
                             "angle": p.angle, "place": p.place} for p in result.predictions]}


def render_option(p) -> None:
    """``--render`` (the default) / ``--no-render``: whether ``render.png`` is written."""
    p.add_argument("--render", action=argparse.BooleanOptionalAction, default=True,
                   help="write render.png: the heat map, the best places outlined and the "
                        "query posed at each prediction (default; --no-render skips it)")


def cmd_detect(args) -> int:

    tensor = load_tensor(args.descriptor)
    options = scene_options(args)
    outdir = _out_path(args.output)
    result = detect(args.scene, tensor, _detect_settings(args), progress=_show_progress(args),
                    **options)
    report = getattr(result.scene, "report", None)
    for warning in (report.warnings if report is not None else []) + result.warnings:
        print(f"itensor: warning: {warning}", file=sys.stderr)
    t0 = time.perf_counter()
    result.save(outdir, descriptor_name=str(args.descriptor), render=args.render)
    if report is not None and report.alignment is not None:
        height = report.alignment.get("camera_height_m")
        camera = "" if height is None else f" (camera height {height} m)"
        mesh = getattr(result.scene, "mesh", None)
        surface = "" if mesh is None else (
            f"; its surface: {len(mesh[1]):,} triangles, noise "
            f"{1000 * getattr(result.scene, 'surface_noise', 0.0):.1f} mm")
        _say(args, f"aligned: {report.alignment['kind']} plane at z = 0{camera}{surface}; "
                   "also wrote predictions_input_frame.json, heatmap_input_frame.ply, "
                   "top_input_frame/")
    _report(args, result, outdir)
    if args.render and not args.json:
        _say(args, f"wrote {outdir}/render.png (saving took {time.perf_counter() - t0:.1f} s)")
    return 0


# --------------------------------------------------------------------------- batch
def cmd_batch(args) -> int:

    _out_path(args.output)
    if args.workers is not None and args.workers < 0:
        raise SettingsError(f"--workers must be 0 (this process) or more, got {args.workers}")
    if args.workers is not None and args.scheduler is not None:
        raise SettingsError("give --workers (a local cluster) or --scheduler, not both")
    options = {"scale": args.scale, "up": args.up}
    if args.scan:
        options["scan"] = True
    result = batch(args.scenes, args.descriptors, args.output, _detect_settings(args),
                   scheduler=args.scheduler, workers=args.workers, render=args.render,
                   progress=_show_progress(args), **options)
    if args.json:
        print(json.dumps(result.summary()))
    else:
        s = result.summary()
        _say(args, f"{s['results']} results: {s['done']} done, {s['skipped']} skipped (done "
                   f"before), {s['failed']} failed, in {s['seconds']:.1f} s on {s['scheduler']}")
        for r in result.rows:
            if r["status"] == "failed":
                print(f"itensor: failed: {r['scene']} x {r['descriptor']}: {r['message']}",
                      file=sys.stderr)
        _say(args, f"wrote {result.outdir}/summary.csv, summary.json, index.html")
    return 1 if result.failed else 0


# --------------------------------------------------------------------------- info
def cmd_info(args) -> int:

    tensor = InteractionTensor.load(args.descriptor)
    summary = tensor.summary()
    if args.json:
        print(json.dumps(summary, indent=1))
        return 0
    meta = summary.pop("meta")
    kp = summary.pop("keypoints")
    for key, value in summary.items():
        print(f"{key:>20}: {value}")
    for name, st in kp.items():
        print(f"{name + ' keypoints':>20}: {st['count']}, |v| {st['min_|v|']:.4f}-"
              f"{st['max_|v|']:.4f} m, mean weight {st['mean_weight']:.3f}")
    for key in ("query_source", "scene_object_source", "query_samples",
                "scene_object_samples", "min_gap", "timings_s", "created_with"):
        if key in meta:
            print(f"{key:>20}: {meta[key]}")
    return 0


# --------------------------------------------------------------------------- demo
def cmd_demo(args) -> int:

    outdir = _out_path(args.output)
    t0 = time.perf_counter()
    ex = demo.build()
    tensor = train(ex.query, ex.scene_object, "placing-bowl", spacing=demo.DEMO_SPACING,
                   seed=args.seed)
    t_train = time.perf_counter() - t0
    _say(args, f"trained 'placing-bowl' (procedural bowl on a 0.75 m table) in {t_train:.2f} s")
    result = detect(ex.scene, tensor, top_k=args.top_k, seed=args.seed,
                    progress=_show_progress(args))
    meshes = {name: (lambda path, g=g: write_mesh(path, g.vertices, g.faces))
              for name, g in (("example_query.ply", ex.query),
                              ("example_scene_object.ply", ex.scene_object),
                              ("scene.ply", ex.scene))}
    result.save(outdir, descriptor_name=str(outdir / "placing-bowl.npz"), render=args.render,
                also={"placing-bowl.npz": tensor.save, **meshes})
    _report(args, result, outdir)
    surfaces = demo.surface_names(ex, [p.position for p in result.predictions[:5]])
    _say(args, "top 5 landed on: " + ", ".join(surfaces))
    if args.render:
        _say(args, f"wrote {outdir}/render.png")
    _say(args, f"demo finished in {time.perf_counter() - t0:.1f} s; open {outdir}/scene.ply "
               f"with {outdir}/heatmap.ply and {outdir}/top/*.ply in MeshLab, "
               f"{outdir}/predictions.glb in a browser's glTF viewer or Blender, or run "
               f"'itensor view {outdir}' for a page to open in a browser")
    return 0


# --------------------------------------------------------------------------- parser
def build_parser() -> argparse.ArgumentParser:
    parser = Parser(
        prog="itensor",
        description="Where in this 3D scene can I do this? The Interaction Tensor "
                    "(Ruiz & Mayol-Cuevas) from a single example.")
    parser.add_argument("--version", action="version", version=f"%(prog)s {__version__}")
    sub = parser.add_subparsers(dest="command", metavar="COMMAND", required=True,
                                parser_class=Parser)

    p = sub.add_parser("train", help="fit a descriptor from one interaction example")
    p.add_argument("query", help="query object (mesh or point cloud), posed in the interaction")
    p.add_argument("scene_object", help="scene-object, in the same frame")
    p.add_argument("--affordance", required=True, help="name of the interaction, e.g. placing-bowl")
    p.add_argument("-o", "--output", required=True, help="descriptor file to write (.npz)")
    p.add_argument("--normal", type=_vector, default=(0.0, 0.0, 1.0),
                   help="expected scene normal N_aff: up (default), down (filling under a tap), "
                        "or x,y,z")
    p.add_argument("--query-points", type=number(int, low=100, high=1_000_000), default=6000,
                   help="area-uniform samples on the query object")
    p.add_argument("--spacing", type=_spacing, default=0.01,
                   help="scene-object sample spacing in metres (detection uses the same)")
    p.add_argument("--vectors", choices=("surface", "points"), default="surface",
                   help="provenance vectors to the sampled surface (default) or to the samples")
    p.add_argument("--reference-point", type=_vector, default=None,
                   help="override the reference point p_scene as x,y,z (metres)")
    p.add_argument("--ground", type=number(float, low=-1e4, high=1e4), default=None,
                   help="height (m) of the floor the example stands on, where the interaction "
                        "needs it (a seated person's feet): the clearance and contact tests "
                        "then count it")
    p.add_argument("--acceptance", choices=tuple(affordances.acceptances()), default=None,
                   help="accept as the paper's affordance does (S_aff, clearance, interior and "
                        "contact tests tuned on validation scenes) instead of the acceptance "
                        "derived from the example")
    seed_option(p)
    quiet_option(p)
    p.add_argument("--json", action="store_true",
                   help="print a one-line JSON summary instead of the report")
    _geometry_options(p)
    p.set_defaults(func=cmd_train)

    p = sub.add_parser("detect", help="find where a trained interaction can happen in a scene")
    p.add_argument("scene", nargs="?", default=None,
                   help="scene mesh or point cloud, or an RGB-D frame directory "
                        "(color.png, depth.png, intrinsics.json); omit with --depth/--intrinsics")
    p.add_argument("descriptor", help="descriptor written by 'itensor train'")
    p.add_argument("-o", "--output", required=True, help="output directory")
    detection_options(p)
    render_option(p)
    quiet_option(p)
    p.add_argument("--json", action="store_true",
                   help="print a one-line JSON summary instead of the report")
    _geometry_options(p)
    real_scene_options(p)
    p.set_defaults(func=cmd_detect)

    p = sub.add_parser("batch", help="many scenes x many descriptors, on a local or remote "
                                     "Dask cluster; resumes where it stopped")
    p.add_argument("--scenes", nargs="+", required=True, metavar="SCENE",
                   help="scene files, globs ('scans/*.ply') or manifest files (one path per "
                        "line, or a JSON list)")
    p.add_argument("--descriptors", nargs="+", required=True, metavar="DESCRIPTOR",
                   help="descriptor files, globs or manifest files")
    p.add_argument("-o", "--output", required=True,
                   help="output directory: OUT/SCENE/DESCRIPTOR/ per pair, summary.csv, "
                        "summary.json, index.html; finished pairs in it are skipped")
    p.add_argument("--scheduler", default=None, metavar="tcp://HOST:PORT",
                   help="a running Dask scheduler (default: a local cluster on this machine)")
    p.add_argument("--workers", type=number(int, low=0, high=1024), default=None,
                   help="local cluster worker processes (default: the machine's cores); "
                        "0 runs in this process without Dask")
    render_option(p)
    detection_options(p)
    p.add_argument("--scan", action="store_true",
                   help="the scenes are captured clouds: clean and gravity-align them")
    p.add_argument("--scale", type=number(low=0, low_open=True), default=None,
                   help="multiply coordinates by this to get metres (0.001 for mm); default: "
                        "metres, with files larger than a scene (100 m) or, for train, an "
                        "object (10 m) refused as probably mm or cm")
    p.add_argument("--up", type=_axis_or_vector, default="auto",
                   help="up axis of the scenes: auto (z; searched with --scan), z, y, or "
                        "x,y,z with --scan")
    quiet_option(p)
    p.add_argument("--json", action="store_true",
                   help="print a one-line JSON summary instead of the report")
    p.set_defaults(func=cmd_batch)

    p = sub.add_parser("info", help="print what a descriptor holds")
    p.add_argument("descriptor", help="descriptor written by 'itensor train'")
    p.add_argument("--json", action="store_true", help="machine-readable output")
    p.set_defaults(func=cmd_info)

    p = sub.add_parser("demo", help="train and detect on built-in procedural data")
    p.add_argument("-o", "--output", default="demo_out", help="output directory")
    p.add_argument("--top-k", type=number(int, low=1), default=10,
                   help="predictions: the best pose of each of the best K places")
    seed_option(p)
    render_option(p)
    quiet_option(p)
    p.add_argument("--json", action="store_true",
                   help="print a one-line JSON summary instead of the report")
    p.set_defaults(func=cmd_demo)

    register_viz(sub)
    register_examples(sub)
    for register in _plugins():
        register(sub)
    return parser


def _plugins() -> list:
    """``register(subparsers)`` functions of installed packages that add ``itensor``
    command groups (entry points of the group ``interaction_tensor.commands``, such as the
    paper's reproduction, ``itensor paper``)."""
    from importlib.metadata import entry_points

    found = []
    for ep in sorted(entry_points(group="interaction_tensor.commands"), key=lambda e: e.name):
        try:
            found.append(ep.load())
        except ImportError:          # a broken plugin must not break the command line
            continue
    return found


class Terminated(KeyboardInterrupt):
    """SIGTERM (what ``timeout``, systemd, Slurm and Kubernetes send), raised where the
    program is, so that every ``finally`` removes its temporary files."""


def _on_sigterm(signum, frame):
    raise Terminated()


def _one_shot_memory() -> None:
    """Memory settings for the command line's one-shot processes (Linux, glibc):

    - glibc raises its mmap threshold to 32 MB after the first large array is freed, so the
      many 1-30 MB arrays of a detection then come from the heap and stay resident when
      freed (on a 2 M-point cloud at 1 % test points: 16-30 MB more peak per stage and
      about 40 MB more resident between stages): kept at 128 kB.
    - At most 2 malloc arenas: the Numba threads' small allocations otherwise spread over
      per-thread arenas.
    - No transparent huge pages under NumPy's arrays (NumPy asks for them under every
      array of 4 MB or more; Linux backs a touched 2 MB range whole, and collapses ranges
      in the background): with them the same detection of a 2 M-point cloud peaked at
      488-490 MB in four runs and 622 MB in a fifth, without them at 475 MB
      in every run. The scene's points and normals, read at random by every query, still
      get them (:func:`scene.hot_copy`).

    Elsewhere, nothing."""
    if not sys.platform.startswith("linux"):
        return
    try:
        import ctypes

        libc = ctypes.CDLL("libc.so.6")
        libc.mallopt(-3, 128 * 1024)      # M_MMAP_THRESHOLD
        libc.mallopt(-8, 2)               # M_ARENA_MAX
    except (OSError, AttributeError):
        pass
    _numpy_small_pages()


def _numpy_small_pages() -> None:
    """NumPy's arrays on 4 kB pages (see :func:`_one_shot_memory`)."""
    import numpy as np

    try:
        np._core.multiarray._set_madvise_hugepage(False)
    except AttributeError:          # not NumPy 2's private switch: its default stays
        pass


def main(argv=None) -> int:
    parser = build_parser()
    args = parser.parse_args(argv)
    if argv is None:                    # the itensor process itself, not a caller's
        _one_shot_memory()
    try:
        previous = signal.signal(signal.SIGTERM, _on_sigterm)
    except ValueError:          # not the main thread: leave the handler alone
        previous = None
    try:
        return _run(args)
    finally:
        if previous is not None:
            signal.signal(signal.SIGTERM, previous)


def _run(args) -> int:
    try:
        code = int(args.func(args) or 0)
        sys.stdout.flush()        # a closed pipe shows here, inside the handlers below
        return code
    except ItensorError as exc:
        print(f"itensor: error: {exc}", file=sys.stderr)
        return 2
    except MemoryError:
        print("itensor: error: out of memory; try a larger --spacing or a smaller "
              "--sample-fraction", file=sys.stderr)
        return 2
    except Terminated:
        print("itensor: terminated; earlier results left as they were", file=sys.stderr)
        return 143
    except KeyboardInterrupt:
        print("itensor: interrupted; earlier results left as they were", file=sys.stderr)
        return 130
    except BrokenPipeError:
        # the reader went away (``itensor info --json x | head -c 10``): stop quietly
        try:
            sys.stdout = open(os.devnull, "w")
        except OSError:
            pass
        return 141
    except OSError as exc:    # unwritable output, full disk, ...: one line, no traceback
        where = f"{exc.filename}: " if exc.filename else ""
        print(f"itensor: error: {where}{exc.strerror or exc}", file=sys.stderr)
        return 2


if __name__ == "__main__":
    sys.exit(main())
