"""Places: accepted pairs grouped into connected regions, one prediction per place, and mesh
samples that nothing can reach left out of the scene."""

from __future__ import annotations

import numpy as np
import pytest
import trimesh

import interaction_tensor as it
from interaction_tensor.detection.places import group_places, place_cell, top_k
from interaction_tensor.examples import demo
from interaction_tensor.examples.procedural import box_part, parts_mesh
from interaction_tensor.geometry.core import Geometry
from interaction_tensor.geometry.grid import KNearest
from interaction_tensor.geometry.sampling import (
    buried_samples,
    closed_windings,
    mean_spacing,
    mesh_area,
    sample_mesh,
    winding_numbers,
)
from interaction_tensor.geometry.scene import thinned


def _patch(rng, lo, hi, z, n):
    """``n`` random points on the horizontal rectangle ``lo``-``hi`` at height ``z``."""
    xy = rng.uniform(lo, hi, size=(n, 2))
    return np.column_stack([xy, np.full(n, z)])


def test_places_are_connected_surfaces_apart_in_height_or_across():
    rng = np.random.default_rng(0)
    # a floor, a shelf 10 cm above part of it, a table top far away; 1 cm samples, 30 % drawn
    floor = _patch(rng, (0, 0), (2, 1), 0.0, 6000)
    shelf = _patch(rng, (0.2, 0.2), (0.8, 0.6), 0.10, 720)
    table = _patch(rng, (3.0, 0.0), (3.5, 0.5), 0.72, 750)
    pts = np.vstack([floor, shelf, table])
    pair_point = np.repeat(np.arange(len(pts)), 2)
    score = rng.uniform(0.5, 0.9, len(pair_point))
    score[2 * len(floor) + 2 * len(shelf) + 7] = 0.99          # the best pair: on the table
    accepted = np.flatnonzero(rng.random(len(pair_point)) < 0.8)
    cell = place_cell(0.01, 0.3)
    place, places = group_places(pts, pair_point, score, accepted, cell)
    assert len(places) == 3
    assert places[0].score == 0.99 and places[0].centroid[0] > 2.9        # the table first
    heights = sorted(round(float(p.centroid[2]), 2) for p in places)
    assert heights == [0.0, 0.1, 0.72]
    for p in places:
        mine = accepted[place == p.index]
        assert p.pairs == len(mine) and p.score == score[mine].max()
        assert p.points == len(np.unique(pair_point[mine]))
        assert np.ptp(pts[pair_point[mine], 2]) == 0
    # the same surfaces seen along another normal: the cells follow the normal
    turn = pts[:, [2, 0, 1]]
    place2, places2 = group_places(turn, pair_point, score, accepted, cell, (1.0, 0.0, 0.0))
    assert len(places2) == 3 and np.array_equal(place2, place)


def test_a_sparse_scene_keeps_surfaces_apart_in_height():
    """In a 3 cm cloud (a 1 cm descriptor, 30 % drawn), a rug's top 7 cm above the floor is
    its own place: the cells are as tall as the descriptor's, not the cloud's, spacing; across
    they follow the cloud's, so neither surface splits."""
    rng = np.random.default_rng(3)
    floor = _patch(rng, (0, 0), (2, 1), 0.0, 670)
    rug = _patch(rng, (0.5, 0.3), (1.5, 0.9), 0.07, 200)
    pts = np.vstack([floor, rug])
    every = np.arange(len(pts))
    cell = place_cell(0.03, 0.3, 0.01)
    assert cell[1] == pytest.approx(0.02) and cell[0] == pytest.approx(2.5 * 0.03 / 0.3 ** 0.5)
    place, places = group_places(pts, every, rng.uniform(0.5, 0.9, len(pts)), every, cell)
    assert len(places) == 2 and len(set(place[len(floor):])) == 1
    # with cells as tall as the cloud's spacing, the rug would join the floor
    assert len(group_places(pts, every, np.ones(len(pts)), every, place_cell(0.03, 0.3))[1]) == 1


def test_a_gap_wider_than_the_cells_splits_a_surface():
    rng = np.random.default_rng(1)
    a = _patch(rng, (0, 0), (0.5, 0.5), 0.4, 800)
    b = _patch(rng, (0.8, 0), (1.3, 0.5), 0.4, 800)           # 30 cm away, same height
    pts = np.vstack([a, b])
    score = rng.uniform(0.5, 0.9, len(pts))
    place, places = group_places(pts, np.arange(len(pts)), score, np.arange(len(pts)),
                                 place_cell(0.01, 0.3))
    assert len(places) == 2
    assert len(set(place[:800])) == 1 and len(set(place[800:])) == 1


def test_top_k_takes_one_pick_per_group():
    pos = np.array([[0, 0, 0], [0.5, 0, 0], [1.0, 0, 0], [5.0, 0, 0], [6.0, 0, 0]], float)
    scores = np.array([0.9, 0.8, 0.7, 0.6, 0.5])
    group = np.array([0, 0, 0, 1, -1])
    assert top_k(pos, scores, 5, 0.1) == [0, 1, 2, 3, 4]
    assert top_k(pos, scores, 5, 0.1, group=group) == [0, 3, 4]
    # the radius parts poses of no place; two places are two answers however near
    assert top_k(pos, scores, 5, 2.0) == [0, 3]
    assert top_k(pos, scores, 5, 2.0, group=np.array([0, 1, 2, 3, 4])) == [0, 1, 2, 3, 4]
    assert top_k(pos, scores, 5, 2.0, group=np.array([0, 1, 2, 3, -1])) == [0, 1, 2, 3]
    # a group whose best is refused gives its next best
    assert top_k(pos, scores, 5, 0.1, group=group, accept=lambda i: i != 0) == [1, 3, 4]
    # through the gathered path (scene points and point indices)
    assert top_k(pos, scores, 2, 0.1, index=np.arange(5), group=group) == [0, 3]


def test_buried_samples_are_those_another_closed_part_covers():
    plate = box_part("plate", (0.0, 0.0, -0.01), (1.0, 1.0, 0.02))      # top at z = 0
    block = box_part("block", (0.0, 0.0, 0.1), (0.2, 0.2, 0.2))         # stands on it
    mesh = parts_mesh([plate, block])
    pts, nrm, faces = sample_mesh(mesh, 40000, 0, with_faces=True)
    buried = buried_samples(mesh.vertices, mesh.faces, pts, nrm, faces)
    top = np.isclose(pts[:, 2], 0.0) & (nrm[:, 2] > 0.9)
    under = top & (np.abs(pts[:, :2]) < 0.1 - 1e-6).all(axis=1)
    clear = top & (np.abs(pts[:, :2]) > 0.1 + 1e-6).any(axis=1)
    assert under.sum() > 100
    assert buried[under].all() and not buried[clear].any()
    assert not buried[pts[:, 2] > 0.01].any()                  # the block's own faces
    # an open surface (one side of the plate only) buries nothing
    open_faces = mesh.faces[:len(mesh.faces) // 2][:10]
    opened = Geometry(mesh.vertices, open_faces)
    p2, n2, f2 = sample_mesh(opened, 2000, 0, with_faces=True)
    assert not buried_samples(opened.vertices, opened.faces, p2, n2, f2).any()


def test_a_mesh_scene_leaves_out_what_another_part_covers():
    ex = demo.build()
    scene = it.load_scene(ex.scene, demo.DEMO_SPACING)
    assert any("inside closed parts" in note for note in scene.notes)
    box = next(p for p in ex.scene_parts if p.name == "box-on-dining")
    lo, hi = np.asarray(box.lo), np.asarray(box.hi)
    inside = ((scene.points > lo + 1e-3) & (scene.points < hi - 1e-3)).all(axis=1)
    assert not inside.any()
    under = ((np.abs(scene.points[:, 2] - lo[2]) < 1e-6)
             & (scene.points[:, :2] > lo[:2] + 0.01).all(axis=1)
             & (scene.points[:, :2] < hi[:2] - 0.01).all(axis=1))
    assert not under.any()


@pytest.fixture(scope="module")
def demo_result():
    ex = demo.build()
    tensor = it.train(ex.query, ex.scene_object, "placing-bowl", spacing=demo.DEMO_SPACING)
    return it.detect(ex.scene, tensor, sample_fraction=0.1)


def test_every_pose_of_a_place(demo_result):
    r = demo_result
    assert r.places and r.stats["places"] == len(r.places)
    assert [p.place for p in r.predictions] == list(range(len(r.predictions)))
    poses = r.place_predictions(1)
    assert len(poses) == r.places[1].pairs
    assert poses[0].score == r.places[1].score == r.predictions[1].score
    assert all(a.score >= b.score for a, b in zip(poses, poses[1:]))
    assert {p.place for p in poses} == {1}
    lo, hi = r.places[1].lo, r.places[1].hi
    assert all(np.all(lo <= p.position) and np.all(p.position <= hi) for p in poses)
    assert len(r.place_predictions(1, limit=3)) == 3
    with pytest.raises(IndexError, match="out of range"):
        r.place_predictions(len(r.places))
    assert "places" in repr(r) and "Place(0:" in repr(r.places[0])


def test_thinning_keeps_one_measured_point_per_cube():
    rng = np.random.default_rng(2)
    n = 160_000                                        # a 2 x 2 m plane, 5 mm apart
    pts = np.column_stack([rng.uniform(0, 2, n), rng.uniform(0, 2, n), np.full(n, 0.3)])
    keep = thinned(pts, 0.02)
    assert np.all(np.diff(keep) > 0)
    cubes = np.floor((pts[keep] - pts.min(axis=0)) / 0.02).astype(int)
    assert len(np.unique(cubes, axis=0)) == len(keep) == 10_000
    assert mean_spacing(pts[keep]) == pytest.approx(0.02, rel=0.05)
    # each kept point is the one of its cube nearest the cube's centre
    one = np.flatnonzero((np.floor((pts - pts.min(axis=0)) / 0.02) == cubes[0]).all(axis=1))
    centre = pts.min(axis=0) + (cubes[0] + 0.5) * 0.02
    assert keep[0] == one[np.argmin(((pts[one] - centre) ** 2).sum(axis=1))]


def test_a_dense_cloud_gives_the_places_of_the_mesh():
    """A room as a 5 mm cloud (an array, no normals) is thinned to the descriptor's 2 cm and
    gives the places of the same room as a mesh; a cloud at the spacing is kept whole."""
    room = _furnished_room()
    ex = demo.build()
    tensor = it.train(ex.query, ex.scene_object, "placing-bowl", spacing=demo.DEMO_SPACING)
    mesh = it.detect(room, tensor)
    dense = sample_mesh(room, round(mesh_area(room) / 0.005 ** 2), 3)[0]
    cloud = it.detect(dense, tensor)
    assert any("thinned from" in n for n in cloud.scene.notes)
    assert cloud.scene.spacing == pytest.approx(demo.DEMO_SPACING, rel=0.1)
    heights = [sorted(round(float(p.centroid[2]), 2) for p in r.places) for r in (mesh, cloud)]
    assert heights[0] == heights[1] == [0.0, 0.4, 0.75], heights
    kept = it.load_scene(sample_mesh(room, round(mesh_area(room) / 0.02 ** 2), 3)[0],
                         demo.DEMO_SPACING)
    assert not any("thinned" in n for n in kept.notes)


def _furnished_room():
    """A floor, a wall, a table and a shelf; boards 5 cm thick, as a scan sees one face of
    thinner ones (a mesh's two faces of a 2 cm board, both sampled, are two surfaces within
    a 3 cm spacing)."""
    parts = [box_part("floor", (0, 0, -0.025), (2.0, 2.0, 0.05)),
             box_part("wall", (0, 1.05, 0.6), (2.0, 0.1, 1.2)),
             box_part("top", (0.2, 0.1, 0.725), (0.9, 0.6, 0.05)),
             box_part("shelf", (-0.6, -0.6, 0.375), (0.5, 0.4, 0.05))]
    parts += [box_part(f"leg{i}", (0.2 + sx * 0.4, 0.1 + sy * 0.25, 0.36), (0.04, 0.04, 0.72))
              for i, (sx, sy) in enumerate([(-1, -1), (1, -1), (-1, 1), (1, 1)])]
    return parts_mesh(parts)


@pytest.mark.parametrize("spacing", [0.005, 0.01, 0.02, 0.03])
def test_a_furnished_room_s_spacing_is_measured_on_its_surfaces(spacing):
    """Other surfaces crossing the counting disk (the wall at the floor's edge, a board's
    other face, a box on the top) do not count: a furnished room sampled at ``spacing`` is
    measured within 5 % of it, with 3 mm of noise too."""
    room = _furnished_room()
    pts = sample_mesh(room, round(mesh_area(room) / spacing ** 2), 4)[0]
    assert mean_spacing(pts) == pytest.approx(spacing, rel=0.05)
    noisy = pts + np.random.default_rng(5).normal(0, 0.003, pts.shape)
    if spacing >= 0.01:                  # noise under a third of the spacing
        assert mean_spacing(noisy) == pytest.approx(spacing, rel=0.05)


@pytest.mark.parametrize("factor", [1.0, 1.5])
def test_a_sparse_cloud_gives_the_places_of_the_mesh(factor):
    """The room as a cloud at the descriptor's 2 cm and 1.5 times sparser (3 cm; an array of
    points and normals) gives the mesh's places: the same surfaces, none split, and the top
    (0.75 m) and the shelf (0.40 m) apart from the floor however tall the cells."""
    room = _furnished_room()
    ex = demo.build()
    tensor = it.train(ex.query, ex.scene_object, "placing-bowl", spacing=demo.DEMO_SPACING)
    mesh = it.detect(room, tensor)
    spacing = factor * demo.DEMO_SPACING
    points, normals = sample_mesh(room, round(mesh_area(room) / spacing ** 2), 3)
    cloud = it.detect(np.column_stack([points, normals]), tensor)
    assert cloud.scene.spacing == pytest.approx(spacing, rel=0.1)
    heights = [sorted(round(float(p.centroid[2]), 1) for p in r.places) for r in (mesh, cloud)]
    assert heights[0] == heights[1] == [0.0, 0.4, 0.8], heights


def test_normals_of_a_sparse_bookcase_are_fitted_on_each_board_s_own_face():
    """A bookcase's 2 cm boards sampled on every face at 2 cm: a point's 16 nearest reach
    past its board's top to the edge and underside, and one plane fitted through them all
    turns a third of the tops' normals more than 15 degrees from up; fitted again with the
    neighbours near the first plane through the point, most come back."""
    from scipy.spatial import cKDTree

    from interaction_tensor.geometry.sampling import estimate_normals

    parts = [box_part(f"board{i}", (0, 0, 0.1 + 0.3 * i), (0.25, 0.85, 0.02))
             for i in range(4)]
    parts += [box_part(f"side{i}", (0, y, 0.5), (0.25, 0.02, 1.0))
              for i, y in enumerate((-0.44, 0.44))]
    case = parts_mesh(parts)
    pts, true = sample_mesh(case, round(mesh_area(case) / 0.02 ** 2), 2)
    tops = true[:, 2] > 0.97
    _, idx = cKDTree(pts).query(pts, k=16)
    nb = pts[idx] - pts[idx].mean(axis=1, keepdims=True)
    once = np.linalg.eigh(np.einsum("nki,nkj->nij", nb, nb))[1][:, :, 0]
    up = np.cos(np.radians(15))
    assert (np.abs(once[tops, 2]) > up).mean() < 0.45
    assert (estimate_normals(pts)[tops, 2] > up).mean() > 0.6


def _closed_parts():
    """Closed, consistently wound surfaces: a box (its vertical faces edge-on from above), a
    sphere, a torus (a ray crosses it four times) and a box wound inwards."""
    box = trimesh.creation.box(extents=(0.4, 0.3, 0.2))
    sphere = trimesh.creation.icosphere(subdivisions=2, radius=0.25)
    torus = trimesh.creation.torus(major_radius=0.3, minor_radius=0.08)
    inward = trimesh.creation.box(extents=(0.2, 0.2, 0.2))
    inward.faces = inward.faces[:, ::-1]
    return [box, sphere, torus, inward]


@pytest.mark.parametrize("k", range(4))
def test_ray_windings_are_the_generalised_winding_numbers_off_the_surface(k):
    mesh = _closed_parts()[k]
    rng = np.random.default_rng(k)
    lo, hi = mesh.bounds
    free = rng.uniform(lo - 0.05, hi + 0.05, size=(3000, 3))
    # points straight under the vertices (rays along edges) and on the surface itself
    under = np.asarray(mesh.vertices) - [0, 0, 0.5]
    on = trimesh.sample.sample_surface(mesh, 300, seed=k)[0]
    pts = np.vstack([free, under, on, np.asarray(mesh.vertices)])
    exact = winding_numbers(pts, mesh.vertices, mesh.faces)
    fast = closed_windings(pts, mesh.vertices, mesh.faces)
    off = np.abs(exact - np.round(exact)) < 1e-6                 # off the surface
    assert off.sum() > 3000
    assert np.allclose(fast[off], exact[off], atol=1e-6)
    # on it (the ray's count is not trusted there), both say the same side of 0.5
    assert np.array_equal(np.abs(fast) >= 0.5, np.abs(exact) >= 0.5)
    assert set(np.round(exact[off]).astype(int)) >= ({0, -1} if k == 3 else {0, 1})


def test_buried_samples_by_rays_are_those_by_winding_numbers():
    ex = demo.build()
    g = ex.scene
    pts, nrm, faces = sample_mesh(g, 60000, 0, with_faces=True)
    by_rays = buried_samples(g.vertices, g.faces, pts, nrm, faces, rays=True)
    by_winding = buried_samples(g.vertices, g.faces, pts, nrm, faces, rays=False)
    assert by_rays.sum() > 100
    assert np.array_equal(by_rays, by_winding)


def test_buckets_gather_every_point_in_a_box():
    rng = np.random.default_rng(3)
    pts = rng.uniform(-1, 2, size=(20000, 3))
    buckets = KNearest(pts, 0.1)
    for lo, hi in [((0, 0, 0), (0.35, 0.2, 1.0)), ((-5, -5, -5), (5, 5, 5)),
                   ((1.99, 1.99, 1.99), (3, 3, 3)), ((0.5, 0.5, 0.5), (0.5, 0.5, 0.5))]:
        got = buckets.within(np.array(lo, float), np.array(hi, float))
        assert len(np.unique(got)) == len(got)
        inside = np.flatnonzero(((pts >= lo) & (pts <= hi)).all(axis=1))
        assert np.isin(inside, got).all()
        # a superset only by the cubes the box meets
        near = ((pts >= np.array(lo) - 0.1) & (pts <= np.array(hi) + 0.1)).all(axis=1)
        assert near[got].all()
    assert len(buckets.within(np.array([5.0, 5, 5]), np.array([6.0, 6, 6]))) == 0
    assert len(buckets.within(np.array([-6.0, -6, -6]), np.array([-5.0, -5, -5]))) == 0
