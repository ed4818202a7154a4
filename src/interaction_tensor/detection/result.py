"""What one detection run found: :class:`Detection`, with the top predictions as arrays and
the outputs it writes.
"""

from __future__ import annotations

import time
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

from interaction_tensor.capture.outputs import write_input_frame_outputs
from interaction_tensor.descriptor.tensor import InteractionTensor
from interaction_tensor.detection.places import Prediction
from interaction_tensor.engine.scoring import PairScores
from interaction_tensor.geometry.files import atomic_dir, output_path
from interaction_tensor.geometry.scene import Scene
from interaction_tensor.outputs.export import (
    DESCRIPTOR_FILE,
    OUTPUT_NAMES,
    export,
    result_open3d,
    result_scene,
)
from interaction_tensor.outputs.render import render_outdir
from interaction_tensor.settings import DetectSettings


@dataclass
class Detection:
    """Everything one detection run found.

    Attributes
    ----------
    scene : the Scene searched
    tensor : the descriptor used
    settings : the DetectSettings used; ``threshold`` the threshold applied
    test_indices : (T,) scene indices drawn as test points
    candidate_indices : (C,) test points that passed the normal filter
    pair_point, pair_orientation : (P,) scene index and orientation of every scored pair
    pairs : PairScores of those pairs; ``pairs.accepted`` is the final decision (score and
        placement tests)
    score_accepted : (P,) bool, accepted by the score alone (False for a pair never scored:
        ``DetectSettings.stage_order`` tests-first scores only the pairs that pass the
        placement tests, see ``scored``)
    clearance_violations : (P,) int16 (int32 past 32,767 clearance points), clearance points
        violated (-1 where not tested: score-first, pairs the score rejected; or no
        clearance test); on
        the Numba backend counted up to the first past the limit (a pair that fails the
        test holds the limit's count + 1)
    placement : (P,) int8, the outcome of the placement tests (see the attribute)
    heat : (N,) per scene point: best accepted score near it (0 where none)
    accepted_count : (N,) accepted orientations at each scene point
    predictions : the top k, best first: the best pose of each of the best places
    places : :class:`~.places.Place` list, best first: the accepted pairs grouped into
        connected regions (a table top, a shelf, a rail)
    stats : counts and seconds per stage
    """

    scene: Scene
    tensor: InteractionTensor
    settings: DetectSettings
    threshold: float
    test_indices: np.ndarray
    candidate_indices: np.ndarray
    pair_point: np.ndarray
    pair_orientation: np.ndarray
    pairs: PairScores
    heat: np.ndarray
    accepted_count: np.ndarray
    predictions: list = field(default_factory=list)
    stats: dict = field(default_factory=dict)
    score_accepted: np.ndarray | None = None
    clearance_violations: np.ndarray | None = None
    #: (N + 1,) the largest score keypoints k.. can still add, in the order they were
    #: compared: ``score + rest[decided_at]`` bounds a rejected pair's full score
    rest: np.ndarray | None = None
    #: (P,) int8 outcome of the placement tests: -1 not tested (score-first: the score
    #: rejected the pair; tests-first tests every pair), 0 placed, else the first test
    #: failed (1 clearance, 2 contact, 3 interior, 4 collision, ...: :mod:`~interaction_tensor.placement.checks`; the
    #: collision test runs on ranked pairs only)
    placement: np.ndarray | None = None
    #: the collision test of ranked pairs (:class:`~.ranking.CollisionCheck`), None until built
    collisions: object = field(default=None, repr=False)
    #: (P,) bool: pairs whose score covers every keypoint (the others hold the partial sum
    #: at their decision); None: those the score accepted
    complete: np.ndarray | None = None
    #: (P,) bool: pairs that were scored at all (``DetectSettings.stage_order``
    #: ``tests-first`` scores only the pairs that pass the placement tests; the others hold
    #: score 0, decided at 0, and ``score_accepted`` False); None: every pair
    scored: np.ndarray | None = None
    #: how the search did its work (:class:`~.search.Engine`)
    engine: object = field(default=None, repr=False)
    #: what a user should know about this result, one line each: an empty result says why
    #: and what to do (:func:`~.search.empty_result_warnings`)
    warnings: list = field(default_factory=list)
    places: list = field(default_factory=list)
    #: (P,) int32 the place of each pair accepted when the places were cut, -1 for the
    #: others; None before ranking
    pair_place: np.ndarray | None = field(default=None, repr=False)
    #: pair -> how far (m) its container was moved up (negative: down) to stand on what is
    #: under it, NaN where nothing is (:meth:`lift`; a descriptor that asks for the filling
    #: tests), for the pairs asked so far
    lifts: dict = field(default_factory=dict, repr=False)

    def lift(self, pair: int) -> float:
        """How far (m) pair ``pair``'s container moves up (negative: down) to stand on the
        highest surface under its base (:func:`~interaction_tensor.placement.taps.settle`):
        a tap's height above the basin is not the example's. NaN where nothing is under it
        within reach; 0 for a descriptor that does not ask for the filling tests."""
        if not self.tensor.fills:
            return 0.0
        if pair not in self.lifts:
            from interaction_tensor.placement import taps

            pose = self._scored_pose(pair)
            self.lifts[pair] = taps.settle(self.tensor.vessel(), pose[:3, :3], pose[:3, 3],
                                           self.scene.points, self.scene.tree)
        return self.lifts[pair]

    def pair_angle(self, pair: int) -> float:
        """The angle (radians) about +Z of pair ``pair``'s orientation."""
        return 2 * np.pi * int(self.pair_orientation[pair]) / self.settings.n_orientations

    def _scored_pose(self, pair: int) -> np.ndarray:
        """The descriptor's pose at pair ``pair``'s test point and orientation: the one its
        score and placement tests are of."""
        return self.tensor.pose(self.scene.points[self.pair_point[pair]], self.pair_angle(pair))

    def pair_pose(self, pair: int) -> np.ndarray:
        """4x4 pose of pair ``pair`` (an index into the pair arrays): the descriptor's pose
        at its test point and orientation, a container stood on what is under it
        (:meth:`lift`, where there is something)."""
        pose = self._scored_pose(pair)
        dz = self.lift(pair)
        if np.isfinite(dz):
            pose[2, 3] += dz
        return pose

    @property
    def accepted(self) -> np.ndarray:
        """Indices into the pair arrays of accepted pairs (int32 when they fit)."""
        return accepted_indices(self.pairs.accepted)

    @property
    def accepted_place(self) -> np.ndarray | None:
        """(A,) the place of each accepted pair (:attr:`accepted` order; a pair the
        collision test rejected after the places were cut is no longer accepted); None
        before ranking."""
        return None if self.pair_place is None else self.pair_place[self.accepted]

    def prediction(self, pair: int, place: int = -1) -> Prediction:
        """The :class:`~.places.Prediction` of pair ``pair`` (an index into the pair arrays)."""
        o, p = int(self.pair_orientation[pair]), int(self.pair_point[pair])
        return Prediction(position=self.scene.points[p].copy(), orientation_index=o,
                          angle=float(self.pair_angle(pair)),
                          score=float(self.pairs.score[pair]), pose=self.pair_pose(pair),
                          point_index=p, place=place)

    def place_predictions(self, place: int, limit: int | None = None) -> list:
        """Every accepted pose of place ``place`` (an index into :attr:`places`), best
        first (at most ``limit``), whether or not the collision test was asked about it."""
        if self.accepted_place is None or not 0 <= place < len(self.places):
            raise IndexError(f"place {place} out of range: this result has "
                             f"{len(self.places)} places")
        acc = self.accepted
        mine = acc[self.pair_place[acc] == place]
        mine = mine[np.argsort(-self.pairs.score[mine], kind="stable")][:limit]
        return [self.prediction(int(i), place) for i in mine]

    # ------------------------------------------------------------ the top predictions as arrays
    @property
    def positions(self) -> np.ndarray:
        """(K, 3) test points of the top predictions, best first (metres)."""
        return np.array([p.position for p in self.predictions], np.float64).reshape(-1, 3)

    @property
    def scores(self) -> np.ndarray:
        """(K,) normalised scores of the top predictions, best first."""
        return np.array([p.score for p in self.predictions], np.float64)

    @property
    def orientations(self) -> np.ndarray:
        """(K,) angles (radians) about +Z of the top predictions."""
        return np.array([p.angle for p in self.predictions], np.float64)

    @property
    def orientation_indices(self) -> np.ndarray:
        """(K,) orientation indices i (angle = i * 2 pi / n_orientations)."""
        return np.array([p.orientation_index for p in self.predictions], np.int64)

    @property
    def poses(self) -> np.ndarray:
        """(K, 4, 4) rigid transforms of the training-frame query object into the scene."""
        return np.array([p.pose for p in self.predictions], np.float64).reshape(-1, 4, 4)

    def __repr__(self) -> str:
        best = f", best {self.predictions[0].score:.3f}" if self.predictions else ""
        return (f"<Detection {self.tensor.affordance!r} in {self.scene.source}: "
                f"{len(self.predictions)} predictions{best}, {len(self.places)} places; "
                f"{int(self.pairs.accepted.sum())} of "
                f"{len(self.pair_point)} pairs accepted at threshold {self.threshold:.3f}>")

    # ------------------------------------------------------------ outputs
    def save(self, outdir, *, render: bool = True, scene_name: str | None = None,
             descriptor_name: str | None = None, also: dict | None = None) -> Path:
        """Write the result into ``outdir`` (what ``itensor detect -o`` writes), as one
        transaction: built in a temporary sibling directory and swapped in, so ``outdir``
        holds either the complete earlier result or the complete new one.

        ``predictions.json``, ``accepted.npz``, ``heatmap.ply`` (score as ``quality`` and
        ``scalar_score``), ``predictions.glb`` (scene heat map and posed objects, for browsers
        and Blender) and ``top/``; ``descriptor.npz``, a copy of the descriptor, unless
        ``descriptor_name`` is the path of its file (so that ``itensor view`` shows the
        training example however the descriptor was made); for a captured scene also the
        same in the input's own frame; ``render.png``, the picture, unless ``render`` is
        False. ``also`` maps further file names to functions that write them (given the
        path), inside the same transaction. An existing ``outdir`` must
        be empty or hold an earlier result (and nothing else). Returns ``outdir`` as a Path.
        """
        outdir = output_path(outdir, "output directory")
        t = time.perf_counter()
        report = getattr(self.scene, "report", None)
        also = dict(also or {})
        # a descriptor named by its file (or written with the result) needs no copy
        given = Path(str(descriptor_name)) if descriptor_name is not None else None
        named = given is not None and given.suffix == ".npz" and (given.is_file()
                                                                  or given.name in also)
        with atomic_dir(outdir, "predictions.json", OUTPUT_NAMES + tuple(also)) as tmp:
            for name, write in also.items():
                write(tmp / name)
            if not named:       # made in Python or moved: the viewer finds a copy beside
                self.tensor.save(tmp / DESCRIPTOR_FILE)
            export(self, tmp, scene_name or (report.source if report is not None else None),
                   descriptor_name, None if named else DESCRIPTOR_FILE)
            if report is not None:
                write_input_frame_outputs(self, tmp, report.transform, report)
            self.stats["seconds"]["export"] = round(time.perf_counter() - t, 4)
            if render:
                render_outdir(tmp, normals=self.scene.normals, spacing=self.scene.spacing)
        return outdir

    def to_trimesh(self):
        """A ``trimesh.Scene``: the scene points coloured by the heat map (grey: nothing
        accepted near) and the query object posed at each top prediction."""
        return result_scene(self)

    def to_open3d(self) -> list:
        """Open3D geometries: the heat-map point cloud, then one posed query per prediction
        (``open3d.visualization.draw_geometries(result.to_open3d())``)."""
        return result_open3d(self)


def accepted_indices(accepted: np.ndarray) -> np.ndarray:
    """Indices of the True entries of a per-pair mask, int32 when they fit (a 2 M-point scene
    at 30 % accepts millions of pairs)."""
    idx = np.flatnonzero(accepted)
    return idx.astype(np.int32) if len(accepted) < 2 ** 31 else idx
