"""``itensor``: the command line, a thin shell over the Python API.

Each subcommand parses its arguments, calls the library, prints a short report and sets the
exit status: 0 on success, 2 on bad input (one line on stderr, no traceback), 130 when
interrupted.
"""

from __future__ import annotations

import argparse
import json
import sys
import time
from pathlib import Path

from . import __version__
from .errors import InputError, ItensorError


# --------------------------------------------------------------------------- helpers
def _vector(text: str) -> tuple:
    named = {"up": (0.0, 0.0, 1.0), "down": (0.0, 0.0, -1.0)}
    if text in named:
        return named[text]
    try:
        values = tuple(float(v) for v in text.split(","))
    except ValueError:
        raise argparse.ArgumentTypeError(f"expected 'up', 'down' or x,y,z, got {text!r}") from None
    if len(values) != 3:
        raise argparse.ArgumentTypeError(f"expected three comma-separated numbers, got {text!r}")
    return values


def _fraction(text: str) -> float:
    value = float(text)
    if not 0 < value <= 1:
        raise argparse.ArgumentTypeError(f"must be in (0, 1], got {text}")
    return value


def _show_progress(args) -> bool:
    return not getattr(args, "quiet", False) and sys.stderr.isatty()


def _say(args, *parts) -> None:
    if not getattr(args, "quiet", False):
        print(*parts)


def _out_dir(path) -> Path:
    path = Path(path)
    if path.exists() and not path.is_dir():
        raise InputError(path, "exists and is not a directory")
    path.mkdir(parents=True, exist_ok=True)
    return path


def _geometry_options(p: argparse.ArgumentParser) -> None:
    p.add_argument("--scale", type=float, default=1.0,
                   help="multiply coordinates by this to get metres (0.001 for mm)")
    p.add_argument("--up", choices=("z", "y"), default="z", help="the files' up axis")


# --------------------------------------------------------------------------- train
def cmd_train(args) -> int:
    from .descriptor import InteractionTensor
    from .io import load_geometry
    from .settings import TrainSettings

    query = load_geometry(args.query, args.scale, args.up)
    scene_object = load_geometry(args.scene_object, args.scale, args.up)
    settings = TrainSettings(query_points=args.query_points, scene_spacing=args.spacing,
                             affordance_normal=args.normal, seed=args.seed, vectors=args.vectors)
    t0 = time.perf_counter()
    tensor = InteractionTensor.fit(query, scene_object, args.affordance, settings,
                                   reference_point=args.reference_point)
    if args.acceptance:
        from .examples.interactions import acceptance

        tensor.set_acceptance(*acceptance(args.acceptance))
    out = tensor.save(args.output)
    _say(args, f"trained {tensor.affordance!r} in {time.perf_counter() - t0:.2f} s: "
               f"{len(tensor.bisector_points)} bisector points, "
               f"{len(tensor.weighted.points)} keypoints, threshold "
               f"{tensor.threshold():.3f} -> {out}")
    return 0


# --------------------------------------------------------------------------- detect
def _detect_settings(args):
    from .settings import DetectSettings

    return DetectSettings(
        sample_fraction=args.sample_fraction, top_k=args.top_k, seed=args.seed,
        criterion=args.criterion, keypoints=args.keypoints, threshold=args.threshold,
        scene_spacing=args.spacing, early_exit=not args.no_early_exit,
        normal_tolerance_deg=args.normal_tolerance, oriented_normals=args.oriented_normals,
        nms_radius=args.nms_radius, backend=args.backend, device=args.device,
        keypoint_order=args.keypoint_order, clearance=not args.no_clearance)


def run_detection(scene_geometry, tensor, settings, outdir, progress, scene_name,
                  descriptor_name):
    """Prepare the scene, detect, export; returns the Detection (shared with the demo)."""
    from .detect import detect
    from .predictions import export
    from .scene import prepare_scene

    t0 = time.perf_counter()
    spacing = settings.scene_spacing or tensor.scene_spacing
    scene = prepare_scene(scene_geometry, spacing, settings.seed, settings.max_scene_points)
    t_prep = time.perf_counter() - t0
    result = detect(scene, tensor, settings, progress=progress)
    result.stats["seconds"]["scene_preparation"] = round(t_prep, 4)
    t1 = time.perf_counter()
    export(result, outdir, scene_name, descriptor_name)
    result.stats["seconds"]["export"] = round(time.perf_counter() - t1, 4)
    return result


def _report(args, result, outdir) -> None:
    st = result.stats
    _say(args, f"scene: {st['scene_points']} points, {st['test_points_sampled']} test points, "
               f"{st['candidates_after_normal_filter']} after the normal filter")
    _say(args, f"scored {st['pairs_scored']} (point, orientation) pairs in "
               f"{st['seconds']['scoring']:.2f} s ({st['backend']}"
               f"{' on ' + st['device'] if st['backend'] == 'torch' else ''}); accepted "
               f"{st['pairs_accepted']}; {st['mean_comparisons_per_decision']:.0f} keypoint "
               "comparisons per decision")
    if st["backend"] == "torch" and st["device"] == "cpu":
        print("itensor: note: no CUDA device, so the torch backend ran on the CPU, where the "
              "default Numba backend is much faster", file=sys.stderr)
    for rank, p in enumerate(result.predictions[:10], 1):
        x, y, z = p.position
        _say(args, f"  #{rank:<2d} score {p.score:.3f} at ({x:.3f}, {y:.3f}, {z:.3f}) m, "
                   f"orientation {p.orientation_index} ({p.angle * 180 / 3.141592653589793:.0f} deg)")
    _say(args, f"wrote {outdir}/predictions.json, heatmap.ply, top/ ({len(result.predictions)} posed objects)")


def cmd_detect(args) -> int:
    from .descriptor import InteractionTensor
    from .detect import detect
    from .io import load_geometry
    from .predictions import export
    from .realdata import is_real_input, scene_from_args, write_input_frame_outputs

    tensor = InteractionTensor.load(args.descriptor)
    real = is_real_input(args)
    if args.criterion is None:
        # captured depth is too noisy for the paper criterion's tight tests on short vectors
        # (README, "Your own RGB-D data"); the authors' own code criterion copes with it
        args.criterion = "gaussian" if real else "paper"
    settings = _detect_settings(args)
    if not real:
        if args.scene is None:
            raise InputError(None, "give a scene file, an RGB-D frame directory, or "
                                   "--depth and --intrinsics")
        up = "z" if args.up == "auto" else args.up
        if up not in ("z", "y"):
            raise InputError(args.scene, f"--up {args.up} needs --scan for a scene file; "
                                         "use z or y")
        scene_geometry = load_geometry(args.scene, args.scale, up)
        outdir = _out_dir(args.output)
        result = run_detection(scene_geometry, tensor, settings, outdir, _show_progress(args),
                               str(args.scene), str(args.descriptor))
    else:
        outdir = _out_dir(args.output)
        t0 = time.perf_counter()
        scene, report, transform = scene_from_args(args, tensor.scene_spacing)
        t_prep = time.perf_counter() - t0
        for warning in report.warnings:
            print(f"itensor: warning: {warning}", file=sys.stderr)
        result = detect(scene, tensor, settings, progress=_show_progress(args))
        result.stats["seconds"]["scene_preparation"] = round(t_prep, 4)
        export(result, outdir, report.source, str(args.descriptor))
        write_input_frame_outputs(result, outdir, transform, report)
        if report.alignment is not None:
            _say(args, f"aligned: {report.alignment['kind']} plane at z = 0 (camera height "
                       f"{report.alignment.get('camera_height_m', '-')} m); also wrote "
                       "predictions_input_frame.json, heatmap_input_frame.ply, top_input_frame/")
    _report(args, result, outdir)
    _after_detect(args, outdir)
    return 0


def _after_detect(args, outdir) -> None:
    """Optional pictures after a detection (``--render``)."""
    if getattr(args, "render", False):
        from .cli_viz import render_after_detect

        render_after_detect(outdir, quiet=getattr(args, "quiet", False))


# --------------------------------------------------------------------------- info
def cmd_info(args) -> int:
    from .descriptor import InteractionTensor

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
    from .descriptor import InteractionTensor
    from .examples import demo
    from .io import write_mesh
    from .settings import DetectSettings, TrainSettings

    outdir = _out_dir(args.output)
    t0 = time.perf_counter()
    ex = demo.build()
    settings = TrainSettings(scene_spacing=demo.DEMO_SPACING, seed=args.seed)
    tensor = InteractionTensor.fit(ex.query, ex.scene_object, "placing-bowl", settings)
    t_train = time.perf_counter() - t0
    tensor.save(outdir / "placing-bowl.npz")
    for name, g in (("example_query.ply", ex.query), ("example_scene_object.ply", ex.scene_object),
                    ("scene.ply", ex.scene)):
        write_mesh(outdir / name, g.vertices, g.faces)
    _say(args, f"trained 'placing-bowl' (procedural bowl on a 0.75 m table) in {t_train:.2f} s")
    result = run_detection(ex.scene, tensor, DetectSettings(top_k=args.top_k, seed=args.seed),
                           outdir, _show_progress(args), "procedural demo room",
                           str(outdir / "placing-bowl.npz"))
    _report(args, result, outdir)
    surfaces = demo.surface_names(ex, [p.position for p in result.predictions[:5]])
    _say(args, "top 5 landed on: " + ", ".join(surfaces))
    _after_detect(args, outdir)
    _say(args, f"demo finished in {time.perf_counter() - t0:.1f} s; open {outdir}/scene.ply "
               f"with {outdir}/heatmap.ply and {outdir}/top/*.ply in MeshLab, or run "
               f"'itensor view {outdir}' for a page to open in a browser")
    return 0


# --------------------------------------------------------------------------- parser
def build_parser() -> argparse.ArgumentParser:
    parser = argparse.ArgumentParser(
        prog="itensor",
        description="Where in this 3D scene can I do this? The Interaction Tensor "
                    "(Ruiz & Mayol-Cuevas) from a single example.")
    parser.add_argument("--version", action="version", version=f"%(prog)s {__version__}")
    sub = parser.add_subparsers(dest="command", metavar="COMMAND", required=True)

    p = sub.add_parser("train", help="fit a descriptor from one interaction example")
    p.add_argument("query", help="query object (mesh or point cloud), posed in the interaction")
    p.add_argument("scene_object", help="scene-object, in the same frame")
    p.add_argument("--affordance", required=True, help="name of the interaction, e.g. placing-bowl")
    p.add_argument("-o", "--output", required=True, help="descriptor file to write (.npz)")
    p.add_argument("--normal", type=_vector, default=(0.0, 0.0, 1.0),
                   help="expected scene normal N_aff: up (default), down, or x,y,z")
    p.add_argument("--query-points", type=int, default=6000, help="samples on the query object")
    p.add_argument("--spacing", type=float, default=0.01,
                   help="scene-object sample spacing in metres (detection uses the same)")
    p.add_argument("--vectors", choices=("surface", "points"), default="surface",
                   help="provenance vectors to the sampled surface (default) or to the samples")
    p.add_argument("--reference-point", type=_vector, default=None,
                   help="override the reference point p_scene as x,y,z (metres)")
    p.add_argument("--acceptance", choices=("placing", "filling", "hanging", "sitting", "riding"),
                   default=None,
                   help="accept as the paper's affordance does (S_aff and clearance limit tuned "
                        "on validation scenes) instead of 0.9 x the example's own score")
    p.add_argument("--seed", type=int, default=0)
    p.add_argument("-q", "--quiet", action="store_true")
    _geometry_options(p)
    p.set_defaults(func=cmd_train)

    p = sub.add_parser("detect", help="find where a trained interaction can happen in a scene")
    p.add_argument("scene", nargs="?", default=None,
                   help="scene mesh or point cloud, or an RGB-D frame directory "
                        "(color.png, depth.png, intrinsics.json); omit with --depth/--intrinsics")
    p.add_argument("descriptor", help="descriptor written by 'itensor train'")
    p.add_argument("-o", "--output", required=True, help="output directory")
    p.add_argument("--top-k", type=int, default=10, help="predictions kept after suppression")
    p.add_argument("--sample-fraction", type=_fraction, default=0.30,
                   help="fraction of scene points used as test points (paper: 0.3)")
    p.add_argument("--seed", type=int, default=0)
    p.add_argument("--criterion", choices=("paper", "gaussian"), default=None,
                   help="score criterion: paper (default for meshes and clouds) or gaussian "
                        "(the authors' code; default for RGB-D frames and --scan)")
    p.add_argument("--keypoints", choices=("weighted", "uniform"), default="weighted")
    p.add_argument("--threshold", type=_fraction, default=None,
                   help="acceptance threshold on the normalised score (default: calibrated)")
    p.add_argument("--spacing", type=float, default=None,
                   help="mesh sampling spacing in metres (default: the descriptor's)")
    p.add_argument("--normal-tolerance", type=float, default=15.0,
                   help="largest angle in degrees between a test normal and N_aff")
    p.add_argument("--oriented-normals", action="store_true",
                   help="trust the sign of scene normals (default: compare the normal line)")
    p.add_argument("--nms-radius", type=float, default=None,
                   help="suppression radius in metres (default: the query object's width)")
    p.add_argument("--no-early-exit", action="store_true",
                   help="compare every keypoint of every candidate")
    p.add_argument("--no-clearance", action="store_true",
                   help="accept on the score alone, without the clearance test")
    p.add_argument("--backend", choices=("auto", "numba", "numpy", "torch"), default="auto",
                   help="scoring backend; torch runs on a CUDA device when present "
                        "(pip install 'interaction-tensor[torch]')")
    p.add_argument("--device", default=None,
                   help="torch device for --backend torch (default: cuda if present, else cpu)")
    p.add_argument("--keypoint-order", choices=("weight", "adaptive"), default="weight",
                   help="compare keypoints in weight order (paper) or those that fail most often "
                        "first (adaptive: same decisions and accepted scores, fewer comparisons; "
                        "rejected pairs keep another partial score)")
    p.add_argument("--render", action="store_true",
                   help="also write render.png: the heat map and the top predictions")
    p.add_argument("-q", "--quiet", action="store_true")
    _geometry_options(p)
    from .realdata import add_realdata_options

    add_realdata_options(p)
    p.set_defaults(func=cmd_detect)

    p = sub.add_parser("info", help="print what a descriptor holds")
    p.add_argument("descriptor")
    p.add_argument("--json", action="store_true", help="machine-readable output")
    p.set_defaults(func=cmd_info)

    p = sub.add_parser("demo", help="train and detect on built-in procedural data")
    p.add_argument("-o", "--output", default="demo_out", help="output directory")
    p.add_argument("--top-k", type=int, default=10)
    p.add_argument("--seed", type=int, default=0)
    p.add_argument("--render", action="store_true",
                   help="also write render.png: the heat map and the top predictions")
    p.add_argument("-q", "--quiet", action="store_true")
    p.set_defaults(func=cmd_demo)

    for register in _EXTENSIONS:
        register(sub)
    return parser


def _register_viz(sub) -> None:
    from .cli_viz import register

    register(sub)


def _register_eval(sub) -> None:
    from .cli_eval import register

    register(sub)


#: Functions that add further subcommands: ``register(subparsers)``.
_EXTENSIONS: list = [_register_viz, _register_eval]


def main(argv=None) -> int:
    parser = build_parser()
    args = parser.parse_args(argv)
    try:
        return int(args.func(args) or 0)
    except ItensorError as exc:
        print(f"itensor: error: {exc}", file=sys.stderr)
        return 2
    except MemoryError:
        print("itensor: error: out of memory; try a larger --spacing or a smaller "
              "--sample-fraction", file=sys.stderr)
        return 2
    except KeyboardInterrupt:
        print("itensor: interrupted", file=sys.stderr)
        return 130


if __name__ == "__main__":
    sys.exit(main())
