"""What the evaluation's modules share: the methods, the affordances, the paper's Table 1,
the machine description and the atomic CSV/JSON writers (imported by the runner, the report,
the merge and the tuning; it imports none of them)."""

from __future__ import annotations

import csv
import json
import platform
from pathlib import Path

import numpy as np

from interaction_tensor.geometry.files import atomic_path

METHODS = ("iT-weighted", "iT-uniform", "Naive", "BS")
AFFORDANCES = ("placing", "sitting", "filling", "riding", "hanging")
#: The paper's Table 1 (accuracy, F-score), for the report.
PAPER = {"placing": {"iT": (96.92, 98.44), "Naive": (3.08, 5.97), "BS": (3.08, 5.97)},
         "sitting": {"iT": (64.62, 78.50), "Naive": (64.62, 78.50), "BS": (35.38, 52.27)},
         "filling": {"iT": (100, 100), "Naive": (100, 100), "BS": (100, 100)},
         "riding": {"iT": (92.31, 96.00), "Naive": (92.31, 96.00), "BS": (7.69, 14.29)},
         "hanging": {"iT": (70.77, 82.88), "Naive": (29.23, 45.24), "BS": (70.77, 82.88)},
         "average": {"iT": (84.92, 91.17), "Naive": (57.85, 64.14), "BS": (43.38, 51.08)}}



def ranking_radius(tensor) -> float:
    """Suppression radius (m) of the evaluation's top and bottom poses: half the query
    object's radius (the runner's ranking, and the tuning's that scores it)."""
    return 0.5 * float(tensor.radius)


def machine() -> str:
    import os

    return (f"{platform.system()} {platform.machine()}, {os.cpu_count()} CPU cores, "
            f"Python {platform.python_version()}")


def _json_default(o):
    if isinstance(o, np.generic):
        return o.item()
    if isinstance(o, Path):
        return str(o)
    raise TypeError(type(o))


def write_csv(path: Path, rows: list[dict], columns: list[str]) -> None:

    with atomic_path(path) as tmp, open(tmp, "w", newline="") as fh:
        w = csv.DictWriter(fh, columns, extrasaction="ignore")
        w.writeheader()
        for r in rows:
            w.writerow({k: (_number(r[k]) if isinstance(r.get(k), float) else r.get(k))
                        for k in columns})


def _number(v: float) -> str:
    """A float for a CSV: to 5 decimals, no trailing zeros (read back, a tuning's pairs must
    decide as they did: 2 decimals moved placing's chosen S_aff from 0.23 to 0.25)."""
    text = f"{v:.5f}".rstrip("0").rstrip(".")
    return "0" if text in ("", "-0") else text


def write_json(path: Path, obj) -> None:

    with atomic_path(path) as tmp:
        Path(tmp).write_text(json.dumps(obj, indent=1, default=_json_default))
