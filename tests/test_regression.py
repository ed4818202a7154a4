"""Detection gives the predictions it gave when they were recorded: the demo and the paper's
bowl on a published office, every count and the top 10 recorded from the code, to guard the
decisions against refactoring (any intended change to them updates this file with the reason
in its commit)."""

from __future__ import annotations

import numpy as np
import pytest

import interaction_tensor as it
from interaction_tensor import affordances
from interaction_tensor.examples import demo

from support import shared_file

#: (x, y, z, orientation index, score) of the top 10, best first
DEMO_TOP = [(3.090727, 2.903413, 0.72, 2, 0.923828125), (1.229407, 1.360839, 0.42, 4, 0.919921875),
            (0.270704, 3.077068, 0.95, 1, 0.866210938), (1.448458, 1.335915, 0.1, 5, 0.866210938),
            (0.238165, 2.765492, 0.6, 6, 0.853515625), (0.233718, 2.640465, 0.2, 6, 0.8515625),
            (0.235438, 2.856326, 0.1, 3, 0.83203125), (2.319292, 3.140287, 0.0, 3, 0.818359375),
            (2.881154, 2.500482, 1.02, 6, 0.810546875)]
DESK_TOP = [(0.3322, -0.00251, 0.430881, 5, 0.876953125), (0.763687, 0.118815, 0.75, 4, 0.876953125),
            (0.819001, 0.357098, 0.2, 7, 0.818359375), (0.141806, 0.624858, 0.9, 0, 0.80078125),
            (0.803321, 0.289955, 0.0, 6, 0.796875), (0.49243, 0.611341, 0.9, 3, 0.770507812),
            (0.826472, 0.060713, 0.17, 0, 0.60546875), (0.457504, 0.438688, 0.8724, 0, 0.411132812),
            (0.978003, 0.573135, 0.9, 1, 0.385742188), (0.345088, 0.654325, 1.11784, 2, 0.1875)]


def _check(result, threshold, pairs, accepted, heat_sum, top):
    assert result.threshold == pytest.approx(threshold, abs=1e-9)
    assert len(result.pair_point) == pairs
    assert int(result.pairs.accepted.sum()) == accepted
    assert float(result.heat.sum()) == pytest.approx(heat_sum, abs=1e-3)
    got = [(*np.round(p.position, 6), p.orientation_index, p.score) for p in result.predictions]
    assert len(got) == len(top)
    for g, w in zip(got, top):
        np.testing.assert_allclose(g[:3], w[:3], atol=2e-6)
        assert g[3] == w[3] and g[4] == pytest.approx(w[4], abs=1e-8)


def test_the_demo_finds_what_it_found():
    ex = demo.build()
    tensor = it.train(ex.query, ex.scene_object, "placing-bowl", spacing=demo.DEMO_SPACING)
    _check(it.detect(ex.scene, tensor, seed=0), 0.785791015625, 145712, 91057, 36371.994141,
           DEMO_TOP)


def test_the_papers_bowl_on_office_desk1_finds_what_it_found():
    tensor = affordances.build_descriptor("placing-bowl",
                                          shared_file("objects/paper_bowl.ply").parent)
    result = it.detect(shared_file("scenes/office-desk1.ply"), tensor, sample_fraction=0.1,
                       seed=0)
    _check(result, 0.03, 17248, 4238, 2397.459961, DESK_TOP)
