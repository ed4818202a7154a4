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
