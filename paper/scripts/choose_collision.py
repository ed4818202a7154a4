"""Choose detection's collision tests per affordance on the judge's labelled set.

For every labelled pose (:mod:`itensor_paper.labelled`) and every test
(``above``: which query triangles are tested, all of them or those above the reference point
by more than ``above`` m, or for a person ``limbs``: its body and each limb on its own, as
the judge tests them; ``depth``: how deep a move may free them, m), the posed query is
tested against the scene's mesh as detection tests it (:class:`~interaction_tensor.detection.search.
CollisionCheck`), and so is the through test (the scene must cross the posed section of what
passed through the query in the example: a rail through the hook; the example's descriptor's
``through_section``). An option is one test or two (a placement must pass both), with or
without the through test. The option kept per affordance rejects the most invalid poses
among those that keep every valid one; ties go to fewer tests (no through test first, one
collision test before two), then to the judge's own rule (``limbs``, for a person), then to
testing more of the query (``above`` None first, then the lower), then to the smaller depth.

Then the ground test (``clearance.below_ground``: the posed query no deeper than ``g`` below
the lowest scene sample around it, on the scene sampled at 1 cm as detection samples it) is
added to the kept option at each depth of ``GROUND_DEPTHS``; it is kept at the smallest depth
that keeps every valid pose and rejects more invalid ones than the option alone.

Then, for the examples with standing contacts (what stood on the example's ground: a seated
person's feet), the feet test (``clearance.feet_gaps_poses``: the drop from each sole to
the highest scene sample under it, or to the scene's ground where nothing is under it, at
most ``r``) at each reach of ``FEET_REACHES`` on
top of the kept option and ground test: kept is the reach that rejects the most invalid
poses among those that keep every valid one, ties to the larger reach (the more lenient),
and only when it rejects more than the option alone.

Then, for riding (the affordances whose judge asks for a support between the legs), the
straddle test (``clearance.straddle_passes_poses``: the scene in the astride box ahead of
the seat, none in a legroom box on either side; ``STRADDLE_OPTIONS``) on top of all that:
kept is the option that rejects the most invalid poses among those that keep every valid
one, ties to the option with the astride box, then to the wider legroom boxes (the more
space tested, as the collision tests' ties go to testing more of the query), and only when
it rejects more than the tests before it.

Then, on top of the kept straddle option, the mount test (``clearance.above_ground``: the
posed reference point, a rider's seat, at most ``h`` above the scene's ground) at each
height of ``MOUNT_HEIGHTS``: kept is the height that rejects the most invalid poses among
those that keep every valid one, ties to the larger height (the more lenient, as for the
feet), and only when it rejects more than the tests before it.

Then, for the people whose contact test was not tuned on the validation pairs (riding: off
there, ``ACCEPTANCE``),
the seat contact test (``clearance.seat_fractions_poses``: the fraction of the person's seat
region, the judge's main contact, whose nearest scene sample, on the scene sampled at 1 cm,
lies within ``d``) at each distance of ``CONTACT_DISTANCES`` and fraction of
``CONTACT_FRACTIONS`` on top of every test kept before: kept is the option that rejects the
most invalid poses among those that keep every valid one, ties to the larger distance and
then the smaller fraction (the more lenient), and only when it rejects more than the tests
before it.

    python paper/scripts/choose_collision.py --objects ../shared/data/objects \\
        --shared ../shared/data -o build/paper/collision
"""

from __future__ import annotations

import argparse
import csv
import time
from pathlib import Path

import numpy as np

from interaction_tensor import affordances as _aff
from interaction_tensor.descriptor.tensor import LIMBS
from interaction_tensor.geometry import collision
from interaction_tensor.geometry.scene import prepare_scene
from interaction_tensor.placement.checks import (
    SEAT_REACH,
    above_ground,
    below_ground,
    feet_gaps_poses,
    seat_fractions_poses,
    standing_groups,
    straddle_passes_poses,
)
from itensor_paper import labelled

TESTS = {a: _aff.get(a).judge.tests for a in _aff.names()}
from interaction_tensor import affordances

ABOVE = (LIMBS, None, -0.05, 0.0, 0.05, 0.10)
DEPTHS = (0.01, 0.02, 0.05, 0.1, 0.2)
GROUND_DEPTHS = (0.01, 0.02, 0.05, 0.1)
FEET_REACHES = (0.1, 0.15, 0.2, 0.25, 0.3, 0.4, 0.5)
AFFORDANCES = ("placing", "sitting", "hanging", "filling", "riding")
PERSONS = ("sitting", "riding")
#: The straddle test's boxes (m, training frame, relative to the seat point; x ahead): the
#: astride box (6 cm wide, 12-32 cm ahead of the seat, 30 cm below to 2 cm above it) and
#: legroom boxes on either side (10 cm behind to 20 cm ahead of the seat, 14 cm below to 2
#: cm above it) at each lateral range (m from the mid-plane) of ``STRADDLE_LATERAL``.
ASTRIDE_BOX = ((0.12, 0.32), (-0.03, 0.03), (-0.30, 0.02))
LEGROOM_ALONG, LEGROOM_HEIGHT = (-0.10, 0.20), (-0.14, 0.02)
STRADDLE_LATERAL = ((0.22, 0.30), (0.20, 0.32), (0.18, 0.35), (0.16, 0.35), (0.18, 0.40),
                    (0.16, 0.40))


def straddle_option(astride: bool, lateral) -> dict:
    """The descriptor's ``straddle`` of one option (astride box or not, legroom lateral range
    or None)."""
    legroom = [] if lateral is None else [
        (LEGROOM_ALONG, (side * lateral[0], side * lateral[1])[::side], LEGROOM_HEIGHT)
        for side in (1, -1)]
    return {"astride": ASTRIDE_BOX if astride else None, "legroom": legroom}


MOUNT_HEIGHTS = (1.0, 1.2, 1.3, 1.5, 2.0)
CONTACT_DISTANCES = (0.01, 0.02, 0.03, 0.05)
CONTACT_FRACTIONS = (0.02, 0.05, 0.1, 0.25)
STRADDLE_OPTIONS = [(a, lat) for a in (True, False) for lat in (None,) + STRADDLE_LATERAL
                    if a or lat is not None]


def _label(above) -> str:
    return "all" if above is None else above if isinstance(above, str) else f"{above:g}"


def options(rows: list) -> list:
    """Every option for one affordance's rows: (tests, through, valid kept, valid, invalid
    rejected, invalid, tie-break key); tests a tuple of (above, depth)."""
    poses = sorted({r["pose"] for r in rows})
    index = {p: k for k, p in enumerate(poses)}
    valid = np.zeros(len(poses), bool)
    crossed = np.zeros(len(poses), bool)
    sep = {}
    for r in rows:
        k = index[r["pose"]]
        valid[k], crossed[k] = r["valid"], r["through"]
        sep.setdefault(r["above"], np.full(len(poses), np.inf))[k] = float(r["separation_m"])
    singles = [((above, depth),) for above in ABOVE if _label(above) in sep for depth in DEPTHS]
    pairs = [a + b for i, a in enumerate(singles) for b in singles[i + 1:]
             if a[0][0] != b[0][0]]
    out = []
    for tests in singles + pairs:
        passes = np.ones(len(poses), bool)
        for above, depth in tests:
            passes &= sep[_label(above)] <= depth
        for through in (False, True):
            ok = passes & crossed if through else passes
            rank = tuple((ABOVE.index(a), d) for a, d in tests)
            out.append((tests, through, int(ok[valid].sum()), int(valid.sum()),
                        int((~ok[~valid]).sum()), int((~valid).sum()),
                        (int(through), len(tests), rank)))
    return out


def passes(rows: list, tests, through: bool):
    """(valid, passes the option, below ground m, {reach: stands}, {straddle option:
    passes}, above ground m, {distance: seat region fraction touching}) per pose of one
    affordance's rows."""
    poses = sorted({r["pose"] for r in rows})
    index = {p: k for k, p in enumerate(poses)}
    valid = np.zeros(len(poses), bool)
    ok = np.ones(len(poses), bool)
    below = np.zeros(len(poses))
    gap = np.zeros(len(poses))
    high = np.zeros(len(poses))
    straddle = {o: np.ones(len(poses), bool) for o in STRADDLE_OPTIONS}
    seat = {d: np.ones(len(poses)) for d in CONTACT_DISTANCES}
    for r in rows:
        k = index[r["pose"]]
        for d in CONTACT_DISTANCES:
            if r[f"seat {d:g}"] != "":
                seat[d][k] = float(r[f"seat {d:g}"])
        for a, lat in STRADDLE_OPTIONS:
            if r[f"straddle {a} {lat}"] is False:
                straddle[(a, lat)][k] = False
        valid[k], below[k], gap[k] = r["valid"], r["below_ground_m"], float(r["feet_gap_m"])
        high[k] = r["above_ground_m"]
        if through and not r["through"]:
            ok[k] = False
        for above, depth in tests:
            if r["above"] == _label(above) and float(r["separation_m"]) > depth:
                ok[k] = False
    return valid, ok, below, {f: gap <= f for f in FEET_REACHES}, straddle, high, seat


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--objects", required=True)
    ap.add_argument("--shared", required=True)
    ap.add_argument("-o", "--out", default="build/paper/collision")
    args = ap.parse_args(argv)
    t0 = time.perf_counter()
    poses = labelled.upright(labelled.load())   # detection's poses are upright
    colliders, scenes, examples, rows, examples_of = {}, {}, {}, [], {}
    for n, p in enumerate(poses):
        if p.scene not in colliders:
            g = labelled.scene_geometry(p.scene, args.shared)
            colliders[p.scene] = collision.MeshCollider(g.vertices, g.faces)
            scenes[p.scene] = prepare_scene(g, 0.01, seed=0)
        if p.example not in examples:
            # the triangles and heights detection tests: the descriptor's own (its reference
            # point is the support for all but filling, whose is the tap's outlet)
            tensor = affordances.build_descriptor(p.example, args.objects)
            v, f = tensor.query_vertices, tensor.query_faces
            bodies = {}
            for above in ABOVE:
                if above == LIMBS:              # a person's body and limbs, each on its own
                    if p.affordance in PERSONS:   # as the descriptor's collision_bodies cuts it
                        pv, parts = collision.person_parts(v, f, tensor.reference_point,
                                                           tensor.straddle is not None)
                        bodies[above] = [collision.Body(pv, part) for _, part in parts]
                    continue
                pv, faces = collision.part_above(v, f, None if above is None
                                                 else tensor.reference_point[2] + above)
                if len(faces):                  # nothing of a bowl lies above its support
                    bodies[above] = collision.Body(pv, faces)
            section = tensor.through_section
            through = collision.Body(*collision.polygon(section)) if len(section) else None
            examples[p.example] = bodies, through, tensor
            examples_of[p.affordance] = tensor
        bodies, through, tensor = examples[p.example]
        pose = np.asarray(p.pose, float)
        straddles = {}
        if "astride" in TESTS[p.affordance]:
            for a, lat in STRADDLE_OPTIONS:
                tensor.set_acceptance(tensor.threshold(), straddle=straddle_option(a, lat))
                straddles[f"straddle {a} {lat}"] = bool(
                    straddle_passes_poses(pose[None], tensor, scenes[p.scene])[0])
            tensor.set_acceptance(tensor.threshold(), straddle="off")
        crossed = through is not None and colliders[p.scene].collides(through, pose)
        at = (pose[:3, :3] @ tensor.reference_point + pose[:3, 3])[None]
        below = float(below_ground(at, tensor, scenes[p.scene])[0])
        high = float(above_ground(at, tensor, scenes[p.scene])[0])
        gap = float(feet_gaps_poses(pose[None], tensor, scenes[p.scene])[0])
        seat = {f"seat {d:g}": round(float(seat_fractions_poses(pose[None], tensor, d,
                                                                scenes[p.scene])[0]), 4)
                for d in CONTACT_DISTANCES} if p.affordance in PERSONS else \
            {f"seat {d:g}": "" for d in CONTACT_DISTANCES}
        for above, body in bodies.items():
            sep = max(colliders[p.scene].separation(b, pose, limit=max(DEPTHS))
                      for b in (body if isinstance(body, list) else [body]))
            rows.append({"affordance": p.affordance, "example": p.example, "scene": p.scene,
                         "case": p.case, "valid": p.valid, "pose": n, "above": _label(above),
                         "separation_m": sep if np.isfinite(sep) else "inf",
                         "through": crossed, "below_ground_m": round(below, 4),
                         "above_ground_m": round(high, 4),
                         "feet_gap_m": round(gap, 4) if np.isfinite(gap) else str(gap),
                         **seat,
                         **{k: straddles.get(k, "") for k in
                            (f"straddle {a} {lat}" for a, lat in STRADDLE_OPTIONS)}})
    out = Path(args.out)
    out.mkdir(parents=True, exist_ok=True)
    with open(out / "labelled_separation.csv", "w", newline="") as fh:
        w = csv.DictWriter(fh, fieldnames=list(rows[0]))
        w.writeheader()
        w.writerows(rows)
    lines = ["# Detection's collision tests, chosen on the judge's labelled set", "",
             f"`python paper/scripts/choose_collision.py --objects {args.objects} --shared "
             f"{args.shared} -o {args.out}` ({time.perf_counter() - t0:.0f} s). A pose passes "
             "a collision test (above, depth) when its query triangles above the reference "
             "point by more than `above` m (all: every triangle) do not cross the scene's or "
             "a move of `depth` m frees them, and the through test when the scene crosses "
             "the posed section of what passed through the query in the example (a rail "
             "through the hook). An option is one or two collision tests, with or without "
             "the through test; a pose must pass all of them. Kept: the most invalid poses "
             "rejected among the options that keep every valid pose (ties: no through test, "
             "then one collision test, then more of the query tested, then the smaller "
             "depth). Shown: every single test with and without the through test, and the "
             "chosen option.", "",
             "| affordance | tests (above m, depth m) | through | valid kept | invalid rejected "
             "| chosen |", "|---|---|:---:|---:|---:|:---:|"]
    chosen = {}
    for aff in AFFORDANCES:
        opts = options([r for r in rows if r["affordance"] == aff])
        if not opts:
            continue
        ok = [o for o in opts if o[2] == o[3]]
        best = max(ok, key=lambda o: (o[4], tuple(-x for x in o[6][:2]),
                                      tuple(-a for a, _ in o[6][2]),
                                      tuple(-d for _, d in o[6][2]))) if ok else None
        chosen[aff] = best
        for o in opts:
            if len(o[0]) == 1 or o is best:
                tests = ", ".join(f"({_label(a)}, {d:g})" for a, d in o[0])
                lines.append(f"| {aff} | {tests} | {'yes' if o[1] else ''} | {o[2]}/{o[3]} | "
                             f"{o[4]}/{o[5]} | {'**yes**' if o is best else ''} |")
    lines += ["", "Chosen (`ACCEPTANCE[...]`: `collision` = [(depth, above), ...], `through`, "
              "`below_ground`):", ""]
    ground = {}
    table = ["", "The ground test added to the kept option:", "",
             "| affordance | ground depth m | valid kept | invalid rejected | chosen |",
             "|---|---:|---:|---:|:---:|"]
    feet_choice = {}
    feet_table = ["", "The feet test added to the kept option and ground test (examples with "
                  "standing contacts):", "",
                  "| affordance | feet reach m | valid kept | invalid rejected | chosen |",
                  "|---|---:|---:|---:|:---:|"]
    straddle_choice, mount_choice, final = {}, {}, {}
    mount_table = ["", "The mount test added to the kept straddle option:", "",
                   "| affordance | seat above the ground m | valid kept | invalid rejected | "
                   "chosen |", "|---|---:|---:|---:|:---:|"]
    straddle_table = ["", "The straddle test added to the kept option and ground test (the "
                      "affordances whose judge asks for a support between the legs; astride "
                      f"box {ASTRIDE_BOX}, legroom boxes {LEGROOM_ALONG} along and "
                      f"{LEGROOM_HEIGHT} high, m from the seat point):", "",
                      "| affordance | astride box | legroom lateral m | valid kept | invalid "
                      "rejected | chosen |", "|---|:---:|---|---:|---:|:---:|"]
    for aff, o in chosen.items():
        if o is None:
            continue
        valid, ok, below, feet, straddle, high, seat = passes(
            [r for r in rows if r["affordance"] == aff], o[0], o[1])
        base = int((~ok[~valid]).sum())
        ground[aff] = None
        for g in GROUND_DEPTHS:
            okg = ok & (below <= g)
            kept, rejected = int(okg[valid].sum()), int((~okg[~valid]).sum())
            take = ground[aff] is None and kept == int(valid.sum()) and rejected > base
            if take:
                ground[aff] = g
            table.append(f"| {aff} | {g:g} | {kept}/{int(valid.sum())} | {rejected}/"
                         f"{int((~valid).sum())} (option alone {base}) | "
                         f"{'**yes**' if take else ''} |")
        okg = ok & (below <= ground[aff]) if ground[aff] is not None else ok
        if "astride" in TESTS[aff]:
            base_s = int((~okg[~valid]).sum())
            tried = [(o, int((okg & straddle[o])[valid].sum()),
                      int((~(okg & straddle[o]))[~valid].sum())) for o in STRADDLE_OPTIONS]
            good = [t for t in tried if t[1] == int(valid.sum()) and t[2] > base_s]
            best_s = max(good, key=lambda t: (t[2], t[0][0],
                                              0 if t[0][1] is None else
                                              t[0][1][1] - t[0][1][0],
                                              0 if t[0][1] is None else -t[0][1][0]))[0] \
                if good else None
            straddle_choice[aff] = best_s
            oks = okg & straddle[best_s] if best_s else okg
            base_m = int((~oks[~valid]).sum())
            tried_m = [(h, int((oks & (high <= h))[valid].sum()),
                        int((~(oks & (high <= h)))[~valid].sum())) for h in MOUNT_HEIGHTS]
            good = [t for t in tried_m if t[1] == int(valid.sum()) and t[2] > base_m]
            # ties go to the judge's own limit, then to the more lenient height
            mount_choice[aff] = max(good, key=lambda t: (t[2], t[0] == SEAT_REACH,
                                                         t[0]))[0] if good else None
            okg = oks & (high <= mount_choice[aff]) if mount_choice[aff] else oks
            for h, kept, rejected in tried_m:
                mount_table.append(f"| {aff} | {h:g} | {kept}/{int(valid.sum())} | {rejected}/"
                                   f"{int((~valid).sum())} (without it {base_m}) | "
                                   f"{'**yes**' if h == mount_choice[aff] else ''} |")
            for o, kept, rejected in tried:
                straddle_table.append(
                    f"| {aff} | {'yes' if o[0] else ''} | "
                    f"{'' if o[1] is None else f'{o[1][0]:g}-{o[1][1]:g}'} | "
                    f"{kept}/{int(valid.sum())} | {rejected}/{int((~valid).sum())} "
                    f"(without it {base_s}) | {'**yes**' if o == best_s else ''} |")
        final[aff] = (valid, seat, okg)
        # a rider's feet reach is the judge's own limit (checks.RIDER_REACH), not chosen here
        if not standing_groups(examples_of[aff]) or examples_of[aff].mount_height is not None:
            feet_choice[aff] = None
            continue
        base_g = int((~okg[~valid]).sum())
        tried = []
        for f in FEET_REACHES:
            okf = okg & feet[f]
            tried.append((f, int(okf[valid].sum()), int((~okf[~valid]).sum())))
        good = [t for t in tried if t[1] == int(valid.sum()) and t[2] > base_g]
        best_f = max(good, key=lambda t: (t[2], t[0]))[0] if good else None
        feet_choice[aff] = best_f
        final[aff] = (valid, seat, okg & feet[best_f] if best_f else okg)
        for f, kept, rejected in tried:
            feet_table.append(f"| {aff} | {f:g} | {kept}/{int(valid.sum())} | {rejected}/"
                              f"{int((~valid).sum())} (without it {base_g}) | "
                              f"{'**yes**' if f == best_f else ''} |")
    contact_choice = {}
    contact_table = ["", "The seat contact test added to every test kept before (the people "
                     "whose contact test was not tuned on the validation pairs):", "",
                     "| affordance | distance m | fraction | valid kept | invalid rejected | "
                     "chosen |", "|---|---:|---:|---:|---:|:---:|"]
    for aff, (valid, seat, okf) in final.items():
        if aff not in PERSONS or affordances.acceptance(aff)["contact"][0] not in ("off",
                                                                                   "seat"):
            continue
        base_c = int((~okf[~valid]).sum())
        tried = [((d, f), int((okf & (seat[d] >= f - 1e-9))[valid].sum()),
                  int((~(okf & (seat[d] >= f - 1e-9)))[~valid].sum()))
                 for d in CONTACT_DISTANCES for f in CONTACT_FRACTIONS]
        good = [t for t in tried if t[1] == int(valid.sum()) and t[2] > base_c]
        contact_choice[aff] = max(good, key=lambda t: (t[2], t[0][0], -t[0][1]))[0] \
            if good else None
        for (d, f), kept, rejected in tried:
            contact_table.append(f"| {aff} | {d:g} | {f:g} | {kept}/{int(valid.sum())} | "
                                 f"{rejected}/{int((~valid).sum())} (without it {base_c}) | "
                                 f"{'**yes**' if (d, f) == contact_choice[aff] else ''} |")
    for aff, o in chosen.items():
        lines.append(f"- {aff}: " + ("none keeps every valid pose" if o is None else
                                     "collision=" + repr([(d, a) for a, d in o[0]]) +
                                     f", through={o[1]}, below_ground={ground.get(aff)}"
                                     f", feet_reach={feet_choice.get(aff)}"
                                     + (f", straddle={straddle_option(*straddle_choice[aff])}"
                                        if straddle_choice.get(aff) else "")
                                     + (f", mount_height={mount_choice[aff]}"
                                        if mount_choice.get(aff) else "")
                                     + (f", contact=('seat', {contact_choice[aff][0]}, "
                                        f"{contact_choice[aff][1]})"
                                        if contact_choice.get(aff) else "")))
    lines += table + feet_table + straddle_table + mount_table + contact_table
    (out / "choice.md").write_text("\n".join(lines) + "\n")
    print("\n".join(lines))
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
