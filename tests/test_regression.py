"""Detection gives the predictions it gave before the library was reorganised: the demo and
the paper's bowl on a published office, every count and the top 10 recorded from the code as
it was, to guard the decisions against refactoring (any intended change to them updates this
file with the reason in its commit)."""

from __future__ import annotations

import numpy as np
import pytest

import interaction_tensor as it
from interaction_tensor import affordances
from interaction_tensor.examples import demo

from support import shared_file

#: (x, y, z, orientation index, score) of the top 10, best first
DEMO_TOP = [(3.276025, 2.713885, 0.72, 4, 0.92578125), (3.090727, 2.903413, 0.72, 2, 0.923828125),
            (1.387253, 1.471124, 0.42, 1, 0.921875), (1.268494, 1.229061, 0.42, 3, 0.919921875),
            (1.831282, 1.485922, 0.42, 1, 0.919921875),
            (3.750809, 2.391447, 0.72, 1, 0.919921875), (1.087732, 1.498154, 0.42, 2, 0.91796875),
            (3.343353, 2.319659, 0.72, 4, 0.91796875), (1.482313, 1.318622, 0.42, 1, 0.916992188),
            (1.17574, 1.372815, 0.42, 7, 0.9140625)]
DESK_TOP = [(0.801744, 0.107465, 0.75, 6, 0.8828125), (0.331984, -0.002081, 0.430881, 5, 0.873046875),
            (0.693222, 0.2091, 0.75, 1, 0.861328125), (0.557209, 0.266848, 0.75, 1, 0.840820312),
            (0.206897, 0.269551, 0.75, 2, 0.833984375), (0.372307, 0.259725, 0.75, 2, 0.823242188),
            (0.735597, 0.573964, 0.75, 4, 0.823242188), (0.796487, 0.320604, 0.2, 4, 0.822265625),
            (0.68181, 0.414742, 0.75, 3, 0.806640625), (0.258924, 0.555927, 0.75, 3, 0.80078125)]


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
    _check(it.detect(ex.scene, tensor, seed=0), 0.785742188, 296312, 92454, 36474.729492,
           DEMO_TOP)


def test_the_papers_bowl_on_office_desk1_finds_what_it_found():
    tensor = affordances.build_descriptor("placing-bowl",
                                          shared_file("objects/paper_bowl.ply").parent)
    result = it.detect(shared_file("scenes/office-desk1.ply"), tensor, sample_fraction=0.1,
                       seed=0)
    _check(result, 0.03, 20480, 5437, 3254.035156, DESK_TOP)
