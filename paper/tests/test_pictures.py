"""The evaluation's close-up pictures show the posed object, whatever stands in front of it."""

from __future__ import annotations

import numpy as np

from interaction_tensor.examples.procedural import box_part, parts_mesh
from interaction_tensor.outputs.raster import Canvas, frame_points
from itensor_paper import pictures


def _green(img: np.ndarray) -> int:
    """Pixels of the valid colour, whatever their shading (the scene is grey)."""
    r, g, b = img.astype(int).transpose(2, 0, 1)
    return int(((g - r > 40) & (g - b > 30)).sum())


def test_an_object_shut_in_a_cabinet_is_drawn_in_front_of_its_doors():
    """A 10 cm box inside a closed 30 cm cabinet, its doors 4 cm from it on every side
    (closer than the near-plane cut): the picture shows the box, and the cabinet round it."""
    cabinet = parts_mesh([
        box_part("floor", (0, 0, -0.155), (0.32, 0.32, 0.01)),
        box_part("top", (0, 0, 0.155), (0.32, 0.32, 0.01)),
        box_part("x-", (-0.095, 0, 0), (0.01, 0.32, 0.30)),
        box_part("x+", (0.095, 0, 0), (0.01, 0.32, 0.30)),
        box_part("y-", (0, -0.095, 0), (0.32, 0.01, 0.30)),
        box_part("y+", (0, 0.095, 0), (0.32, 0.01, 0.30))])
    sp, sn = pictures._samples(cabinet, 0.01)
    qp, qn = pictures._samples(parts_mesh([box_part("box", (0, 0, 0), (0.1, 0.1, 0.1))]), 0.004)
    img = pictures.closeup(sp, sn, qp, qn, np.eye(4), pictures.VALID)
    seen = _green(img)
    assert seen > 500                                     # the box is seen
    r, g, b = img.astype(int).transpose(2, 0, 1)
    grey = (np.abs(r - b) < 25) & (np.abs(g - b) < 25) & (r < 200)
    assert grey.sum() > 3 * seen                          # and the cabinet round it
    # without leaving out what hides it, a sliver of the box would show
    hidden = pictures.closeup(sp, sn, qp, qn, np.eye(4), pictures.VALID, touch=np.inf)
    assert _green(hidden) < seen / 5


def test_canvas_visibility_is_the_depth_test_over_each_3x3_window():

    rng = np.random.default_rng(0)
    pts, q = rng.uniform(-1, 1, (5000, 3)), rng.uniform(-1.2, 1.2, (800, 3))
    for az in (0, 45, 200):
        cv = Canvas(frame_points(pts, az, 20, 160, 120), supersample=1)
        cv.points(pts, (0, 0, 0), size=0.03, lit=False)
        got = cv.visible(q, 0.02)
        px, py, z = cv.cam.project(q)
        ix, iy = np.rint(px).astype(int), np.rint(py).astype(int)
        inside = (ix >= 1) & (ix < cv.w - 1) & (iy >= 1) & (iy < cv.h - 1) & (z > cv.cam.near)
        d = cv.depth.reshape(cv.h, cv.w)
        ref = np.zeros(len(q), bool)
        for k in np.flatnonzero(inside):           # the reference: one window at a time
            ref[k] = z[k] <= d[iy[k] - 1:iy[k] + 2, ix[k] - 1:ix[k] + 2].max() + 0.02
        assert (got == ref).all() and 0 < got.sum() < len(q)
