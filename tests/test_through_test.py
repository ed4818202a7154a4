"""Detection's sampled through test (hanging: ``DetectSettings.through``, the descriptor's
``through`` and ``through_section``).

Every pair the score accepts asks whether scene samples cross the posed opening of the hook
(where the example's rail went through it); the exact test on the scene's triangles
(``CollisionCheck``) asks the same of the pairs it ranks. These tests check the grid search
against the cKDTree reference, the hooks it must keep (on a rail, on a thin desk top's edge:
that one is the collision test's to reject) and reject (beside the rail, above it, off its
end, on a cabinet's top), that it keeps every valid hang of the labelled set's validation
rooms, and what detection does with it on and off.
"""

from __future__ import annotations

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

import interaction_tensor as it
from interaction_tensor import affordances
from interaction_tensor.cli.main import _detect_settings, build_parser
from interaction_tensor.engine.numba_backend import available as numba_available
from interaction_tensor.examples.procedural import box_part, parts_mesh
from interaction_tensor.geometry.collision import MeshCollider
from interaction_tensor.placement.checks import (
    FAILS_THROUGH,
    PLACED,
    check_placements,
    through_crossed,
    through_crossed_poses,
    through_polygon,
)

#: only the through test decides
THROUGH_ONLY = ("clearance", "contact", "interior", "ground", "feet", "straddle", "mount")


@pytest.fixture(scope="module")
def room(hanging):
    """The example's rail (along y at the origin), a cabinet (top at 1.6 m) beside it, a desk
    top 3 cm thick (top at 0.75 m) and a wall."""
    ex, _ = hanging
    parts = [box_part("cabinet", (0.6, 0, 0.8), (0.4, 0.4, 1.6)),
             box_part("desk", (-1.0, 0, 0.735), (1.2, 0.6, 0.03)),
             box_part("wall", (0, 1.0, 1.0), (3.0, 0.05, 2.0))]
    geom = parts_mesh(parts)
    rail = ex.scene_object
    both = it.Geometry(np.vstack([geom.vertices, rail.vertices]),
                       np.vstack([geom.faces, rail.faces + len(geom.vertices)]))
    return it.prepare_scene(both, 0.01, seed=0)


def test_the_polygon_is_the_section_in_its_own_plane(hanging):
    _, tensor = hanging
    centre, axes, ring = through_polygon(tensor.through_section)
    np.testing.assert_allclose(axes @ axes.T, np.eye(3), atol=1e-9)
    lifted = centre + ring @ axes[:2]
    # the same vertices (the ring may be turned to run counter-clockwise)
    dist = np.linalg.norm(lifted[:, None] - tensor.through_section[None], axis=2)
    assert dist.min(axis=1).max() < 1e-9
    x, y = ring[:, 0], ring[:, 1]
    assert np.dot(x, np.roll(y, -1)) - np.dot(np.roll(x, -1), y) > 0      # counter-clockwise
    assert np.abs((tensor.through_section - centre) @ axes[2]).max() < 1e-6   # flat


@pytest.mark.skipif(not numba_available(), reason="Numba not installed")
@settings(max_examples=15, deadline=None)
@given(st.integers(0, 2 ** 31 - 1))
def test_the_grid_search_is_the_reference_search(hanging, room, seed):
    _, tensor = hanging
    rng = np.random.default_rng(seed)
    n = 400
    pts = room.points[rng.integers(0, len(room), n)] + rng.normal(0, 0.01, (n, 3))
    orient = rng.integers(0, 8, n)
    fast = through_crossed(pts, orient, tensor, room, 8, room.grid())
    ref = through_crossed(pts, orient, tensor, room, 8, None)
    np.testing.assert_array_equal(fast, ref)
    assert 0 < ref.sum() < n                         # both answers occur


def test_a_hook_on_its_rail_passes_and_beside_above_or_on_a_top_fails(hanging, room):
    ex, tensor = hanging
    rail_top = float(ex.scene_object.vertices[:, 2].max())
    at = np.array([[0.0, 0.0, rail_top]])
    grid = room.grid() if numba_available() else None
    for turn in (0, 4):                                  # hooked from either side
        assert through_crossed(at, [turn], tensor, room, 8, grid).all()
    end = float(np.abs(ex.scene_object.vertices[:, 1]).max()) + 0.05
    cases = {"beside the rail": (0.08, 0, 0), "above it": (0, 0, 0.05),
             "off its end": (0, end, 0), "on the cabinet's top": (0.6, 0, 1.6 - rail_top)}
    for name, shift in cases.items():
        assert not through_crossed(at + shift, [0], tensor, room, 8, grid).any(), name
    # the desk top thinner than the hook goes through it (the collision test rejects it)
    desk = np.array([[-1.0, 0.0, 0.75]])
    assert through_crossed(desk, [0], tensor, room, 8, grid).all()
    # the same through 4x4 poses, and as the exact test on the scene's triangles answers
    poses = np.array([tensor.pose(p, 0.0) for p in
                      [at[0], at[0] + cases["beside the rail"], desk[0]]])
    np.testing.assert_array_equal(through_crossed_poses(poses, tensor, room, grid),
                                  [True, False, True])
    collider, body = MeshCollider(*room.mesh), tensor.through_body()
    assert [collider.collides(body, p) for p in poses] == [True, False, True]


def test_the_placement_tests_reject_hooks_with_nothing_through(hanging, room):
    _, tensor = hanging
    top = float(room.points[:, 2].max())
    on_cabinet = np.array([0.6, 0.0, 1.6])
    on_rail = np.array([0.0, 0.0, float(hanging[0].scene_object.vertices[:, 2].max())])
    pts = np.array([on_rail, on_cabinet])
    assert top >= 1.6
    for grid in ([None, room.grid()] if numba_available() else [None]):
        out = check_placements(pts, np.zeros(2, np.int64), tensor,
                               it.DetectSettings(skip_tests=THROUGH_ONLY), room, grid)[1]
        assert out.tolist() == [PLACED, FAILS_THROUGH]
        off = check_placements(pts, np.zeros(2, np.int64), tensor,
                               it.DetectSettings(skip_tests=THROUGH_ONLY + ("through",)), room, grid)[1]
        assert off.tolist() == [PLACED, PLACED]
    # a descriptor that does not ask for it is not tested
    bare = affordances.build_descriptor("hanging-hanger")
    bare.set_acceptance(bare.threshold(), through=False)
    assert (check_placements(pts, np.zeros(2, np.int64), bare,
                             it.DetectSettings(skip_tests=THROUGH_ONLY), room)[1] == PLACED).all()


def test_detection_spends_the_exact_tests_on_hooks_with_something_through(hanging, room):
    _, tensor = hanging
    up = np.flatnonzero(room.points[:, 2] > 1.55)        # the cabinet's top and the rail's
    base = dict(threshold=1e-3, top_k=5)
    skip = ("clearance", "contact", "interior", "ground", "hangs")   # the through tests alone
    det = it.detect(room, tensor, it.DetectSettings(**base, skip_tests=skip), test_indices=up)
    off = it.detect(room, tensor, it.DetectSettings(**base, skip_tests=skip + ("through",)),
                    test_indices=up)
    assert det.stats["pairs_failing_through"] > 0 and off.stats["pairs_failing_through"] == 0
    # the exact test no longer meets the cabinet-top hooks (both spend the tests allowed:
    # the rail holds fewer than 5 hangers a suppression radius apart)
    assert off.stats["through_test"] == "on" and off.stats["pairs_with_nothing_through"] > 0
    assert det.stats["pairs_with_nothing_through"] < off.stats["pairs_with_nothing_through"]
    # the same predictions, each with something through the hook: the best on the rail
    # (then hooks over the wall's ends and the cabinet's corner edge, other places)
    collider, body = MeshCollider(*room.mesh), tensor.through_body()
    for d in (det, off):
        assert d.predictions and all(collider.collides(body, p.pose) for p in d.predictions)
        assert abs(d.predictions[0].position[0]) < 0.05
        assert len({p.place for p in d.predictions}) == len(d.predictions)
    # the same best pose; then places (grouped from pairs the placement test filtered or
    # not) as far as the exact tests allowed go, which without the placement test are spent
    # on hooks with nothing through sooner
    assert det.predictions[0].point_index == off.predictions[0].point_index
    assert len(off.predictions) >= 3 and len(det.predictions) >= len(off.predictions)


def test_the_cli_turns_the_test_off():

    args = build_parser().parse_args(["detect", "scene.ply", "d.npz", "-o", "out",
                                      "--skip-test", "through"])
    assert not _detect_settings(args).runs("through")
    args = build_parser().parse_args(["detect", "scene.ply", "d.npz", "-o", "out"])
    assert _detect_settings(args).runs("through")
