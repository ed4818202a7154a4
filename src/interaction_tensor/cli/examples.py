"""``itensor examples``: the paper's eight interaction examples, listed and built into descriptors.

Registered in :mod:`interaction_tensor.cli.main` through ``register(subparsers)``.
"""

from __future__ import annotations

from interaction_tensor import affordances
from interaction_tensor.cli.common import (
    _out_path,
    _spacing,
    examples_option,
    objects_dir,
    quiet_option,
    seed_option,
)
from interaction_tensor.geometry.files import write_json, write_mesh, write_ply_points


def cmd_examples_list(args) -> int:

    for name in affordances.example_names():
        sp = affordances.spec(name)
        normal = "down" if sp.normal[2] < 0 else "up"
        real = sp.real_query or "-"
        print(f"{name:<16} {sp.affordance:<8} N_aff {normal:<4}  real query: {real:<24} "
              f"{sp.description}")
    return 0


def cmd_examples_build(args) -> int:

    out = _out_path(args.output)
    out.mkdir(parents=True, exist_ok=True)
    objects = objects_dir(args.objects)
    names = examples_option(args.examples) or affordances.example_names()
    listing = []
    for n in names:
        ex = affordances.build(n, objects, args.seed, real_scene_object=args.real_scene_objects)
        tensor = affordances.build_descriptor(n, seed=args.seed, spacing=args.spacing,
                                               example=ex)
        tensor.save(out / f"{n}.npz")
        for kind, g in (("query", ex.query), ("scene_object", ex.scene_object)):
            if g.is_mesh:
                write_mesh(out / f"{n}_{kind}.ply", g.vertices, g.faces)
            else:
                write_ply_points(out / f"{n}_{kind}.ply", g.vertices)
        listing.append({"example": n, "affordance": ex.spec.affordance,
                        "affordance_normal": list(ex.spec.normal),
                        "query": ex.query.source, "scene_object": ex.scene_object.source,
                        "descriptor": f"{n}.npz", "threshold": tensor.threshold(),
                        "self_score": tensor.self_scores["paper-weighted"]})
        if not args.quiet:
            print(f"{n:<16} -> {out / (n + '.npz')} (query: {ex.query.source}; threshold "
                  f"{tensor.threshold():.3f})")
    write_json(out / "examples.json", listing)
    return 0


def register(sub) -> None:
    """Add ``examples`` to the ``itensor`` subparsers."""
    p = sub.add_parser("examples", help="the paper's 8 interaction examples")
    esub = p.add_subparsers(dest="examples_command", metavar="ACTION", required=True)
    q = esub.add_parser("list", help="list the examples")
    q.set_defaults(func=cmd_examples_list)
    q = esub.add_parser("build", help="pose every example and write one descriptor each")
    q.add_argument("-o", "--output", required=True, help="output directory")
    q.add_argument("--objects", default=None,
                   help="directory of real query objects (e.g. ../shared/data/objects)")
    q.add_argument("--real-scene-objects", action="store_true",
                   help="also use real scene-objects from --objects (sitting: stool.ply)")
    q.add_argument("--examples", nargs="*", help="only these examples")
    q.add_argument("--spacing", type=_spacing, default=0.01, help="scene-object spacing (m)")
    seed_option(q)
    quiet_option(q)
    q.set_defaults(func=cmd_examples_build)
