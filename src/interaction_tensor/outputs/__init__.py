"""Pictures and an HTML viewer of detections and descriptors.

- :func:`render_outdir`: ``render.png`` of a detection directory (heat map, colour bar, the
  query object at the top predictions, cameras chosen to see them).
- :func:`render_tensor`: a descriptor drawn like the paper's figure 2.
- :func:`write_viewer`: ``index.html``, a self-contained interactive 3D page.

Rendering is done in software (a NumPy z-buffer that splats points with Lambert shading and
eye-dome lighting), so it needs no display, no OpenGL and no GPU: the same code runs on a
laptop, a headless server and CI. Pillow writes the PNG and draws the text.
"""

from interaction_tensor.outputs.html import write_viewer
from interaction_tensor.outputs.render import render_outdir, render_tensor

__all__ = ["render_outdir", "render_tensor", "write_viewer"]
