"""RGB-D frames: intrinsics files, depth and colour images, back-projection to a cloud."""

from __future__ import annotations

import json
import math
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from interaction_tensor.errors import InputError, SettingsError
from interaction_tensor.geometry.core import Geometry, validate_geometry

#: Depth conventions when neither the intrinsics file nor the caller gives them: 1000 units
#: per metre (millimetre PNGs of Kinect v2, RealSense, Azure Kinect) and 3 m truncation,
#: Open3D's defaults for ``RGBDImage.create_from_color_and_depth``.
DEFAULT_DEPTH_SCALE = 1000.0
DEFAULT_DEPTH_TRUNC = 3.0
#: A frame's surface (:func:`depth_faces`): neighbouring pixels are joined into a triangle
#: only when their depths differ by at most ``DEPTH_JUMP_ABS + DEPTH_JUMP_REL * z`` (m; z the
#: nearest of the three): 1 cm plus 2 % of the depth. A smooth surface seen at a grazing
#: angle stays joined (a floor 3 m away under a camera 1.8 m up: about 1 cm between rows,
#: within one step of a Kinect's depth quantisation there, about 2.6 cm), while the edge of a
#: desk against the floor behind it, or a cup against the wall, is left open.
DEPTH_JUMP_ABS = 0.01
DEPTH_JUMP_REL = 0.02
#: Most triangles a frame's surface may have: larger depth images are triangulated on every
#: k-th pixel (k the smallest stride that fits), which bounds the collision model's memory
#: (python-fcl's BVH, a few hundred bytes a triangle) whatever the camera.
MAX_FRAME_FACES = 1_000_000
#: What intrinsics may hold, checked before any image is read: images of at most this many
#: pixels a side; focal lengths (pixels) from 0.05 x the image's shorter side (a 175-degree
#: view: nothing a pinhole model describes is wider) to 20 x its longer side (a 3-degree
#: telephoto); at most this many depth units per metre (a micrometre PNG) and this range (m).
MAX_IMAGE_SIDE = 16384
FOCAL_MIN_FACTOR, FOCAL_MAX_FACTOR = 0.05, 20.0
MAX_DEPTH_SCALE = 1e6
MAX_DEPTH_TRUNC = 100.0


# ============================================================================ intrinsics
@dataclass(frozen=True)
class Intrinsics:
    """Pinhole intrinsics and depth convention of one RGB-D frame.

    Attributes
    ----------
    width, height : image size in pixels
    fx, fy : focal lengths in pixels
    cx, cy : principal point in pixels (0 is the centre of the first pixel)
    depth_scale : depth-image units per metre (5000 for TUM, 1000 for millimetre PNGs)
    depth_trunc : depth beyond this (m) is ignored
    source : where the values came from
    """

    width: int
    height: int
    fx: float
    fy: float
    cx: float
    cy: float
    depth_scale: float = DEFAULT_DEPTH_SCALE
    depth_trunc: float = DEFAULT_DEPTH_TRUNC
    source: str = "<intrinsics>"

    def __post_init__(self):
        check_intrinsics({k: getattr(self, k) for k in _FIELDS}, self.source)

    def to_dict(self) -> dict:
        return {k: getattr(self, k) for k in _FIELDS + ("source",)}


_FIELDS = ("width", "height", "fx", "fy", "cx", "cy", "depth_scale", "depth_trunc")


def check_intrinsics(values: dict, source, overridden=()) -> None:
    """Refuse intrinsics no camera has, before anything uses them: ``values`` maps each of
    width, height, fx, fy, cx, cy, depth_scale and depth_trunc to a number. The image at
    most :data:`MAX_IMAGE_SIDE` pixels a side, whole; focal lengths within
    :data:`FOCAL_MIN_FACTOR` x the shorter side and :data:`FOCAL_MAX_FACTOR` x the longer
    side; the principal point inside the image; depth_scale in (0, :data:`MAX_DEPTH_SCALE`]
    units per metre and depth_trunc in (0, :data:`MAX_DEPTH_TRUNC`] m. Raises
    :class:`InputError` naming ``source`` and the field (:class:`SettingsError` for a value
    in ``overridden``, which came from the caller, not the file)."""

    def bad(key, message):              # message: what follows the field's name
        if key in overridden:
            raise SettingsError(f"{key}{message} (given to override {source})")
        raise InputError(source, f"{key}{message}")

    values = dict(values)
    for key in _FIELDS:
        value = values[key]
        if isinstance(value, bool) or not isinstance(value, (int, float, np.integer,
                                                              np.floating)):
            bad(key, f" must be a number, got {_short(value)}")
        try:
            values[key] = float(value)
        except OverflowError:               # an integer too large for a float
            values[key] = math.inf
        if not math.isfinite(values[key]):
            bad(key, f" must be finite, got {_short(value)}")
    for key in ("width", "height"):
        if values[key] != int(values[key]):
            bad(key, f" must be a whole number of pixels, got {values[key]}")
    for key in _FIELDS:
        if not values[key] > 0 and key not in ("cx", "cy"):
            bad(key, f" must be positive, got {values[key]:g}")
    w, h = values["width"], values["height"]
    for key in ("width", "height"):
        if values[key] > MAX_IMAGE_SIDE:
            bad(key, f" must be at most {MAX_IMAGE_SIDE} pixels, got {values[key]:.0f}")
    low, high = FOCAL_MIN_FACTOR * min(w, h), FOCAL_MAX_FACTOR * max(w, h)
    for key in ("fx", "fy"):
        if not low <= values[key] <= high:
            bad(key, f"={values[key]:g} pixels is no camera's focal length for a "
                     f"{w:.0f}x{h:.0f} image (expected {low:g} to {high:g} pixels)")
    if not 0 <= values["cx"] <= w:
        bad("cx", f"={values['cx']:g} lies outside the image width {w:.0f}")
    if not 0 <= values["cy"] <= h:
        bad("cy", f"={values['cy']:g} lies outside the image height {h:.0f}")
    if values["depth_scale"] > MAX_DEPTH_SCALE:
        bad("depth_scale", f" must be at most {MAX_DEPTH_SCALE:g} depth units per metre, "
                           f"got {values['depth_scale']:g}")
    if values["depth_trunc"] > MAX_DEPTH_TRUNC:
        bad("depth_trunc", f" must be at most {MAX_DEPTH_TRUNC:g} m, got "
                           f"{values['depth_trunc']:g}")


def load_intrinsics(path, overrides: dict | None = None) -> Intrinsics:
    """Read and validate camera intrinsics from a JSON file.

    Two layouts are accepted: flat keys ``width height fx fy cx cy`` (optionally
    ``depth_scale depth_trunc``), as in ``shared/data/rgbd/tum_desk/intrinsics.json``; and
    Open3D's ``PinholeCameraIntrinsic`` JSON (``width``, ``height``, ``intrinsic_matrix``: 9
    values, column-major).

    Parameters
    ----------
    path : str or Path, the JSON file
    overrides : dict or None; non-None values replace the file's (e.g. ``depth_scale``,
        ``depth_trunc`` from the command line)

    Raises :class:`InputError` naming ``path`` and the field when a value is missing, not a
    number, or not what a camera has (:func:`check_intrinsics`); :class:`SettingsError`
    when an override is not.
    """
    path = Path(path)
    if not path.exists():
        raise InputError(path, "no such file")
    if path.is_dir():
        raise InputError(path, "is a directory, expected an intrinsics JSON file")
    try:
        data = json.loads(path.read_text())
    except (OSError, UnicodeDecodeError) as exc:
        raise InputError(path, f"cannot read: {exc}") from None
    except json.JSONDecodeError as exc:
        raise InputError(path, f"not valid JSON ({exc.msg} at line {exc.lineno})") from None
    if not isinstance(data, dict):
        raise InputError(path, "expected a JSON object with width, height, fx, fy, cx, cy")
    data = dict(data)
    if "intrinsic_matrix" in data and "fx" not in data:     # Open3D layout, column-major
        m = data["intrinsic_matrix"]
        if not (isinstance(m, list) and len(m) == 9):
            raise InputError(path, "intrinsic_matrix must hold 9 numbers")
        data.update(fx=m[0], fy=m[4], cx=m[6], cy=m[7])
    overridden = {key for key, value in (overrides or {}).items() if value is not None}
    values = {}
    for key in ("width", "height", "fx", "fy", "cx", "cy"):
        if key not in data:
            raise InputError(path, f"intrinsics lack {key!r} (need width, height, fx, fy, cx, cy)")
        values[key] = _number(path, key, data[key])
    for key, default in (("depth_scale", DEFAULT_DEPTH_SCALE), ("depth_trunc", DEFAULT_DEPTH_TRUNC)):
        values[key] = _number(path, key, data.get(key, default))
    for key in overridden:
        values[key] = _number(path, key, overrides[key], override=True)
    check_intrinsics(values, path, overridden)
    return Intrinsics(int(values["width"]), int(values["height"]), values["fx"], values["fy"],
                      values["cx"], values["cy"], values["depth_scale"], values["depth_trunc"],
                      str(path))


def _number(path, key, value, override: bool = False) -> float:
    """``value`` as a finite float; otherwise one line naming the file and ``key`` (or, for
    a caller's ``override``, the setting)."""
    def bad(message):
        if override:
            raise SettingsError(f"{key} {message} (given to override {path})")
        raise InputError(path, f"{key} {message}")

    if isinstance(value, bool):
        bad(f"must be a number, got {_short(value)}")
    try:
        number = float(value)
    except (TypeError, ValueError):
        bad(f"must be a number, got {_short(value)}")
    except OverflowError:                   # an integer too large for a float
        bad(f"must be finite, got {_short(value)}")
    if not math.isfinite(number):
        bad(f"must be finite, got {_short(value)}")
    return number


def _short(value, limit: int = 60) -> str:
    """``repr(value)`` on one line, cut to ``limit`` characters."""
    try:
        text = repr(value)
    except ValueError:                      # an integer with too many digits to print
        text = f"<{type(value).__name__}>"
    return text if len(text) <= limit else text[:limit - 3] + "..."


# ============================================================================ RGB-D frames
def _open_image(path, what: str):
    from PIL import Image, UnidentifiedImageError

    path = Path(path)
    if not path.exists():
        raise InputError(path, "no such file")
    if path.is_dir():
        raise InputError(path, f"is a directory, expected a {what} image")
    try:
        image = Image.open(path)
        image.load()
    except (UnidentifiedImageError, OSError, ValueError, Image.DecompressionBombError) as exc:
        raise InputError(path, f"cannot read as an image: {exc}") from None
    return image


def read_depth(path, intrinsics: Intrinsics) -> np.ndarray:
    """Depth image in metres, (H, W) float64; 0 where there is no data or beyond truncation.

    The image must be single-channel (16-bit PNG as written by Kinect, RealSense, TUM; 32-bit
    integer or float TIFF also work): ``metres = value / depth_scale``.
    """
    image = _open_image(path, "depth")
    if image.mode not in ("I;16", "I;16B", "I;16L", "I", "F"):
        raise InputError(path, f"depth must be a single-channel 16-bit (or 32-bit) image, "
                               f"got mode {image.mode!r}")
    if image.size != (intrinsics.width, intrinsics.height):
        raise InputError(path, f"depth image is {image.size[0]}x{image.size[1]} but the "
                               f"intrinsics ({intrinsics.source}) are for "
                               f"{intrinsics.width}x{intrinsics.height}")
    raw = np.asarray(image).astype(np.float64)
    depth = raw / intrinsics.depth_scale
    depth[~np.isfinite(depth) | (depth <= 0) | (depth > intrinsics.depth_trunc)] = 0.0
    return depth


def read_color(path, size) -> np.ndarray:
    """Colour image as (H, W, 3) uint8 RGB; ``size`` = (width, height) it must have."""
    image = _open_image(path, "colour")
    if image.size != tuple(size):
        raise InputError(path, f"colour image is {image.size[0]}x{image.size[1]} but the depth "
                               f"image is {size[0]}x{size[1]}; register and resize them first")
    if image.mode in ("I;16", "I;16B", "I;16L", "I", "F"):
        raise InputError(path, f"colour image has mode {image.mode!r}; is it the depth image?")
    return np.asarray(image.convert("RGB"))


def back_project(depth: np.ndarray, intrinsics: Intrinsics) -> tuple[np.ndarray, np.ndarray]:
    """Pixels with depth -> 3D points in the optical camera frame (vectorised).

    Parameters
    ----------
    depth : (H, W) float, metres; 0 = no data

    Returns
    -------
    points : (M, 3) float64, metres; +x right, +y down, +z forward
    valid : (H, W) bool, the pixels the points came from (row-major order)
    """
    valid = depth > 0
    v, u = np.nonzero(valid)
    z = depth[v, u]
    x = (u - intrinsics.cx) * z / intrinsics.fx
    y = (v - intrinsics.cy) * z / intrinsics.fy
    return np.column_stack([x, y, z]), valid


def depth_faces(depth: np.ndarray, max_faces: int = MAX_FRAME_FACES) -> np.ndarray:
    """The surface a depth image sees, as triangles over its pixel grid (vectorised).

    Each square of four neighbouring pixels (on every ``stride``-th row and column, the
    smallest stride that keeps the count within ``max_faces``) gives two triangles; a
    triangle is kept when its three pixels have depth and their depths differ by at most
    :data:`DEPTH_JUMP_ABS` + :data:`DEPTH_JUMP_REL` x the nearest of them, so that a depth
    discontinuity (an object's edge against what lies behind it) stays open instead of
    becoming a wall no one can pass.

    Parameters
    ----------
    depth : (H, W) float, metres; 0 = no data (as :func:`read_depth` returns it)

    Returns
    -------
    faces : (F, 3) int64 indices into the points of :func:`back_project` (its row-major order
        of the valid pixels), wound so that their normals face the camera
    """
    depth = np.asarray(depth, np.float64)
    h, w = depth.shape
    stride = 1
    while 2 * ((h - 1) // stride) * ((w - 1) // stride) > max_faces:
        stride += 1
    valid = depth > 0
    index = np.full((h, w), -1, np.int64)
    index[valid] = np.arange(int(valid.sum()))
    rows, cols = np.arange(0, h, stride), np.arange(0, w, stride)
    z, idx = depth[np.ix_(rows, cols)], index[np.ix_(rows, cols)]
    # the corners of every square: a = (r, c), b = (r, c+1), c = (r+1, c), d = (r+1, c+1)
    corners = [(z[:-1, :-1], idx[:-1, :-1]), (z[:-1, 1:], idx[:-1, 1:]),
               (z[1:, :-1], idx[1:, :-1]), (z[1:, 1:], idx[1:, 1:])]
    faces = []
    # +y is down in the image and +z away from the camera: (a, c, b) and (b, c, d) have
    # their normals toward the camera
    for i, j, k in ((0, 2, 1), (1, 2, 3)):
        (zi, ii), (zj, jj), (zk, kk) = corners[i], corners[j], corners[k]
        lo = np.minimum(np.minimum(zi, zj), zk)
        hi = np.maximum(np.maximum(zi, zj), zk)
        keep = (lo > 0) & (hi - lo <= DEPTH_JUMP_ABS + DEPTH_JUMP_REL * lo)
        faces.append(np.column_stack([ii[keep], jj[keep], kk[keep]]))
    return np.concatenate(faces).astype(np.int64)


def rgbd_to_geometry(color_path, depth_path, intrinsics, *,
                     surface: bool = False) -> tuple[Geometry, np.ndarray]:
    """Back-project an RGB-D frame into a coloured point cloud in the camera frame (with
    ``surface``: a mesh, the cloud and the triangles :func:`depth_faces` joins it into).

    Parameters
    ----------
    color_path : str, Path or None; a colour image registered to the depth image (any
        format Pillow reads). None: no colours.
    depth_path : str or Path, a single-channel depth image
    intrinsics : :class:`Intrinsics` or a path to an intrinsics JSON file

    Returns
    -------
    geometry : Geometry point cloud, metres, optical camera frame (+x right, +y down,
        +z forward), ``colors`` (N, 3) uint8 when a colour image was given
    camera : (3,) float64, the camera centre in that frame (the origin)

    Raises :class:`InputError` naming the file for unreadable images, images whose size
    differs from each other or from the intrinsics, or a frame with no valid depth.
    """
    if not isinstance(intrinsics, Intrinsics):
        intrinsics = load_intrinsics(intrinsics)
    depth = read_depth(depth_path, intrinsics)
    points, valid = back_project(depth, intrinsics)
    colors = None
    if color_path is not None:
        colors = read_color(color_path, (intrinsics.width, intrinsics.height))[valid]
    if len(points) < 4:
        raise InputError(depth_path, f"no valid depth: {len(points)} pixels between 0 and "
                                     f"depth_trunc={intrinsics.depth_trunc} m "
                                     f"(depth_scale {intrinsics.depth_scale:g} units per metre)")
    faces = depth_faces(depth) if surface else None
    geometry = Geometry(points, faces if faces is not None and len(faces) else None, None,
                        colors, str(depth_path))
    return validate_geometry(geometry, depth_path), np.zeros(3)


def load_rgbd(color_path, depth_path, intrinsics_path, depth_scale=None, depth_trunc=None,
              *, surface: bool = False):
    """Intrinsics + back-projection in one call: (Geometry in the camera frame, camera (3,),
    Intrinsics); with ``surface``, the Geometry also has the frame's triangles
    (:func:`depth_faces`)."""
    intr = load_intrinsics(intrinsics_path, {"depth_scale": depth_scale,
                                             "depth_trunc": depth_trunc})
    geometry, camera = rgbd_to_geometry(color_path, depth_path, intr, surface=surface)
    return geometry, camera, intr
