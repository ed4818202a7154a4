"""Detection's hanging tests (``InteractionTensor.hangs``, :mod:`interaction_tensor.placement.hooks`).

A ranked hanger must hang from what crosses its hook: the scene through the opening stays
inside the hook's own outline (a rail does; a board's edge along the hook, a cabinet's
corner or a wall's end goes on through the wire), and its bottom keeps off tops and floors.
The paper's judge applies the same functions with its own loop.
"""

from __future__ import annotations

import numpy as np
import pytest
from scipy.spatial import cKDTree

import interaction_tensor as it
from interaction_tensor import affordances
from interaction_tensor.cli.main import _detect_settings, build_parser
from interaction_tensor.examples import shapes
from interaction_tensor.examples.procedural import box_part, parts_mesh
from interaction_tensor.placement import hooks

from support import check_switch_round_trip

#: only the ranked tests and the through test decide
RANKED_ONLY = ("clearance", "contact", "interior", "ground")


def _with(ex, parts) -> it.Scene:
    """The example's rail (along y at the origin) and box ``parts``, sampled at 1 cm."""
    geom = parts_mesh(parts)
    rail = ex.scene_object
    both = it.Geometry(np.vstack([geom.vertices, rail.vertices]),
                       np.vstack([geom.faces, rail.faces + len(geom.vertices)]))
    return it.prepare_scene(both, 0.01, seed=0)


@pytest.fixture(scope="module")
def room(hanging):
    """The rail, a cabinet (top at 1.6 m) beside it and a wall behind."""
    return _with(hanging[0], [box_part("cabinet", (0.6, 0, 0.8), (0.4, 0.4, 1.6)),
                              box_part("wall", (0, 1.0, 1.0), (3.0, 0.05, 2.0))])


def test_the_opening_is_the_hook_round_the_rail(hanging):
    ex, tensor = hanging
    op = tensor.hook_opening()
    # the rail's section, widened by a spacing, fills the hook: its centre within the rail,
    # the plane across the rail, as wide as the hook's opening
    assert abs(op.axis[1]) == pytest.approx(1.0, abs=0.05)
    rail_top = float(ex.scene_object.vertices[:, 2].max())
    assert abs(op.centre[2] - (rail_top - 0.0125)) < 0.0125
    assert op.inside == pytest.approx(shapes.HOOK_INNER, abs=0.005)
    # the wire over the rail and the hanger below close it all round: what passes through
    # may not go on past the opening in any direction
    assert (op.limit == op.inside).all()
    # a descriptor that does not ask for the test has none
    bare = affordances.build_descriptor("hanging-hanger", example=ex)
    bare.set_acceptance(bare.threshold(), hangs=False)
    assert bare.hook_opening() is None


def test_a_rail_fits_and_a_board_along_the_hook_does_not(hanging):
    ex, tensor = hanging
    rot, t = np.eye(3), np.zeros(3)                   # the example's own pose
    op = tensor.hook_opening()
    rail = it.prepare_scene(ex.scene_object, 0.01, seed=0)
    assert hooks.fits(op, rot, t, rail.points, rail.tree, rail.spacing)
    # a 1.5 cm board whose edge runs along the hook's plane, its top where the rail's is:
    # it crosses the opening and goes on through the wire on both sides
    top = float(ex.scene_object.vertices[:, 2].max())
    board = it.prepare_scene(parts_mesh([box_part("board", (0.0, -0.2, top - 0.0075),
                                                  (0.6, 0.42, 0.015))]), 0.01, seed=0)
    assert not hooks.fits(op, rot, t, board.points, board.tree, board.spacing)
    # nothing near: nothing to fit
    far = board.points + [5.0, 0, 0]
    assert hooks.fits(op, rot, t, far, cKDTree(far), 0.01)


def test_a_hanger_resting_on_a_shelf_does_not_hang_free(hanging):
    ex, tensor = hanging
    bottom = tensor.hook_bottom()
    low = float(bottom[:, 2].min())
    assert bottom[:, 2].max() <= low + hooks.FREE_BAND + 1e-9
    shelf = it.prepare_scene(parts_mesh([box_part("shelf", (0.0, 0.0, low - 0.01),
                                                  (0.8, 0.3, 0.02))]), 0.01, seed=0)
    flats = hooks.flat_tree(shelf.points, shelf.normals)
    assert not hooks.hangs_free(bottom, flats)
    assert hooks.hangs_free(bottom + [0, 0, 0.1], flats)
    # a wall beside the bottom is no top to rest on
    wall = it.prepare_scene(parts_mesh([box_part("wall", (0.0, 0.02, low), (0.8, 0.02, 0.4))]),
                            0.01, seed=0)
    assert hooks.hangs_free(bottom, hooks.flat_tree(wall.points, wall.normals))


def test_detection_keeps_the_rail_and_drops_hooks_on_a_corner_or_a_wall_s_end(hanging, room):
    _, tensor = hanging
    up = np.flatnonzero(room.points[:, 2] > 1.55)        # the cabinet's top, the rail, the wall's
    base = dict(threshold=1e-3, top_k=5)
    det = it.detect(room, tensor, it.DetectSettings(**base, skip_tests=RANKED_ONLY),
                    test_indices=up)
    off = it.detect(room, tensor, it.DetectSettings(**base, skip_tests=RANKED_ONLY + ("hangs",)),
                    test_indices=up)
    assert det.stats["hanging_test"] == "on" and det.stats["pairs_not_hanging"] > 0
    assert off.stats["hanging_test"] == "off (settings)" and off.stats["pairs_not_hanging"] == 0
    op = tensor.hook_opening()
    for p in det.predictions:                            # each hangs from what it is on
        assert hooks.fits(op, p.pose[:3, :3], p.pose[:3, 3], room.points, room.tree,
                          room.spacing)
    assert det.predictions and abs(det.predictions[0].position[0]) < 0.05
    assert all(abs(p.position[0]) < 0.05 for p in det.predictions)      # on the rail only
    # without it, hooks over the cabinet's corner and the wall's end are predicted
    away = [p for p in off.predictions if abs(p.position[0]) > 0.3]
    assert away and not any(hooks.fits(op, p.pose[:3, :3], p.pose[:3, 3], room.points,
                                       room.tree, room.spacing) for p in away)
    # the pairs it rejected lost their acceptance, and every accepted pair keeps its place
    failed = det.collisions.state == 1
    assert failed.any() and not det.pairs.accepted[failed].any()
    assert len(det.accepted_place) == len(det.accepted)
    assert (det.accepted_place >= 0).all()
    for place in range(len(det.places)):
        assert all(p.place == place for p in det.place_predictions(place, limit=5))


def test_accepted_pairs_keep_their_places_in_the_saved_result(hanging, room, tmp_path):
    _, tensor = hanging
    up = np.flatnonzero(room.points[:, 2] > 1.55)
    det = it.detect(room, tensor, it.DetectSettings(threshold=1e-3, top_k=5,
                                                    skip_tests=RANKED_ONLY), test_indices=up)
    assert (det.collisions.state == 1).any()
    out = det.save(tmp_path / "r", render=False)
    with np.load(out / "accepted.npz") as data:
        cols = {k: data[k] for k in data.files}
    assert {len(v) for v in cols.values()} == {len(det.accepted)}
    np.testing.assert_array_equal(cols["point_index"], det.pair_point[det.accepted])
    np.testing.assert_array_equal(cols["place"], det.accepted_place)


def test_the_setting_survives_a_file_and_a_bad_one_is_refused(hanging, tmp_path):
    check_switch_round_trip(hanging[1], "hangs", tmp_path)


def test_the_cli_skips_the_test():
    args = build_parser().parse_args(["detect", "s.ply", "d.npz", "-o", "out",
                                      "--skip-test", "hangs"])
    assert not _detect_settings(args).runs("hangs")
    args = build_parser().parse_args(["detect", "s.ply", "d.npz", "-o", "out"])
    assert _detect_settings(args).runs("hangs")
