"""The paper's eight interaction examples: posed, in contact, without penetration."""

from __future__ import annotations

import numpy as np
import pytest
from scipy.spatial import cKDTree

import interaction_tensor as it
from interaction_tensor import affordances
from interaction_tensor.cli.main import main
from interaction_tensor.errors import InputError
from interaction_tensor.examples import posing, shapes

from support import SHARED_DATA


def test_eight_examples_with_the_papers_normals():
    assert affordances.example_names() == ["filling-mug", "filling-cup", "placing-bottle",
                                    "placing-bowl", "hanging-hanger", "hanging-handbag",
                                    "sitting-human", "riding-human"]
    for name in affordances.example_names():
        sp = affordances.spec(name)
        assert sp.normal == ((0.0, 0.0, -1.0) if sp.affordance == "filling" else (0.0, 0.0, 1.0))


def _gaps(ex, count=60000):
    q = posing.surface_points(ex.query, count)
    s = posing.surface_points(ex.scene_object, 300000, 1)
    return q, s, cKDTree(s).query(q)[0]


def _objects(real):
    if not real:
        return None
    objects = SHARED_DATA / "objects"
    if not (objects / "ycb_mug.ply").exists():
        pytest.skip("shared data not found")
    return objects


@pytest.mark.parametrize("real", [False, True])
@pytest.mark.parametrize("name", ["placing-bowl", "placing-bottle"])
def test_placed_object_stands_on_the_table_top(name, real):
    ex = affordances.build(name, _objects(real))
    q, _, gap = _gaps(ex)
    bottom = q[:, 2] <= q[:, 2].min() + 0.002
    assert abs(q[:, 2].min() - 0.75) < 0.002               # resting on the top at 0.75 m
    assert gap[bottom].max() < 0.006
    assert np.linalg.norm(q.mean(axis=0)[:2]) < 0.03       # centred on the table


@pytest.mark.parametrize("real", [False, True])
@pytest.mark.parametrize("name", ["filling-mug", "filling-cup"])
def test_mug_stands_in_the_basin_under_the_tap_outlet(name, real):
    ex = affordances.build(name, _objects(real))
    q, _, gap = _gaps(ex)
    assert abs(q[:, 2].min() - shapes.SINK_BOTTOM) < 0.002      # on the basin bottom
    rim = q[q[:, 2] >= q[:, 2].max() - 0.005]
    centre = rim[:, :2].mean(axis=0)
    radius = np.linalg.norm(rim[:, :2] - centre, axis=1).max()
    ox, oy, oz = shapes.TAP_OUTLET
    assert np.hypot(ox - centre[0], oy - centre[1]) < 0.6 * radius   # outlet over the opening
    assert 0.02 < oz - q[:, 2].max() < 0.30                        # 2-30 cm above the rim


@pytest.mark.parametrize("name", ["hanging-hanger", "hanging-handbag"])
def test_hook_hangs_on_the_rail(name):
    ex = affordances.build(name)
    q, _, gap = _gaps(ex)
    top = shapes.RAIL_HEIGHT + shapes.RAIL_RADIUS
    assert gap.min() < 0.002                                   # touching the rail
    touching = q[gap < 0.003]
    assert touching[:, 2].min() > top - 0.004                  # ... on its top
    assert np.abs(touching[:, 0]).max() < 0.015
    centre, inner, axis = ex.loop
    rail_axis = np.array([0.0, shapes.RAIL_HEIGHT])
    assert np.linalg.norm(centre[[0, 2]] - rail_axis) < inner - shapes.RAIL_RADIUS + 0.002
    assert q.mean(axis=0)[2] < shapes.RAIL_HEIGHT - 0.05       # hangs below the rail


@pytest.mark.parametrize("real", [False, True])
def test_seated_person_sits_on_the_seat_with_feet_on_the_floor(real):
    ex = affordances.build("sitting-human", _objects(real))
    top = ex.support_point[2]
    assert ex.scene_object.vertices[:, 2].max() == pytest.approx(top, abs=1e-9)
    zs, seat = posing.seat_region(ex.query)
    stool = ex.scene_object.vertices
    lo, hi = stool[:, :2].min(axis=0), stool[:, :2].max(axis=0)
    faces = seat[(seat[:, 2] <= zs + 0.01)]                    # the seat faces: thighs, buttocks
    over = np.all((faces[:, :2] > lo) & (faces[:, :2] < hi), axis=1)
    assert over.mean() > 0.6                                   # mostly over the stool ...
    d = cKDTree(posing.surface_points(ex.scene_object, 300000, 1)).query(faces[over])[0]
    assert zs == pytest.approx(top, abs=0.002)
    assert np.quantile(d, 0.95) < 0.01                         # ... within 1 cm of its top
    assert ex.query.vertices[:, 2].min() == pytest.approx(0.0, abs=1e-9)   # feet on the floor
    assert ex.scene_object.vertices[:, 2].min() == pytest.approx(0.0, abs=1e-9)
    # nothing of the person is under the seat top except the legs in front of it
    q = posing.surface_points(ex.query, 60000)
    stool = ex.scene_object.vertices
    over = np.all((q[:, :2] > lo) & (q[:, :2] < hi), axis=1)
    assert q[over, 2].min() > top - 0.002


@pytest.mark.parametrize("real", [False, True])
def test_rider_sits_on_the_seat_hands_on_the_grips_feet_on_the_pegs(real):
    ex = affordances.build("riding-human", _objects(real))
    q, s, gap = _gaps(ex)
    sp = ex.support_point                                      # the seat's top centre
    seat = ((np.abs(q[:, 0] - sp[0]) <= 0.12) & (np.abs(q[:, 1] - sp[1]) <= 0.08)
            & (np.abs(q[:, 2] - sp[2]) < 0.05))
    assert gap[seat].min() < 0.006                             # the rider sits on the seat
    feet = q[:, 2] < q[:, 2].min() + 0.01
    assert gap[feet].min() < 0.01
    for side in (1, -1):                                       # each hand on a grip
        hand = (q[:, 1] * side > 0.15) & (q[:, 0] > 0.15) & (q[:, 2] > 0.8)
        assert gap[hand].min() < 0.02
    assert s[:, 2].min() == pytest.approx(0.0, abs=0.005)      # wheels on the ground
    left, right, inside = _astride(q, s, sp)
    assert min(left, right) > 0.4 * (left + right)             # a leg on each side ...
    assert inside < 0.1 * (left + right + inside)              # ... the motorbike between


def _astride(q, s, seat, cell: float = 0.03):
    """(left, right, inside): the rider's samples below the seat beside the motorbike (in
    3 cm cells of height and length under the seat, left of the bike's samples in the
    same cell, right of them, or within its width there)."""
    def cells(p):
        d = p[:, [0, 2]] - seat[[0, 2]]
        m = (np.abs(d[:, 0]) <= 0.4) & (d[:, 1] < -0.05) & (d[:, 1] > -0.45)
        ij = np.floor(d[m] / cell).astype(np.int64) + [20, 20]
        return ij[:, 0] * 64 + ij[:, 1], p[m, 1]
    cs, ys = cells(s)
    lo, hi = np.full(64 * 64, np.inf), np.full(64 * 64, -np.inf)
    np.minimum.at(lo, cs, ys)
    np.maximum.at(hi, cs, ys)
    cq, yq = cells(q)
    beside = np.isfinite(lo[cq])
    left, right = beside & (yq > hi[cq]), beside & (yq < lo[cq])
    return int(left.sum()), int(right.sum()), int((beside & ~left & ~right).sum())


def test_sizes_are_realistic():
    assert np.ptp(shapes.mug().vertices[:, 2]) == pytest.approx(0.095, abs=0.002)
    assert shapes.stool().vertices[:, 2].max() == pytest.approx(0.45)
    bike = affordances.build("riding-human").scene_object
    assert bike.vertices[:, 2].min() == pytest.approx(0.0, abs=0.005)      # wheels on the ground


def test_filling_descriptor_reference_point_is_the_tap():
    tensor = affordances.build_descriptor("filling-cup", spacing=0.02)
    assert tensor.affordance_normal[2] == pytest.approx(-1.0)
    assert tensor.reference_point[2] == pytest.approx(shapes.TAP_OUTLET[2], abs=0.02)


def test_missing_objects_file_is_an_input_error(tmp_path):
    with pytest.raises(InputError, match="no such object file"):
        affordances.build("placing-bowl", tmp_path)
    with pytest.raises(InputError, match="unknown example"):
        affordances.spec("juggling-balls")


def test_drop_onto_measures_the_vertical_gap():
    q = np.array([[0.0, 0.0, 1.0], [0.1, 0.0, 1.2]])
    s = np.array([[0.0, 0.0, 0.7], [0.1, 0.0, 0.5], [0.0, 0.0, 1.5]])
    assert posing.drop_onto(q, s) == pytest.approx(0.3)
    assert posing.drop_onto(q + [5, 5, 0], s) == np.inf


def test_cli_examples_list_and_build(tmp_path, capsys):

    assert main(["examples", "list"]) == 0
    assert "riding-human" in capsys.readouterr().out
    out = tmp_path / "ex"
    assert main(["examples", "build", "-o", str(out), "--examples", "placing-bowl",
                 "--spacing", "0.02", "-q"]) == 0

    t = it.InteractionTensor.load(out / "placing-bowl.npz")
    assert t.affordance == "placing-bowl"
    assert (out / "placing-bowl_query.ply").exists() and (out / "examples.json").exists()
    assert main(["examples", "build", "-o", str(out), "--objects", str(tmp_path / "nope")]) == 2
