"""What the library's tests share: the path of ../shared/data and small procedural examples.

(A module of its own, not conftest.py, so that test modules import it by a name no other
test directory uses.)
"""

from __future__ import annotations

import os
from pathlib import Path

import numpy as np
import pytest

import interaction_tensor as it
from interaction_tensor.errors import InputError
from interaction_tensor.examples.procedural import box_part, parts_mesh

ROOT = Path(__file__).resolve().parents[1]
SHARED_DATA = Path(os.environ.get("ITENSOR_SHARED_DATA", ROOT.parent / "shared" / "data"))


def shared_file(relative: str) -> Path:
    """A file of ../shared/data; the test is skipped when the data set is absent."""
    path = SHARED_DATA / relative
    if not path.exists():
        pytest.skip(f"shared data not found: {path}")
    return path


def descriptor_with_header(src, dst, drop: str | None = None, **changes):
    """Write the descriptor file ``src`` again as ``dst`` with its JSON header's fields
    changed (``changes``) or one field removed (``drop``: a file from before that field);
    returns ``dst``."""
    import json

    with np.load(src) as data:
        raw = {k: data[k] for k in data.files}
    header = {k: v for k, v in json.loads(raw["header"].tobytes()).items() if k != drop}
    raw["header"] = np.frombuffer(json.dumps({**header, **changes}).encode(), np.uint8)
    np.savez(dst, **raw)
    return dst


def check_switch_round_trip(tensor, name: str, tmp_path) -> None:
    """A descriptor's on/off acceptance field ``name`` (on in ``tensor``): written and read
    back on and off, a file holding something else refused naming it, a file from before
    the field read as off."""
    assert getattr(tensor, name) is True and tensor.acceptance()[name] is True
    path = tensor.save(tmp_path / f"{name}.npz")
    assert getattr(it.InteractionTensor.load(path), name) is True
    tensor.set_acceptance(tensor.threshold(), **{name: False})
    try:
        off = it.InteractionTensor.load(tensor.save(tmp_path / f"{name}-off.npz"))
        assert getattr(off, name) is False
    finally:
        tensor.set_acceptance(tensor.threshold(), **{name: True})
    with pytest.raises(InputError, match=name):
        it.InteractionTensor.load(descriptor_with_header(path, tmp_path / "bad.npz",
                                                         **{name: "yes"}))
    old = descriptor_with_header(path, tmp_path / "old.npz", drop=name)
    assert getattr(it.InteractionTensor.load(old), name) is False


def plane(z: float, half: float = 0.1) -> it.Geometry:
    """A square (2 triangles) of side 2*half at height z, normal +Z."""
    v = np.array([[-half, -half, z], [half, -half, z], [half, half, z], [-half, half, z]])
    f = np.array([[0, 1, 2], [0, 2, 3]])
    return it.Geometry(v, f, source=f"plane z={z}")


def corner_example():
    """A 0.2 x 0.1 x 0.08 m box standing in the corner of a floor and two walls.

    Returns (query, scene_object) as Geometry, in metres.
    """
    parts = [box_part("floor", (0, 0, -0.01), (0.6, 0.6, 0.02)),
             box_part("wall-x", (0.31, 0, 0.15), (0.02, 0.6, 0.3)),
             box_part("wall-y", (0, 0.31, 0.15), (0.6, 0.02, 0.3))]
    scene_object = parts_mesh(parts)
    query = parts_mesh([box_part("box", (0.3 - 0.1, 0.3 - 0.05, 0.04), (0.2, 0.1, 0.08))])
    return query, scene_object


def bench_bed_room():
    """A bench 10 cm wide along x (top 0.5 m, x from -1 to 1), a bed 1.6 m wide (top 0.5 m)
    at x = 3, a partition 10 cm wide (top 2.4 m) along x at y = 1, and a floor."""
    parts = [box_part("bench", (0.0, 0.0, 0.25), (2.0, 0.10, 0.5)),
             box_part("bed", (3.0, 0.0, 0.25), (1.0, 1.6, 0.5)),
             box_part("partition", (0.0, 1.0, 1.2), (2.0, 0.10, 2.4)),
             box_part("floor", (1.5, 0.0, -0.01), (6.0, 3.0, 0.02))]
    return it.prepare_scene(parts_mesh(parts), 0.01, seed=0)


def stool_counter_room(floor: bool, counter: float = 0.9):
    """A stool (top 0.45 m) and a counter (top ``counter`` m, its front edge at x = 0.1),
    with or without a floor; the lowest thing scanned without one is the furniture's base."""
    parts = [box_part("stool", (2.0, 0.0, 0.225), (0.4, 0.4, 0.45)),
             box_part("counter", (-0.2, 0.0, counter / 2), (0.6, 1.2, counter))]
    if floor:
        parts.append(box_part("floor", (0.5, 0.0, -0.01), (4.0, 3.0, 0.02)))
    return it.prepare_scene(parts_mesh(parts), 0.01, seed=0)


class FakeCheck:
    """A CollisionCheck stand-in: ``free`` answers from a table and records what it was
    asked."""

    on, exhausted = True, False

    def __init__(self, free):
        self.table, self.asked = free, []

    def free(self, i):
        self.asked.append(i)
        return self.table[i]


def parallel_kernels_run(path, tensor) -> None:
    """Write to ``path`` (.npz) what Numba's parallel kernels decide on a small case: a
    cloud's estimated normals, and the corner box's pairs in its corner as a mesh and as a
    cloud, scored by the grid search and through the neighbour cache. The same in any number of
    threads (a test runs it with several, in a process of its own). ``tensor``: the corner
    box's descriptor file."""
    from interaction_tensor.detection.search import Engine, detect

    _, scene_object = corner_example()
    tensor = it.load_tensor(tensor)
    mesh = it.prepare_scene(scene_object, 0.01, seed=2)
    out = {"normals": it.prepare_scene(it.Geometry(mesh.points), 0.01).normals}
    cloud = it.prepare_scene(it.Geometry(mesh.points, normals=mesh.normals), 0.01)
    for name, scene in (("mesh", mesh), ("cloud", cloud)):
        for cache in (False, True):
            det = detect(scene, tensor, it.DetectSettings(sample_fraction=0.3, seed=4),
                         engine=Engine(neighbour_cache=cache, batch_size=256))
            for field in ("score", "accepted", "decided_at"):
                out[f"{name}-{cache}-{field}"] = getattr(det.pairs, field)
            out[f"{name}-{cache}-top"] = np.array([p.pose for p in det.predictions])
    np.savez(path, **out)
