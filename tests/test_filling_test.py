"""Detection's filling tests (``InteractionTensor.fills``, :mod:`interaction_tensor.placement.taps`).

A ranked container must stand where it could be filled: a tap's spout above its opening, a
basin round it and a sink under it. Filling's test points lie on undersides (N_aff points
down), so without these tests a mug is predicted under any shelf, overhang or desk top. The
paper's judge applies the same functions.
"""

from __future__ import annotations

import numpy as np
import pytest

import interaction_tensor as it
from interaction_tensor import affordances
from interaction_tensor.cli.main import _detect_settings, build_parser
from interaction_tensor.examples import shapes
from interaction_tensor.examples.procedural import box_part, parts_mesh
from interaction_tensor.placement import taps

from support import check_switch_round_trip


@pytest.fixture(scope="module")
def filling():
    ex = affordances.build("filling-mug")
    return ex, affordances.build_descriptor("filling-mug", example=ex)


@pytest.fixture(scope="module")
def kitchen(filling):
    """The example's sink with its tap, and 2 m away a table with a shelf 20 cm over it."""
    ex, _ = filling
    other = parts_mesh([box_part("table", (2.0, 0, 0.7), (1.2, 0.6, 0.04)),
                        box_part("shelf", (2.0, 0, 0.92), (1.0, 0.3, 0.02)),
                        box_part("floor", (1.0, 0, -0.005), (4.0, 2.0, 0.01))])
    sink = ex.scene_object
    both = it.Geometry(np.vstack([other.vertices, sink.vertices]),
                       np.vstack([other.faces, sink.faces + len(other.vertices)]))
    return it.prepare_scene(both, 0.01, seed=0)


def test_the_vessel_is_the_mug_standing_in_the_sink(filling):
    ex, tensor = filling
    v = tensor.vessel()
    top = float(ex.query.vertices[:, 2].max())
    assert v.opening[2] == pytest.approx(top)
    assert v.support == pytest.approx(shapes.SINK_BOTTOM, abs=0.002)
    assert 0.03 < v.side < 0.1
    bare = affordances.build_descriptor("filling-mug", example=ex)
    bare.set_acceptance(bare.threshold(), fills=False)
    assert bare.vessel() is None


def test_the_example_fills_and_a_mug_under_a_shelf_does_not(filling, kitchen):
    ex, tensor = filling
    v = tensor.vessel()
    sink = it.prepare_scene(ex.scene_object, 0.01, seed=0)
    assert taps.tap_above(sink.points, sink.tree, v.opening)
    assert taps.basin_sectors(sink.points, sink.tree, v.com, v.support, v.opening[2], v.side,
                              sink.spacing) >= taps.BASIN_SECTORS
    assert taps.sink_sectors(sink.points, sink.normals, sink.tree, v.opening,
                             v.support) >= taps.SINK_SECTORS
    assert taps.fills(v, np.eye(3), np.zeros(3), sink.points, sink.normals, sink.tree,
                      sink.spacing)
    # turned about its axis in the sink: still under the tap
    c, s = np.cos(0.5), np.sin(0.5)
    rot = np.array([[c, -s, 0], [s, c, 0], [0, 0, 1.0]])
    t = v.com - rot @ v.com
    assert taps.fills(v, rot, t, sink.points, sink.normals, sink.tree, sink.spacing)
    # on the table under the shelf: the shelf covers the opening, no spout reaches it
    on_table = np.array([2.0, 0.0, 0.72 - v.support])
    assert not taps.tap_above(kitchen.points, kitchen.tree, v.opening + on_table)
    assert not taps.fills(v, np.eye(3), on_table, kitchen.points, kitchen.normals,
                          kitchen.tree, kitchen.spacing)
    # on the counter beside the basin, under nothing
    counter = np.array([0.4, 0.0, 0.9 - v.support])
    assert not taps.fills(v, np.eye(3), counter, kitchen.points, kitchen.normals,
                          kitchen.tree, kitchen.spacing)


def test_detection_finds_the_tap_and_not_the_shelf(filling, kitchen):
    _, tensor = filling
    det = it.detect(kitchen, tensor, it.DetectSettings(top_k=5))
    off = it.detect(kitchen, tensor, it.DetectSettings(top_k=5, skip_tests=("fills",)))
    assert det.stats["filling_test"] == "on" and det.stats["pairs_not_filling"] > 0
    assert off.stats["filling_test"] == "off (settings)"
    ox, oy, _ = shapes.TAP_OUTLET
    assert len(det.predictions) == 1
    assert np.linalg.norm(det.predictions[0].position[:2] - [ox, oy]) < 0.03
    # without the test, the shelf's underside over the table is a place too
    assert any(p.position[0] > 1.3 for p in off.predictions)
    assert off.predictions[0].point_index == det.predictions[0].point_index


def test_the_setting_survives_a_file_and_a_bad_one_is_refused(filling, tmp_path):
    check_switch_round_trip(filling[1], "fills", tmp_path)


def test_the_cli_skips_the_test():
    args = build_parser().parse_args(["detect", "s.ply", "d.npz", "-o", "out",
                                      "--skip-test", "fills"])
    assert not _detect_settings(args).runs("fills")
