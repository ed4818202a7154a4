"""One reader per file format, each checking the file against what it declares.

Every reader takes a :class:`~pathlib.Path` and returns a :class:`~interaction_tensor.geometry.core.Geometry`
in the file's own units and axes (``load_geometry`` scales, turns and validates it). A reader
refuses, with an :class:`InputError` naming the file, anything it would otherwise have to
guess at: a header whose counts disagree with the data, an unknown encoding, ragged rows,
face indices out of range.

=============================  ===============================  ==========================
suffix                         read by                          holds
=============================  ===============================  ==========================
``.ply``                       plyfile (ASCII, binary LE/BE)    mesh or cloud, normals,
                                                                colours
``.obj``                       here (rows and indices checked)  mesh or cloud, vertex
                                                                colours
``.stl .glb .gltf``            trimesh                          mesh (vertex colours kept)
``.off``                       here (counts checked)            mesh, colours (COFF)
``.pcd``                       here (ascii, binary); Open3D     cloud, normals, colours
                               for binary_compressed
``.xyz``                       here                             ``x y z [r g b]``
``.xyzn``                      here                             ``x y z nx ny nz``
``.pts``                       here                             ``[count]`` then
                                                                ``x y z [i] [r g b]``
``.npy``                       NumPy (no pickle)                ``(N, 3)`` points or
                                                                ``(N, 6)`` points + normals
``.las .laz``                  laspy (extra ``las``)            cloud, colours
``.e57``                       pye57 (extra ``e57``)            cloud(s), colours
=============================  ===============================  ==========================
"""

from __future__ import annotations

import os
import re
from pathlib import Path

import numpy as np

from interaction_tensor.errors import InputError
from interaction_tensor.geometry.core import Geometry, from_object


def _geometry(vertices, faces=None, normals=None, colors=None):

    return Geometry(np.asarray(vertices, np.float64),
                    None if faces is None or len(faces) == 0 else np.asarray(faces, np.int64),
                    None if normals is None else np.asarray(normals, np.float64),
                    None if colors is None else np.asarray(colors, np.uint8))


def _colors_from(columns: np.ndarray, path, what: str) -> np.ndarray:
    """(N, 3) uint8 from colour columns that are integers 0-255 or fractions 0-1."""
    c = np.asarray(columns, np.float64)
    if not np.isfinite(c).all():
        raise InputError(path, f"{what} colours hold NaN or infinite values")
    if c.size and c.min() >= 0 and c.max() <= 1 and not np.all(c == np.round(c)):
        return np.round(c * 255).astype(np.uint8)
    if c.size and (c.min() < 0 or c.max() > 255 or not np.all(c == np.round(c))):
        raise InputError(path, f"{what} colour columns are neither 0-255 integers nor 0-1 "
                               "fractions")
    return c.astype(np.uint8)


# --------------------------------------------------------------------------- PLY
def read_ply(path) -> dict:
    """Parse a PLY file strictly: ``{"vertex": {name: (N,) array}, "faces": (F, 3) or None}``.

    ASCII, binary little- and big-endian (plyfile). The data must match the header exactly:
    fewer rows or bytes than declared and more than declared are both refused. Polygons are
    split into triangles (fans); face indices must be in range.
    """
    import plyfile

    path = Path(path)
    try:
        try:   # triangle meshes: plyfile's fast path reads the face lists as one array
            data = plyfile.PlyData.read(str(path), known_list_len={
                "face": {"vertex_indices": 3, "vertex_index": 3}})
        except plyfile.PlyElementParseError as exc:
            if "unexpected list length" not in str(exc):
                raise
            data = plyfile.PlyData.read(str(path))
    except plyfile.PlyHeaderParseError as exc:
        raise InputError(path, f"bad PLY header: {exc}") from None
    except plyfile.PlyElementParseError as exc:
        raise InputError(path, f"PLY data does not match its header ({exc})") from None
    except (ValueError, UnicodeDecodeError, EOFError) as exc:
        raise InputError(path, f"cannot parse as PLY: {exc}") from None
    names = [el.name for el in data.elements]
    if "vertex" not in names:
        raise InputError(path, "PLY file has no vertex element")
    _check_ply_length(path, data)
    vert = data["vertex"].data
    vertex = {name: np.asarray(vert[name]) for name in vert.dtype.names}
    faces = None
    if "face" in names and data["face"].count:
        face = data["face"].data
        key = next((k for k in ("vertex_indices", "vertex_index") if k in face.dtype.names),
                   None)
        if key is None:
            raise InputError(path, "PLY faces have no vertex_indices list")
        faces = _triangulate(face[key], path)
        if len(faces) and (faces.min() < 0 or faces.max() >= len(vert)):
            raise InputError(path, f"PLY faces index vertices that do not exist "
                                   f"(indices {faces.min()}..{faces.max()}, {len(vert)} vertices)")
    return {"vertex": vertex, "faces": faces, "text": data.text}


def _row_bytes(element) -> int:
    """Bytes of all rows of a binary PLY element (list lengths as stored)."""
    total = 0
    for prop in element.properties:
        col = element.data[prop.name]
        if hasattr(prop, "len_dtype"):
            lengths = np.fromiter((len(v) for v in col), np.int64, len(col)) \
                if col.dtype == object else np.full(len(col), col.shape[1] if col.ndim > 1 else 0)
            total += len(col) * np.dtype(prop.len_dtype).itemsize
            total += int(lengths.sum()) * np.dtype(prop.val_dtype).itemsize
        else:
            total += len(col) * np.dtype(prop.val_dtype).itemsize
    return total


def _check_ply_length(path: Path, data) -> None:
    """Refuse data after the last declared row (the header and the data disagree)."""
    raw_head = b""
    with open(path, "rb") as fh:
        while True:
            line = fh.readline()
            if not line:
                return
            raw_head += line
            if line.strip() == b"end_header":
                break
        start = fh.tell()
        if data.text:
            rows = sum(1 for line in fh if line.strip())
            declared = sum(el.count for el in data.elements)
            if rows > declared:
                raise InputError(path, f"PLY file has {rows} data rows, its header declares "
                                       f"{declared}")
            return
    size = os.path.getsize(path) - start
    expected = sum(_row_bytes(el) for el in data.elements)
    if size > expected:
        raise InputError(path, f"PLY file has {size - expected} bytes after the data its "
                               "header declares")


def _fan(flat: np.ndarray, lengths: np.ndarray) -> np.ndarray:
    """(F, 3) triangle fans of polygons given as their concatenated vertex indices ``flat``
    and their ``lengths`` (each at least 3)."""
    starts = np.concatenate([[0], np.cumsum(lengths)[:-1]]).astype(np.int64)
    per_face = lengths - 2
    face_of = np.repeat(np.arange(len(lengths)), per_face)
    k = np.arange(per_face.sum()) - np.repeat(np.cumsum(per_face) - per_face, per_face)
    s = starts[face_of]
    return np.column_stack([flat[s], flat[s + k + 1], flat[s + k + 2]])


def _triangulate(lists, path) -> np.ndarray:
    """(F, 3) int64 triangles from PLY face lists (fans for polygons)."""
    arr = np.asarray(lists)
    if arr.dtype != object and arr.ndim == 2:
        poly = arr.astype(np.int64)
    else:
        lengths = np.fromiter((len(f) for f in lists), np.int64, len(lists))
        if lengths.size and lengths.min() < 3:
            raise InputError(path, "PLY has faces with fewer than 3 vertices")
        if lengths.size and (lengths == lengths[0]).all():
            poly = np.stack(lists).astype(np.int64)
        else:
            return _fan(np.concatenate(lists).astype(np.int64), lengths)
    if poly.shape[1] < 3:
        raise InputError(path, "PLY has faces with fewer than 3 vertices")
    if poly.shape[1] == 3:
        return poly
    k = np.arange(1, poly.shape[1] - 1)
    return np.stack([np.repeat(poly[:, :1], len(k), 1), poly[:, k], poly[:, k + 1]],
                    axis=-1).reshape(-1, 3)


def _ply_geometry(path: Path):
    ply = read_ply(path)
    v = ply["vertex"]
    missing = [k for k in "xyz" if k not in v]
    if missing:
        raise InputError(path, f"PLY vertices have no {', '.join(missing)} property")
    points = np.column_stack([v["x"], v["y"], v["z"]])
    normals = None
    if all(k in v for k in ("nx", "ny", "nz")):
        normals = np.column_stack([v["nx"], v["ny"], v["nz"]])
    colors = None
    for names in (("red", "green", "blue"), ("r", "g", "b"),
                  ("diffuse_red", "diffuse_green", "diffuse_blue")):
        if all(k in v for k in names):
            cols = np.column_stack([v[k] for k in names])
            if cols.dtype.kind == "f":
                colors = _colors_from(cols, path, "PLY")
            else:
                colors = np.clip(cols, 0, 255).astype(np.uint8) if cols.dtype.itemsize == 1 \
                    else (cols.astype(np.int64) >> 8).clip(0, 255).astype(np.uint8)
            break
    faces = ply["faces"]
    return _geometry(points, faces, None if faces is not None and len(faces) else normals,
                     colors)


# --------------------------------------------------------------------------- OBJ
_OBJ_NUMBER = r"[-+]?(?:\d+\.?\d*|\.\d+)(?:[eE][-+]?\d+)?"
_OBJ_VERTEX = re.compile(rf"v(?:[ \t]+{_OBJ_NUMBER}){{3,7}}[ \t]*")
_OBJ_FACE = re.compile(r"f(?:[ \t]+-?\d+(?:/-?\d*){0,2}){3,}[ \t]*")


def _obj_geometry(path: Path):
    """Wavefront OBJ, read strictly: every ``v`` row x y z [w] or x y z r g b [a], every
    ``f`` row three or more vertex references (``i``, ``i/t``, ``i//n``, ``i/t/n``, negative
    ones relative), indices in range, and a last geometry row that is not cut off. Polygons
    are fanned; ``vt``, ``vn``, ``l``, groups and materials are ignored."""
    raw = path.read_bytes()
    text = raw.decode("utf-8", "replace")
    if "#" in text:
        text = re.sub(r"#[^\n]*", "", text)
    lines = np.array([ln.strip() for ln in text.splitlines()], dtype=object)
    head = np.array([ln.split(None, 1)[0] if ln else "" for ln in lines], dtype=object)
    kind = np.zeros(len(lines), np.int8)
    kind[head == "v"] = 1                     # a row's keyword: a bare "f" is a bad face
    kind[head == "f"] = 2
    rows = np.flatnonzero(kind)
    if len(rows) and not raw.endswith((b"\n", b"\r")) and rows[-1] == len(lines) - 1:
        raise InputError(path, f"OBJ ends in the middle of line {len(lines)} (the file looks "
                               "cut); re-export it, or end it with a line break if it is whole")
    blocks = {}
    for code, pattern, what in ((1, _OBJ_VERTEX, "a vertex needs x y z (or x y z r g b)"),
                                (2, _OBJ_FACE, "a face needs three or more vertex indices")):
        idx = np.flatnonzero(kind == code)
        block = "\n".join(lines[idx].tolist()).replace("\t", " ")
        bad = re.search(rf"^(?!{pattern.pattern}$).*$", block, re.M) if len(idx) else None
        if bad:
            line = int(idx[block.count("\n", 0, bad.start())])
            raise InputError(path, f"OBJ line {line + 1} {lines[line].strip()[:40]!r}: {what}")
        blocks[code] = (idx, re.sub(r" +", " ", block))
    v_idx, v_block = blocks[1]
    widths = np.char.count(np.array(v_block.split("\n"), dtype=str), " ") if len(v_idx) else []
    if len(set(np.asarray(widths).tolist())) > 1:
        raise InputError(path, f"OBJ vertex rows have {sorted(set(widths.tolist()))} values; "
                               "mixed rows are not supported")
    table = (np.array(v_block.replace("v", " ").split(), np.float64).reshape(len(v_idx), -1)
             if len(v_idx) else np.zeros((0, 3)))
    colors = _colors_from(table[:, 3:6], path, "OBJ") if table.shape[1] >= 6 else None
    f_idx, f_block = blocks[2]
    faces = None
    if len(f_idx):
        f_block = re.sub(r"/[^ \n]*", "", f_block).strip()
        lengths = np.char.count(np.array(f_block.split("\n"), dtype=str).astype(str), " ")
        flat = np.array(f_block.replace("f", " ").split(), np.int64)
        seen = np.cumsum(kind == 1)[f_idx]               # vertices defined before each face
        flat = np.where(flat < 0, np.repeat(seen, lengths) + flat, flat - 1)
        if ((flat < 0) | (flat >= len(table))).any():
            raise InputError(path, f"OBJ faces refer to vertices outside the {len(table)} "
                                   "it defines")
        faces = _fan(flat, lengths)
    return _geometry(table[:, :3], faces, None, colors)


# --------------------------------------------------------------------------- trimesh formats
def _trimesh_geometry(path: Path):
    import trimesh

    try:
        loaded = trimesh.load(str(path), process=False, force=None)
    except InputError:
        raise
    except Exception as exc:  # trimesh's parsers raise every kind of error
        raise InputError(path, f"cannot parse as {path.suffix[1:].upper()}: {exc}") from None
    if isinstance(loaded, (trimesh.Scene, trimesh.Trimesh, trimesh.PointCloud)):

        return from_object(loaded, str(path))
    raise InputError(path, f"unsupported content {type(loaded).__name__}")


# --------------------------------------------------------------------------- PCD
_PCD_TYPES = {("F", 4): "<f4", ("F", 8): "<f8", ("U", 1): "<u1", ("U", 2): "<u2",
              ("U", 4): "<u4", ("I", 1): "<i1", ("I", 2): "<i2", ("I", 4): "<i4",
              ("U", 8): "<u8", ("I", 8): "<i8"}


def _pcd_geometry(path: Path):
    raw = path.read_bytes()
    header = {}
    offset = 0
    while True:
        end = raw.find(b"\n", offset)
        if end < 0:
            raise InputError(path, "PCD header has no DATA line")
        line = raw[offset:end].decode("ascii", "replace").strip()
        offset = end + 1
        if not line or line.startswith("#"):
            continue
        key, _, value = line.partition(" ")
        header[key.upper()] = value.split()
        if key.upper() == "DATA":
            break
    try:
        names = header["FIELDS"]
        sizes = [int(s) for s in header["SIZE"]]
        types = header["TYPE"]
        counts = [int(c) for c in header.get("COUNT", ["1"] * len(names))]
        n = int(header["POINTS"][0])
        mode = header["DATA"][0].lower()
    except (KeyError, ValueError, IndexError):
        raise InputError(path, "PCD header lacks FIELDS/SIZE/TYPE/POINTS") from None
    if not len(names) == len(sizes) == len(types) == len(counts):
        raise InputError(path, "PCD header's FIELDS, SIZE, TYPE and COUNT differ in length")
    if n < 0 or min(counts, default=1) < 1:
        raise InputError(path, f"PCD header declares {n} points or a field COUNT below 1")
    try:
        wh = int(header["WIDTH"][0]) * int(header["HEIGHT"][0])
    except (KeyError, ValueError, IndexError):
        wh = n
    if wh != n:
        raise InputError(path, f"PCD header's WIDTH x HEIGHT ({wh}) is not POINTS ({n})")
    if mode == "binary_compressed":
        try:
            import open3d as o3d
        except ImportError:
            raise InputError(path, "binary_compressed PCD needs Open3D: "
                                   "pip install 'interaction-tensor[open3d]'") from None
        pc = o3d.io.read_point_cloud(str(path))
        pts = np.asarray(pc.points, dtype=np.float64)
        nrm = np.asarray(pc.normals, dtype=np.float64) if pc.has_normals() else None
        col = (np.asarray(pc.colors) * 255).astype(np.uint8) if pc.has_colors() else None
        return _geometry(pts, None, nrm, col)
    dtype = []
    for name, size, typ, count in zip(names, sizes, types, counts):
        base = _PCD_TYPES.get((typ.upper(), size))
        if base is None:
            raise InputError(path, f"PCD field {name!r} has unsupported type {typ}{size}")
        dtype.append((name if name != "_" else f"_pad{len(dtype)}", base, (count,)) if count > 1
                     else (name if name != "_" else f"_pad{len(dtype)}", base))
    dtype = np.dtype(dtype)
    if mode == "binary":
        if len(raw) - offset != n * dtype.itemsize:
            raise InputError(path, f"PCD binary data is {len(raw) - offset} bytes, its header "
                                   f"declares {n * dtype.itemsize}")
        data = np.frombuffer(raw, dtype=dtype, count=n, offset=offset)
    elif mode == "ascii":
        rows = [ln for ln in raw[offset:].decode("ascii", "replace").splitlines() if ln.strip()]
        if len(rows) != n:
            raise InputError(path, f"PCD header says {n} points, file has {len(rows)}")
        widths = {len(ln.split()) for ln in rows}
        if n and widths != {sum(counts)}:
            raise InputError(path, f"PCD rows have {sorted(widths)} values, the header "
                                   f"declares {sum(counts)}")
        table = np.loadtxt(rows, ndmin=2) if n else np.zeros((0, sum(counts)))
        data = np.zeros(n, dtype=dtype)
        col = 0
        for name, count in zip(dtype.names, counts):
            data[name] = table[:, col] if count == 1 else table[:, col:col + count]
            col += count
    else:
        raise InputError(path, f"unknown PCD DATA mode {mode!r}")
    if not all(k in data.dtype.names for k in "xyz"):
        raise InputError(path, "PCD has no x y z fields")
    pts = np.column_stack([data["x"], data["y"], data["z"]]).astype(np.float64)
    keep = np.isfinite(pts).all(axis=1)  # PCL marks missing points with NaN
    normals = None
    if all(k in data.dtype.names for k in ("normal_x", "normal_y", "normal_z")):
        normals = np.column_stack([data["normal_x"], data["normal_y"], data["normal_z"]])[keep]
    colors = None
    for key in ("rgb", "rgba"):
        if key in data.dtype.names:
            packed = np.ascontiguousarray(data[key]).view(np.uint32)[keep]
            colors = np.column_stack([(packed >> 16) & 255, (packed >> 8) & 255,
                                      packed & 255]).astype(np.uint8)
    geometry = _geometry(pts[keep], None, normals, colors)
    dropped = int(len(keep) - keep.sum())
    if dropped:
        geometry.notes.append(f"{dropped} of {len(keep)} PCD points with NaN or infinite "
                              "coordinates dropped (PCL marks missing points so)")
    return geometry


# --------------------------------------------------------------------------- OFF
def _off_geometry(path: Path):
    """OFF / COFF: the header's vertex and face counts must match the data exactly."""
    lines = []
    for ln in path.read_bytes().decode("utf-8", "replace").splitlines():
        ln = ln.split("#", 1)[0].strip()
        if ln:
            lines.append(ln)
    if not lines or lines[0].split()[0] not in ("OFF", "COFF"):
        raise InputError(path, "not an OFF file (no OFF keyword)")
    first = lines[0].split()
    rest = lines[1:]
    counts_line = first[1:] if len(first) > 1 else (rest.pop(0).split() if rest else [])
    try:
        nv, nf = int(counts_line[0]), int(counts_line[1])
    except (IndexError, ValueError):
        raise InputError(path, "OFF header has no vertex and face counts") from None
    if nv < 0 or nf < 0:
        raise InputError(path, f"OFF header declares {nv} vertices and {nf} faces")
    if len(rest) != nv + nf:
        raise InputError(path, f"OFF header declares {nv} vertices and {nf} faces "
                               f"({nv + nf} rows), the file has {len(rest)} rows")
    vrows, frows = rest[:nv], rest[nv:]
    widths = {len(r.split()) for r in vrows}
    if not widths or min(widths) < 3 or len(widths) > 1:
        raise InputError(path, f"OFF vertex rows have {sorted(widths)} values; expected 3 "
                               "(or the same number with colours) on every row")
    vert = np.loadtxt(vrows, ndmin=2)
    colors = None
    if vert.shape[1] in (6, 7):
        colors = _colors_from(vert[:, 3:6], path, "OFF")
    faces = None
    if nf:
        lists = []
        for r in frows:
            vals = r.split()
            k = int(vals[0]) if vals[0].lstrip("-").isdigit() else -1
            if k < 3 or len(vals) < k + 1:
                raise InputError(path, f"OFF face row {r[:40]!r} does not hold its {k} indices")
            lists.append(np.array(vals[1:k + 1], dtype=np.int64))
        faces = _triangulate(lists, path)
        if len(faces) and (faces.min() < 0 or faces.max() >= nv):
            raise InputError(path, f"OFF faces index vertices that do not exist "
                                   f"({faces.min()}..{faces.max()} for {nv} vertices)")
    return _geometry(vert[:, :3], faces, None, colors)


# --------------------------------------------------------------------------- text points
def _load_table(path: Path, skip_first: bool = False) -> np.ndarray:
    """Numeric rows of a whitespace- or comma-separated point file; ragged rows refused."""
    import io as _io

    text = path.read_bytes().decode("utf-8", "replace").replace(",", " ")
    lines = [ln for ln in text.splitlines()
             if ln.strip() and not ln.lstrip().startswith(("#", "//"))]
    if skip_first:
        lines = lines[1:]
    if not lines:
        raise InputError(path, "no points")
    widths = {len(ln.split()) for ln in lines}
    if len(widths) > 1:
        raise InputError(path, f"rows have different numbers of columns ({sorted(widths)})")
    try:
        table = np.loadtxt(_io.StringIO("\n".join(lines)), ndmin=2)
    except ValueError as exc:
        raise InputError(path, f"not a table of numbers ({exc})") from None
    return table


def _xyz_geometry(path: Path):
    table = _load_table(path)
    if table.shape[1] == 3:
        return _geometry(table)
    if table.shape[1] == 6:
        return _geometry(table[:, :3], colors=_colors_from(table[:, 3:], path, "XYZ"))
    raise InputError(path, f"XYZ rows have {table.shape[1]} columns; expected 3 (x y z) or "
                           "6 (x y z r g b); use .xyzn for x y z nx ny nz")


def _xyzn_geometry(path: Path):
    table = _load_table(path)
    if table.shape[1] != 6:
        raise InputError(path, f"XYZN rows have {table.shape[1]} columns; expected 6 "
                               "(x y z nx ny nz)")
    return _geometry(table[:, :3], normals=table[:, 3:])


def _pts_geometry(path: Path):
    """Leica PTS: an optional first line with the point count, then x y z [i] [r g b]."""
    text = path.read_bytes().decode("utf-8", "replace")
    first = next((ln.split() for ln in text.splitlines() if ln.strip()), [])
    count = None
    if len(first) == 1:
        try:
            count = int(first[0])
        except ValueError:
            raise InputError(path, f"PTS first line {first[0]!r} is not a point count") from None
    table = _load_table(path, skip_first=count is not None)
    if count is not None and count != len(table):
        raise InputError(path, f"PTS header says {count} points, file has {len(table)}")
    width = table.shape[1]
    if width in (3, 4):
        return _geometry(table[:, :3])
    if width in (6, 7):
        return _geometry(table[:, :3], colors=_colors_from(table[:, width - 3:], path, "PTS"))
    raise InputError(path, f"PTS rows have {width} columns; expected 3, 4 (x y z i), "
                           "6 (x y z r g b) or 7 (x y z i r g b)")


def _npy_geometry(path: Path):
    try:
        arr = np.load(path, allow_pickle=False)
    except ValueError as exc:
        raise InputError(path, f"not a plain NumPy array file ({exc})") from None
    if arr.dtype.kind not in "fiu" or arr.ndim != 2 or arr.shape[1] not in (3, 6):
        raise InputError(path, f"expected an (N, 3) or (N, 6) numeric array, got "
                               f"{arr.shape} {arr.dtype}")
    return _geometry(arr[:, :3], normals=arr[:, 3:] if arr.shape[1] == 6 else None)


# --------------------------------------------------------------------------- extras
def _las_geometry(path: Path):
    try:
        import laspy
    except ImportError:
        raise InputError(path, "LAS/LAZ files need laspy: "
                               "pip install 'interaction-tensor[las]'") from None
    try:
        las = laspy.read(str(path))
    except laspy.errors.LaspyException as exc:
        text = str(exc)
        if "laz" in text.lower() and "backend" in text.lower():
            raise InputError(path, "LAZ files need a LAZ backend: "
                                   "pip install 'interaction-tensor[las]'") from None
        raise InputError(path, f"cannot parse as LAS: {text}") from None
    points = np.column_stack([np.asarray(las.x), np.asarray(las.y), np.asarray(las.z)])
    if len(points) != las.header.point_count:
        raise InputError(path, f"LAS header says {las.header.point_count} points, file has "
                               f"{len(points)}")
    colors = None
    dims = set(las.point_format.dimension_names)
    if {"red", "green", "blue"} <= dims:
        rgb = np.column_stack([las.red, las.green, las.blue]).astype(np.int64)
        colors = (rgb >> 8 if rgb.max(initial=0) > 255 else rgb).clip(0, 255)
    return _geometry(points, colors=colors)


def _e57_geometry(path: Path):
    try:
        import pye57
    except ImportError:
        raise InputError(path, "E57 files need pye57: "
                               "pip install 'interaction-tensor[e57]'") from None
    try:
        e57 = pye57.E57(str(path))
        parts, colors = [], []
        for i in range(e57.scan_count):
            header = e57.get_header(i)
            fields = set(header.point_fields)
            want_color = {"colorRed", "colorGreen", "colorBlue"} <= fields
            data = e57.read_scan(i, colors=want_color, ignore_missing_fields=True,
                                 transform=True)
            parts.append(np.column_stack([data["cartesianX"], data["cartesianY"],
                                          data["cartesianZ"]]))
            colors.append(np.column_stack([data["colorRed"], data["colorGreen"],
                                           data["colorBlue"]]) if want_color else None)
    except InputError:
        raise
    except Exception as exc:  # libE57 reports damage as its own exception types
        raise InputError(path, f"cannot parse as E57: {exc}") from None
    if not parts:
        raise InputError(path, "E57 file holds no scans")
    points = np.concatenate(parts)
    color = None
    if all(c is not None for c in colors):
        color = np.concatenate(colors).clip(0, 255)
    return _geometry(points, colors=color)


#: suffix -> reader
READERS = {
    ".ply": _ply_geometry, ".obj": _obj_geometry, ".off": _off_geometry,
    ".stl": _trimesh_geometry, ".glb": _trimesh_geometry, ".gltf": _trimesh_geometry,
    ".xyz": _xyz_geometry, ".xyzn": _xyzn_geometry, ".pts": _pts_geometry,
    ".npy": _npy_geometry, ".pcd": _pcd_geometry, ".las": _las_geometry, ".laz": _las_geometry,
    ".e57": _e57_geometry,
}
