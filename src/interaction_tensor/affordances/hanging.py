"""Hanging: an object hooked over a rail, rod, edge or peg, hanging free below it.

The paper's examples are a coat hanger and a handbag on a clothes rail; the rail passes
through the hook (or the strap's loop).
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
from interaction_tensor.examples.posing import drop_onto, surface_points, translated
from interaction_tensor.geometry.core import Geometry


def pose(query: Geometry, spec: ExampleSpec, scene_object_file, seed: int) -> Posed:
    """The hook's frame origin on the rail's axis, lowered until it rests on the rail."""
    rail = shapes.coat_rail()
    q_pts = surface_points(query, 20000, seed)
    t = np.array([0.0, 0.0, shapes.RAIL_HEIGHT + 0.002])
    dz = drop_onto(q_pts + t, surface_points(rail, 200000, seed + 1))
    t = t - [0, 0, dz if np.isfinite(dz) else 0.0]
    inner = shapes.HOOK_INNER if spec.name == "hanging-hanger" else shapes.LOOP_INNER
    return Posed(translated(query, t), rail,
                 (0.0, 0.0, shapes.RAIL_HEIGHT + shapes.RAIL_RADIUS),
                 (t.copy(), inner, np.array([0.0, 1.0, 0.0])))


AFFORDANCE = Affordance(
    name="hanging",
    question="Could this object be hung up here like this?",
    normal=UP,
    anchor="hook",
    examples=(ExampleSpec("hanging-hanger", "a coat hanger hooked on a clothes rail",
                          shapes.coat_hanger),
              ExampleSpec("hanging-handbag", "a handbag hanging from a clothes rail by its "
                          "strap", shapes.handbag)),
    pose=pose,
    # S_aff and the clearance limit tuned on the validation rooms with the tests chosen on the
    # labelled set applied first: the collision test, the through test (something crosses the
    # hook's opening), the hanging tests (what crosses fits in the hook, which hangs free;
    # the judge's) and the ground test.
    acceptance=dict(threshold=0.03, gaussian_threshold=0.16,
                    clearance_limit=0.10, interior_limit=1.0,
                    contact=("off", 0.02, 0.1, 90.0),
                    collision=[(0.01, None)], through=True, hangs=True, below_ground=0.01),
    judge=JudgeRule(("upright", "penetration", "contact", "loop", "fits", "free", "ground")),
)
