"""The blind panel: people's verdicts, which the judge is a model of and is checked against.

Raters see each pose as two views of one picture, the posed object in one neutral colour,
with nothing that tells the method, the rank, the score or any verdict; they are asked only
the affordance's question (:attr:`interaction_tensor.affordances.Affordance.question`) and
answer yes or no. Their verdicts are kept as labelled data (``data/panel.csv``: the pose,
where it came from, each rater's answer), and :func:`agreement` measures how often the judge
says what the panel's majority says.

:func:`select` draws the poses of a panel from an evaluation's judged poses (its
``judgements.csv``): per affordance, from several scenes, from iT's top and bottom and from
Naive's top, in a seeded order; :func:`draw` renders them as rating sheets of a few poses
each, labelled only by an id, with a key that maps ids back (kept from the raters).
"""

from __future__ import annotations

import csv
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

from interaction_tensor import affordances
from interaction_tensor.errors import InputError
from interaction_tensor.geometry.files import atomic_path, write_json
from interaction_tensor.geometry.load import load_geometry
from interaction_tensor.outputs.render import _font
from itensor_paper.common import write_csv
from itensor_paper.judge import Judge, JudgeScene
from itensor_paper.pictures import _samples, closeup, floor_under

#: What raters are told beside the question.
INSTRUCTIONS = (
    "Each sheet shows poses of the object (drawn in one colour) in a scene, each beside its "
    "id, in five pictures. The upper three are views: from one side, from another side "
    "higher up, and from close by with the scene in front of the object taken away. The "
    "lower two are cuts by two upright planes at right angles through the point where the "
    "object rests on or hangs from the scene, seen square on: the scene's surfaces as grey "
    "lines, the object's outline in its colour; they show what the object rests on and "
    "whether anything passes into it. "
    "For each id, answer yes or no to the question for the pose exactly as drawn, as you "
    "would judge it in a real room, where nothing passes into furniture, walls or the "
    "floor.")
#: The one colour every posed object is drawn in.
NEUTRAL = (196, 150, 82)
#: The file of the panel's verdicts, shipped with the package.
DATA_FILE = Path(__file__).resolve().parent / "data" / "panel.csv"
#: Its columns: the pose and where it came from, the raters' answers (``yes``/``no``,
#: ``;``-separated, one per rater) and the held-out flag (poses the judge was not fixed on).
COLUMNS = ["id", "affordance", "example", "scene", "method", "group", "rank", "held_out",
           "answers", "pose"]
#: Where the panel's poses come from: (method, group) and its share of an affordance's poses.
SOURCES = (("iT-weighted", "top", 0.4), ("iT-weighted", "bottom", 0.3), ("Naive", "top", 0.3))


@dataclass
class PanelPose:
    """One pose shown to the panel."""

    id: str
    affordance: str
    example: str
    scene: str
    method: str
    group: str
    rank: int
    pose: np.ndarray
    held_out: bool = True
    answers: list = field(default_factory=list)

    @property
    def majority(self) -> bool | None:
        """The panel's verdict: True when more raters said yes than no, None on a tie or with
        no answer."""
        yes = sum(a == "yes" for a in self.answers)
        no = sum(a == "no" for a in self.answers)
        return None if yes == no else yes > no

    def row(self) -> dict:
        return {"id": self.id, "affordance": self.affordance, "example": self.example,
                "scene": self.scene, "method": self.method, "group": self.group,
                "rank": self.rank, "held_out": self.held_out,
                "answers": ";".join(self.answers),
                "pose": " ".join(f"{v:.6g}" for v in np.asarray(self.pose).ravel())}


#: Scenes whose poses the judge's rules may be fixed on; the others' poses are held out to
#: measure the judge (a rule fitted to a scene's furniture cannot pass for agreement there).
DEVELOPMENT_SCENES = ("kitchen3", "kitchen5", "living-room2", "living-room4", "office-desk2",
                      "office-desk6")


def select(judgements, per_affordance: int = 60, seed: int = 0, affordance_names=None,
           scenes=None, first_id: int = 1) -> list:
    """Poses for a panel from an evaluation's judged poses (rows of its ``judgements.csv``):
    per affordance ``per_affordance`` of them, :data:`SOURCES` in their shares, taken scene by
    scene in turn (so that every scene gives some), each source's poses in a seeded order;
    only from ``scenes`` when given. Returns :class:`PanelPose` s with ids in a seeded random
    order (``P0001``, ... from ``first_id``), held out unless their scene is one of
    :data:`DEVELOPMENT_SCENES`."""
    rng = np.random.default_rng(seed)
    rows = [r for r in judgements if r.get("pose") and (scenes is None or r["scene"] in scenes)]
    names = affordance_names or affordances.names()
    picked = []
    for aff in names:
        for method, group, share in SOURCES:
            want = int(round(share * per_affordance))
            pool = [r for r in rows if r["affordance"] == aff and r["method"] == method
                    and r["group"] == group]
            by_scene: dict = {}
            for r in pool:
                by_scene.setdefault(r["scene"], []).append(r)
            for scene_rows in by_scene.values():
                rng.shuffle(scene_rows)
            scenes = sorted(by_scene)
            rng.shuffle(scenes)
            taken = []
            while len(taken) < want and any(by_scene[s] for s in scenes):
                for s in scenes:
                    if by_scene[s] and len(taken) < want:
                        taken.append(by_scene[s].pop())
            picked += taken
    order = rng.permutation(len(picked))
    out = []
    for k, i in enumerate(order):
        r = picked[i]
        out.append(PanelPose(f"P{first_id + k:04d}", r["affordance"], r["example"], r["scene"],
                             r["method"], r["group"], int(r["rank"]),
                             np.array([float(v) for v in r["pose"].split()]).reshape(4, 4),
                             r["scene"] not in DEVELOPMENT_SCENES))
    return sorted(out, key=lambda p: p.id)


def shuffled_ids(poses, seed: int = 0, prefix: str = "Q") -> list:
    """``poses`` with new ids (``Q0001``, ... with ``prefix`` Q) in a seeded random order, so
    that an id says nothing about where its pose came from."""
    order = np.random.default_rng(seed).permutation(len(poses))
    for k, i in enumerate(order):
        poses[i].id = f"{prefix}{k + 1:04d}"
    return sorted(poses, key=lambda p: p.id)


def unseen(judgements, rated, tolerance: float = 1e-4) -> list:
    """The rows of an evaluation's ``judgements`` whose pose no :class:`PanelPose` of
    ``rated`` shows (the same scene and affordance, every entry of the 4x4 within
    ``tolerance``): the poses a new round of raters can be shown."""
    seen: dict = {}
    for p in rated:
        seen.setdefault((p.scene, p.affordance), []).append(np.asarray(p.pose, float).ravel())
    out = []
    for r in judgements:
        if not r.get("pose"):
            continue
        mine = seen.get((r["scene"], r["affordance"]))
        pose = np.array([float(v) for v in r["pose"].split()])
        if mine is None or np.abs(np.asarray(mine) - pose).max(axis=1).min() > tolerance:
            out.append(r)
    return out


def new_round(judgements, rated, per_affordance: int, seed: int, affordance_names=None,
              prefix: str = "R") -> list:
    """A new round of a panel: :func:`select` from the poses of ``judgements`` that the
    panel ``rated`` has not shown (:func:`unseen`), from every scene, all held out (the
    judge's rules were not fixed on them), ids ``prefix``-numbered in a seeded order
    (``seed + 1``)."""
    poses = select(unseen(judgements, rated), per_affordance, seed, affordance_names)
    for p in poses:
        p.held_out = True
    return shuffled_ids(poses, seed + 1, prefix)


#: The size of one view (pixels); a pose is shown in three.
VIEW = (400, 320)
#: The size of one cut.
CUT = (600, 320)


def _views(scene_samples, query_samples, pose, affordance: str = "") -> np.ndarray:
    """(H, 3W, 3) uint8: three views of a pose. The first two leave the scene whole, so that
    what it hides (a body through a floor, an object inside a cabinet) stays hidden, as to
    anyone looking at the place: from the side that sees most of the object, then a quarter
    turn around and higher up. The third takes away the scene in front of the object, to
    show what it passes into or rests on. A rider is seen first from the front or the back,
    low, where both legs show on either side of what is between them."""
    sp, sn = scene_samples
    qp, qn = query_samples
    yaw = float(np.degrees(np.arctan2(pose[1, 0], pose[0, 0])))
    if affordance == "riding":
        first_az = tuple(yaw + a for a in (0, 180, 25, -25, 155, 205))
        second_az = tuple(yaw + a for a in (90, -90, 60, -60, 120, -120))
        first_el, second_el = 12.0, 45.0
    else:
        first_az, second_az = (210, 300, 30, 120), (120, 210, 300, 30)
        first_el, second_el = 22.0, 55.0
    views = [closeup(sp, sn, qp, qn, pose, NEUTRAL, size=VIEW, azimuths=first_az,
                     elevation=first_el, see_through=False, to_floor=True),
             closeup(sp, sn, qp, qn, pose, NEUTRAL, size=VIEW, azimuths=second_az,
                     elevation=second_el, see_through=False, to_floor=True),
             closeup(sp, sn, qp, qn, pose, NEUTRAL, size=VIEW, azimuths=second_az,
                     margin=0.3, elevation=15.0, see_through=True)]
    return np.concatenate(views, axis=1)


def _cuts(scene_samples, query_samples, pose, support, margin: float = 0.3,
          scene_slab: float = 0.012, query_slab: float = 0.006) -> np.ndarray:
    """(H, 2W, 3) uint8: the posed object and the scene cut by two upright planes through
    the point the interaction rests on (``support``, training frame: a bottle's or a
    bowl's foot, a hook's top, a person's seat), along the object's own forward (+X) and
    side (+Y) axes, seen square on, down to the floor under it: the
    scene samples within ``scene_slab`` of a plane in grey, the object's within
    ``query_slab`` in :data:`NEUTRAL`, framed to the object and ``margin`` around it."""
    sp = scene_samples[0]
    qp = query_samples[0] @ pose[:3, :3].T + pose[:3, 3]
    centre = pose[:3, :3] @ np.asarray(support, float) + pose[:3, 3]
    floor = floor_under(sp, qp.min(axis=0) - margin, qp.max(axis=0) + margin)
    out = []
    for axis in (pose[:3, 0], pose[:3, 1]):
        along = np.array([axis[0], axis[1], 0.0])
        along /= max(np.linalg.norm(along), 1e-9)
        normal = np.array([-along[1], along[0], 0.0])
        img = np.full((CUT[1], CUT[0], 3), 255, np.uint8)
        q_u, q_z = (qp - centre) @ along, qp[:, 2] - centre[2]
        half_u = max(np.abs(q_u).max(), 0.05) + margin
        top = q_z.max() + margin
        bottom = min(q_z.min() - margin, floor - centre[2] - 0.05)
        scale = min(CUT[0] / (2 * half_u), CUT[1] / (top - bottom))
        mid = (top + bottom) / 2
        for pts, slab, colour in ((sp, scene_slab, (80, 80, 80)), (qp, query_slab, NEUTRAL)):
            d = pts - centre
            u, z = d @ along, d[:, 2]
            m = (np.abs(d @ normal) <= slab) & (np.abs(u) <= half_u) & (z <= top) & \
                (z >= bottom)
            x = np.round(CUT[0] / 2 + u[m] * scale).astype(np.int64)
            y = np.round(CUT[1] / 2 - (z[m] - mid) * scale).astype(np.int64)
            for dx in (0, 1):
                for dy in (0, 1):
                    ok = (x + dx >= 0) & (x + dx < CUT[0]) & (y + dy >= 0) & (y + dy < CUT[1])
                    img[y[ok] + dy, x[ok] + dx] = colour
        out.append(img)
    return np.concatenate(out, axis=1)


def draw(poses, scenes_dir, objects_dir, out_dir, per_sheet: int = 2) -> Path:
    """Rating sheets of ``poses`` (:class:`PanelPose`) in ``out_dir``: per affordance,
    ``<affordance>/sheet_NN.png`` with ``per_sheet`` poses each (three views and two cuts
    a pose, its id beside it, nothing else), ``<affordance>/question.txt`` (the
    affordance's question and how to answer) and, for the panel's keeper, ``key.csv`` (ids
    and where the poses come from). Returns ``out_dir``."""
    from PIL import Image, ImageDraw

    out_dir = Path(out_dir)
    by_aff: dict = {}
    for p in poses:
        by_aff.setdefault(p.affordance, []).append(p)
    queries, supports, scenes = {}, {}, {}
    for aff, items in sorted(by_aff.items()):
        items.sort(key=lambda p: p.id)
        folder = out_dir / aff
        folder.mkdir(parents=True, exist_ok=True)
        for s in range(0, len(items), per_sheet):
            chunk = items[s:s + per_sheet]
            w, h = 3 * VIEW[0], VIEW[1] + CUT[1] + 4
            img = Image.new("RGB", (w + 90, len(chunk) * (h + 16)), (255, 255, 255))
            d = ImageDraw.Draw(img)
            for k, p in enumerate(chunk):
                if p.example not in queries:
                    ex = affordances.build(p.example, objects_dir)
                    queries[p.example] = _samples(ex.query, 0.004)
                    supports[p.example] = ex.support_point
                if p.scene not in scenes:
                    scenes[p.scene] = _samples(load_geometry(Path(scenes_dir) / f"{p.scene}.ply"),
                                               0.01)
                y = k * (h + 16)
                img.paste(Image.fromarray(_views(scenes[p.scene], queries[p.example], p.pose,
                                                 p.affordance)), (90, y))
                img.paste(Image.fromarray(_cuts(scenes[p.scene], queries[p.example], p.pose,
                                                supports[p.example])),
                          (90, y + VIEW[1] + 4))
                d.rectangle([90, y, 90 + w - 1, y + h - 1], outline=(200, 200, 200))
                d.line([90, y + VIEW[1] + 2, 90 + w - 1, y + VIEW[1] + 2], fill=(200, 200, 200))
                d.text((8, y + h // 2 - 10), p.id, fill=(20, 20, 20), font=_font(18))
            with atomic_path(folder / f"sheet_{s // per_sheet + 1:02d}.png") as tmp:
                img.save(tmp, format="PNG", optimize=True)
        aff_q = affordances.get(aff).question
        (folder / "question.txt").write_text(
            f"{aff_q}\n\n{INSTRUCTIONS}\n")
    write_csv(out_dir / "key.csv", [p.row() for p in poses], COLUMNS)
    write_json(out_dir / "poses.json", {"count": len(poses),
                                         "per_affordance": {a: len(v) for a, v in
                                                            by_aff.items()}})
    return out_dir


def load(path=DATA_FILE) -> list:
    """The panel's poses and verdicts (:data:`DATA_FILE`)."""
    path = Path(path)
    if not path.exists():
        return []
    with open(path, newline="") as fh:
        return [PanelPose(r["id"], r["affordance"], r["example"], r["scene"], r["method"],
                          r["group"], int(r["rank"]),
                          np.array([float(v) for v in r["pose"].split()]).reshape(4, 4),
                          r["held_out"] == "True",
                          [a for a in r["answers"].split(";") if a])
                for r in csv.DictReader(fh)]


def save(poses, path=DATA_FILE) -> Path:
    """Write the panel's poses and verdicts (atomically)."""
    path = Path(path)
    with atomic_path(path) as tmp:
        write_csv(tmp, [p.row() for p in poses], COLUMNS)
    return path


def judge_poses(poses, scenes_dir, objects_dir=None, log=None) -> dict:
    """The judge's verdict on each pose of the panel whose scene is in ``scenes_dir``:
    ``{id: valid}``."""
    judges, scenes, out = {}, {}, {}
    for p in sorted(poses, key=lambda p: (p.scene, p.example)):
        path = Path(scenes_dir) / f"{p.scene}.ply"
        if not path.exists():
            continue
        if p.scene not in scenes:
            scenes[p.scene] = JudgeScene(load_geometry(path))
            if log:
                log(f"panel: judging the poses in {p.scene}")
        if p.example not in judges:
            judges[p.example] = Judge.for_example(affordances.build(p.example, objects_dir))
        out[p.id] = bool(judges[p.example].judge(scenes[p.scene], p.pose).valid)
    return out


def _tally(items, judged: dict) -> dict:
    """Of ``items`` (poses the judge judged), those the panel decided (a majority): how
    many, on how many the judge agrees, that share (%), and how many each calls valid."""
    decided = [p for p in items if p.majority is not None]
    agree = sum(judged[p.id] == p.majority for p in decided)
    return {"poses": len(decided), "agree": agree,
            "agreement": round(100.0 * agree / len(decided), 1) if decided else None,
            "panel_valid": sum(bool(p.majority) for p in decided),
            "judge_valid": sum(bool(judged[p.id]) for p in decided)}


def agreement(poses, judged: dict, held_out_only: bool = True) -> list:
    """Per affordance (and overall): how many poses the panel decided (a majority), on how
    many of them the judge agrees, and that share in %. ``judged`` maps a pose's id to the
    judge's verdict (True: valid)."""
    mine = [p for p in poses if (p.held_out or not held_out_only) and p.id in judged]
    rows = [{"affordance": aff, **_tally([p for p in mine if p.affordance == aff], judged)}
            for aff in affordances.names()]
    return rows + [{"affordance": "all", **_tally(mine, judged)}]


def answers_from(path) -> dict:
    """A rater's answers: ``{id: "yes" | "no"}`` from a CSV of ``id,answer`` lines (a header
    line is skipped; anything but yes or no is refused)."""
    out = {}
    with open(path, newline="") as fh:
        for row in csv.reader(fh):
            if not row or row[0].strip().lower() == "id":
                continue
            pid, ans = row[0].strip(), row[1].strip().lower()
            if ans not in ("yes", "no"):
                raise InputError(path, f"answer for {pid} is {ans!r}, not yes or no")
            out[pid] = ans
    return out


def merge_answers(poses, *answer_files) -> list:
    """``poses`` with each file's answers appended (a rater a file)."""
    by_id = {p.id: p for p in poses}
    for f in answer_files:
        for pid, ans in answers_from(f).items():
            if pid in by_id:
                by_id[pid].answers.append(ans)
    return poses


def add_round(rated, new, tolerance: float = 1e-4) -> list:
    """The labelled data ``rated`` with a new round's poses ``new`` (their answers merged)
    added: a pose ``rated`` already shows (the same scene and example, every entry of the
    4x4 within ``tolerance``) takes the new answers beside its own, the others are added
    under their round's ids; an id that ``rated`` gives another pose is refused."""
    out = list(rated)
    ids = {p.id: p for p in out}
    for p in new:
        same = next((q for q in out if q.scene == p.scene and q.example == p.example
                     and np.abs(np.asarray(q.pose) - np.asarray(p.pose)).max() <= tolerance),
                    None)
        if same is not None:
            same.answers.extend(p.answers)
        elif p.id in ids:
            raise InputError(None, f"pose id {p.id} is already another pose's in the "
                                   "labelled data")
        else:
            out.append(p)
            ids[p.id] = p
    return out


def rater_agreement(poses) -> float | None:
    """How often two raters of the same pose gave the same answer (%, over every pair of
    raters of every pose), or None without two answers to any pose."""
    same = pairs = 0
    for p in poses:
        a = p.answers
        for i in range(len(a)):
            for j in range(i + 1, len(a)):
                pairs += 1
                same += a[i] == a[j]
    return round(100.0 * same / pairs, 1) if pairs else None


def agreement_rows(poses, judged: dict) -> list:
    """Per affordance and split (``development``: the poses the judge's rules were fixed
    on; ``held-out``: the others): :func:`_tally`'s counts and how often two raters agree
    (%)."""
    rows = []
    for aff in affordances.names():
        for split, held in (("development", False), ("held-out", True)):
            items = [p for p in poses if p.affordance == aff and p.held_out == held
                     and p.id in judged]
            rows.append({"affordance": aff, "split": split, **_tally(items, judged),
                         "raters_agree": rater_agreement(items)})
    return rows


#: The columns of ``panel_agreement.csv`` (:func:`agreement_rows`).
AGREEMENT_COLUMNS = ["affordance", "split", "poses", "agree", "agreement", "panel_valid",
                     "judge_valid", "raters_agree"]


def agreement_markdown(rows: list) -> str:
    """:func:`agreement_rows` as a Markdown table, one line per affordance."""
    lines = ["| affordance | judge agrees with the panel: held-out poses | development poses | "
             "panel / judge call valid (held-out) | two raters agree |",
             "|---|---:|---:|---:|---:|"]
    for aff in affordances.names():
        held = next(r for r in rows if r["affordance"] == aff and r["split"] == "held-out")
        dev = next(r for r in rows if r["affordance"] == aff and r["split"] == "development")

        def share(r):
            return f"{r['agree']}/{r['poses']} ({r['agreement']} %)" if r["poses"] else "-"
        lines.append(f"| {aff} | {share(held)} | {share(dev)} | {held['panel_valid']} / "
                     f"{held['judge_valid']} | {held['raters_agree']} % |")
    return "\n".join(lines)


def add_panel_agreement(rows: list, scenes_dir, objects_dir=None, log=None) -> list:
    """The judge's accuracy ``rows`` (per affordance, :func:`~.labelled.judge_accuracy`) with
    its agreement with the panel's majority on the held-out poses beside it (``panel_n``,
    ``panel_agree``, ``panel_agreement`` %), judged in the scenes of ``scenes_dir``."""
    poses = load()
    judged = judge_poses([p for p in poses if p.held_out], scenes_dir, objects_dir, log)
    by_aff = {r["affordance"]: r for r in agreement(poses, judged)}
    for r in rows:
        a = by_aff.get(r["affordance"], {})
        r["panel_n"], r["panel_agree"] = a.get("poses", 0), a.get("agree", 0)
        r["panel_agreement"] = a.get("agreement")
    return rows
