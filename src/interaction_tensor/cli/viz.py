"""``itensor view``, ``itensor show`` and ``itensor render``: pictures and the HTML viewer.

Registered into the main parser through ``cli._EXTENSIONS``. (``detect`` and ``demo`` draw
``render.png`` inside their output transaction, ``Detection.save``, unless ``--no-render``.)
"""

from __future__ import annotations

import time

from interaction_tensor.cli.common import _out_file, number, quiet_option
from interaction_tensor.outputs import render_outdir, render_tensor, write_viewer


def cmd_view(args) -> int:

    t0 = time.perf_counter()
    path = write_viewer(args.outdir, max_points=args.max_points)
    if not args.quiet:
        print(f"wrote {path} ({path.stat().st_size / 1e6:.1f} MB) in "
              f"{time.perf_counter() - t0:.1f} s; open it in a browser (no network needed)")
    return 0


def cmd_show(args) -> int:

    _out_file(args.render, "--render", "the PNG file to write")
    t0 = time.perf_counter()
    path = render_tensor(args.descriptor, args.render)
    if not args.quiet:
        print(f"wrote {path} in {time.perf_counter() - t0:.1f} s")
    return 0


def cmd_render(args) -> int:

    if args.output is not None:
        _out_file(args.output, "-o/--output", "the PNG file to write (or leave -o out for "
                                              "OUTDIR/render.png)")
    t0 = time.perf_counter()
    path = render_outdir(args.outdir, args.output, top_k=args.top_k)
    if not args.quiet:
        print(f"wrote {path} in {time.perf_counter() - t0:.1f} s")
    return 0


def register(subparsers) -> None:
    """Add ``view``, ``show`` and ``render`` to the ``itensor`` subcommands."""
    p = subparsers.add_parser("view", help="write OUTDIR/index.html, an interactive 3D page")
    p.add_argument("outdir", help="a directory written by 'itensor detect' or 'itensor demo'")
    p.add_argument("--max-points", type=number(int, low=1, high=50_000_000), default=200_000,
                   help="scene points kept for the browser (default 200000)")
    quiet_option(p)
    p.set_defaults(func=cmd_view)

    p = subparsers.add_parser("show", help="draw a descriptor like the paper's figure 2")
    p.add_argument("descriptor", help="descriptor written by 'itensor train'")
    p.add_argument("--render", required=True, metavar="OUT.png", help="PNG file to write")
    quiet_option(p)
    p.set_defaults(func=cmd_show)

    p = subparsers.add_parser("render", help="(re)draw OUTDIR/render.png for a detection")
    p.add_argument("outdir", help="a directory written by 'itensor detect' or 'itensor demo'")
    p.add_argument("-o", "--output", default=None, help="PNG to write (default OUTDIR/render.png)")
    p.add_argument("--top-k", type=number(int, low=0), default=None,
                   help="objects drawn (default: all)")
    quiet_option(p)
    p.set_defaults(func=cmd_render)
