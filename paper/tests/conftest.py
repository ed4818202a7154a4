"""Fixtures of the reproduction's tests (their helpers are in paper_support.py)."""

import os

from hypothesis import settings as _hypothesis_settings

_hypothesis_settings.register_profile("default", derandomize=True, deadline=None,
                                      print_blob=True)
_hypothesis_settings.register_profile("explore", max_examples=500, deadline=None)
_hypothesis_settings.load_profile(os.environ.get("HYPOTHESIS_PROFILE", "default"))
