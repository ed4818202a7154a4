"""Interactions of a user's own (itensor_paper.own): each example as posed is the interaction
its name says to the judge, its rooms build, and the summary counts what it says."""

from __future__ import annotations

import numpy as np
import pytest

from itensor_paper import own


@pytest.mark.parametrize("name", [e.name for e in own.EXAMPLES])
def test_each_example_is_its_interaction_to_the_judge(name):
    assert own.check_example(own.example(name)) == []


def test_six_examples_none_of_the_papers():
    from interaction_tensor import affordances

    names = [e.name for e in own.EXAMPLES]
    assert len(set(names)) == len(names) >= 6
    assert not set(names) & set(affordances.example_names())
    for e in own.EXAMPLES:
        assert e.rooms_with and e.rooms_without
        assert set(e.rooms_with + e.rooms_without) <= set(own.ROOMS)


def test_hanging_examples_hang_from_their_loop():
    for name in ("umbrella-rail", "towel-bar", "mug-hook"):
        q, s, p, loop = own.example(name).build()
        centre, inner, axis = loop
        assert 0.005 < inner < 0.05 and np.isclose(np.linalg.norm(axis), 1.0)
        # the support's top is within the loop's opening, above its centre
        assert centre[2] < p[2] <= centre[2] + 1.25 * inner      # a handle is no circle
        assert q.vertices[:, 2].min() < p[2] - 0.1            # the object hangs below it


@pytest.mark.parametrize("name", list(own.ROOMS))
def test_rooms_build(name):
    scene = own.build_room(name)
    assert len(scene.geometry.faces) > 100
    lo, hi = scene.geometry.vertices.min(axis=0), scene.geometry.vertices.max(axis=0)
    assert (hi - lo).max() < 6.0 and lo[2] >= -0.06


def test_unknown_names_are_refused():
    with pytest.raises(KeyError, match="known: book-shelf"):
        own.example("hat-peg")
    with pytest.raises(KeyError, match="known: study"):
        own.build_room("attic")


def test_summary_counts_rooms_and_precision():
    rows = [dict(example="a", room="r1", holds_place=True, predictions=4, valid=3),
            dict(example="a", room="r2", holds_place=True, predictions=2, valid=0),
            dict(example="a", room="r3", holds_place=False, predictions=0, valid=0),
            dict(example="a", room="r4", holds_place=False, predictions=1, valid=0)]
    (s,) = own.summary(rows)
    assert (s["valid"], s["accepted"], s["precision"]) == (3, 7, 42.9)
    assert (s["rooms_with_found"], s["rooms_with"]) == (1, 2)
    assert (s["rooms_without_silent"], s["rooms_without"]) == (1, 2)
    assert "| a | 3/7 | 42.9 | 1/2 | 1/2 |" in own.summary_markdown(rows)


def test_the_rooms_cup_hooks_are_the_examples_board_on_the_wall():
    """The board stands 2 cm proud of the room's wall, as in the example, so that the mug
    hangs there as it hangs in the example."""
    _, s, _, _ = own.example("mug-hook").build()
    board_face = float(s.vertices[:, 1][np.isclose(s.vertices[:, 2], 1.49)].max())
    peg_tip = float(s.vertices[:, 1].max())
    v = own.build_room("kitchen").geometry.vertices
    near = v[(np.abs(v[:, 0] - 2.4) < 0.16) & (np.abs(v[:, 2] - 1.45) < 0.05)]
    assert near[:, 1].max() == pytest.approx(0.02 + (peg_tip - board_face), abs=0.006)
    assert np.isclose(near[:, 1], 0.02).sum() >= 4              # the board's face
