"""Procedural furniture with labelled affordance sites, and the validation rooms built of it."""

from __future__ import annotations

import math

import numpy as np
import pytest
import trimesh

from itensor_paper.rooms import furniture as F
from itensor_paper.rooms import validation as V

MINIMA = {"seat": 25, "astride": 15, "hang": 25, "place": 25, "fill": 8}
_CACHE: dict = {}


def scene(name):
    if name not in _CACHE:
        _CACHE[name] = V.build_scene(name)
    return _CACHE[name]


def samples(name, spacing=0.02):
    """Surface samples of every closed primitive of a scene (about ``spacing`` apart, at least
    20 each): points (N, 3), the piece index of each (-1 for the room) and its primitive."""
    key = (name, spacing)
    if key not in _CACHE:
        sc = scene(name)
        prims = [(i, m) for i, p in enumerate(sc.pieces) for m in p.meshes]
        prims += [(-1, m) for m in sc.shell]
        pts, owner, prim = [], [], []
        for j, (i, m) in enumerate(prims):
            n = max(20, int(m.area / spacing ** 2))
            p, _ = trimesh.sample.sample_surface(m, n, seed=j)
            pts.append(np.vstack([p, m.vertices]))
            owner.append(np.full(len(pts[-1]), i))
            prim.append(np.full(len(pts[-1]), j))
        _CACHE[key] = (np.vstack(pts), np.concatenate(owner), np.concatenate(prim),
                       [m for _, m in prims])
    return _CACHE[key]


def frame(site):
    f = np.r_[site.facing, 0.0]
    return f, np.array([-f[1], f[0], 0.0])


def in_box(pts, p, f, l, u, v, z):
    d = pts - p
    a, b = d @ f, d @ l
    return ((a >= u[0]) & (a <= u[1]) & (b >= v[0]) & (b <= v[1]) & (pts[:, 2] >= z[0])
            & (pts[:, 2] <= z[1]))


def surface_distance(meshes, point):
    best = np.inf
    for m in meshes:
        tri = np.asarray(m.triangles)
        cp = trimesh.triangles.closest_point(tri, np.repeat(np.asarray(point)[None], len(tri), 0))
        best = min(best, float(np.linalg.norm(cp - point, axis=1).min()))
    return best


# ------------------------------------------------------------------ scenes
def test_scene_names_and_contents():
    names = V.scene_names()
    assert len(names) >= 6
    for required in ("living_a", "living_b", "kitchen_a", "kitchen_b", "office_a",
                     "office_nofloor", "garage"):
        assert required in names
    with pytest.raises(KeyError):
        V.build_scene("nowhere")
    has = {n: " | ".join(p.name for p in scene(n).pieces) for n in names}
    for n, words in {"living_a": ["sofa", "armchair", "coffee table", "side table", "bookcase",
                                  "TV stand", "floor lamp", "door", "pegs"],
                     "living_b": ["sofa", "bed", "bench", "clothes rail", "vaulting horse"],
                     "kitchen_a": ["counter", "dining table", "dining chair 4", "bar stool",
                                   "breakfast bar"],
                     "kitchen_b": ["island", "washbasin", "shelves"],
                     "office_a": ["desk", "office chair", "bookcase", "clothes rail", "pegs"],
                     "office_nofloor": ["desk", "office chair", "stool", "panel"],
                     "garage": ["motorbike", "gym bench", "workbench", "pegs", "rail"]}.items():
        for w in words:
            assert w in has[n], f"{n} has no {w}"


@pytest.mark.parametrize("name", V.scene_names())
def test_scene_is_deterministic(name):
    a, b = scene(name), V.build_scene(name)
    assert np.array_equal(a.geometry.vertices, b.geometry.vertices)
    assert np.array_equal(a.geometry.faces, b.geometry.faces)
    assert a.sites == b.sites


def test_site_count_minima_and_sizes():
    total = {k: 0 for k in F.KINDS}
    for name in V.scene_names():
        sc = scene(name)
        assert sc.sites == [s for p in sc.pieces for s in p.sites]
        for k, v in sc.counts().items():
            total[k] += v
        area = sc.surface_area()
        assert area < 155.0, f"{name}: {area:.0f} m^2 of surface (sampling at 1 cm too dense)"
        if name == "office_nofloor":
            assert not sc.shell
            assert sc.geometry.vertices[:, 2].min() == pytest.approx(0.0, abs=1e-9)
        else:
            assert 15.0 <= sc.floor_area() <= 40.0
            lo, hi = sc.shell[0].bounds
            assert hi[2] == pytest.approx(0.0, abs=1e-12)            # floor top at z = 0
    for k, m in MINIMA.items():
        assert total[k] >= m, f"only {total[k]} {k} sites (need {m})"


@pytest.mark.parametrize("name", V.scene_names())
def test_scene_passes_its_checks(name):
    assert V.check_scene(scene(name)) == []


@pytest.mark.parametrize("name", V.scene_names())
def test_primitives_are_finite_and_closed_and_pieces_stand(name):
    sc = scene(name)
    g = sc.geometry
    assert np.isfinite(g.vertices).all() and g.faces.dtype == np.int64
    assert g.vertices.dtype == np.float64 and g.faces.max() < len(g.vertices)
    for p in sc.pieces:
        for m in p.meshes:
            assert m.is_watertight and m.volume > 0, p.name
        zmin = min(m.bounds[0][2] for m in p.meshes)
        if p.wall_mounted:
            assert zmin > 0.05, p.name
        else:
            assert abs(zmin) < 1e-9, f"{p.name} floats or sinks ({zmin})"


@pytest.mark.parametrize("name", V.scene_names())
def test_pieces_do_not_interpenetrate(name):
    sc = scene(name)
    manager = trimesh.collision.CollisionManager()
    for i, p in enumerate(sc.pieces):
        manager.add_object(str(i), trimesh.util.concatenate(p.meshes))
    for k, m in enumerate(sc.shell[1:]):
        manager.add_object(f"wall{k}", m)
    hit, pairs = manager.in_collision_internal(return_names=True)
    pairs = {p for p in pairs if not (p[0].startswith("wall") and p[1].startswith("wall"))}
    assert not pairs, pairs
    # nor is one inside another: no piece's bounding box centre inside another's solid
    space = V.Space(sc.pieces)
    for i, p in enumerate(sc.pieces):
        lo = np.min([m.bounds[0] for m in p.meshes], axis=0)
        hi = np.max([m.bounds[1] for m in p.meshes], axis=0)
        inside = space.inside_any((lo + hi)[None] / 2, np.flatnonzero(space.owner != i))
        assert inside[0] < 0, p.name


# ------------------------------------------------------------------ sites
@pytest.mark.parametrize("name", V.scene_names())
def test_site_values(name):
    for p in scene(name).pieces:
        for s in p.sites:
            assert s.kind in F.KINDS and s.note
            assert len(s.point) == 3 and len(s.facing) == 2
            assert math.hypot(*s.facing) == pytest.approx(1.0)
            if s.kind == "seat":
                assert s.width > 0.1 and 0.38 <= s.point[2] <= 0.7
            elif s.kind == "astride":
                assert 0.05 <= s.width <= 0.30 and 0.4 <= s.point[2] <= 0.85
            elif s.kind == "hang":
                assert 0.01 <= s.width <= 0.04 and 0.8 <= s.point[2] <= 2.1
            elif s.kind == "place":
                assert s.width >= 0.12 and s.facing == (1.0, 0.0)
            else:
                assert 0.15 <= s.width <= 0.35


@pytest.mark.parametrize("name", V.scene_names())
def test_sites_lie_on_their_piece_surface(name):
    for p in scene(name).pieces:
        for s in p.sites:
            d = surface_distance(p.meshes, np.asarray(s.point))
            assert d < 0.002, f"{p.name} {s.note}: {d * 1000:.1f} mm off the surface"


@pytest.mark.parametrize("name", V.scene_names())
def test_free_space_at_sites_by_sampling(name):
    """An independent check on surface samples (2 cm apart, and every vertex)."""
    sc = scene(name)
    pts, owner, prim, meshes = samples(name)
    for i, p in enumerate(sc.pieces):
        for s in p.sites:
            q = np.asarray(s.point)
            f, l = frame(s)
            z = q[2]
            tag = f"{p.name} {s.note}"
            if s.kind == "place":
                assert not in_box(pts, q, f, l, (-0.06, 0.06), (-0.06, 0.06),
                                  (z + 0.005, z + 0.3)).any(), tag
            elif s.kind == "seat":
                back = min(s.width, 0.3) - 0.015
                assert not in_box(pts, q, f, l, (-back, 0.2), (-0.2, 0.2),
                                  (z + 0.005, z + 1.0)).any(), tag
            elif s.kind == "astride":
                free = []
                for sgn in (-1, 1):
                    v = tuple(sorted((sgn * (s.width / 2 + 0.015), sgn * (s.width / 2 + 0.35))))
                    full = in_box(pts, q, f, l, (-0.2, 0.2), v, (0.02, z + 0.3)).any()
                    ledge = in_box(pts, q, f, l, (-0.2, 0.2), v, (z - 0.15, z + 0.3)).any()
                    assert not ledge, tag
                    free.append(not full)
                assert all(free) or ("arm" in s.note and any(free)), tag
            elif s.kind == "hang":
                support = {j for j in set(prim[owner == i].tolist())
                           if surface_distance([meshes[j]], q) < 0.003}
                assert support, tag
                keep = ~np.isin(prim, list(support))
                ext = np.vstack([meshes[j].vertices for j in support])
                a, b = (f, l) if np.ptp(ext @ f) >= np.ptp(ext @ l) else (l, f)
                below = in_box(pts[keep], q, a, b, (-0.015, 0.015), (-0.015, 0.015),
                               (z - 0.45, z - s.width - 0.02))
                assert not below.any(), tag
                for sgn in (-1, 1):
                    v = tuple(sorted((sgn * (s.width / 2 + 0.025), sgn * 0.25)))
                    assert not in_box(pts[keep], q, a, b, (-0.035, 0.035), v,
                                      (z - 0.45, z - 0.05)).any(), tag
            elif s.kind == "fill":
                col = np.hypot(*(pts[:, :2] - q[:2]).T) < 0.008
                above = pts[col & (pts[:, 2] > z + 0.01), 2]
                assert above.min() - z == pytest.approx(s.width, abs=0.006), tag
                assert not in_box(pts, q, f, l, (-0.035, 0.035), (-0.035, 0.035),
                                  (z + 0.01, z + s.width - 0.006)).any(), tag
                band = (pts[:, 2] > z + 0.03) & (pts[:, 2] < z + 0.08) & (owner == i)
                for d in (f, -f, l, -l):
                    dd = (pts[band] - q) @ d
                    side = np.abs((pts[band] - q) @ np.cross([0, 0, 1.0], d)) < 0.02
                    assert ((dd > 0.04) & (dd < 0.4) & side).any(), f"{tag}: no wall {d}"


def test_fill_site_under_each_tap_outlet():
    for name in V.scene_names():
        for p in scene(name).pieces:
            for s in (s for s in p.sites if s.kind == "fill"):
                q = np.asarray(s.point)
                space = V.Space([p])
                up = space.ray(q + [0, 0, 0.001], np.array([0, 0, 1.0]), 1.0) + 0.001
                assert up == pytest.approx(s.width, abs=0.002), f"{p.name}: {up}"


# ------------------------------------------------------------------ builders
def test_placement_moves_and_turns_sites():
    a = F.dining_chair((0.0, 0.0), 0.0)
    b = F.dining_chair((2.0, 1.0), 90.0)
    sa, sb = a.sites[0], b.sites[0]
    assert sa.kind == sb.kind == "seat"
    assert sb.facing == pytest.approx((0.0, 1.0), abs=1e-12)
    assert sb.point == pytest.approx((2.0 - sa.point[1], 1.0 + sa.point[0], sa.point[2]))
    assert sa.width == pytest.approx(sb.width)
    va = np.vstack([m.vertices for m in a.meshes])
    vb = np.vstack([m.vertices for m in b.meshes])
    assert vb[:, 2].min() == pytest.approx(0.0, abs=1e-12)
    assert np.ptp(va[:, 0]) == pytest.approx(np.ptp(vb[:, 1]))


def test_builders_realistic_heights():
    chair = F.dining_chair((0, 0)).sites
    assert 0.42 <= chair[0].point[2] <= 0.48 and chair[1].kind == "hang"
    assert 0.38 <= F.armchair((0, 0)).sites[-1].point[2] <= 0.44
    assert 0.62 <= F.bar_stool((0, 0)).sites[0].point[2] <= 0.66
    sofa = F.sofa((0, 0), places=3)
    assert [s.kind for s in sofa.sites].count("seat") == 3
    arm = [s for s in sofa.sites if s.kind == "astride"]
    assert len(arm) == 2 and all(0.55 <= s.point[2] <= 0.65 and 0.15 <= s.width <= 0.25
                                 for s in arm)
    assert F.sofa((0, 0), arm_sites=(False, True)).sites[0].note.endswith("left arm")
    assert 0.45 <= F.bed((0, 0)).sites[0].point[2] <= 0.55
    gym = F.gym_bench((0, 0)).sites
    assert {s.kind for s in gym} == {"seat", "astride"} and gym[0].width == 0.25
    rail = F.clothes_rail((0, 0), height=1.3, radius=0.01).sites
    assert rail[0].point[2] == pytest.approx(1.31) and rail[0].width == pytest.approx(0.02)
    door = F.door_in_partition((0, 0)).sites
    assert all(s.point[2] == pytest.approx(2.01) and s.width == 0.04 for s in door)
    bike = F.motorbike_frame((0, 0)).sites[0]
    assert bike.kind == "astride" and bike.point[2] == pytest.approx(0.8)
    for fn in (F.floor_lamp, F.radiator, F.tv_stand, F.plant_pot, F.fridge):
        assert fn((0, 0)).sites == []
    low = F.wall_shelves((0, 0), boards=(1.0, 1.2, 1.6))          # no headroom on 1.0
    assert sorted({s.point[2] for s in low.sites}) == [1.2, 1.6]
    assert [s.point[2] for s in F.coffee_table((0, 0)).sites] == [0.42, 0.42]


# ------------------------------------------------------------------ the checks catch errors
def _errors(pieces, shell=()):
    return V.check_scene(V.compose("probe", pieces, shell))


def test_checks_catch_blocked_and_wrong_sites():
    from dataclasses import replace

    table = F.dining_table((1.5, 1.5), 0)
    assert _errors([table]) == []
    shelf = F.Piece("low shelf", [F.cbox((1.0, 1.0, 0.9), (2.0, 2.0, 0.92))], [])
    assert any("not 0.3 m free above" in e for e in _errors([table, shelf]))
    lifted = F.Piece(table.name, table.meshes,
                     [replace(table.sites[0], point=(*table.sites[0].point[:2],
                                                     table.sites[0].point[2] + 0.01))])
    assert any("from the piece's surface" in e for e in _errors([lifted]))
    wrong = F.Piece(table.name, table.meshes, [replace(table.sites[0], width=0.4)])
    assert any("nearest edge" in e for e in _errors([wrong]))

    bench = F.gym_bench((1.0, 1.0), 0)
    chair = F.dining_chair((1.3, 0.7), 180)                       # beside the bench
    errs = _errors([bench, chair])
    assert any("astride" in e and "side" in e for e in errs)

    rail = F.clothes_rail((1.0, 1.0), 0)
    box = F.Piece("box", [F.cbox((0.9, 0.8, 0.0), (1.1, 1.2, 1.2))], [])
    assert any("free" in e and "hang" in e for e in _errors([rail, box]))

    basin = F.washbasin((0.0, 1.0), 0)
    bad = F.Piece(basin.name, basin.meshes, [replace(basin.sites[0], width=0.3)])
    assert any("first thing above" in e for e in _errors([bad]))

    chair = F.dining_chair((1.0, 1.0), 0)
    bad = F.Piece(chair.name, chair.meshes, [replace(chair.sites[0], width=0.3)])
    assert any("backrest" in e for e in _errors([bad]))
    assert any("cross each other" in e
               for e in _errors([chair, F.dining_chair((1.2, 1.0), 0, name="other chair")]))
    floating = F.Piece("floating", [F.cbox((3, 3, 0.1), (3.5, 3.5, 0.5))], [])
    assert any("does not stand" in e for e in _errors([floating]))
