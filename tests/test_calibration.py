"""A descriptor trained from a new example derives its acceptance from the example
(descriptor/calibration.py): S_aff from perturbed copies of its scene-object, and the
hanging tests when the example hangs from it."""

from __future__ import annotations

import numpy as np
import pytest

import interaction_tensor as it
from interaction_tensor import affordances
from interaction_tensor.descriptor import calibration
from interaction_tensor.descriptor.calibration import Perturbation, hangs_from
from interaction_tensor.examples import shapes
from interaction_tensor.examples.posing import surface_points
from interaction_tensor.geometry.core import Geometry


@pytest.fixture(scope="module")
def hanger():
    ex = affordances.build("hanging-hanger")
    return ex, it.train(ex.query, ex.scene_object, affordance="my-hanger")


@pytest.fixture(scope="module")
def bottle():
    b = shapes.bottle()
    table = shapes.table_mesh(height=0.75)
    q = Geometry(b.vertices + [0.0, 0.0, 0.75], b.faces)
    return it.train(q, table, affordance="my-bottle")


def _lowest(tensor, key):
    crit = key.split("-")[0]
    kinds = {p.name: p.criteria for p in calibration.PERTURBATIONS}
    got = [c[key] for c in tensor.meta["calibration"]
           if c[key] is not None and crit in kinds[c["perturbation"]]]
    return min(got + [tensor.self_scores[key]])


@pytest.mark.parametrize("key", ["paper-weighted", "paper-uniform", "gaussian-weighted",
                                 "gaussian-uniform"])
def test_threshold_lets_every_perturbed_copy_of_the_example_through(bottle, key):
    copies = bottle.meta["calibration"]
    assert [c["perturbation"] for c in copies] == [p.name for p in calibration.PERTURBATIONS]
    low = _lowest(bottle, key)
    # the copies' scores are kept to 4 decimals
    ratio = it.TrainSettings().calibration_ratio
    assert bottle.thresholds[key] == pytest.approx(max(ratio * low, calibration.MIN_THRESHOLD),
                                                   abs=1e-4)
    kinds = {p.name: p.criteria for p in calibration.PERTURBATIONS}
    for c in copies:
        if c[key] is not None and key.split("-")[0] in kinds[c["perturbation"]]:
            assert c[key] >= bottle.thresholds[key]


def test_a_noisy_copy_calibrates_the_gaussian_criterion_only():
    noisy = [p for p in calibration.PERTURBATIONS if p.noise]
    assert noisy and all(p.criteria == ("gaussian",) for p in noisy)


def test_the_derived_threshold_is_deterministic(bottle):
    b = shapes.bottle()
    q = Geometry(b.vertices + [0.0, 0.0, 0.75], b.faces)
    again = it.train(q, shapes.table_mesh(height=0.75), affordance="my-bottle")
    assert again.thresholds == bottle.thresholds


def test_an_example_hanging_from_its_support_gets_the_hanging_tests(hanger, bottle):
    _, tensor = hanger
    assert tensor.through and tensor.hangs
    assert tensor.below_ground == calibration.HANGING_BELOW_GROUND
    assert tensor.hook_opening() is not None
    assert not (bottle.through or bottle.hangs) and bottle.below_ground is None


def test_hangs_from_needs_the_mass_below_and_something_through():
    ex = affordances.build("hanging-hanger")
    pts = surface_points(ex.query, 5000, 0)
    ref = ex.support_point
    section = np.array([[0.0, 0.0, 0.0], [0.01, 0.0, 0.0], [0.0, 0.0, 0.01]])
    assert hangs_from(pts, ref, (0, 0, 1), section)
    assert not hangs_from(pts, ref, (0, 0, 1), np.zeros((0, 3)))        # nothing through it
    assert not hangs_from(pts, ref, (0, 0, -1), section)                 # it stands on it
    up = pts - [0.0, 0.0, pts[:, 2].min() - ref[2]]                      # moved on top
    assert not hangs_from(up, ref, (0, 0, 1), section)


def test_the_hanging_tests_survive_the_file(hanger, tmp_path):
    _, tensor = hanger
    back = it.InteractionTensor.load(tensor.save(tmp_path / "hanger.npz"))
    assert (back.through, back.hangs, back.below_ground) == (True, True,
                                                             calibration.HANGING_BELOW_GROUND)
    assert back.thresholds == tensor.thresholds
    assert back.meta["calibration"] == tensor.meta["calibration"]


def test_a_preset_replaces_what_was_derived(hanger):
    ex, _ = hanger
    tensor = it.train(ex.query, ex.scene_object, affordance="my-hanger", acceptance="placing")
    assert tensor.threshold() == affordances.acceptance("placing")["threshold"]
    assert tensor.hangs and tensor.through is False            # placing's preset: no through


@pytest.mark.parametrize("p", calibration.PERTURBATIONS, ids=lambda p: p.name)
def test_perturbations_scale_about_the_reference_point(p):
    rng = np.random.default_rng(3)
    v = rng.normal(size=(50, 3))
    ref = np.array([0.2, -0.1, 0.7])
    g = Geometry(np.vstack([v, ref]), np.zeros((0, 3), np.int64))
    moved = p.apply(g, ref, (0.0, 0.0, 1.0)).vertices
    np.testing.assert_allclose(moved[-1], ref, atol=1e-12)
    np.testing.assert_allclose(moved[:-1] - ref, p.scale * (v - ref), atol=1e-12)


def test_a_hanging_example_is_also_calibrated_on_its_support_turned(hanger, bottle):
    _, tensor = hanger
    names = [c["perturbation"] for c in tensor.meta["calibration"]]
    assert names[-1] == "turned" and "turned" not in [c["perturbation"]
                                                     for c in bottle.meta["calibration"]]
    turned = calibration.HANGING_PERTURBATIONS[0]
    rng = np.random.default_rng(4)
    v = rng.normal(size=(40, 3))
    ref, n = np.array([0.3, 0.1, 1.6]), np.array([0.0, 0.0, 1.0])
    moved = turned.apply(Geometry(v, np.zeros((0, 3), np.int64)), ref, n).vertices
    np.testing.assert_allclose((moved - ref) @ n, (v - ref) @ n, atol=1e-12)   # about N_aff
    np.testing.assert_allclose(np.linalg.norm(moved - ref, axis=1),
                               np.linalg.norm(v - ref, axis=1), atol=1e-12)
    c, s = np.cos(np.radians(22.5)), np.sin(np.radians(22.5))
    np.testing.assert_allclose((moved - ref)[:, :2], (v - ref)[:, :2] @ np.array([[c, s], [-s, c]]),
                               atol=1e-12)


def _bar_with_brackets(length=0.6):
    """A 2 cm bar along y at 1 m between two end posts rising 6 cm above it, and a 50 cm
    block resting on it between them (4 cm clear of each post)."""
    bar = shapes.rod((0.0, -length / 2, 1.0), (0.0, length / 2, 1.0), 0.01, 24)
    parts = [bar] + [shapes.box((0.0, s * (length / 2 + 0.01), 1.0), (0.04, 0.02, 0.12))
                     for s in (-1, 1)]
    support = shapes._geometry(parts, "bar")
    block = shapes._geometry([shapes.box((0.0, 0.0, 1.035), (0.06, 0.5, 0.05))], "block")
    return block, support


def test_a_copy_on_which_the_example_no_longer_holds_does_not_count():
    block, support = _bar_with_brackets()
    ref = np.array([0.0, 0.0, 1.01])
    smaller = Perturbation("smaller", scale=0.8).apply(support, ref, (0, 0, 1))
    larger = Perturbation("larger", scale=1.25).apply(support, ref, (0, 0, 1))
    # 20 % smaller, the brackets come through the block; 25 % larger, they move away
    assert not calibration.still_holds(block, support, smaller, 0.01)
    assert calibration.still_holds(block, support, larger, 0.01)
    assert calibration.still_holds(block, support, support, 0.01)
    # a point cloud has no triangles to tell: its copies count
    cloud = Geometry(smaller.vertices, np.zeros((0, 3), np.int64))
    assert calibration.still_holds(block, support, cloud, 0.01)
    tensor = it.train(block, support, affordance="block-on-bar")
    copies = {c["perturbation"]: c for c in tensor.meta["calibration"]}
    assert copies["smaller"]["holds"] is False and copies["larger"]["holds"] is True
    assert all(v is None for k, v in copies["smaller"].items() if "-" in k)
    low = min(c["paper-weighted"] for c in copies.values()
              if c["holds"] and c["paper-weighted"] is not None)
    low = min(low, tensor.self_scores["paper-weighted"])
    assert tensor.thresholds["paper-weighted"] == pytest.approx(
        max(it.TrainSettings().calibration_ratio * low, calibration.MIN_THRESHOLD), abs=1e-4)
