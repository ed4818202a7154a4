"""Every parameter of training and detection, in one place, with the paper's defaults.

Each default cites where it comes from: ``paper`` is ``shared/paper.tex`` (Ruiz &
Mayol-Cuevas), ``code`` the authors' public implementation as summarised in
``shared/REFERENCE.md``, and ``ours`` a choice of this project, explained in the comment.
"""

from __future__ import annotations

import math
import numbers
import re
from dataclasses import asdict, dataclass, fields, replace

from interaction_tensor.errors import SettingsError

CRITERIA = ("paper", "gaussian")
KEYPOINT_SETS = ("weighted", "uniform")
BACKENDS = ("auto", "numba", "numpy", "torch")
#: The placement tests by name (``DetectSettings.skip_tests``); the per-pair ones run in
#: the order of ``placement.checks.TEST_ORDER``, the ranked ones (collision, hangs) on the
#: poses that would enter the top k.
PLACEMENT_TESTS = ("clearance", "contact", "interior", "ground", "feet", "straddle", "mount",
                   "through", "collision", "hangs", "fills")
#: The normal filter's tolerance (degrees) where neither the settings nor the descriptor
#: give one (``DetectSettings.normal_tolerance_deg``).
NORMAL_TOLERANCE_DEG = 15.0
#: Smallest sampling spacing (m): finer sampling grows memory as 1 / spacing^2 (a 1e-6 m
#: spacing asked for gigabytes before any check), and no scan resolves below a millimetre.
MIN_SPACING = 1e-3


def _check_seed(seed) -> None:
    _check(isinstance(seed, numbers.Integral) and not isinstance(seed, bool)
           and 0 <= seed < 2 ** 63, f"seed must be an integer in [0, 2**63), got {seed!r}")


def _check(cond: bool, message: str) -> None:
    if not cond:
        raise SettingsError(message)


@dataclass(frozen=True)
class TrainSettings:
    """How an Interaction Tensor is fitted from one example."""

    #: Area-uniform samples on the query object. Paper/code: 100k. Ours: 6000 is enough
    #: for the bisector near the contact and keeps the Voronoi step well under a second.
    query_points: int = 6000
    #: Mean spacing (m) of the samples on the scene-object. Detection samples mesh scenes at
    #: the same spacing, so that the provenance vectors learnt here and the test vectors
    #: measured there see the same point density (ours).
    scene_spacing: float = 0.01
    #: Scene-object samples are kept within ``crop_factor * radius`` of the query centroid
    #: before the Voronoi step. Bisector points whose empty sphere leaves that ball are
    #: dropped, so every point kept is exactly a point of the full diagram (ours).
    crop_factor: float = 2.0
    #: Affordance keypoints per set. Paper: N = 512.
    n_keypoints: int = 512
    #: Provenance (and later test) vectors: ``surface``, to the nearest point of the sampled
    #: surface (each sample a disk of radius ``scene_spacing``), or ``points``, to the nearest
    #: sample as in the paper's dense clouds. ``surface`` makes the vectors independent of
    #: where random samples fell, which the paper's tight tests on short vectors need (ours).
    vectors: str = "surface"
    #: Expected normal N_aff of the scene-object at the interaction, +Z up. Paper: up for
    #: placing, hanging, sitting, riding; down for filling (the tap).
    affordance_normal: tuple = (0.0, 0.0, 1.0)
    #: Contact: query samples within this distance (m) of the scene-object, plus the smallest
    #: gap, define the contact region whose centre gives the reference point (ours).
    contact_tolerance: float = 0.01
    #: Acceptance threshold of each criterion as a fraction of the lowest score the training
    #: example gets on perturbed copies of its scene-object (other samplings, densities,
    #: noise, sizes, turns: :mod:`~interaction_tensor.descriptor.calibration`; ours, the
    #: paper tunes S_aff by hand per affordance).
    calibration_ratio: float = 0.95
    #: Clearance points: query surface samples whose free space is recorded (the clearance
    #: idea of the authors' later iTClearance work: the query needs room, not an identical
    #: scene-object). 0 disables it (ours).
    clearance_points: int = 256
    #: Largest clearance (m) recorded per clearance point: the free space around the query
    #: that a new scene must leave, up to this (ours).
    clearance_max: float = 0.02
    #: Fraction of the clearance points a placement may violate before detection rejects it
    #: (stored in the descriptor; ours).
    clearance_limit: float = 0.05
    #: Depth (m) of the collision test a trained descriptor carries (a mesh query only):
    #: detection rejects a ranked placement whose query no move of this length frees from
    #: the scene's triangles, the judge's rule for an object. Raised to the example's own
    #: depth where its query lies deeper in its scene-object, so that the example passes
    #: its own test. None: no collision test until an acceptance preset sets one (ours).
    collision_depth: float | None = 0.01
    #: Interior points: points inside the query mesh, at least ``interior_min_depth`` (m)
    #: from its surface, whose depth (at most ``interior_max``) the scene must not come
    #: within: a surface passing through the object (a board through a seated body) meets
    #: many of them, a surface touching it none (see clearance.py). 0 disables it; a point
    #: cloud query has none (ours).
    interior_points: int = 512
    interior_min_depth: float = 0.015
    interior_max: float = 0.05
    #: Fraction of the interior points a placement may violate (stored in the descriptor;
    #: 1 turns the test off; ours).
    interior_limit: float = 0.05
    #: Contact groups: the query's samples within ``contact_tolerance`` of the scene-object
    #: (or of the example's ground plane) joined into groups by links of ``contact_link``
    #: (m), at most ``contact_group_points`` kept per group (ours).
    contact_group_points: int = 32
    contact_link: float = 0.03
    #: The contact test stored in the descriptor: ``main`` (the group at the reference
    #: point), ``all`` groups, ``off``, or ``auto``: all where the example touched in several
    #: places, else main; a group keeps its contact when at least ``contact_fraction`` of its
    #: points have a scene sample within ``contact_distance`` (m) (ours; the paper's
    #: examples carry values tuned per affordance).
    contact_groups: str = "auto"
    contact_distance: float = 0.02
    contact_fraction: float = 0.25
    #: ... and, below 90, the normal line of that nearest sample within this angle (degrees)
    #: of the normal the example's scene-object (or ground) had there: a hook's inner arc
    #: meets a round rail's normals all around, a flat shelf top's only at its apex (ours).
    contact_angle: float = 90.0
    #: Seed of every random step of training.
    seed: int = 0

    def __post_init__(self):
        _check(100 <= self.query_points <= 1_000_000,
               "query_points must be between 100 and 1,000,000 (memory grows with it)")
        _check(self.clearance_points >= 0, "clearance_points must be non-negative")
        _check(self.clearance_max > 0, "clearance_max must be positive (metres)")
        _check(0 <= self.clearance_limit <= 1, "clearance_limit must be in [0, 1]")
        _check(self.collision_depth is None
               or (isinstance(self.collision_depth, numbers.Real)
                   and 0 < self.collision_depth <= 0.2),
               "collision_depth must be None or in (0, 0.2] (metres)")
        _check_seed(self.seed)
        _check(math.isfinite(self.scene_spacing) and MIN_SPACING <= self.scene_spacing <= 1.0,
               f"scene_spacing must be between {MIN_SPACING} and 1 metre (samples cost "
               "memory as 1 / spacing^2), got {self.scene_spacing}")
        _check(self.crop_factor >= 1.0, "crop_factor must be at least 1")
        _check(self.n_keypoints >= 8, "n_keypoints must be at least 8")
        _check(self.vectors in ("surface", "points"), "vectors must be 'surface' or 'points'")
        _check(0 < self.calibration_ratio <= 1, "calibration_ratio must be in (0, 1]")
        _check(self.contact_tolerance > 0, "contact_tolerance must be positive")
        _check(self.interior_points >= 0, "interior_points must be non-negative")
        _check(0 < self.interior_min_depth <= self.interior_max,
               "interior_min_depth must be positive and at most interior_max (metres)")
        _check(0 <= self.interior_limit <= 1, "interior_limit must be in [0, 1]")
        _check(self.contact_group_points >= 1, "contact_group_points must be at least 1")
        _check(self.contact_link > 0, "contact_link must be positive (metres)")
        _check(self.contact_groups in ("off", "main", "all", "seat", "auto"),
               "contact_groups must be 'off', 'main', 'all', 'seat' or 'auto'")
        _check(self.contact_distance > 0, "contact_distance must be positive (metres)")
        _check(0 <= self.contact_fraction <= 1, "contact_fraction must be in [0, 1]")
        _check(0 < self.contact_angle <= 90, "contact_angle must be in (0, 90] degrees")
        n = [float(v) for v in self.affordance_normal]
        _check(len(n) == 3 and math.isfinite(sum(n)) and sum(v * v for v in n) > 0,
               "affordance_normal must be a non-zero 3-vector")

    def to_dict(self) -> dict:
        d = asdict(self)
        d["affordance_normal"] = [float(v) for v in self.affordance_normal]
        return d


@dataclass(frozen=True)
class DetectSettings:
    """How a scene is searched for places where a trained interaction can happen: the
    paper's parameters and the switches a user needs."""

    #: Fraction of scene points drawn at random as test points. Paper: 30 %.
    sample_fraction: float = 0.30
    #: Orientations of the query object about +Z, i * 2 pi / n. Paper and code: 8.
    n_orientations: int = 8
    #: Largest angle (degrees) between a test point's normal line and N_aff. Normals of CAD
    #: scenes and scans are not consistently oriented, so the sign is ignored unless
    #: ``oriented_normals`` (ours; the paper only says n_i ~ N_aff). None: the
    #: descriptor's own (``InteractionTensor.normal_tolerance``), else
    #: :data:`NORMAL_TOLERANCE_DEG` (:meth:`normal_tolerance`).
    normal_tolerance_deg: float | None = None
    oriented_normals: bool = False
    #: ``paper``: eq. 5 angle and magnitude tests; ``gaussian``: the authors' code criterion.
    #: None: by the kind of scene, ``gaussian`` for captured data (RGB-D frames and scans,
    #: whose depth noise the paper criterion's tight tests on short vectors do not tolerate),
    #: ``paper`` for meshes and clouds (see :meth:`for_scene`).
    criterion: str | None = None
    #: Paper criterion: theta_max = pi / 18 and c = 5 (paper, section 3.2).
    theta_max: float = math.pi / 18
    c: float = 5.0
    #: Gaussian criterion: sigma = a (1 + w) (code).
    gaussian_a: float = 0.4
    #: Acceptance threshold S_aff on the normalised score in [0, 1]. None: the descriptor's
    #: own for the criterion (tuned per affordance, or calibrated on its example).
    threshold: float | None = None
    #: Which keypoint set to compare: ``weighted`` (paper) or ``uniform``.
    keypoints: str = "weighted"
    #: Placement tests not to run, by name (:data:`PLACEMENT_TESTS`). Each runs where the
    #: descriptor asks for it: clearance (the scene no nearer the object than in the
    #: example), contact (what touched in the example touches again), interior (no scene
    #: surface through the object), ground (not below the floor around it), feet (a seated
    #: person's feet find a floor), straddle and mount (a rider astride, within reach of the
    #: ground), through (something through a hook's loop) and collision (the ranked poses'
    #: triangles against the scene's, where the scene has triangles).
    skip_tests: tuple = ()
    #: Predictions: the best pose of each of the best ``top_k`` places.
    top_k: int = 10
    #: Spacing (m) at which mesh scenes are sampled; None: the descriptor's training spacing.
    scene_spacing: float | None = None
    #: ``auto``: the Numba kernels when Numba imports, else ``numpy``; ``numpy``: the plain
    #: vectorised reference over SciPy's cKDTree; ``torch``: PyTorch, on a CUDA device when
    #: one is present (see ``device``). Every backend makes the same decisions.
    backend: str = "auto"
    #: Torch device of the ``torch`` backend; None: ``cuda`` when present, else ``cpu``.
    device: str | None = None
    #: Seed of the test-point draw and of scene sampling.
    seed: int = 0

    def __post_init__(self):
        _check(0 < self.sample_fraction <= 1, "sample_fraction must be in (0, 1]")
        _check(isinstance(self.n_orientations, numbers.Integral)
               and 1 <= self.n_orientations <= 360, "n_orientations must be in [1, 360]")
        _check(self.normal_tolerance_deg is None or 0 <= self.normal_tolerance_deg <= 180,
               "normal_tolerance_deg must be in [0, 180]")
        _check(self.criterion is None or self.criterion in CRITERIA,
               f"criterion must be one of {CRITERIA} (or None: by the kind of scene)")
        _check(self.keypoints in KEYPOINT_SETS, f"keypoints must be one of {KEYPOINT_SETS}")
        _check(self.theta_max > 0 and self.c > 0 and self.gaussian_a > 0,
               "theta_max, c and gaussian_a must be positive")
        _check(self.threshold is None or 0 < self.threshold <= 1,
               "threshold must be in (0, 1]")
        _check(isinstance(self.skip_tests, (tuple, list, frozenset, set)),
               "skip_tests must be a tuple of placement test names")
        unknown = sorted(set(self.skip_tests) - set(PLACEMENT_TESTS))
        _check(not unknown, f"skip_tests: unknown test{'s' if len(unknown) > 1 else ''} "
                            f"{', '.join(map(str, unknown))}; known: {', '.join(PLACEMENT_TESTS)}")
        object.__setattr__(self, "skip_tests", tuple(t for t in PLACEMENT_TESTS
                                                     if t in set(self.skip_tests)))
        _check(isinstance(self.top_k, numbers.Integral) and self.top_k >= 1,
               "top_k must be a positive integer")
        _check(self.scene_spacing is None or (math.isfinite(self.scene_spacing) and
                                              MIN_SPACING <= self.scene_spacing <= 1.0),
               f"scene_spacing must be between {MIN_SPACING} and 1 metre (samples cost "
               f"memory as 1 / spacing^2), got {self.scene_spacing}")
        _check(self.backend in BACKENDS, f"backend must be one of {BACKENDS}")
        _check(self.device is None or self.backend == "torch",
               f"device {self.device!r} applies to the torch backend only "
               f"(backend is {self.backend!r}; add --backend torch / backend='torch')")
        _check(self.device is None or isinstance(self.device, str) and bool(
            re.fullmatch(r"auto|cpu|mps|cuda(:\d+)?", self.device)),
            f"device must be auto, cpu, mps, cuda or cuda:N, got {self.device!r}")
        _check_seed(self.seed)

    def runs(self, test: str) -> bool:
        """Whether placement test ``test`` (:data:`PLACEMENT_TESTS`) may run."""
        return test not in self.skip_tests

    def to_dict(self) -> dict:
        d = {f.name: getattr(self, f.name) for f in fields(self)}
        d["skip_tests"] = list(self.skip_tests)
        return d

    def normal_tolerance(self, tensor) -> float:
        """The normal filter's tolerance (degrees) for ``tensor``: these settings', else the
        descriptor's, else :data:`NORMAL_TOLERANCE_DEG`."""
        if self.normal_tolerance_deg is not None:
            return float(self.normal_tolerance_deg)
        own = getattr(tensor, "normal_tolerance", None)
        return NORMAL_TOLERANCE_DEG if own is None else float(own)

    def for_scene(self, scene) -> "DetectSettings":
        """These settings with the defaults that depend on the scene filled in: the criterion
        (``gaussian`` for a captured scene, ``scene.captured``; else ``paper``)."""
        if self.criterion is not None:
            return self
        return replace(self, criterion="gaussian" if getattr(scene, "captured", False)
                       else "paper")
