"""The known crossings of a collision test: moves that leave a triangle pair found crossing
still crossing are blocked without fcl, and the separation is fcl's alone."""

from __future__ import annotations

import numpy as np
import pytest
import trimesh
from hypothesis import given, settings
from hypothesis import strategies as st
from hypothesis.extra.numpy import arrays

from interaction_tensor.examples.procedural import box_part, parts_mesh
from interaction_tensor.geometry import collision
from interaction_tensor.geometry.collision import Body, Crossings, MeshCollider

ONE = np.array([[0, 1, 2]])
coords = st.floats(-0.05, 0.05, allow_nan=False, width=64)


@settings(max_examples=150, deadline=None)
@given(arrays(np.float64, (2, 3, 3), elements=coords),
       arrays(np.float64, (6, 3), elements=st.floats(-0.03, 0.03, allow_nan=False)),
       st.booleans())
def test_a_pair_taken_as_crossing_is_one_fcl_finds_crossing(tris, moves, flat):
    """The kernel's rule is the NumPy rule, and every move it calls blocked is a move at
    which fcl finds the two triangles intersecting (a triangle of no area included)."""
    if flat:
        tris[0, 2] = tris[0, 0]                         # a triangle of no area
    scene = MeshCollider(tris[1], ONE)
    body = Body(tris[0], ONE)
    known = Crossings(scene, body, np.eye(4), np.array([[0, 0]]))
    kept = known.kept(moves)
    assert np.array_equal(kept, known.kept(moves, reference=True))
    for move, blocked in zip(moves, kept):
        pose = np.eye(4)
        pose[:3, 3] = move
        if blocked:
            assert scene.collides(body, pose)


def _scene_and_body(edge: float | None = None):
    """A seat with a backrest and a floor (its triangles cut to ``edge`` m, as a scanned
    room's are small), and an upright blob about a person's torso in size."""
    scene = parts_mesh([box_part("seat", (0, 0, 0.45), (0.5, 0.5, 0.05)),
                        box_part("back", (0, 0.23, 0.8), (0.5, 0.04, 0.7)),
                        box_part("floor", (0, 0, -0.01), (3, 3, 0.02))])
    v, f = scene.vertices, scene.faces
    if edge is not None:
        v, f = trimesh.remesh.subdivide_to_size(v, f, max_edge=edge, max_iter=20)
    blob = trimesh.creation.icosphere(subdivisions=3, radius=0.12)
    blob.apply_scale((1.0, 0.6, 1.6))
    return MeshCollider(v, f), Body(blob.vertices, blob.faces)


def _count_fcl_calls(monkeypatch) -> list:
    """A list that grows by one at each fcl call of a :class:`MeshCollider`."""
    calls = []
    ask = MeshCollider.crossing_pairs

    def counted(self, *args, **kwargs):
        calls.append(1)
        return ask(self, *args, **kwargs)

    monkeypatch.setattr(MeshCollider, "crossing_pairs", counted)
    return calls


def test_the_separation_is_the_one_fcl_alone_gives_and_asks_it_less(monkeypatch):
    collider, body = _scene_and_body()
    rng = np.random.default_rng(3)
    poses = []
    for _ in range(60):
        pose = np.eye(4)
        angle = rng.uniform(0, 2 * np.pi)
        pose[:3, :3] = trimesh.transformations.rotation_matrix(angle, (0, 0, 1))[:3, :3]
        pose[:3, 3] = rng.uniform((-0.3, -0.1, 0.3), (0.3, 0.35, 0.9))
        poses.append(pose)
    calls = _count_fcl_calls(monkeypatch)
    limits = (0.02, 0.05, None)
    with_known = [collider.separation(body, p, limit=lim) for p in poses for lim in limits]
    asked = len(calls)
    monkeypatch.setattr(collision, "CROSSING_KEPT", 0)       # every move to fcl
    calls.clear()
    alone = [collider.separation(body, p, limit=lim) for p in poses for lim in limits]
    assert with_known == alone
    assert {0.0, float("inf")} <= set(alone)                   # free, stuck and between
    assert any(0 < s < float("inf") for s in alone)
    assert asked < 0.6 * len(calls)


def test_a_triangle_s_ring_is_its_neighbours_by_shared_vertices():
    box = trimesh.creation.box()
    near = collision.ring(box.faces, 1)
    for f in range(len(box.faces)):
        shares = {g for g in range(len(box.faces)) if g != f
                  and set(box.faces[g]) & set(box.faces[f])}
        assert set(near.indices[near.indptr[f]:near.indptr[f + 1]]) == shares
    two = collision.ring(box.faces, 2)
    assert (np.diff(two.indptr) >= np.diff(near.indptr)).all()
    assert (np.diff(two.indptr) == len(box.faces) - 1).all()     # a cube: all within two


@pytest.mark.parametrize("kept", [1, 5])
def test_the_known_pairs_are_bounded_and_the_latest_come_first(monkeypatch, kept):
    collider, body = _scene_and_body()
    monkeypatch.setattr(collision, "CROSSING_KEPT", kept)
    pose = np.eye(4)
    pose[:3, 3] = (0, 0.2, 0.7)                                # through the backrest
    first = collider.crossing_pairs(body, pose)
    known = Crossings(collider, body, pose, first)
    assert len(known.pairs) == kept
    assert tuple(known.pairs[0]) == tuple(first[0])
    moved = pose.copy()
    moved[:3, 3] += (0.05, 0, 0)
    later = collider.crossing_pairs(body, moved)
    known.add(later)
    assert len(known.pairs) == kept and tuple(known.pairs[0]) == tuple(later[0])


def test_the_crossings_of_earlier_poses_answer_the_same_as_fcl_and_ask_it_less(monkeypatch):
    """Poses a centimetre or two apart in four orientations, as a detection tests them along
    a seat and its backrest: the memory of earlier poses' crossings gives every pose the
    separation of a fresh test, with far fewer fcl calls."""
    collider, body = _scene_and_body(edge=0.05)
    turns = [trimesh.transformations.rotation_matrix(a, (0, 0, 1))[:3, :3]
             for a in (0.0, np.pi / 2, np.pi, 1.0)]
    poses = []
    for x in np.arange(-0.2, 0.21, 0.01):                     # along the seat, in turn
        for rot, (y, z) in zip(turns, [(0.2, 0.7), (0.0, 0.68), (0.0, 0.662), (0.0, 0.62)]):
            pose = np.eye(4)
            pose[:3, :3] = rot
            pose[:3, 3] = (x, y, z)
            poses.append(pose)
    calls = _count_fcl_calls(monkeypatch)
    fresh = [collider.separation(body, p, limit=0.02) for p in poses]
    alone = len(calls)
    calls.clear()
    memory = collision.CrossingMemory()
    remembered = [collider.separation(body, p, limit=0.02, memory=memory) for p in poses]
    assert remembered == fresh
    assert {0.0, float("inf")} <= set(fresh)               # free, stuck and between
    assert any(0 < x < float("inf") for x in fresh)
    assert len(calls) < 0.5 * alone, (len(calls), alone)
    crossed = {p[:3, :3].tobytes() for p, x in zip(poses, fresh) if x > 0}
    assert len(memory._known) == len(crossed) == len(turns) - 1   # one row is free


def test_crossings_posed_in_one_orientation_refuse_a_pose_in_another():
    collider, body = _scene_and_body()
    pose = np.eye(4)
    pose[:3, 3] = (0, 0.2, 0.7)
    known = Crossings(collider, body, pose, collider.crossing_pairs(body, pose))
    moved = pose.copy()
    moved[:3, 3] += (0.01, 0, 0)
    assert np.allclose(known.offset(moved), (0.01, 0, 0))
    turned = pose.copy()
    turned[:3, :3] = trimesh.transformations.rotation_matrix(0.1, (0, 0, 1))[:3, :3]
    with pytest.raises(ValueError, match="otherwise"):
        known.offset(turned)
