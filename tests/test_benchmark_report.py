"""The benchmark report: repeated detection runs give each case's median, and each case's
baseline figures are labelled with the revision they were measured on."""

import importlib.util
from pathlib import Path

_spec = importlib.util.spec_from_file_location(
    "benchmarks_run", Path(__file__).resolve().parents[1] / "benchmarks" / "run.py")
run = importlib.util.module_from_spec(_spec)
_spec.loader.exec_module(run)


def _figures(seconds, digest="a"):
    return {"scene_points": 10, "candidates": 5, "seconds": seconds, "decisions": digest,
            "placement_tests_s": 0.1, "scoring_s": 0.2, "collision_s": 0.0,
            "candidates_per_s": 5 / seconds,
            "reference": {"identical_decisions": True, "numba_candidates_per_s": 2.0,
                          "reference_candidates_per_s": 1.0, "ratio": 2.0}}


def test_repeated_runs_report_each_cases_median_with_the_range():
    runs = [{"a": _figures(s), "b": _figures(t)} for s, t in ((3.0, 9.0), (1.0, 7.0),
                                                                (2.0, 8.0))]
    med = run.median_run(runs)
    assert med["a"]["seconds"] == 2.0 and med["a"]["seconds_runs"] == [1.0, 2.0, 3.0]
    assert med["b"]["seconds"] == 8.0
    assert run.median_run(runs[:2])["a"]["seconds"] == 1.0          # the lower middle one
    assert run.median_run(runs[:1]) is runs[0]
    res = {"machine": "m", "detect": med, "baseline": {"detect": run.median_run(runs[::-1])},
           "baseline_revs": {"detect": "abc1234"}}
    text = run.markdown(res)
    assert "| 2.0 (median of 3: 1.0-3.0) |" in text
    assert "`abc1234` seconds" in text


def test_each_cases_baseline_keeps_its_own_revision():
    res = {"machine": "m", "detect": {"a": _figures(2.0)},
           "prepare": {"mesh": {"points": 1, "s_per_million": 1.0},
                       "cloud": {"points": 1, "s_per_million": 2.0},
                       "write": {"points": 1, "seconds": 3.0}},
           "baseline": {"detect": {"a": _figures(4.0)},
                        "prepare": {"mesh": {"s_per_million": 2.0},
                                    "cloud": {"s_per_million": 2.0},
                                    "write": {"seconds": 6.0}}},
           "baseline_rev": "new0000", "baseline_revs": {"prepare": "old0000"}}
    text = run.markdown(res)
    assert "(`old0000` 6.0, 2.0x)" in text           # prepare: measured on old0000
    assert "`new0000` seconds" in text                # detect: on the latest revision
    assert "`new0000` (detect), `old0000` (prepare)" in text
