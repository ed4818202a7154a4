"""Fixtures of the library's tests (their helpers are in support.py)."""

from __future__ import annotations

import os

# Each xdist worker gets its share of the cores for Numba's threads (all of them without
# xdist): two workers each running two threads on 2 cores only wait for each other.
# Before Numba is first imported, which reads the setting once.
if "NUMBA_NUM_THREADS" not in os.environ and os.environ.get("PYTEST_XDIST_WORKER_COUNT"):
    os.environ["NUMBA_NUM_THREADS"] = str(max(
        1, (os.cpu_count() or 1) // int(os.environ["PYTEST_XDIST_WORKER_COUNT"])))

import pytest
from hypothesis import settings as _hypothesis_settings

import interaction_tensor as it
from interaction_tensor import affordances
from interaction_tensor.cli.main import main

# Property-based tests: a fixed-seed sample by default (CI and local runs draw the same
# cases, so a failure reproduces); HYPOTHESIS_PROFILE=explore draws new, and more, cases.
_hypothesis_settings.register_profile("default", derandomize=True, deadline=None,
                                      print_blob=True)
_hypothesis_settings.register_profile("explore", max_examples=500, deadline=None)
_hypothesis_settings.load_profile(os.environ.get("HYPOTHESIS_PROFILE", "default"))

from support import corner_example  # noqa: E402


@pytest.fixture(scope="module")
def hanging():
    """The hanger example and its tuned descriptor (one per test module: tests change its
    acceptance and restore it)."""
    ex = affordances.build("hanging-hanger")
    return ex, affordances.build_descriptor("hanging-hanger", example=ex)


@pytest.fixture(scope="session")
def corner_tensor():
    query, scene_object = corner_example()
    return it.InteractionTensor.fit(query, scene_object, "corner-box",
                                    it.TrainSettings(query_points=3000, seed=1))


@pytest.fixture(scope="session")
def demo_run(tmp_path_factory):
    """The built-in demo, run once through the real CLI entry point."""

    out = tmp_path_factory.mktemp("demo")
    code = main(["demo", "-o", str(out), "--quiet"])
    assert code == 0
    return out
