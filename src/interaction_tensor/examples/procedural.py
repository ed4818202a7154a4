"""Procedural meshes in metres, +Z up: boxes, furniture, a bowl, and rooms built of them.

Every piece of furniture is a list of named axis-aligned boxes (:class:`Part`), so that tests
can check collisions analytically, and one mesh for the detector.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from interaction_tensor.geometry.core import Geometry


@dataclass(frozen=True)
class Part:
    """An axis-aligned box: ``lo`` and ``hi`` corners (m) and a name."""

    name: str
    lo: tuple
    hi: tuple

    def contains(self, points: np.ndarray, margin: float = 0.0) -> np.ndarray:
        """(N,) bool: points strictly inside the box shrunk by ``margin`` on every side."""
        lo = np.asarray(self.lo) + margin
        hi = np.asarray(self.hi) - margin
        return np.all((points > lo) & (points < hi), axis=1)


def box_part(name: str, centre, size) -> Part:
    c, s = np.asarray(centre, float), np.asarray(size, float) / 2
    return Part(name, tuple(c - s), tuple(c + s))


def parts_mesh(parts: list[Part]) -> Geometry:
    """One mesh (outward normals) of all ``parts``."""
    import trimesh

    meshes = []
    for p in parts:
        lo, hi = np.asarray(p.lo), np.asarray(p.hi)
        m = trimesh.creation.box(extents=hi - lo)
        m.apply_translation((lo + hi) / 2)
        meshes.append(m)
    m = trimesh.util.concatenate(meshes)
    return Geometry(np.asarray(m.vertices, float), np.asarray(m.faces, np.int64),
                    source="procedural")


def table(name: str, centre_xy, size_xy, height: float, top: float = 0.03,
          leg: float = 0.05, lower_shelf: float | None = None) -> list[Part]:
    """A table: top surface at ``height``, four legs, optionally a lower shelf whose top is
    at ``lower_shelf``."""
    x, y = centre_xy
    w, d = size_xy
    parts = [box_part(f"{name}-top", (x, y, height - top / 2), (w, d, top))]
    for i, (sx, sy) in enumerate([(-1, -1), (-1, 1), (1, -1), (1, 1)]):
        parts.append(box_part(f"{name}-leg{i}", (x + sx * (w / 2 - leg / 2), y + sy * (d / 2 - leg / 2),
                                                 (height - top) / 2), (leg, leg, height - top)))
    if lower_shelf is not None:
        parts.append(box_part(f"{name}-shelf", (x, y, lower_shelf - 0.01),
                              (w - 2 * leg, d - 2 * leg, 0.02)))
    return parts


def bookcase(name: str, centre_xy, size_xy, boards: list[float], board: float = 0.02,
             side: float = 0.02) -> list[Part]:
    """Side panels and horizontal boards whose top surfaces are at ``boards`` (m)."""
    x, y = centre_xy
    w, d = size_xy
    top = max(boards)
    parts = [box_part(f"{name}-side0", (x - w / 2 + side / 2, y, top / 2), (side, d, top)),
             box_part(f"{name}-side1", (x + w / 2 - side / 2, y, top / 2), (side, d, top))]
    for i, z in enumerate(boards):
        parts.append(box_part(f"{name}-board{i}", (x, y, z - board / 2), (w - 2 * side, d, board)))
    return parts


def bowl(radius: float = 0.072, height: float = 0.05, foot: float = 0.03,
         wall: float = 0.004, sections: int = 48) -> Geometry:
    """A watertight bowl of revolution resting on z = 0 at the origin (foot ring below)."""
    import trimesh

    r, h, f, t = radius, height, foot, wall
    profile = np.array([
        [0.0, 0.0], [f, 0.0], [f + 0.004, 0.004], [0.62 * r, 0.35 * h], [0.9 * r, 0.75 * h],
        [r, h], [r - t, h], [0.9 * r - t, 0.75 * h - t / 2], [0.62 * r - t, 0.35 * h + t / 2],
        [f, 0.004 + t], [0.0, 0.004 + t]])
    m = trimesh.creation.revolve(profile, sections=sections)
    return Geometry(np.asarray(m.vertices, float), np.asarray(m.faces, np.int64),
                    source="procedural bowl")


def room_shell(size_xy, wall_height: float = 2.4, floor: float = 0.05,
               walls: str = "xy") -> list[Part]:
    """A floor slab (top at z = 0) and walls along the -x and -y sides."""
    w, d = size_xy
    parts = [box_part("floor", (w / 2, d / 2, -floor / 2), (w, d, floor))]
    if "x" in walls:
        parts.append(box_part("wall-x", (-0.05, d / 2, wall_height / 2), (0.1, d, wall_height)))
    if "y" in walls:
        parts.append(box_part("wall-y", (w / 2, -0.05, wall_height / 2), (w, 0.1, wall_height)))
    return parts
