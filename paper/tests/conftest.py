"""Fixtures of the reproduction's tests (their helpers are in paper_support.py; the
procedural test scenes they share with the library's tests come from tests/support.py)."""

import os
import sys
from pathlib import Path

from hypothesis import settings as _hypothesis_settings

_hypothesis_settings.register_profile("default", derandomize=True, deadline=None,
                                      print_blob=True)
_hypothesis_settings.register_profile("explore", max_examples=500, deadline=None)
_hypothesis_settings.load_profile(os.environ.get("HYPOTHESIS_PROFILE", "default"))

sys.path.insert(0, str(Path(__file__).resolve().parents[2] / "tests"))
