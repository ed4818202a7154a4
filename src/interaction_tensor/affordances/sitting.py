"""Sitting: a person seated on something that carries the thighs, the feet on a floor.

The paper's example is a person on a stool; the stool is built under the person's seat
(procedural) or, with the paper's stool file, moved under it.
"""

from __future__ import annotations

import numpy as np

from interaction_tensor.affordances.registry import (
    UP,
    Affordance,
    ExampleSpec,
    JudgeRule,
    Posed,
)
from interaction_tensor.examples import shapes
from interaction_tensor.examples.posing import seat_region, surface_points, translated
from interaction_tensor.geometry.core import Geometry
from interaction_tensor.geometry.load import load_geometry


def sitter_and_stool(person: Geometry, stool_file=None, seed: int = 0):
    """A seated person in its own frame (feet flat on z = 0) on a stool built under its seat;
    returns the person, the stool and the stool's top centre.

    The stool's top touches the lowest point of the person's thighs and buttocks over the
    stool; it reaches from 2 cm behind the buttocks to 3 cm short of the calves, 40 cm wide,
    its legs on z = 0, the plane the feet stand on. With ``stool_file`` that stool (the paper's
    stool point cloud, ``stool.ply``) is moved under the seat instead (its top to the seat).
    """
    pts = surface_points(person, 60000, seed)
    person = translated(person, [0.0, 0.0, -float(pts[:, 2].min())])      # feet on z = 0
    pts = pts - [0.0, 0.0, pts[:, 2].min()]
    zs, seat = seat_region(person)
    calves = pts[(pts[:, 2] < zs - 0.1) & (pts[:, 2] > 0.1)]
    front = float(calves[:, 0].min()) - 0.03 if len(calves) else float(seat[:, 0].max())
    back = float(seat[:, 0].min()) - 0.02
    cy = float((seat[:, 1].min() + seat[:, 1].max()) / 2)
    depth, width = front - back, 0.40
    dense = surface_points(person, 200000, seed + 3)
    over = ((np.abs(dense[:, 0] - (front + back) / 2) <= depth / 2)
            & (np.abs(dense[:, 1] - cy) <= width / 2) & (dense[:, 2] > 0.1))
    top = float(dense[over, 2].min())
    if stool_file is None:
        stool = shapes.stool(top, centre_xy=((front + back) / 2, cy), size_xy=(depth, width))
        stool.source = f"procedural stool (top at {top:.3f} m)"
        return person, stool, ((front + back) / 2, cy, top)
    stool = load_geometry(stool_file)
    v = stool.vertices
    centre = (v[:, :2].min(axis=0) + v[:, :2].max(axis=0)) / 2
    stool_top = float(np.percentile(v[np.linalg.norm(v[:, :2] - centre, axis=1) < 0.15, 2], 99))
    shift = np.r_[np.array([(front + back) / 2, cy]) - centre, top - stool_top]
    return person, translated(stool, shift), ((front + back) / 2, cy, top)


def pose(query: Geometry, spec: ExampleSpec, scene_object_file, seed: int) -> Posed:
    person, stool, support = sitter_and_stool(query, scene_object_file, seed)
    return Posed(person, stool, support)


AFFORDANCE = Affordance(
    name="sitting",
    question="Could a person sit here like this?",
    normal=UP,
    anchor="seat",
    examples=(ExampleSpec("sitting-human", "a person seated on a stool", shapes.seated_human,
                          "human_sitting.ply", "stool.ply"),),
    pose=pose,
    # Chosen by the tuning on the validation rooms (the validation top 5 ranked as the
    # evaluation ranks them); the collision test (the body and each limb freed by its own
    # move of at most 2 cm, the judge's rule), the ground test and the feet test on the
    # judge's labelled set (paper/scripts/choose_collision.py).
    acceptance=dict(threshold=0.11, gaussian_threshold=0.17,
                    clearance_limit=0.10, interior_limit=0.02,
                    contact=("main", 0.10, 0.75, 90.0),
                    collision=[(0.02, "limbs")],
                    through=False, below_ground=0.02, feet_reach=0.25),
    judge=JudgeRule(("upright", "penetration", "contact", "support", "feet"), person=True),
)
