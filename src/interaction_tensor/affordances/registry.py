"""The affordance registry: each affordance declared once, with everything that makes it one.

An :class:`Affordance` holds its name, the question a person answers about a pose of it, N_aff,
its training examples (:class:`ExampleSpec`: a procedural query and, optionally, a real query
file), how an example is posed on its scene-object, the tuned acceptance its descriptors get,
and the tests of the judge that stands for people's verdicts (:class:`JudgeRule`; the judge
itself lives in the paper's reproduction, which reads them from here). The five affordances of
the paper are modules of this package, registered on import; :func:`register` adds another.

Every example is posed by the same rule: its affordance's ``pose`` builds the scene-object and
moves the query object onto it (:mod:`interaction_tensor.examples.posing`); :func:`build`
returns the posed :class:`Example` and :func:`build_descriptor` fits its tensor.
"""

from __future__ import annotations

from dataclasses import dataclass, field, replace
from pathlib import Path
from typing import Callable

import numpy as np

from interaction_tensor.descriptor.tensor import InteractionTensor
from interaction_tensor.errors import InputError
from interaction_tensor.geometry.core import Geometry
from interaction_tensor.geometry.load import load_geometry
from interaction_tensor.settings import TrainSettings

UP = (0.0, 0.0, 1.0)
DOWN = (0.0, 0.0, -1.0)
#: The judge's tests (the paper's reproduction implements each; ``itensor_paper.judge``).
JUDGE_TESTS = ("upright", "penetration", "contact", "support", "overhead", "basin", "sink",
               "loop", "fits", "free", "ground", "feet", "astride", "legroom", "mount")


@dataclass(frozen=True)
class ExampleSpec:
    """One training example of an affordance.

    Attributes
    ----------
    name : ``<affordance>-<object>``, e.g. ``placing-bowl``
    description : one line, e.g. "a bowl resting on a table"
    query : builds the procedural query object (metres, +Z up)
    real_query : file in an objects directory used instead of the procedural query object
    real_scene_object : file used instead of the procedural scene-object (sitting: the stool)
    affordance, normal, anchor : filled from the affordance that declares the example
    """

    name: str
    description: str
    query: Callable[[], Geometry] = field(repr=False, compare=False)
    real_query: str | None = None
    real_scene_object: str | None = None
    affordance: str = ""
    normal: tuple = UP
    anchor: str = "bottom"


@dataclass(frozen=True)
class JudgeRule:
    """How the judge decides whether a pose of the affordance is right.

    Attributes
    ----------
    tests : the judge's tests that must pass (:data:`JUDGE_TESTS`)
    hull : the query is a container, tested as its convex hull (its cavity must stay free)
    person : the query is a person (a larger penetration allowance, limbs tested apart)
    """

    tests: tuple
    hull: bool = False
    person: bool = False


@dataclass(frozen=True)
class Posed:
    """What an affordance's ``pose`` returns: the query moved into the interaction, the
    scene-object, the point of it the interaction rests on, and for a hook or strap its loop
    ``(centre (3,), inner radius, axis (3,))``."""

    query: Geometry
    scene_object: Geometry
    support_point: tuple
    loop: tuple | None = None


@dataclass(frozen=True)
class Affordance:
    """One affordance (module docstring).

    Attributes
    ----------
    name : e.g. ``placing``
    question : what a person is asked about a pose (the blind panel's question)
    normal : N_aff, the expected scene normal at the interaction (unit 3-vector)
    anchor : the query's posing anchor, ``bottom``, ``seat`` or ``hook``
        (:func:`~interaction_tensor.examples.posing.anchor_point`)
    examples : the training examples
    pose : ``pose(query, spec, scene_object_file, seed) -> Posed``: builds the scene-object
        (or moves ``scene_object_file``'s) and poses the query on it
    acceptance : keyword arguments of :meth:`InteractionTensor.set_acceptance`: S_aff for both
        criteria and the placement tests, tuned on procedural validation rooms
    judge : the judge's rule
    reference_at_support : the descriptor's reference point is the support point (False:
        found by training on the scene-object, as for filling, whose test points lie on the
        tap)
    """

    name: str
    question: str
    normal: tuple
    anchor: str
    examples: tuple
    pose: Callable = field(repr=False, compare=False)
    acceptance: dict = field(default_factory=dict, repr=False, compare=False)
    judge: JudgeRule = JudgeRule(("upright", "penetration", "contact"))
    reference_at_support: bool = True

    def __post_init__(self):
        object.__setattr__(self, "examples", tuple(
            replace(e, affordance=self.name, normal=tuple(self.normal), anchor=self.anchor)
            for e in self.examples))
        unknown = sorted(set(self.judge.tests) - set(JUDGE_TESTS))
        if unknown:
            raise ValueError(f"affordance {self.name!r}: unknown judge tests {unknown}")


@dataclass
class Example:
    """One interaction example, posed: the query object and the scene-object in one frame.

    Attributes
    ----------
    spec : what the example is
    query, scene_object : the two objects, posed, metres, +Z up
    support_point : (3,) the point of the scene-object the interaction rests on: the table
        top under the object, the basin bottom under the mug, the rail top under the hook,
        the seat top under the person. The judge's main contact is the query's contact
        nearest to it.
    loop : for hanging, ``(centre (3,), inner radius, axis (3,))`` of the hook or strap loop
        that the support passes through; None otherwise
    real_query, real_scene_object : whether they were read from files
    ground : height (m) of the floor the scene-object stands on (its lowest point): the
        seated person's feet rest on it
    """

    spec: ExampleSpec
    query: Geometry
    scene_object: Geometry
    support_point: np.ndarray
    loop: tuple | None = None
    real_query: bool = False
    real_scene_object: bool = False
    ground: float | None = None


_AFFORDANCES: dict[str, Affordance] = {}
_EXAMPLES: dict[str, ExampleSpec] = {}


def register(affordance: Affordance) -> Affordance:
    """Add ``affordance`` and its examples to the registry; returns it. A name already
    registered (an affordance's or an example's) is refused."""
    if affordance.name in _AFFORDANCES:
        raise ValueError(f"affordance {affordance.name!r} is already registered")
    clash = [e.name for e in affordance.examples if e.name in _EXAMPLES]
    if clash:
        raise ValueError(f"examples already registered: {', '.join(clash)}")
    _AFFORDANCES[affordance.name] = affordance
    _EXAMPLES.update({e.name: e for e in affordance.examples})
    return affordance


def unregister(name: str) -> None:
    """Remove affordance ``name`` and its examples from the registry."""
    aff = _AFFORDANCES.pop(name)
    for e in aff.examples:
        _EXAMPLES.pop(e.name, None)


def names() -> list[str]:
    """The registered affordances' names, in the order they were registered."""
    return list(_AFFORDANCES)


def get(name: str) -> Affordance:
    """The affordance ``name``; an unknown name is refused with the known ones."""
    if name not in _AFFORDANCES:
        raise InputError(None, f"unknown affordance {name!r}; known: {', '.join(_AFFORDANCES)}")
    return _AFFORDANCES[name]


def example_names() -> list[str]:
    """Every registered example's name, affordance by affordance."""
    return list(_EXAMPLES)


def spec(name: str) -> ExampleSpec:
    """The example ``name``; an unknown name is refused with the known ones."""
    if name not in _EXAMPLES:
        raise InputError(None, f"unknown example {name!r}; known: {', '.join(_EXAMPLES)}")
    return _EXAMPLES[name]


def of(example: str) -> Affordance:
    """The affordance of example ``example``."""
    return get(spec(example).affordance)


def acceptance(affordance: str) -> dict:
    """The tuned acceptance of affordance ``affordance``: keyword arguments of
    :meth:`InteractionTensor.set_acceptance`."""
    aff = get(affordance)
    if not aff.acceptance:
        raise InputError(None, f"affordance {affordance!r} has no tuned acceptance")
    return dict(aff.acceptance)


def acceptances() -> dict:
    """Every registered affordance's tuned acceptance, by affordance name (those that have
    one)."""
    return {name: dict(aff.acceptance) for name, aff in _AFFORDANCES.items() if aff.acceptance}


def load_object(objects_dir, file: str) -> Geometry:
    """``file`` of an objects directory (a real query or scene-object)."""
    path = Path(objects_dir) / file
    if not path.exists():
        raise InputError(path, "no such object file (expected in the --objects directory)")
    return load_geometry(path)


def build(name: str, objects_dir=None, seed: int = 0, real_scene_object: bool = False) -> Example:
    """The example ``name`` posed in interaction.

    Parameters
    ----------
    name : a registered example
    objects_dir : directory holding real query objects (``ExampleSpec.real_query``); None
        for procedural objects only. Examples without a real file stay procedural.
    real_scene_object : also read the scene-object from ``objects_dir`` where the example has
        one (sitting: ``stool.ply``, the paper's stool, a point cloud). Off by default: the
        point-cloud stool scores its own re-sampled copy poorly (self-score about 0.15), and
        the procedural stool is a clean mesh.
    """
    sp = spec(name)
    aff = get(sp.affordance)
    real_q = objects_dir is not None and sp.real_query is not None
    real_s = real_scene_object and objects_dir is not None and sp.real_scene_object is not None
    query = load_object(objects_dir, sp.real_query) if real_q else sp.query()
    scene_object_file = Path(objects_dir) / sp.real_scene_object if real_s else None
    posed = aff.pose(query, sp, scene_object_file, seed)
    ground = min(float(posed.scene_object.vertices[:, 2].min()),
                 float(posed.query.vertices[:, 2].min()))
    return Example(sp, posed.query, posed.scene_object,
                   np.asarray(posed.support_point, float), posed.loop, real_q, real_s, ground)


def train_settings(name: str, spacing: float = 0.01, seed: int = 0,
                   query_points: int = 6000) -> TrainSettings:
    """TrainSettings of example ``name``: its N_aff, the spacing and the seed."""
    return TrainSettings(affordance_normal=spec(name).normal, scene_spacing=spacing,
                         query_points=query_points, seed=seed)


def build_descriptor(name: str, objects_dir=None, seed: int = 0, spacing: float = 0.01,
                     example: Example | None = None, tuned: bool = True) -> InteractionTensor:
    """Fit the Interaction Tensor of example ``name`` (see :func:`build`).

    The reference point p_scene is the example's support point (the seat's, the rail's or the
    table's point under the query), where detection's test points will be, unless the
    affordance finds it by training (filling: on the tap). With ``tuned``, the affordance's
    acceptance replaces the calibrated threshold.
    """
    ex = example or build(name, objects_dir, seed)
    aff = get(ex.spec.affordance)
    ref = ex.support_point if aff.reference_at_support else None
    tensor = InteractionTensor.fit(ex.query, ex.scene_object, name,
                                   train_settings(name, spacing, seed), reference_point=ref,
                                   ground=ex.ground)
    if tuned and aff.acceptance:
        tensor.set_acceptance(**aff.acceptance)
    return tensor
