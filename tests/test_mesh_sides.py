"""What a mesh scene says about its surfaces beyond their samples: which side of a closed
part is out (the underside of a shelf or a peg does not face up, whatever its winding), and
where a surface curves tighter than the sampling spacing (a peg's top, sampled a quarter
spacing apart along it)."""

from __future__ import annotations

import numpy as np
import pytest
import trimesh

import interaction_tensor as it
from interaction_tensor.detection.search import candidate_mask, candidates
from interaction_tensor.examples.procedural import box_part, parts_mesh
from interaction_tensor.geometry.sampling import (
    CREST_STEP,
    crest_faces,
    crest_samples,
    outward_faces,
)


def _box(centre=(0, 0, 0), size=(1, 1, 1)):
    b = trimesh.creation.box(extents=size)
    b.apply_translation(centre)
    return np.asarray(b.vertices), np.asarray(b.faces)


def test_a_closed_part_says_which_side_is_out_whatever_its_winding():
    v, f = _box()
    assert (outward_faces(v, f) == 1).all()
    assert (outward_faces(v, f[:, ::-1]) == -1).all()        # wound inwards: flipped
    mixed = f.copy()
    mixed[0] = mixed[0, ::-1]                                # not wound consistently
    assert (outward_faces(v, mixed) == 0).all()
    assert (outward_faces(v, f[:-1]) == 0).all()              # open: nothing known
    # two parts, one of each: each on its own
    v2, f2 = _box((3, 0, 0))
    both = outward_faces(np.vstack([v, v2]), np.vstack([f, f2[:, ::-1] + len(v)]))
    assert (both[:12] == 1).all() and (both[12:] == -1).all()


def test_the_scene_turns_closed_parts_normals_out_and_says_where():
    v, f = _box((0, 0, 0.5), (1.0, 1.0, 0.04))
    open_v, open_f = np.array([[3, 0, 0.5], [4, 0, 0.5], [4, 1, 0.5]], float), np.array([[0, 2, 1]])
    g = it.Geometry(np.vstack([v, open_v]), np.vstack([f[:, ::-1], open_f + len(v)]))
    scene = it.prepare_scene(g, 0.01, seed=0)
    closed = scene.points[:, 0] < 2
    assert scene.oriented is not None
    assert scene.oriented[closed].all() and not scene.oriented[~closed].any()
    top = closed & np.isclose(scene.points[:, 2], 0.52)
    under = closed & np.isclose(scene.points[:, 2], 0.48)
    assert top.sum() > 1000 and under.sum() > 1000
    assert (scene.normals[top, 2] > 0.99).all() and (scene.normals[under, 2] < -0.99).all()
    # the open triangle keeps its winding's normal (down here), its side unknown
    assert (scene.normals[~closed, 2] < -0.99).all()


def test_an_underside_is_no_candidate_where_the_side_is_known():
    n = np.array([[0, 0, 1.0], [0, 0, -1.0], [0, 0, -1.0]])
    known = np.array([True, True, False])
    assert candidate_mask(n, [0, 0, 1], 15, known).tolist() == [True, False, True]
    assert candidate_mask(n, [0, 0, -1], 15, known).tolist() == [False, True, True]
    # a shelf's board: its top is a candidate for placing, its underside is not
    board = parts_mesh([box_part("board", (0, 0, 0.8), (0.6, 0.3, 0.02))])
    scene = it.prepare_scene(board, 0.01, seed=0)
    block = it.train(it.Geometry(*_box((0, 0, 0.03), (0.1, 0.1, 0.06))),
                     parts_mesh([box_part("table", (0, 0, -0.015), (0.8, 0.8, 0.03))]),
                     affordance="block-on-table")
    idx = candidates(scene, block, it.DetectSettings(sample_fraction=1.0))
    z = scene.points[idx, 2]
    assert len(idx) and (z > 0.805).all()


def _rod(radius, sections, length=0.1):
    return trimesh.creation.cylinder(radius=radius, height=length, sections=sections,
                                     transform=trimesh.transformations.rotation_matrix(
                                         np.pi / 2, (1, 0, 0)))


@pytest.mark.parametrize("radius,sections,crest", [(0.005, 16, True), (0.004, 12, True),
                                                   (0.03, 64, False), (0.005, 4, False)])
def test_crest_faces_are_those_of_surfaces_curved_tighter_than_the_spacing(radius, sections,
                                                                          crest):
    rod = _rod(radius, sections)
    faces = crest_faces(rod.vertices, rod.faces, 0.01)
    normals = rod.face_normals
    level = np.abs(normals[:, 2]) >= np.cos(np.radians(30))
    assert not faces[~level].any()                    # only near level: a peg's top or bottom
    assert faces.any() == crest
    if crest:
        assert faces[level & (np.abs(normals[:, 1]) < 0.1)].all()   # its side wall, not its caps


def test_crest_samples_lie_a_quarter_spacing_apart_along_a_peg():
    rod = _rod(0.005, 16, length=0.1)
    g = it.Geometry(rod.vertices, rod.faces)
    pts, nrm, faces = crest_samples(g, 0.01, seed=0)
    assert len(pts) and crest_faces(g.vertices, g.faces, 0.01)[faces].all()
    np.testing.assert_allclose(np.linalg.norm(nrm, axis=1), 1.0)
    # on the faces they belong to
    tri = g.vertices[g.faces[faces]]
    normal = np.cross(tri[:, 1] - tri[:, 0], tri[:, 2] - tri[:, 0])
    normal /= np.linalg.norm(normal, axis=1, keepdims=True)
    assert np.abs(np.einsum("ij,ij->i", pts - tri[:, 0], normal)).max() < 1e-9
    # the peg's top: about a sample every quarter spacing of its length on each top face
    top = pts[:, 2] > 0.0045
    assert top.sum() >= 0.1 / (CREST_STEP * 0.01)
    # and a scene holds them beside its area-uniform samples
    scene = it.prepare_scene(g, 0.01, seed=0)
    area = rod.area / 0.01 ** 2
    assert len(scene.points) >= area + len(pts) - 1
    assert crest_samples(g, 0.01, seed=0)[0].tolist() == pts.tolist()   # seeded
