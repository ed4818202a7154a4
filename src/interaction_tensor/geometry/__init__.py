"""Geometry and formats: the Geometry type, readers and writers, sampling, collision, the
scene index.

- :mod:`.core`: :class:`Geometry` (metres, +Z up) and its checks
- :mod:`.readers`, :mod:`.load`: one reader per file format; :func:`load_geometry`,
  :func:`as_geometry`
- :mod:`.files`: atomic files and directories, JSON, PLY and mesh writers
- :mod:`.sampling`: area-uniform samples, normals, spacing, winding numbers
- :mod:`.collision`: exact triangle collisions (python-fcl)
- :mod:`.grid`, :mod:`.scene`: the scene index (points, normals, grid, KD-tree, ground)
"""

from interaction_tensor.geometry.core import Geometry, validate_geometry
from interaction_tensor.geometry.load import as_geometry, load_geometry

__all__ = ["Geometry", "validate_geometry", "as_geometry", "load_geometry"]
