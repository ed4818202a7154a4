import numpy as np
import pytest
import trimesh

import interaction_tensor as it
from interaction_tensor.geometry.files import write_json, write_ply_points
from interaction_tensor.geometry.load import load_geometry


@pytest.fixture()
def box_mesh():
    return trimesh.creation.box(extents=(0.2, 0.1, 0.05))


@pytest.mark.parametrize("suffix", [".ply", ".obj", ".off", ".stl"])
def test_mesh_formats_load(tmp_path, box_mesh, suffix):
    path = tmp_path / f"box{suffix}"
    box_mesh.export(path)
    g = load_geometry(path)
    assert g.is_mesh
    np.testing.assert_allclose(np.ptp(g.vertices, axis=0), [0.2, 0.1, 0.05], atol=1e-6)


def test_scale_and_up_axis(tmp_path, box_mesh):
    path = tmp_path / "box.ply"
    box_mesh.export(path)
    g = load_geometry(path, scale=10.0, up="y")
    # y-up file: (x, y, z) -> (x, -z, y); extents (0.2, 0.1, 0.05) * 10 -> (2, 0.5, 1)
    np.testing.assert_allclose(np.ptp(g.vertices, axis=0), [2.0, 0.5, 1.0], atol=1e-5)


def _pcd(points, mode):
    header = ("# .PCD v0.7\nVERSION 0.7\nFIELDS x y z\nSIZE 4 4 4\nTYPE F F F\nCOUNT 1 1 1\n"
              f"WIDTH {len(points)}\nHEIGHT 1\nVIEWPOINT 0 0 0 1 0 0 0\nPOINTS {len(points)}\n"
              f"DATA {mode}\n")
    if mode == "ascii":
        return (header + "\n".join(" ".join(f"{v:.6f}" for v in p) for p in points) + "\n").encode()
    return header.encode() + points.astype("<f4").tobytes()


@pytest.mark.parametrize("mode", ["ascii", "binary"])
def test_pcd_loads(tmp_path, mode):
    pts = np.random.default_rng(0).random((50, 3))
    path = tmp_path / "c.pcd"
    path.write_bytes(_pcd(pts, mode))
    g = load_geometry(path)
    assert not g.is_mesh
    np.testing.assert_allclose(g.vertices, pts, atol=1e-6)


def test_point_cloud_ply_round_trip(tmp_path):
    pts = np.random.default_rng(1).random((100, 3))
    write_ply_points(tmp_path / "p.ply", pts, colors=np.full((100, 3), 7, np.uint8),
                     score=np.linspace(0, 1, 100))
    g = load_geometry(tmp_path / "p.ply")
    assert not g.is_mesh and len(g.vertices) == 100
    np.testing.assert_allclose(g.vertices, pts, atol=1e-6)


def test_errors_name_the_file_and_the_problem(tmp_path):
    with pytest.raises(it.InputError, match="no such file"):
        load_geometry(tmp_path / "missing.ply")
    with pytest.raises(it.InputError, match="is a directory"):
        load_geometry(tmp_path)
    empty = tmp_path / "empty.ply"
    empty.write_bytes(b"")
    with pytest.raises(it.InputError, match="empty"):
        load_geometry(empty)
    unknown = tmp_path / "scene.abc"
    unknown.write_text("1 2 3\n")
    with pytest.raises(it.InputError, match="unknown format"):
        load_geometry(unknown)
    garbage = tmp_path / "garbage.ply"
    garbage.write_bytes(b"this is not a ply file at all\n" * 10)
    with pytest.raises(it.InputError) as info:
        load_geometry(garbage)
    assert "garbage.ply" in str(info.value)
    pts = np.random.default_rng(0).random((10, 3))
    bad = pts.copy()
    bad[2, 1] = np.inf
    nanply = tmp_path / "inf.ply"
    write_ply_points(nanply, bad)
    with pytest.raises(it.InputError, match="NaN or infinite"):
        load_geometry(nanply)
    big = tmp_path / "mm.ply"
    write_ply_points(big, pts * 5000)
    with pytest.raises(it.InputError, match="--scale"):
        load_geometry(big)


def test_degenerate_geometry_is_rejected(tmp_path):
    flat = it.Geometry(np.zeros((10, 3)), source="zeros")
    with pytest.raises(it.InputError, match="coincide"):
        it.validate_geometry(flat)
    v = np.array([[0, 0, 0], [1, 0, 0], [2, 0, 0]], float)
    line = it.Geometry(v, np.array([[0, 1, 2]]), source="line")
    with pytest.raises(it.InputError, match="zero surface area|at least|one line"):
        it.validate_geometry(line, min_points=3)


def test_write_json_writes_long_arrays_block_by_block_as_json_lists(tmp_path):
    """A NumPy array longer than a block is written as the one JSON list it is (floats to 6
    decimals), within the indented document."""
    import json

    rng = np.random.default_rng(3)
    base = rng.random(250_003)
    write_json(tmp_path / "a.json", {"g": base, "n": 2, "nested": [np.arange(3)]})
    doc = json.loads((tmp_path / "a.json").read_text())
    assert doc["n"] == 2 and doc["nested"] == [[0, 1, 2]]
    np.testing.assert_allclose(doc["g"], np.round(base, 6), atol=0)
