"""Filling: a container standing under a tap, over a sink, where water would fill it.

The paper's examples are a mug and a cup in a sink under the tap. N_aff points down: the test
points lie on the tap's underside, and the descriptor's reference point is found there by
training.
"""

from __future__ import annotations

from interaction_tensor.affordances.registry import (
    DOWN,
    Affordance,
    ExampleSpec,
    JudgeRule,
    Posed,
)
from interaction_tensor.examples import shapes
from interaction_tensor.examples.posing import pose_on
from interaction_tensor.geometry.core import Geometry


def pose(query: Geometry, spec: ExampleSpec, scene_object_file, seed: int) -> Posed:
    sink = shapes.sink_with_tap()
    ox, oy, _ = shapes.TAP_OUTLET
    return Posed(pose_on(query, sink, "bottom", (ox, oy), shapes.SINK_BOTTOM, seed), sink,
                 (ox, oy, shapes.SINK_BOTTOM))


AFFORDANCE = Affordance(
    name="filling",
    question="Could this container be filled where it stands, from a tap in the scene?",
    normal=DOWN,
    anchor="bottom",
    examples=(ExampleSpec("filling-mug", "a mug in a sink under the tap", shapes.mug,
                          "ycb_mug.ply"),
              ExampleSpec("filling-cup", "a cup in a sink under the tap", shapes.cup,
                          "hoi4d_mug.ply")),
    pose=pose,
    # The clearance limit of largest F1 against the judge on the validation rooms' pairs,
    # with the filling tests applied first; the collision test chosen on the labelled set;
    # the filling tests (a tap above, standing, a basin round it, a sink under it) the
    # judge's. They decide: every S_aff from 0.02 to 0.16 gives the validation rooms the
    # same precision and recall (no valid pair there scores below 0.17), and the lowest is
    # kept, as taps unlike the example's score lower (0.05-0.07 under kitchen3's spout).
    # The gaussian criterion's S_aff is its tuning's choice.
    # Settling stands the mug on its support, so there is no through test (what went
    # through the mug was that support). The normal tolerance: a spout's underside turns
    # 25 degrees off straight down.
    acceptance=dict(threshold=0.02, gaussian_threshold=0.02,
                    clearance_limit=0.10, interior_limit=1.0,
                    contact=("off", 0.02, 0.1, 90.0),
                    collision=[(0.01, None)], through=False, fills=True,
                    normal_tolerance=30.0),
    judge=JudgeRule(("upright", "penetration", "contact", "support", "overhead", "basin",
                     "sink"), hull=True),
    reference_at_support=False,
)
