"""Posing an example: the same rule for every query object.

Move the query object's *anchor* (:func:`anchor_point`) over the scene-object's target point,
lift it 1 cm above the supporting surface, then drop it along -Z until it touches
(:func:`drop_onto`, vertical columns of 4 mm between surface samples). Anchors: ``bottom`` the
x-y centre of the object's lowest 1 cm (placing, filling: it ends resting on the table or the
sink bottom); ``seat`` the lowest point of the body above 30 % of its height near its mid-plane
(sitting, riding: it ends seated); ``hook`` the frame origin, which hanging objects put on the
rail axis.
"""

from __future__ import annotations

import numpy as np
from scipy.spatial import cKDTree

from interaction_tensor.errors import InputError
from interaction_tensor.geometry.core import Geometry
from interaction_tensor.geometry.sampling import estimate_normals, sample_mesh


def surface_points(g: Geometry, count: int = 20000, seed: int = 0) -> np.ndarray:
    """(N, 3) area-uniform samples of a mesh, or the points of a cloud (at most ``count``)."""
    if g.is_mesh:
        return sample_mesh(g, count, seed)[0]
    v = g.vertices
    if len(v) > count:
        v = v[np.random.default_rng(seed).choice(len(v), count, replace=False)]
    return v


def drop_onto(query_points: np.ndarray, scene_points: np.ndarray, column: float = 0.004,
              below: float | None = None) -> float:
    """How far (m) the query can move down along -Z before it touches the scene-object.

    Scene points in the same vertical column as a query point (within ``column`` in x-y)
    and lower than it count; with ``below`` set, every scene point lower than ``below`` m
    counts, so that a query starting slightly inside its support is pushed up (a negative
    answer). Returns +inf when nothing is under it.
    """
    tq, ts = cKDTree(query_points[:, :2]), cKDTree(scene_points[:, :2])
    pairs = tq.sparse_distance_matrix(ts, column, output_type="ndarray")
    if len(pairs) == 0:
        return float("inf")
    gap = query_points[pairs["i"], 2] - scene_points[pairs["j"], 2]
    if below is None:
        gap = gap[gap >= 0]
    else:
        gap = gap[scene_points[pairs["j"], 2] < below]
    return float(gap.min()) if len(gap) else float("inf")


def translated(g: Geometry, t) -> Geometry:
    m = np.eye(4)
    m[:3, 3] = t
    out = g.transformed(m)
    out.source = g.source
    return out


def anchor_point(g: Geometry, anchor: str, pts: np.ndarray | None = None,
                 rear: bool = False) -> np.ndarray:
    """(3,) the anchor of a query object (module docstring): x-y and its lowest z.

    ``seat``: among the surface samples facing down (normal z < -0.5) above 30 % of the
    object's height and within 5 cm of its x-z mid-plane, the x-y centre of the lowest 2 cm
    (the pelvis and thighs, not the shins or feet); with ``rear`` only the rear half (x at
    most the median), where a rider leaning forward has the pelvis.
    """
    pts = surface_points(g) if pts is None else pts
    z0, z1 = pts[:, 2].min(), pts[:, 2].max()
    if anchor == "bottom":
        low = pts[pts[:, 2] <= z0 + 0.01]
        return np.r_[low[:, :2].mean(axis=0), z0]
    if anchor == "seat":
        if g.is_mesh:
            p, n = sample_mesh(g, 40000, 7)
        else:
            p, n = pts, estimate_normals(pts)
        mid = (p[:, 2] > z0 + 0.3 * (z1 - z0)) & (np.abs(p[:, 1] - np.median(p[:, 1])) < 0.05)
        if rear:
            mid &= p[:, 0] <= np.median(p[:, 0])
        down = n[:, 2] < -0.5 if g.is_mesh else np.abs(n[:, 2]) > 0.5
        cand = p[mid & down] if (mid & down).any() else p[mid]
        zs = cand[:, 2].min()
        low = cand[cand[:, 2] <= zs + 0.02]
        return np.r_[low[:, :2].mean(axis=0), zs]
    if anchor == "hook":
        return np.zeros(3)
    raise ValueError(f"unknown anchor {anchor!r}")


def pose_on(query: Geometry, scene_object: Geometry, anchor: str, target_xy, support_z: float,
            seed: int = 0) -> Geometry:
    """The posing rule: anchor over ``target_xy``, 1 cm above ``support_z``, dropped along -Z."""
    q_pts = surface_points(query, 20000, seed)
    a = anchor_point(query, anchor, q_pts)
    t = np.r_[np.asarray(target_xy, float) - a[:2], support_z + 0.01 - a[2]]
    s_pts = surface_points(scene_object, 200000, seed + 1)
    dz = drop_onto(q_pts + t, s_pts, below=support_z + 0.03)
    if np.isfinite(dz):
        t[2] -= dz
    return translated(query, t)


def seat_region(person: Geometry, seed: int = 7):
    """Where a seated person's weight rests, measured on its mesh.

    Returns ``(z, samples)``: the height (m) of the lowest down-facing surface of the thighs
    and buttocks (area samples with normal z < -0.5 between 25 % and 60 % of the body's height:
    not the feet, not the forearms) and those samples within 3 cm of it, (S, 3).
    """
    if person.is_mesh:
        p, n = sample_mesh(person, 80000, seed)
        down = n[:, 2] < -0.5
    else:
        p = person.vertices
        down = np.abs(estimate_normals(p)[:, 2]) > 0.5
    z0, z1 = p[:, 2].min(), p[:, 2].max()
    band = down & (p[:, 2] > z0 + 0.25 * (z1 - z0)) & (p[:, 2] < z0 + 0.6 * (z1 - z0))
    if not band.any():
        raise InputError(person.source, "no seat (down-facing thighs or buttocks) found on the "
                                        "seated person")
    zs = float(p[band, 2].min())
    return zs, p[band & (p[:, 2] <= zs + 0.03)]


