"""Every input format round-trips on tiny files; damaged files are refused, never half-read."""

from __future__ import annotations

import io
import json
import os

import numpy as np
import pytest
import trimesh
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

import interaction_tensor as it
from interaction_tensor.examples import demo
from interaction_tensor.geometry.load import load_geometry
from interaction_tensor.geometry.readers import read_ply

# a small tetrahedron-like mesh with a non-trivial extent (metres)
V = np.array([[0.0, 0.0, 0.0], [0.3, 0.0, 0.0], [0.0, 0.2, 0.0], [0.0, 0.0, 0.1],
              [0.25, 0.15, 0.05]])
F = np.array([[0, 2, 1], [0, 1, 3], [0, 3, 2], [1, 2, 3], [1, 4, 2]])
C = np.array([[255, 0, 0], [0, 255, 0], [0, 0, 255], [10, 20, 30], [200, 100, 50]], np.uint8)
N = V[:, [1, 2, 0]] - 0.1
N = N / np.linalg.norm(N, axis=1, keepdims=True)


def _ply_bytes(text: bool, faces: bool = True, colors: bool = False, normals: bool = False,
               byte_order: str = "<") -> bytes:
    import plyfile

    fields = [("x", "f4"), ("y", "f4"), ("z", "f4")]
    fields += [("nx", "f4"), ("ny", "f4"), ("nz", "f4")] if normals else []
    fields += [("red", "u1"), ("green", "u1"), ("blue", "u1")] if colors else []
    v = np.zeros(len(V), dtype=fields)
    v["x"], v["y"], v["z"] = V.T
    if normals:
        v["nx"], v["ny"], v["nz"] = N.T
    if colors:
        v["red"], v["green"], v["blue"] = C.T
    els = [plyfile.PlyElement.describe(v, "vertex")]
    if faces:
        f = np.array([(row,) for row in F], dtype=[("vertex_indices", "i4", (3,))])
        els.append(plyfile.PlyElement.describe(f, "face"))
    buf = io.BytesIO()
    plyfile.PlyData(els, text=text, byte_order=byte_order).write(buf)
    return buf.getvalue()


def _close(a, b):
    return np.allclose(a, b, atol=1e-6)


@pytest.mark.parametrize("text", [True, False])
@pytest.mark.parametrize("byte_order", ["<", ">"])
def test_ply_mesh_and_cloud(tmp_path, text, byte_order):
    if text and byte_order == ">":
        pytest.skip("byte order applies to binary files only")
    mesh = tmp_path / "mesh.ply"
    mesh.write_bytes(_ply_bytes(text, faces=True, colors=True, byte_order=byte_order))
    g = load_geometry(mesh)
    assert g.is_mesh and _close(g.vertices, V) and np.array_equal(g.faces, F)
    assert np.array_equal(g.colors, C)
    cloud = tmp_path / "cloud.ply"
    cloud.write_bytes(_ply_bytes(text, faces=False, colors=True, normals=True,
                                 byte_order=byte_order))
    g = load_geometry(cloud)
    assert not g.is_mesh and _close(g.vertices, V) and _close(g.normals, N)
    assert np.array_equal(g.colors, C)


def test_ply_polygons_become_triangle_fans(tmp_path):
    text = ("ply\nformat ascii 1.0\nelement vertex 5\nproperty float x\nproperty float y\n"
            "property float z\nelement face 2\nproperty list uchar int vertex_indices\n"
            "end_header\n0 0 0\n1 0 0\n1 1 0\n0 1 0\n0.5 0.5 1\n4 0 1 2 3\n3 0 1 4\n")
    (tmp_path / "quad.ply").write_text(text)
    g = load_geometry(tmp_path / "quad.ply")
    assert g.faces.tolist() == [[0, 1, 2], [0, 2, 3], [0, 1, 4]]


@pytest.mark.parametrize("suffix", [".obj", ".off", ".stl", ".glb"])
def test_trimesh_formats(tmp_path, suffix):
    mesh = trimesh.Trimesh(V, F, process=False)
    path = tmp_path / f"mesh{suffix}"
    mesh.export(path)
    g = load_geometry(path)
    assert g.is_mesh
    # STL stores triangles, not shared vertices: compare the triangles' corners
    assert _close(np.sort(g.vertices[g.faces].reshape(-1, 3), axis=0),
                  np.sort(V[F].reshape(-1, 3), axis=0))


def test_gltf_with_its_buffer_and_vertex_colours(tmp_path):
    mesh = trimesh.Trimesh(V, F, vertex_colors=np.column_stack([C, np.full(5, 255)]),
                           process=False)
    files = trimesh.exchange.gltf.export_gltf(trimesh.Scene(mesh))
    for name, data in files.items():
        (tmp_path / name).write_bytes(data)
    g = load_geometry(tmp_path / "model.gltf")
    assert g.is_mesh and len(g.faces) == len(F)
    assert _close(np.sort(g.vertices, axis=0), np.sort(V, axis=0))
    assert g.colors is not None and {tuple(c) for c in g.colors} == {tuple(c) for c in C}


def test_obj_keeps_vertex_colours(tmp_path):
    lines = [f"v {x} {y} {z} {r / 255:.6f} {gg / 255:.6f} {b / 255:.6f}"
             for (x, y, z), (r, gg, b) in zip(V, C)]
    lines += [f"f {a + 1} {b + 1} {c + 1}" for a, b, c in F]
    (tmp_path / "c.obj").write_text("\n".join(lines) + "\n")
    g = load_geometry(tmp_path / "c.obj")
    assert g.colors is not None and np.abs(g.colors.astype(int) - C).max() <= 1


def test_text_point_formats(tmp_path):
    (tmp_path / "p.xyz").write_text("\n".join(" ".join(f"{v:.6f}" for v in p) for p in V))
    assert _close(load_geometry(tmp_path / "p.xyz").vertices, V)
    (tmp_path / "c.xyz").write_text("\n".join(
        " ".join([*(f"{v:.6f}" for v in p), *(str(int(c)) for c in col)]) for p, col in zip(V, C)))
    g = load_geometry(tmp_path / "c.xyz")
    assert _close(g.vertices, V) and np.array_equal(g.colors, C)
    (tmp_path / "n.xyzn").write_text("\n".join(
        " ".join(f"{v:.8f}" for v in [*p, *n]) for p, n in zip(V, N)))
    g = load_geometry(tmp_path / "n.xyzn")
    assert _close(g.vertices, V) and _close(g.normals, N)
    # Leica PTS: a count line, then x y z intensity r g b
    rows = [" ".join([*(f"{v:.6f}" for v in p), "-512", *(str(int(c)) for c in col)])
            for p, col in zip(V, C)]
    (tmp_path / "s.pts").write_text(f"{len(V)}\n" + "\n".join(rows) + "\n")
    g = load_geometry(tmp_path / "s.pts")
    assert _close(g.vertices, V) and np.array_equal(g.colors, C)
    np.save(tmp_path / "p.npy", V)
    assert _close(load_geometry(tmp_path / "p.npy").vertices, V)
    np.save(tmp_path / "pn.npy", np.column_stack([V, N]))
    g = load_geometry(tmp_path / "pn.npy")
    assert _close(g.vertices, V) and _close(g.normals, N)


def test_pcd_ascii(tmp_path):
    header = ("# .PCD v0.7\nVERSION 0.7\nFIELDS x y z normal_x normal_y normal_z\n"
              "SIZE 4 4 4 4 4 4\nTYPE F F F F F F\nCOUNT 1 1 1 1 1 1\n"
              f"WIDTH {len(V)}\nHEIGHT 1\nPOINTS {len(V)}\nDATA ascii\n")
    body = "\n".join(" ".join(f"{v:.7f}" for v in [*p, *n]) for p, n in zip(V, N))
    (tmp_path / "c.pcd").write_text(header + body + "\n")
    g = load_geometry(tmp_path / "c.pcd")
    assert _close(g.vertices, V) and np.allclose(g.normals, N, atol=1e-6)


def test_las_and_laz(tmp_path):
    laspy = pytest.importorskip("laspy")
    header = laspy.LasHeader(point_format=2, version="1.2")
    header.scales = [1e-4, 1e-4, 1e-4]
    header.offsets = [0.0, 0.0, 0.0]
    las = laspy.LasData(header)
    las.x, las.y, las.z = V.T
    las.red, las.green, las.blue = (C.astype(np.uint16) * 257).T
    las.write(tmp_path / "c.las")
    g = load_geometry(tmp_path / "c.las")
    assert np.allclose(g.vertices, V, atol=1e-4) and np.array_equal(g.colors, C)
    try:
        las.write(tmp_path / "c.laz")
    except laspy.errors.LaspyException:
        pytest.skip("no LAZ backend installed")
    g = load_geometry(tmp_path / "c.laz")
    assert np.allclose(g.vertices, V, atol=1e-4)


def test_e57(tmp_path):
    pye57 = pytest.importorskip("pye57")
    path = tmp_path / "c.e57"
    e57 = pye57.E57(str(path), mode="w")
    e57.write_scan_raw({"cartesianX": V[:, 0], "cartesianY": V[:, 1], "cartesianZ": V[:, 2],
                        "colorRed": C[:, 0], "colorGreen": C[:, 1], "colorBlue": C[:, 2]})
    e57.close()
    g = load_geometry(path)
    assert _close(g.vertices, V) and np.array_equal(g.colors, C)


def test_missing_extra_gives_an_install_hint(tmp_path, monkeypatch):
    import builtins

    real_import = builtins.__import__

    def no_laspy(name, *args, **kwargs):
        if name == "laspy":
            raise ImportError("no laspy")
        return real_import(name, *args, **kwargs)

    (tmp_path / "c.las").write_bytes(b"LASF" + bytes(400))
    monkeypatch.setattr(builtins, "__import__", no_laspy)
    with pytest.raises(it.InputError, match=r"pip install 'interaction-tensor\[las\]'"):
        load_geometry(tmp_path / "c.las")


# ----------------------------------------------------------------------------- refusals
def _refused(path, pattern):
    with pytest.raises(it.InputError, match=pattern) as info:
        load_geometry(path)
    assert str(path) in str(info.value)


def test_header_and_data_must_agree(tmp_path):
    good = _ply_bytes(True, faces=False)
    claims_more = good.replace(b"element vertex 5", b"element vertex 6")
    (tmp_path / "more.ply").write_bytes(claims_more)
    _refused(tmp_path / "more.ply", "does not match its header")
    (tmp_path / "extra.ply").write_bytes(good + b"1 2 3\n")
    _refused(tmp_path / "extra.ply", "6 data rows, its header declares 5")
    binary = _ply_bytes(False, faces=True)
    (tmp_path / "tail.ply").write_bytes(binary + b"\x00" * 12)
    _refused(tmp_path / "tail.ply", "12 bytes after the data")
    (tmp_path / "mid.ply").write_bytes(binary.replace(b"binary_little_endian",
                                                      b"binary_middle_endian"))
    _refused(tmp_path / "mid.ply", "bad PLY header")
    bad_face = _ply_bytes(True).replace(b"3 1 4 2", b"3 1 9 2")
    (tmp_path / "face.ply").write_bytes(bad_face)
    _refused(tmp_path / "face.ply", "index vertices that do not exist")


def test_point_files_refuse_what_they_cannot_read(tmp_path):
    (tmp_path / "r.xyz").write_text("0 0 0\n1 0 0\n0 1 0 5\n0 0 1\n")
    _refused(tmp_path / "r.xyz", "different numbers of columns")
    (tmp_path / "w.xyz").write_text("0 0 0 1\n1 0 0 1\n0 1 0 1\n0 0 1 1\n")
    _refused(tmp_path / "w.xyz", "4 columns")
    (tmp_path / "c.pts").write_text("7\n0 0 0\n1 0 0\n0 1 0\n0 0 1\n")
    _refused(tmp_path / "c.pts", "header says 7 points, file has 4")
    np.save(tmp_path / "o.npy", np.array([{"a": 1}] * 4, dtype=object))
    _refused(tmp_path / "o.npy", "not a plain NumPy array")
    np.save(tmp_path / "s.npy", np.zeros((4, 2)))
    _refused(tmp_path / "s.npy", r"\(N, 3\)")


@pytest.mark.skipif(not hasattr(os, "mkfifo"), reason="no named pipes here")
def test_a_named_pipe_is_refused_at_once(tmp_path):
    fifo = tmp_path / "scene.ply"
    os.mkfifo(fifo)
    _refused(fifo, "not a regular file")


@settings(max_examples=40, deadline=None, suppress_health_check=[HealthCheck.function_scoped_fixture])
@given(text=st.booleans(), faces=st.booleans(), fraction=st.floats(0.0, 1.0))
def test_a_cut_ply_is_never_half_read(tmp_path, text, faces, fraction):
    """Any PLY cut before its last data row is refused (hypothesis picks the cut)."""
    raw = _ply_bytes(text, faces=faces)
    start = raw.index(b"end_header\n") + len(b"end_header\n")
    end = raw.rstrip(b"\n").rindex(b"\n") + 1 if text else len(raw)   # start of the last row
    cut = start + int(fraction * (end - start - 1))
    path = tmp_path / f"cut-{text}-{faces}.ply"
    path.write_bytes(raw[:cut])
    with pytest.raises(it.InputError):
        load_geometry(path)


@settings(max_examples=30, deadline=None, suppress_health_check=[HealthCheck.function_scoped_fixture])
@given(rows=st.lists(st.lists(st.floats(allow_nan=True, allow_infinity=True, width=32),
                              min_size=1, max_size=7), min_size=0, max_size=8))
def test_any_xyz_table_is_read_whole_or_refused_in_one_line(tmp_path, rows):
    """Random tables (ragged, NaN, too few points) either load completely or are refused
    with an InputError naming the file: never another exception."""
    path = tmp_path / "t.xyz"
    path.write_text("\n".join(" ".join(repr(v) for v in r) for r in rows) + "\n")
    try:
        g = load_geometry(path)
    except it.InputError as exc:
        assert str(path) in str(exc) and "\n" not in str(exc)
        return
    assert len(g.vertices) == len(rows) and np.isfinite(g.vertices).all()


def test_heatmap_and_glb_open_in_viewers(tmp_path):
    """heatmap.ply carries the score as MeshLab's quality and a CloudCompare scalar field;
    predictions.glb holds the heat map and the posed objects."""

    ex = demo.build()
    tensor = it.train(ex.query, ex.scene_object, "placing-bowl", spacing=demo.DEMO_SPACING)
    result = it.detect(ex.scene, tensor, sample_fraction=0.05, top_k=3)
    result.save(tmp_path)

    heat = read_ply(tmp_path / "heatmap.ply")["vertex"]
    assert np.allclose(heat["quality"], result.heat, atol=1e-6)
    assert np.allclose(heat["scalar_score"], result.heat, atol=1e-6)
    glb = trimesh.load(tmp_path / "predictions.glb")
    assert isinstance(glb, trimesh.Scene) and len(glb.geometry) == 1 + len(result.predictions)
    doc = json.loads((tmp_path / "predictions.json").read_text())
    assert len(doc["predictions"]) == len(result.predictions) >= 1


def _off_text(colors=False):
    rows = [" ".join(f"{v:.6f}" for v in p) + ("" if not colors else " " + " ".join(
        str(int(c)) for c in col)) for p, col in zip(V, C)]
    faces = [f"3 {a} {b} {c}" for a, b, c in F]
    return ("COFF" if colors else "OFF") + f"\n{len(V)} {len(F)} 0\n" + "\n".join(rows + faces) + "\n"


def test_off_with_colours_and_its_counts_checked(tmp_path):
    (tmp_path / "m.off").write_text(_off_text())
    g = load_geometry(tmp_path / "m.off")
    assert _close(g.vertices, V) and np.array_equal(g.faces, F)
    (tmp_path / "c.off").write_text(_off_text(colors=True))
    assert np.array_equal(load_geometry(tmp_path / "c.off").colors, C)
    (tmp_path / "more.off").write_text(_off_text().replace(f"{len(V)} {len(F)} 0", f"{len(V) + 1} {len(F)} 0"))
    _refused(tmp_path / "more.off", "declares 6 vertices")
    (tmp_path / "idx.off").write_text(_off_text().replace("3 1 4 2", "3 1 9 2"))
    _refused(tmp_path / "idx.off", "index vertices that do not exist")


def _pcd_text(n_declared=None, width=None):
    n = len(V) if n_declared is None else n_declared
    return ("VERSION 0.7\nFIELDS x y z\nSIZE 4 4 4\nTYPE F F F\nCOUNT 1 1 1\n"
            f"WIDTH {n if width is None else width}\nHEIGHT 1\nPOINTS {n}\nDATA ascii\n"
            + "\n".join(" ".join(f"{v:.6f}" for v in p) for p in V) + "\n")


def test_pcd_header_must_match(tmp_path):
    (tmp_path / "neg.pcd").write_text(_pcd_text(-5, width=-5))
    _refused(tmp_path / "neg.pcd", "declares -5 points")
    (tmp_path / "wh.pcd").write_text(_pcd_text(width=9))
    _refused(tmp_path / "wh.pcd", "WIDTH x HEIGHT")
    (tmp_path / "more.pcd").write_text(_pcd_text(7))
    _refused(tmp_path / "more.pcd", "says 7 points, file has 5")
    header = ("VERSION 0.7\nFIELDS x y z\nSIZE 4 4 4\nTYPE F F F\nCOUNT 1 1 1\nWIDTH 5\n"
              "HEIGHT 1\nPOINTS 5\nDATA binary\n").encode()
    body = V.astype("<f4").tobytes()
    (tmp_path / "ok.pcd").write_bytes(header + body)
    assert _close(load_geometry(tmp_path / "ok.pcd").vertices, V)
    (tmp_path / "tail.pcd").write_bytes(header + body + b"\0" * 12)
    _refused(tmp_path / "tail.pcd", "declares 60")
    (tmp_path / "short.pcd").write_bytes(header + body[:-4])
    _refused(tmp_path / "short.pcd", "declares 60")


@settings(max_examples=40, deadline=None, suppress_health_check=[HealthCheck.function_scoped_fixture])
@given(kind=st.sampled_from(["off", "pcd", "pts"]), fraction=st.floats(0.0, 1.0))
def test_cut_off_pcd_and_pts_files_are_never_half_read(tmp_path, kind, fraction):
    """Cut anywhere before the last row (hypothesis picks the cut): refused, never read."""
    text = {"off": _off_text(), "pcd": _pcd_text(),
            "pts": f"{len(V)}\n" + "\n".join(" ".join(f"{v:.6f}" for v in p) for p in V) + "\n"}[kind]
    raw = text.encode()
    start = raw.index(b"\n") + 1 if kind != "pcd" else raw.index(b"DATA ascii\n") + 11
    end = raw.rstrip(b"\n").rindex(b"\n") + 1
    cut = start + int(fraction * (end - start - 1))
    path = tmp_path / f"cut.{kind}"
    path.write_bytes(raw[:cut])
    with pytest.raises(it.InputError):
        load_geometry(path)


def _obj_text() -> str:
    mesh = trimesh.creation.icosphere(1)
    lines = [f"v {x:.6f} {y:.6f} {z:.6f}" for x, y, z in mesh.vertices]
    lines += [f"f {a + 1}/{a + 1} {b + 1}//{b + 1} {c + 1}" for a, b, c in mesh.faces]
    return "# a comment\n" + "\n".join(lines) + "\n"


def test_obj_rows_indices_and_polygons(tmp_path):
    (tmp_path / "ok.obj").write_text("v 0 0 0\nv 1 0 0\nv 0 1 0\nv 0 0 1\nvn 0 0 1\n"
                                     "f 1/1/1 2//1 3 4\nf -1 -2 -3\n")
    g = load_geometry(tmp_path / "ok.obj")
    assert g.faces.tolist() == [[0, 1, 2], [0, 2, 3], [3, 2, 1]]    # fan, then relative
    # indented rows and trailing blanks are valid OBJ: read, not skipped or miscounted
    (tmp_path / "ws.obj").write_text("  v 0 0 0\n\tv 1 0 0  \nv 0 1 0\nv 0 0 1\t\n"
                                     "  f 1 2 3 4   \n")
    g = load_geometry(tmp_path / "ws.obj")
    assert len(g.vertices) == 4 and g.faces.tolist() == [[0, 1, 2], [0, 2, 3]]
    for text, says in (("v 0 0 0\nv 1 0 0\nv 0 1 0\nv 0 0\nf 1 2 3\n", "line 4 'v 0 0'"),
                       ("v 0 0 0\nv 1 0 0\nv 0 1 0\nv 0 0 1\nf 1 2\n", "line 5 'f 1 2'"),
                       ("v 0 0 0\nv 1 0 0\nv 0 1 0\nv 0 0 1\nf 1 2 9\n", "outside the 4"),
                       ("v 0 0 0\nv 1 0 0\nv 0 1 0 1 1 1\nv 0 0 1\n", "mixed rows"),
                       ("v 0 0 0\nv 1 0 0\nv 0 1 0\nv 0 0 1\nf 1 2 3", "middle of line 5"),
                       ("v 0 0 0\nv 1 0 nan\nv 0 1 0\nv 0 0 1\n", "line 2")):
        (tmp_path / "bad.obj").write_text(text)
        _refused(tmp_path / "bad.obj", says)


@settings(max_examples=60, deadline=None, suppress_health_check=[HealthCheck.function_scoped_fixture])
@given(fraction=st.floats(0.0, 1.0))
def test_a_cut_obj_is_refused_or_read_exactly_as_far_as_it_goes(tmp_path, fraction):
    """OBJ declares no counts, so a file cut at a line break is a smaller whole file: it must
    then hold exactly the rows before the cut; cut inside a row, it is refused."""
    raw = _obj_text().encode()
    cut = int(fraction * (len(raw) - 1))
    path = tmp_path / "cut.obj"
    path.write_bytes(raw[:cut])
    lines = raw[:cut].decode().split("\n")
    # the rows before the cut; None when the cut falls inside a v or f row
    whole = None if lines[-1][:2] in ("v ", "f ") else [ln for ln in lines[:-1]
                                                        if ln[:2] in ("v ", "f ")]
    try:
        g = load_geometry(path)
    except it.InputError as exc:
        assert str(exc).startswith(str(path)) and "\n" not in str(exc)
        return
    assert whole is not None, "a row cut in the middle was read"
    full = load_geometry_text(_obj_text(), tmp_path)
    n_v = sum(ln.startswith("v ") for ln in whole)
    n_f = sum(ln.startswith("f ") for ln in whole)
    assert _close(g.vertices, full.vertices[:n_v])
    assert (0 if g.faces is None else len(g.faces)) == n_f
    if n_f:
        assert (g.faces == full.faces[:n_f]).all()


def load_geometry_text(text: str, tmp_path):
    (tmp_path / "whole.obj").write_text(text)
    return load_geometry(tmp_path / "whole.obj")


@settings(max_examples=40, deadline=None, suppress_health_check=[HealthCheck.function_scoped_fixture])
@given(kind=st.sampled_from(["stl", "stl-ascii", "glb"]), fraction=st.floats(0.0, 0.999))
def test_cut_stl_and_glb_files_are_refused(tmp_path, kind, fraction):
    """Binary STL declares its triangle count, ASCII STL ends with endsolid and GLB declares
    its length: cut anywhere, they are refused in one line naming the file."""
    mesh = trimesh.creation.icosphere(1)
    raw = (trimesh.exchange.stl.export_stl_ascii(mesh).encode() if kind == "stl-ascii"
           else mesh.export(file_type=kind.split("-")[0]))
    path = tmp_path / f"cut.{kind.split('-')[0]}"
    path.write_bytes(raw[:int(fraction * len(raw))])
    with pytest.raises(it.InputError) as exc:
        load_geometry(path)
    assert str(exc.value).startswith(str(path)) and "\n" not in str(exc.value)
