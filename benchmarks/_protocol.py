"""What the benchmarks of the paper's protocol share: its 8 example descriptors, trained as
``itensor evaluate`` trains them (real query objects from ``../shared/data/objects`` where
there are some), and a published scene prepared at 1 cm."""

from __future__ import annotations

import os
from pathlib import Path

HERE = Path(__file__).resolve().parent
DATA = Path(os.environ.get("ITENSOR_SHARED_DATA", HERE.parent.parent / "shared" / "data"))


def protocol_descriptors(names=None, seed: int = 0) -> tuple[list, list]:
    """(names, descriptors) of the examples ``names`` (default: the protocol's 8)."""
    from interaction_tensor import affordances

    names = list(names or affordances.example_names())
    return names, [affordances.build_descriptor(n, DATA / "objects", seed=seed, spacing=0.01)
                   for n in names]


def published_scene(name: str, seed: int = 0):
    """The published scene ``name`` (``../shared/data/scenes/NAME.ply``), prepared at 1 cm."""
    import interaction_tensor as it

    return it.prepare_scene(it.load_geometry(DATA / "scenes" / f"{name}.ply"), 0.01, seed=seed)
