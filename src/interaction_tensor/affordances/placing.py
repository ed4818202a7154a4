"""Placing: an object resting on a horizontal surface, level and fully supported.

The paper's examples are a bowl and a bottle on a table top.
"""

from __future__ import annotations

from interaction_tensor.affordances.registry import (
    UP,
    Affordance,
    ExampleSpec,
    JudgeRule,
    Posed,
)
from interaction_tensor.examples import procedural, shapes
from interaction_tensor.examples.posing import pose_on
from interaction_tensor.geometry.core import Geometry

#: Height (m) of the example's table top.
TABLE_TOP = 0.75


def pose(query: Geometry, spec: ExampleSpec, scene_object_file, seed: int) -> Posed:
    table = shapes.table_mesh(height=TABLE_TOP)
    return Posed(pose_on(query, table, "bottom", (0.0, 0.0), TABLE_TOP, seed), table,
                 (0.0, 0.0, TABLE_TOP))


AFFORDANCE = Affordance(
    name="placing",
    question="Could this object be put down here, to rest there on its own?",
    normal=UP,
    anchor="bottom",
    examples=(ExampleSpec("placing-bottle", "a bottle standing on a table", shapes.bottle,
                          "ycb_mustard_bottle.ply"),
              ExampleSpec("placing-bowl", "a bowl resting on a table", procedural.bowl,
                          "paper_bowl.ply")),
    pose=pose,
    # S_aff, the clearance and interior limits and the contact test of largest F1 against the
    # judge on the validation rooms' pairs; the collision test chosen on the labelled set.
    acceptance=dict(threshold=0.03, gaussian_threshold=0.13,
                    clearance_limit=0.05, interior_limit=0.02,
                    contact=("main", 0.02, 0.9, 90.0),
                    collision=[(0.01, None)], through=False),
    judge=JudgeRule(("upright", "penetration", "contact", "support"), hull=True),
)
