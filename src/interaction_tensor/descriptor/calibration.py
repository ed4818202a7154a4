"""What a descriptor trained from a new example accepts, derived from the example itself.

No one tuned an acceptance for a user's own pair, so training derives it from the example:

- **S_aff** from perturbed copies of the scene-object (:data:`PERTURBATIONS`): the changes a
  new scene brings to a place where the interaction is right (another sampling and density,
  sensor noise, another size; for a hanging example, a rail crossing the hook at an angle).
  On each copy the example's pose is scored at the test points detection would have near
  the reference point; the threshold is ``calibration_ratio`` x the lowest of the copies'
  best scores, so that every such place would pass. A copy counts only where the example's
  pose is still the interaction on it (:func:`still_holds`): a towel over a bar 20 %
  shorter than itself has the bar's brackets through its cloth, and over a bar turned
  under it the bar through both its sheets, so neither is a place to find.
- **The contact test** of every place the example touched, where it touched in several (a
  person lying from head to heels; ``TrainSettings.contact_groups = "auto"``).
- **The hanging tests** when the example hangs (:func:`hangs_from`): the query's mass lies
  below the point it rests on and the scene-object passes through it (a rail through a
  hook, a bar through a towel's fold, a peg through a mug's handle). Something must then
  cross the same opening in a new scene, fit inside it and leave the object hanging free
  (:mod:`~interaction_tensor.placement.hooks`), and the object may not reach below the
  scene's ground.

The clearance, interior and collision tests are the training settings' own, on by default
(:class:`~interaction_tensor.settings.TrainSettings`).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from scipy.spatial.transform import Rotation

from interaction_tensor.geometry.collision import Body, MeshCollider
from interaction_tensor.geometry.core import Geometry

#: Test points scored per perturbed copy: the nearest to the reference point.
CALIBRATION_POINTS = 32

#: The lowest threshold derived: the score then decides little, the placement tests the
#: rest (the paper's hanging and filling examples are tuned to 0.02-0.03 the same way).
MIN_THRESHOLD = 0.01

#: How far (m) below its ground a hanging example's object may reach in a new scene (the
#: hanging preset's).
HANGING_BELOW_GROUND = 0.01

#: An example hangs when its query's centre of mass lies at least this fraction of the
#: query's extent along N_aff below the reference point.
HANGING_DEPTH = 0.25


@dataclass(frozen=True)
class Perturbation:
    """One change of the example's scene-object: re-sampled at ``spacing`` x the
    descriptor's spacing, samples moved by gaussian ``noise`` (x the spacing, per axis),
    scaled by ``scale`` and turned by ``turn`` degrees about N_aff, both about the
    reference point. It calibrates the thresholds of ``criteria`` (a noisy copy is a
    captured scene's, whose criterion is the gaussian one)."""

    name: str
    spacing: float = 1.0
    noise: float = 0.0
    scale: float = 1.0
    turn: float = 0.0
    criteria: tuple = ("paper", "gaussian")

    def apply(self, scene_object: Geometry, reference, normal) -> Geometry:
        """The scaled and turned scene-object (sampling and noise are the caller's)."""
        if self.scale == 1.0 and self.turn == 0.0:
            return scene_object
        axis = np.asarray(normal, float) / np.linalg.norm(normal)
        rot = Rotation.from_rotvec(np.radians(self.turn) * axis).as_matrix()
        v = ((np.asarray(scene_object.vertices, float) - reference) @ rot.T) * self.scale \
            + reference
        normals = None if scene_object.normals is None else scene_object.normals @ rot.T
        return Geometry(v, scene_object.faces, normals=normals, source=scene_object.source)


#: The copies the thresholds are derived from: two other samplings, a 1.5x and 2x sparser
#: one (a cloud), noise of a third of the spacing (a scan: the gaussian criterion's only),
#: the scene-object 20 % smaller and 25 % larger. Not turned: a box pushed into a corner or
#: a person along a bench turned by half an orientation step is no longer the interaction
#: (more orientations find such places, a lower threshold does not).
PERTURBATIONS = (
    Perturbation("resampled"),
    Perturbation("resampled again"),
    Perturbation("1.5x sparser", spacing=1.5),
    Perturbation("2x sparser", spacing=2.0),
    Perturbation("noisy", noise=0.3, criteria=("gaussian",)),
    Perturbation("smaller", scale=0.8),
    Perturbation("larger", scale=1.25),
)

#: And for an example that hangs: a hook hangs from a rail crossing it at an angle, so the
#: rail turned by half of detection's 45-degree orientation step is a right place too.
HANGING_PERTURBATIONS = (Perturbation("turned", turn=22.5),)


def still_holds(query: Geometry, scene_object: Geometry, copy: Geometry,
                depth: float) -> bool:
    """Whether the example's query, as posed, is still the interaction on a perturbed
    ``copy`` of its ``scene_object``: it lies no deeper in the copy than ``depth`` (m) or
    than in the scene-object itself, whichever is deeper (the shortest freeing move,
    :meth:`~interaction_tensor.geometry.collision.MeshCollider.separation`). Meshes only:
    a point cloud on either side has no triangles to test, and its copies all count."""
    if copy is scene_object or not (query.is_mesh and copy.is_mesh):
        return True
    body = Body(query.vertices, query.faces)
    own = MeshCollider(scene_object.vertices, scene_object.faces).separation(body, np.eye(4))
    allowed = max(float(depth), own)
    return not MeshCollider(copy.vertices, copy.faces).penetrates(body, np.eye(4), allowed)[0]


def hangs_from(query_points: np.ndarray, reference_point, normal,
               through_section: np.ndarray) -> bool:
    """Whether the example hangs from its scene-object: the query's centre of mass (of its
    surface samples ``query_points``) at least :data:`HANGING_DEPTH` of its extent along
    ``normal`` (N_aff) below ``reference_point``, and a section of the scene-object through
    it (``through_section``, at least a triangle)."""
    if len(through_section) < 3 or len(query_points) == 0:
        return False
    n = np.asarray(normal, float) / np.linalg.norm(normal)
    h = (np.asarray(query_points, float) - reference_point) @ n
    extent = float(h.max() - h.min())
    return extent > 0 and float(h.mean()) <= -HANGING_DEPTH * extent
