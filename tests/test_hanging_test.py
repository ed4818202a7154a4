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
    # may not go on past the opening in any direction, nor past the hook's own wire where
    # that is nearer (a few millimetres nearer in a few directions)
    assert np.isfinite(op.limit).all() and (op.limit <= op.inside).all()
    assert (op.limit > 0.9 * op.inside).all()
    loose = hooks.opening(tensor._hook_samples(), op.centre, op.axis, op.inside)
    assert (loose.limit == op.inside).all()
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
    # a place whose pairs all failed is no place found: every place keeps an accepted pair,
    # and its best score is its best accepted pair's
    assert (np.bincount(det.accepted_place, minlength=len(det.places)) > 0).all()
    for place in det.places:
        mine = det.accepted[det.accepted_place == place.index]
        assert place.score == pytest.approx(det.pairs.score[mine].max())
        assert place.pairs == len(mine)
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


def _sections(parts):
    from interaction_tensor.geometry.sections import MeshSections

    g = parts_mesh(parts)
    return MeshSections(g.vertices, g.faces)


def test_a_plane_cuts_a_box_along_its_outline():
    cut = _sections([box_part("b", (0.0, 0.0, 0.5), (0.4, 0.2, 0.1))])
    seg = cut.segments((0.0, 0.0, 0.5), (0.0, 1.0, 0.0), reach=1.0)
    pts = seg.reshape(-1, 3)
    np.testing.assert_allclose(pts[:, 1], 0.0, atol=1e-12)          # in the plane
    # on the box's outline: |x| = 0.2 or |z - 0.5| = 0.05, within the box
    edge = np.isclose(np.abs(pts[:, 0]), 0.2) | np.isclose(np.abs(pts[:, 2] - 0.5), 0.05)
    assert edge.all() and (np.abs(pts[:, 0]) <= 0.2 + 1e-12).all()
    assert np.linalg.norm(seg[:, 1] - seg[:, 0], axis=1).sum() == pytest.approx(2 * (0.4 + 0.1))
    along = cut.points((0.0, 0.0, 0.5), (0.0, 1.0, 0.0), reach=1.0, step=0.002)
    assert len(along) >= 1.0 / 0.002
    # within reach only, and nothing where the plane misses the box
    near = cut.points((0.0, 0.0, 0.5), (0.0, 1.0, 0.0), reach=0.1, step=0.002)
    assert len(near) and (np.linalg.norm(near - [0.0, 0.0, 0.5], axis=1) <= 0.1 + 1e-12).all()
    assert not len(cut.segments((0.0, 0.5, 0.5), (0.0, 1.0, 0.0), reach=1.0))


def test_the_fit_kernel_decides_as_its_reference(hanging, room):
    """The Numba cut-and-pieces kernel against NumPy and SciPy's, on hooks posed over the
    rail, the cabinet's top and edges, the wall and open air, turned every way about +Z and
    tilted: the same decision for every pose, both decisions among them."""
    from scipy.spatial.transform import Rotation

    _, tensor = hanging
    op, cut = tensor.hook_opening(), room.sections()
    rng = np.random.default_rng(11)
    anchors = np.vstack([np.column_stack([rng.normal(scale=0.02, size=40),
                                          rng.uniform(-0.4, 0.4, 40),
                                          rng.normal(scale=0.02, size=40)]),
                         room.points[rng.choice(len(room.points), 120)]])
    got = []
    for i, t in enumerate(anchors):
        rot = Rotation.from_euler("zx", [rng.uniform(0, 360), rng.normal(scale=8)],
                                  degrees=True).as_matrix()
        t = t - rot @ op.centre
        args = (op, rot, t, room.points, room.tree, room.spacing)
        fast = hooks.fits(*args, sections=cut, normals=room.normals)
        assert fast == hooks.fits(*args, sections=cut, normals=room.normals,
                                  reference=True), i
        got.append(fast)
    assert any(got) and not all(got)


def test_a_cut_visits_the_faces_near_it_as_every_face_s_box_says():
    """The faces indexed by the cubes their boxes meet give a query exactly the faces whose
    boxes come within its reach, as testing every face does: small and large triangles
    (a floor's, listed apart), queries inside, across and outside the mesh, of any reach."""
    from interaction_tensor.geometry.sections import MeshSections

    rng = np.random.default_rng(5)
    small = rng.uniform(-1, 1, (400, 1, 3)) + rng.normal(scale=0.05, size=(400, 3, 3))
    large = rng.uniform(-3, 3, (6, 3, 3))
    tri = np.concatenate([small, large])
    cut = MeshSections(tri.reshape(-1, 3), np.arange(len(tri) * 3).reshape(-1, 3), cell=0.15)
    assert len(cut.large) >= 1
    for centre in rng.uniform(-2.5, 2.5, (60, 3)):
        for reach in (0.01, 0.1, 0.3, 2.0):
            brute = np.flatnonzero(((cut.lo <= centre + reach)
                                    & (cut.hi >= centre - reach)).all(axis=1))
            got = cut.triangles_near(centre, reach).reshape(-1, 9)
            want = tri[brute].reshape(-1, 9)
            assert np.array_equal(got[np.lexsort(got.T)], want[np.lexsort(want.T)]), \
                (centre, reach)
    empty = MeshSections(np.zeros((0, 3)), np.zeros((0, 3), np.int64))
    assert not len(empty.triangles_near(np.zeros(3), 0.3))
    assert not len(empty.segments(np.zeros(3), (0.0, 0.0, 1.0), 0.3))


def test_on_a_mesh_a_thick_top_under_the_hook_does_not_fit_however_it_was_sampled(hanging):
    """A 10 cm wall's top under the hook: its samples in a thin slab leave gaps of several
    centimetres, where it looks like a rod; the mesh's exact cut does not."""
    ex, tensor = hanging
    op = tensor.hook_opening()
    rot, t = np.eye(3), np.zeros(3)
    # the wall along the rail, its top inside the hook's opening: its section is a 10 cm
    # wide slab's end
    top = float(op.centre[2] + 0.5 * op.inside)
    wall = [box_part("wall", (0.0, 0.0, top - 0.5), (0.1, 2.0, 1.0))]
    cut = _sections(wall)
    scene = it.prepare_scene(parts_mesh(wall), 0.01, seed=0)
    assert not hooks.fits(op, rot, t, scene.points, scene.tree, scene.spacing, sections=cut)
    # the rail itself fits, cut exactly as sampled
    rail = it.prepare_scene(ex.scene_object, 0.01, seed=0)
    assert hooks.fits(op, rot, t, rail.points, rail.tree, rail.spacing,
                      sections=rail.sections())
    # nothing crossing the plane near the hook: nothing to fit
    far = _sections([box_part("far", (3.0, 0.0, top - 0.5), (0.1, 2.0, 1.0))])
    assert hooks.fits(op, rot, t, scene.points + 3.0, None, 0.01, sections=far)


def test_on_a_mesh_what_runs_along_the_hook_beside_its_plane_does_not_fit(hanging,
                                                                         monkeypatch):
    """Beside the rail, a pipe rising from inside the hook a few millimetres off its plane
    (a faucet's elbow) and a plate lying along the plane (a lamp shade's flat end) go on
    through the wire: the cuts beside the plane find the pipe and the slab's samples facing
    along the axis the plate, which the plane's own cut misses."""
    ex, tensor = hanging
    op = tensor.hook_opening()
    rot, t = np.eye(3), np.zeros(3)
    c = op.centre
    pipe = box_part("pipe", (c[0], c[1] + 0.005, c[2] + 0.1), (0.006, 0.006, 0.2))
    plate = box_part("plate", (c[0], c[1] + 0.003, c[2] + 0.1), (0.1, 0.002, 0.2))
    for part in (pipe, plate):
        scene = _with(ex, [part])
        args = (op, rot, t, scene.points, scene.tree, scene.spacing)
        cut = scene.sections()
        assert not hooks.fits(*args, sections=cut, normals=scene.normals)
        assert not hooks.fits(*args, sections=cut, normals=scene.normals, reference=True)
        with monkeypatch.context() as m:
            m.setattr(hooks, "SECTION_OFFSETS", (0.0,))
            assert hooks.fits(*args, sections=cut)
    # the plate's faces lie between the cuts: only its samples find it
    scene = _with(ex, [plate])
    assert hooks.fits(op, rot, t, scene.points, scene.tree, scene.spacing,
                      sections=scene.sections())
    rail = it.prepare_scene(ex.scene_object, 0.01, seed=0)
    assert hooks.fits(op, rot, t, rail.points, rail.tree, rail.spacing,
                      sections=rail.sections(), normals=rail.normals)


def test_a_fold_round_its_bar_is_tight_and_a_bar_under_the_cloth_does_not_fit():
    """A towel's fold hugs its bar closer than the bar's section widened by a spacing: the
    bar held up against the cloth from inside (the towel hung from the bar's underside)
    goes on past the fold."""
    r, inner, cloth = 0.011, 0.014, 0.004
    ang = np.linspace(0.0, np.pi, 24)
    arc = np.c_[(inner + cloth / 2) * np.cos(ang), np.zeros_like(ang),
                (inner + cloth / 2) * np.sin(ang) - (inner - r)]
    sheets = [np.c_[np.full(40, sx * (inner + cloth / 2)), np.zeros(40),
                    np.linspace(-0.3, -(inner - r), 40)] for sx in (-1, 1)]
    fold = np.vstack([arc] + sheets)
    fold = np.vstack([fold + [0.0, y, 0.0] for y in np.linspace(-0.01, 0.01, 5)])
    section = np.c_[(r + 0.01) * np.cos(np.linspace(0, 2 * np.pi, 24, endpoint=False)),
                    np.zeros(24), (r + 0.01) * np.sin(np.linspace(0, 2 * np.pi, 24,
                                                                  endpoint=False))]
    op = hooks.opening_of(fold, section)
    assert op is not None and np.isfinite(op.limit).any()
    assert op.limit[np.isfinite(op.limit)].min() < op.inside - 0.005
    bar = [box_part("bar", (0.0, 0.0, 0.0), (0.02, 0.6, 0.02))]
    cut, scene = _sections(bar), it.prepare_scene(parts_mesh(bar), 0.005, seed=0)
    rot = np.eye(3)
    assert hooks.fits(op, rot, np.zeros(3), scene.points, scene.tree, scene.spacing,
                      sections=cut)
    low = np.array([0.0, 0.0, -2 * r])                 # the fold 2.2 cm down: the bar in it
    assert not hooks.fits(op, rot, low, scene.points, scene.tree, scene.spacing, sections=cut)
