"""A small software renderer: perspective cameras and a z-buffer of point splats.

Surfaces are drawn as dense point samples ("splats": small screen-space disks sized from the
sample spacing and the depth), lit with Lambert shading from per-point normals (two-sided)
and outlined with eye-dome lighting computed from the depth buffer. Lines are sampled into
unlit one-pixel splats. Vectorised NumPy, the z-buffer's splat a Numba kernel; no OpenGL,
display or GPU.
"""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np

BACKGROUND = (255, 255, 255)


def _unit(v) -> np.ndarray:
    v = np.asarray(v, dtype=float)
    n = np.linalg.norm(v)
    return v / n if n > 0 else v


@dataclass
class Camera:
    """A pinhole camera looking from ``eye`` at ``target`` with +Z up.

    Attributes
    ----------
    eye, target : (3,) metres
    width, height : image size in pixels
    fov_deg : vertical field of view in degrees
    near : points closer than this (m, along the view axis) are clipped, which cuts away
        whatever stands between the camera and what it looks at
    """

    eye: np.ndarray
    target: np.ndarray
    width: int = 640
    height: int = 480
    fov_deg: float = 40.0
    near: float = 0.02
    up: np.ndarray = field(default_factory=lambda: np.array([0.0, 0.0, 1.0]))

    def __post_init__(self):
        self.eye = np.asarray(self.eye, float)
        self.target = np.asarray(self.target, float)
        self.forward = _unit(self.target - self.eye)
        right = np.cross(self.forward, self.up)
        if np.linalg.norm(right) < 1e-9:  # looking straight up or down
            right = np.array([1.0, 0.0, 0.0])
        self.right = _unit(right)
        self.upv = np.cross(self.right, self.forward)
        self.focal = 0.5 * self.height / np.tan(np.radians(self.fov_deg) / 2)

    def scaled(self, factor: int) -> "Camera":
        """The same view at ``factor`` times the resolution."""
        return Camera(self.eye, self.target, self.width * factor, self.height * factor,
                      self.fov_deg, self.near, self.up)

    def project(self, points: np.ndarray):
        """Pixel coordinates and depth of (N, 3) points: px (N,), py (N,), depth (N,) m."""
        px, py, z, _ = self._project(points)
        return px, py, z

    def _project(self, points: np.ndarray):
        """:meth:`project`, and the points' coordinates in the camera's frame (right, up,
        forward: three (N,) arrays), in the arithmetic of the splat's Numba kernel
        (:func:`~._splat.prepare`), so that both give the same bits."""
        d = np.asarray(points, float) - self.eye
        ax = self.axes
        c0, c1, c2 = (d[:, 0] * ax[k, 0] + d[:, 1] * ax[k, 1] + d[:, 2] * ax[k, 2]
                      for k in range(3))
        zs = np.where(np.abs(c2) > 1e-9, c2, 1e-9)
        px = 0.5 * self.width + self.focal * c0 / zs
        py = 0.5 * self.height - self.focal * c1 / zs
        return px, py, c2, (c0, c1, c2)

    @property
    def axes(self) -> np.ndarray:
        """(3, 3) rows: the camera's right, up and forward directions."""
        return np.array([self.right, self.upv, self.forward])


def orbit_camera(target, azimuth_deg: float, elevation_deg: float, distance: float,
                 width: int, height: int, fov_deg: float = 40.0, near: float = 0.02) -> Camera:
    """A camera ``distance`` m from ``target`` at the given azimuth (about +Z, from +X) and
    elevation (above the horizontal), in degrees."""
    az, el = np.radians(azimuth_deg), np.radians(elevation_deg)
    direction = np.array([np.cos(el) * np.cos(az), np.cos(el) * np.sin(az), np.sin(el)])
    target = np.asarray(target, float)
    return Camera(target + distance * direction, target, width, height, fov_deg, near)


def frame_points(points: np.ndarray, azimuth_deg: float, elevation_deg: float, width: int,
                 height: int, fov_deg: float = 40.0, margin: float = 0.08,
                 near_cut: float | None = None) -> Camera:
    """An orbit camera at the given angles that frames ``points`` (N, 3), centred.

    The distance starts from the bounding sphere and is refined a few times on the
    projected extent. ``near_cut`` (m): clip everything nearer than the framed points
    minus this (a cut-away through walls in front); None keeps the default near plane.
    """
    pts = np.asarray(points, float)
    lo, hi = pts.min(axis=0), pts.max(axis=0)
    target = (lo + hi) / 2
    radius = max(float(np.linalg.norm(pts - target, axis=1).max()), 1e-3)
    half = np.radians(fov_deg) / 2
    aspect = width / height
    distance = radius / np.sin(min(half, np.arctan(np.tan(half) * aspect))) * 1.02
    for _ in range(4):
        cam = orbit_camera(target, azimuth_deg, elevation_deg, distance, width, height, fov_deg)
        px, py, z = cam.project(pts)
        if np.any(z <= 1e-6):
            distance *= 1.5
            continue
        x = (px - width / 2) / (width / 2)
        y = (py - height / 2) / (height / 2)
        # re-centre: move the target by the mid-point of the projected extent
        mx, my = (x.min() + x.max()) / 2, (y.min() + y.max()) / 2
        target = target + (mx * np.tan(half) * aspect * distance) * cam.right \
            - (my * np.tan(half) * distance) * cam.upv
        extent = max(x.max() - x.min(), y.max() - y.min()) / 2
        distance *= max(extent / (1 - margin), 0.2) ** 0.85
    cam = orbit_camera(target, azimuth_deg, elevation_deg, distance, width, height, fov_deg)
    if near_cut is not None:
        _, _, z = cam.project(pts)
        cam.near = max(0.02, float(z.min()) - near_cut)
    return cam


def _disk(radius: int):
    r = int(radius)
    d = np.arange(-r, r + 1)
    dx, dy = np.meshgrid(d, d)
    keep = dx ** 2 + dy ** 2 <= r * r + r
    return dx[keep].ravel(), dy[keep].ravel()


class Canvas:
    """A z-buffer being filled with splats; :meth:`image` shades and returns RGB.

    Parameters
    ----------
    camera : the view, at output resolution
    supersample : render at this factor and average down (anti-aliasing)
    """

    MAX_SPLAT_RADIUS = 18  # pixels at render resolution; larger would cost too much

    def __init__(self, camera: Camera, supersample: int = 2):
        self.out_size = (camera.width, camera.height)
        self.ss = int(supersample)
        self.cam = camera.scaled(self.ss)
        self.w, self.h = self.cam.width, self.cam.height
        n = self.w * self.h
        self.depth = np.full(n, np.inf, np.float32)
        self.albedo = np.zeros((n, 3), np.float32)
        self.normal = np.zeros((n, 3), np.float32)
        self.lit = np.zeros(n, bool)
        self._winner = None         # the splat kernel's winners, -1 between splats

    # ------------------------------------------------------------------ drawing
    def points(self, points, colors, normals=None, size: float | None = None,
               radius_px: int | None = None, lit: bool = True, reference: bool = False) -> None:
        """Splat (N, 3) ``points`` with colours (N, 3) or (3,) uint8.

        ``size``: the sample spacing in metres (the splat covers about that much surface);
        or ``radius_px``: a fixed radius in output pixels. ``normals`` (N, 3) are flipped to
        face the camera (two-sided lighting); without normals, or with ``lit=False``, the
        colour is drawn as is. The points are projected and the z-buffer filled by Numba
        kernels (:mod:`._splat`); ``reference``: by the NumPy reference instead (the same
        picture, slower).
        """
        pts = np.ascontiguousarray(points, float)
        if len(pts) == 0:
            return
        colors = np.asarray(colors, np.float32).reshape(-1, 3)
        if len(colors) not in (1, len(pts)):
            raise ValueError(f"{len(colors)} colours for {len(pts)} points")
        normals = np.ascontiguousarray(normals, float) if normals is not None and lit \
            else None
        if normals is not None and normals.shape != pts.shape:
            raise ValueError(f"normals of shape {normals.shape} for {len(pts)} points")
        half_size = 0.5 * (0.01 if size is None else size)
        fixed = -1 if radius_px is None else int(radius_px) * self.ss
        prepared = (self._prepare_reference if reference else self._prepare)(
            pts, normals, half_size, fixed)
        if prepared is None:
            return
        idx, ix, iy, z, rad, nrm, gx, gy = prepared
        if not reference:
            self._splat(ix, iy, z, gx, gy, rad, idx, colors, nrm)
            return
        cols = np.broadcast_to(colors / 255.0, (len(pts), 3))[idx]
        for r in np.unique(rad):
            sel = np.flatnonzero(rad == r)
            dx, dy = _disk(r)
            step = max(1, 8_000_000 // len(dx))
            for s in range(0, len(sel), step):
                part = sel[s:s + step]
                xx = (ix[part, None] + dx[None, :]).ravel()
                yy = (iy[part, None] + dy[None, :]).ravel()
                src = np.repeat(part, len(dx))
                ok = (xx >= 0) & (xx < self.w) & (yy >= 0) & (yy < self.h)
                flat = (yy[ok] * self.w + xx[ok])
                src = src[ok]
                d = z[src].astype(np.float32)
                if gx is not None:
                    ddx = np.tile(dx, len(part))[ok].astype(np.float32)
                    ddy = np.tile(dy, len(part))[ok].astype(np.float32)
                    d = d + gx[src] * ddx + gy[src] * ddy
                np.minimum.at(self.depth, flat, d)
                win = d <= self.depth[flat]
                self._paint(flat[win], src[win], cols, nrm)

    def _prepare_reference(self, pts, normals, half_size, fixed):
        """The points in the picture's reach and, for each, its pixel, depth and splat
        radius (``fixed`` pixels, or covering ``half_size`` m either side), with
        ``normals`` its normal turned to face the camera and its depth's slopes across the
        disk: (idx, ix, iy, z, radius, normals or None, gx or None, gy or None), or None
        where no point is in reach. NumPy, in the arithmetic of :func:`~._splat.prepare`."""
        cam, ax = self.cam, self.cam.axes
        px, py, c2, (c0, c1, _) = cam._project(pts)
        keep = (c2 > cam.near) & (px > -50) & (px < self.w + 50) & (py > -50) & \
            (py < self.h + 50) & np.isfinite(px) & np.isfinite(py)
        if not keep.any():
            return None
        idx = np.flatnonzero(keep)
        c0, c1, z, px, py = c0[idx], c1[idx], c2[idx], px[idx], py[idx]
        if fixed >= 0:
            rad = np.full(len(idx), fixed, np.int64)
        else:
            rad = np.clip(np.rint(half_size * cam.focal / z).astype(np.int64), 0,
                          self.MAX_SPLAT_RADIUS)
        ix, iy = np.rint(px).astype(np.int64), np.rint(py).astype(np.int64)
        if normals is None:
            return idx, ix, iy, z, rad, None, None, None
        # oriented splats: depth follows each point's tangent plane across its disk, so
        # overlapping splats of one surface blend into a smooth surface
        n = normals[idx]
        a, b, c = (n[:, 0] * ax[k, 0] + n[:, 1] * ax[k, 1] + n[:, 2] * ax[k, 2]
                   for k in range(3))
        sign = np.where(a * c0 + b * c1 + c * z > 0, -1.0, 1.0)
        n *= sign[:, None]
        a, b, c = a * sign, b * sign, c * sign
        c = np.where(c < 0, np.minimum(c, -0.35), np.maximum(c, 0.35))
        gx = (-a / c * z / cam.focal).astype(np.float32)
        gy = (b / c * z / cam.focal).astype(np.float32)
        return idx, ix, iy, z, rad, n, gx, gy

    def _prepare(self, pts, normals, half_size, fixed):
        """:meth:`_prepare_reference` by two Numba kernels (:func:`~._splat.visible`,
        :func:`~._splat.prepare`): the same values."""
        from interaction_tensor.outputs._splat import prepare, visible

        cam = self.cam
        eye, axes = np.ascontiguousarray(cam.eye, float), np.ascontiguousarray(cam.axes)
        keep = np.empty(len(pts), bool)
        visible(pts, eye, axes, float(cam.focal), self.w, self.h, float(cam.near), keep)
        idx = np.flatnonzero(keep)
        if len(idx) == 0:
            return None
        m = len(idx)
        shaded = normals is not None
        ix, iy, rad = np.empty(m, np.int64), np.empty(m, np.int64), np.empty(m, np.int64)
        z = np.empty(m)
        nrm = np.empty((m if shaded else 0, 3))
        gx, gy = np.empty(m if shaded else 0, np.float32), np.empty(m if shaded else 0,
                                                                    np.float32)
        prepare(pts, normals if shaded else np.zeros((0, 3)), idx, eye, axes,
                float(cam.focal), self.w, self.h, float(half_size), int(fixed),
                self.MAX_SPLAT_RADIUS, ix, iy, z, rad, nrm, gx, gy)
        return (idx, ix, iy, z, rad) + ((nrm, gx, gy) if shaded else (None, None, None))

    def _splat(self, ix, iy, z, gx, gy, rad, idx, colors, nrm) -> None:
        """The reference's splats, smallest disks first, drawn and painted by one Numba
        kernel (:func:`~._splat.splat`) in bands of rows: the points ``idx`` of those
        given, with their ``colors`` ((1, 3) for all or (N, 3), float32, 0-255)."""
        import numba

        from interaction_tensor.outputs._splat import splat

        order = np.argsort(rad.astype(np.uint16), kind="stable")   # a radix sort
        sizes = np.flatnonzero(np.bincount(rad))
        disks = [_disk(r) for r in sizes]
        counts = np.zeros(int(sizes.max()) + 1, np.int64)
        counts[sizes] = [len(d[0]) for d in disks]
        first = np.concatenate([[0], np.cumsum(counts)]).astype(np.int64)
        dx = np.concatenate([d[0] for d in disks]).astype(np.int64)
        dy = np.concatenate([d[1] for d in disks]).astype(np.int64)
        # the box of pixels the disks reach: only it is searched for winners and reset
        r = int(sizes.max())
        x0, x1 = max(int(ix.min()) - r, 0), min(int(ix.max()) + r + 1, self.w)
        y0, y1 = max(int(iy.min()) - r, 0), min(int(iy.max()) + r + 1, self.h)
        if x0 >= x1 or y0 >= y1:
            return
        if self._winner is None:
            self._winner = np.full(self.w * self.h, -1, np.int64)
        empty = np.zeros(0, np.float32)
        bands = min(self.h, numba.get_num_threads()) if len(ix) > 50_000 else 1
        splat(ix, iy, z, empty if gx is None else gx, empty if gy is None else gy, rad,
              order, dx, dy, first, self.w, self.h, bands, self.depth, self._winner,
              np.array([x0, x1, y0, y1], np.int64), idx, colors,
              np.zeros((0, 3)) if nrm is None else nrm, self.albedo, self.normal, self.lit)

    def _paint(self, flat, src, cols, nrm) -> None:
        """Give pixels ``flat`` the colour (and normal, lit) of the splatted points ``src``
        that won their depth test."""
        self.albedo[flat] = cols[src]
        if nrm is not None:
            self.normal[flat] = nrm[src]
            self.lit[flat] = True
        else:
            self.lit[flat] = False

    def lines(self, starts, ends, colors, width_px: int = 0) -> None:
        """Draw (N, 3) segments ``starts`` -> ``ends``, unlit, with (N, 3) or (3,) colours."""
        a, b = np.asarray(starts, float), np.asarray(ends, float)
        if len(a) == 0:
            return
        cols = np.broadcast_to(np.asarray(colors), (len(a), 3))
        pa, pb = self.cam.project(a), self.cam.project(b)
        length = np.hypot(pa[0] - pb[0], pa[1] - pb[1])
        steps = np.clip(np.nan_to_num(length, nan=2.0), 2, 4000).astype(int) + 1
        seg = np.repeat(np.arange(len(a)), steps)
        first = np.repeat(np.cumsum(steps) - steps, steps)
        t = (np.arange(len(seg)) - first) / np.maximum(steps[seg] - 1, 1)
        pts = a[seg] + (b[seg] - a[seg]) * t[:, None]
        self.points(pts, cols[seg], radius_px=width_px, lit=False)

    # ------------------------------------------------------------------ output
    def project(self, points):
        """Output-resolution pixel coordinates and depth of (N, 3) points."""
        px, py, z = self.cam.project(points)
        return px / self.ss, py / self.ss, z

    def visible(self, points, tolerance: float) -> np.ndarray:
        """(N,) bool: which points are inside the image and not hidden (depth test with
        ``tolerance`` metres, looking at a 3x3 neighbourhood)."""
        px, py, z = self.cam.project(points)
        ix, iy = np.rint(px).astype(int), np.rint(py).astype(int)
        inside = (ix >= 1) & (ix < self.w - 1) & (iy >= 1) & (iy < self.h - 1) & \
            (z > self.cam.near)
        from scipy.ndimage import maximum_filter

        out = np.zeros(len(z), bool)
        far = maximum_filter(self.depth.reshape(self.h, self.w), size=3)   # 3x3 windows
        out[inside] = z[inside] <= far[iy[inside], ix[inside]] + tolerance
        return out

    def image(self, background=BACKGROUND, edl_strength: float = 6.0,
              edl_threshold: float = 0.05) -> np.ndarray:
        """Shade and down-sample: (H, W, 3) uint8 at output resolution."""
        h, w, s = self.h, self.w, self.ss
        f32 = np.float32
        depth = self.depth.reshape(h, w)
        fg = np.isfinite(depth)
        # Lambert: a headlight plus a key light from above, on two-sided normals
        nrm = self.normal.reshape(h, w, 3)
        head = (-self.cam.forward).astype(f32)
        key = _unit(np.array([0.3, 0.5, 1.0])).astype(f32)
        lam = f32(0.38) + f32(0.42) * np.clip(nrm @ head, 0, 1) \
            + f32(0.28) * np.clip(nrm @ key, 0, 1)
        shade = np.where(self.lit.reshape(h, w), np.clip(lam, 0, 1), f32(1))
        # eye-dome lighting: darken pixels that lie behind their neighbours (outlines);
        # the background and what lies past the picture's edges are far behind, so a step
        # down to them is no edge
        far = f32(1e30)
        logd = np.full((h + 2 * s, w + 2 * s), far, f32)
        inner = logd[s:s + h, s:s + w]
        np.log(depth, out=inner, where=fg)
        acc = np.zeros((h, w), f32)
        for dy, dx in ((s, 0), (-s, 0), (0, s), (0, -s)):
            nb = logd[s - dy:s - dy + h, s - dx:s - dx + w]    # the neighbour dy, dx back
            # small steps between overlapping splats of one surface are not edges
            acc += np.clip(inner - nb - f32(edl_threshold), 0, None)
        shade *= np.exp(f32(-edl_strength * 10) * acc)
        rgb = self.albedo.reshape(h, w, 3) * shade[..., None]
        rgb[~fg] = np.asarray(background, f32) / 255
        ow, oh = self.out_size
        rgb = rgb[:oh * s, :ow * s].reshape(oh, s, ow, s, 3).mean(axis=(1, 3))
        return (np.clip(rgb, 0, 1) * 255 + 0.5).astype(np.uint8)
