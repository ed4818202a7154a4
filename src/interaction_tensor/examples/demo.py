"""The built-in demo: a bowl placed on a table (the example) and a different room (the scene).

The room has tables and shelves at other heights than the training table, a floor, walls, a
low gap under a coffee-table shelf and inside a bookcase where the bowl would fit physically
but has no free space above it, and objects on the dining table the bowl would collide with.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from interaction_tensor.examples.procedural import (
    Part,
    bookcase,
    bowl,
    box_part,
    parts_mesh,
    room_shell,
    table,
)
from interaction_tensor.geometry.core import Geometry

TRAIN_TABLE_HEIGHT = 0.75
#: Sample spacing (m) of the demo, coarser than the library's 1 cm default so that the whole
#: demo (training, 30 % of a 20 m^2 room, outputs) runs in well under a minute on 2 cores.
DEMO_SPACING = 0.02


@dataclass
class DemoExample:
    """The training example and the scene of the demo, with their box parts."""

    query: Geometry
    scene_object: Geometry
    scene: Geometry
    scene_parts: list[Part]
    free_surfaces: dict


def training_example() -> tuple[Geometry, Geometry]:
    """A bowl resting on the middle of a 1.0 x 0.8 m table whose top is at 0.75 m."""
    b = bowl()
    b.vertices = b.vertices + np.array([0.0, 0.0, TRAIN_TABLE_HEIGHT])
    tbl = parts_mesh(table("train-table", (0.0, 0.0), (1.0, 0.8), TRAIN_TABLE_HEIGHT))
    tbl.source = "procedural table (top at 0.75 m)"
    return b, tbl


def demo_room() -> tuple[Geometry, list[Part], dict]:
    """A 5 x 4 m room: floor, two walls, a dining table with a box and a vase on it, a coffee
    table with a low shelf, and a bookcase with a tight lower compartment.

    Returns the mesh, its parts, and the free horizontal surfaces {name: height}.
    """
    parts = room_shell((5.0, 4.0))
    parts += table("dining", (3.2, 2.6), (1.4, 0.9), 0.72)
    # objects on the dining table: the bowl would collide with them
    parts.append(box_part("box-on-dining", (2.9, 2.5, 0.72 + 0.15), (0.30, 0.30, 0.30)))
    parts.append(box_part("vase-on-dining", (3.6, 2.8, 0.72 + 0.12), (0.12, 0.12, 0.24)))
    # coffee table: top at 0.42 m, lower shelf top at 0.10 m (only 0.08 m under it)
    parts += table("coffee", (1.5, 1.4), (1.0, 0.6), 0.42, lower_shelf=0.10)
    # bookcase against the -x wall: boards at 0.10 (a 0.10 m gap above it), 0.20, 0.60, 0.95
    parts += bookcase("bookcase", (0.25, 3.0), (0.36, 1.0), [0.10, 0.20, 0.60, 0.95])
    mesh = parts_mesh(parts)
    mesh.source = "procedural demo room"
    free = {"floor": 0.0, "dining-top": 0.72, "coffee-top": 0.42, "coffee-shelf": 0.10,
            "bookcase-board2": 0.60, "bookcase-top": 0.95}
    return mesh, parts, free


def build() -> DemoExample:
    """The demo's example and scene."""
    q, so = training_example()
    scene, parts, free = demo_room()
    return DemoExample(q, so, scene, parts, free)


def support_part(parts: list[Part], position, tolerance: float = 0.015):
    """The part whose top face holds ``position`` (within ``tolerance`` m), or None."""
    x, y, z = position
    for p in parts:
        if (abs(p.hi[2] - z) <= tolerance and p.lo[0] <= x <= p.hi[0]
                and p.lo[1] <= y <= p.hi[1]):
            return p
    return None


def surface_names(example: DemoExample, positions) -> list[str]:
    """Names of the parts the ``positions`` rest on ("nothing" if none)."""
    out = []
    for pos in positions:
        part = support_part(example.scene_parts, pos)
        out.append(part.name if part is not None else "nothing")
    return out


def collisions(example: DemoExample, points: np.ndarray, margin: float = 0.002) -> int:
    """Number of ``points`` inside any part of the demo room (shrunk by ``margin``)."""
    inside = np.zeros(len(points), bool)
    for p in example.scene_parts:
        inside |= p.contains(points, margin)
    return int(inside.sum())


def clearance_above(example: DemoExample, position, half_width: float = 0.07) -> float:
    """Free height (m) above ``position`` over a square of ``half_width`` around it."""
    x, y, z = position
    best = np.inf
    for p in example.scene_parts:
        if (p.lo[0] < x + half_width and p.hi[0] > x - half_width and p.lo[1] < y + half_width
                and p.hi[1] > y - half_width and p.lo[2] > z + 1e-3):
            best = min(best, p.lo[2] - z)
    return float(best)
