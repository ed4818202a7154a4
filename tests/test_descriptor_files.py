"""Descriptor files are validated on load: a tampered file is refused naming the field, never
used, never a traceback, and nothing is loaded with pickle."""

from __future__ import annotations

import io
import json

import numpy as np
import pytest
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

import interaction_tensor as it
from interaction_tensor import affordances
from interaction_tensor.descriptor.tensor import _ARRAYS
from interaction_tensor.errors import InputError

from support import corner_example


@pytest.fixture(scope="module")
def real(tmp_path_factory):
    """A real descriptor's header and arrays."""
    query, scene_object = corner_example()
    t = it.InteractionTensor.fit(query, scene_object, "corner",
                                 it.TrainSettings(query_points=800, seed=1))
    path = tmp_path_factory.mktemp("desc") / "c.npz"
    t.save(path)
    with np.load(path, allow_pickle=False) as data:
        arrays = {k: data[k] for k in data.files}
    header = json.loads(arrays.pop("header").tobytes().decode())
    return header, arrays


def _write(path, header, arrays):
    buf = io.BytesIO()
    np.savez(buf, header=np.frombuffer(json.dumps(header).encode(), np.uint8), **arrays)
    path.write_bytes(buf.getvalue())
    return path


def _refused(path, field):
    with pytest.raises(it.InputError) as info:
        it.InteractionTensor.load(path)
    text = str(info.value)
    assert str(path) in text and f"'{field}'" in text and "\n" not in text, text
    assert "allow_pickle" not in text


ARRAY_TAMPERING = {
    "nan": lambda a: np.where(np.arange(a.size).reshape(a.shape) == 0, np.nan, a),
    "inf": lambda a: np.full(a.shape, np.inf),
    "shape": lambda a: a.reshape(-1)[: max(a.size - 1, 1)].reshape(-1, 1)
    if a.size > 1 else np.zeros((2, 2)),
    "strings": lambda a: np.array(["x"] * max(a.size, 1)),
    "empty": lambda a: a[:0],
    "drop": None,
}


@settings(max_examples=60, deadline=None,
          suppress_health_check=[HealthCheck.function_scoped_fixture])
@given(name=st.sampled_from(sorted(_ARRAYS)), how=st.sampled_from(sorted(ARRAY_TAMPERING)))
def test_tampered_arrays_are_refused_naming_the_field(real, tmp_path, name, how):
    header, arrays = real
    arrays = dict(arrays)
    if how == "drop":
        del arrays[name]
    else:
        arrays[name] = ARRAY_TAMPERING[how](arrays[name].astype(float))
    path = _write(tmp_path / f"{name}-{how}.npz", header, arrays)
    try:
        t = it.InteractionTensor.load(path)
    except it.InputError as exc:
        text = str(exc)
        assert str(path) in text and "\n" not in text and "allow_pickle" not in text
        # the problem is named (a field, or its partner in a count check)
        assert "descriptor field" in text, text
        return
    # accepted only where the change leaves a valid descriptor: an optional list emptied
    # or dropped (the placement tests' points of older format versions, contact or scene
    # points) where its partner is empty as well
    optional = ("clearance_points", "clearance_radius", "interior_points", "interior_radius",
                "contact_group_points", "contact_group_ids", "contact_group_normals",
                "contact_points", "scene_points")
    assert (how in ("empty", "drop") and name in optional) or \
        (how == "empty" and name == "query_faces"), (name, how)
    assert np.isfinite(t.weighted.points).all()


def test_the_real_descriptor_has_every_placement_test(real):
    header, arrays = real
    assert header["format_version"] == 3
    assert len(arrays["interior_points"]) > 0 and len(arrays["contact_group_ids"]) > 0


def test_a_version_2_descriptor_loads_without_the_new_tests(real, tmp_path):
    """A file written before interior points and contact groups existed (format version 2)
    loads, and detection then skips those two tests."""
    header, arrays = real
    old = {k: v for k, v in header.items() if k not in (
        "interior_limit", "contact_groups", "contact_distance", "contact_fraction",
        "contact_angle", "ground")}
    old["format_version"] = 2
    a = {k: v for k, v in arrays.items() if not k.startswith(("interior_", "contact_group"))}
    t = it.InteractionTensor.load(_write(tmp_path / "v2.npz", old, a))
    assert len(t.interior_points) == 0 and len(t.contact_group_ids) == 0
    assert t.contact_groups == "off" and t.interior_limit == 1.0 and t.ground is None
    assert len(t.clearance_points) == len(arrays["clearance_points"])


def test_contact_group_ids_must_number_the_groups(real, tmp_path):
    header, arrays = real
    a = dict(arrays)
    a["contact_group_ids"] = a["contact_group_ids"].copy() + 1         # no group 0
    _refused(_write(tmp_path / "g.npz", header, a), "contact_group_ids")
    a = dict(arrays)
    a["contact_group_normals"] = a["contact_group_normals"] * 2.0       # not unit vectors
    _refused(_write(tmp_path / "n.npz", header, a), "contact_group_normals")


@pytest.mark.parametrize("field,value", [
    ("radius", float("nan")), ("radius", -1.0), ("radius", "big"), ("scene_spacing", 1e-6),
    ("scene_spacing", 0), ("scene_spacing", None), ("vectors", "bogus"),
    ("clearance_limit", 2.0), ("affordance", ""), ("affordance", 7), ("thresholds", [0.5]),
    ("meta", "x"), ("interior_limit", 1.5), ("contact_groups", "some"),
    ("contact_distance", -0.01), ("contact_fraction", 2.0), ("contact_angle", 0.0),
    ("contact_angle", 120.0), ("ground", "floor"), ("ground", float("inf"))])
def test_tampered_header_fields_are_refused(real, tmp_path, field, value):
    header, arrays = real
    path = _write(tmp_path / "h.npz", {**header, field: value}, arrays)
    _refused(path, field)


def test_bad_thresholds_weights_and_faces_are_refused(real, tmp_path):
    header, arrays = real
    bad = {**header, "thresholds": {**header["thresholds"], "paper-weighted": float("nan")}}
    _refused(_write(tmp_path / "t.npz", bad, arrays), "thresholds.paper-weighted")
    for name, value in (("weighted_weights", -0.5), ("weights", 1e300)):
        a = dict(arrays)
        a[name] = a[name].copy()
        a[name][0] = value
        _refused(_write(tmp_path / f"{name}.npz", header, a), name)
    a = dict(arrays)
    a["affordance_normal"] = np.zeros(3)
    _refused(_write(tmp_path / "n.npz", header, a), "affordance_normal")
    a = dict(arrays)
    a["query_faces"] = a["query_faces"].copy()
    a["query_faces"][0, 0] = len(a["query_vertices"]) + 5
    _refused(_write(tmp_path / "f.npz", header, a), "query_faces")
    a = dict(arrays)
    a["reference_point"] = a["query_centroid"] + 1e3
    _refused(_write(tmp_path / "r.npz", header, a), "reference_point")


def test_not_descriptors_never_load_and_never_mention_pickle(real, tmp_path):
    import pickle

    header, arrays = real
    cases = {"random.npz": bytes(range(256)) * 4,
             "pickle.npz": pickle.dumps({"header": 1}),
             "list-header.npz": None}
    for name, data in cases.items():
        path = tmp_path / name
        if data is None:
            buf = io.BytesIO()
            np.savez(buf, header=np.frombuffer(b"[1, 2]", np.uint8), **arrays)
            data = buf.getvalue()
        path.write_bytes(data)
        with pytest.raises(it.InputError) as info:
            it.InteractionTensor.load(path)
        assert "allow_pickle" not in str(info.value) and str(path) in str(info.value)
    # an object array inside an otherwise plausible file
    buf = io.BytesIO()
    np.savez(buf, header=np.frombuffer(json.dumps(header).encode(), np.uint8),
             **{**arrays, "weights": np.array([{"a": 1}], dtype=object)})
    (tmp_path / "object.npz").write_bytes(buf.getvalue())
    with pytest.raises(it.InputError, match="never loaded") as info:
        it.InteractionTensor.load(tmp_path / "object.npz")
    assert "allow_pickle" not in str(info.value)


@pytest.mark.parametrize("content, says", [
    (b"a plain text file\n", "not a .npz archive"),
    (b"", "an empty file"),
    (None, "a pickle: it holds Python objects"),
    (b"\x93NUMPY\x01\x00", "a single .npy array"),
])
def test_a_file_that_is_not_a_descriptor_is_refused_for_what_it_is(tmp_path, content, says):
    import pickle

    path = tmp_path / "d.npz"
    path.write_bytes(pickle.dumps([1, 2]) if content is None else content)
    with pytest.raises(it.InputError) as info:
        it.InteractionTensor.load(path)
    assert str(info.value) == f"{path}: not a descriptor file ({says}" + \
        str(info.value).split(says, 1)[1]
    assert says in str(info.value) and "\n" not in str(info.value)


@pytest.mark.parametrize("example, field, default, good, wrong, wrong_in_file", [
    ("sitting-human", "feet_reach", 0.25, 0.3, (-0.01, 2.0, "on", True), ("far", -1.0, 3.0)),
    ("riding-human", "mount_height", 1.2, 1.3, (-0.1, 11.0, "high", True),
     ("tall", -1.0, 50.0)),
])
def test_a_height_setting_survives_a_file_and_a_bad_one_is_refused(
        tmp_path, example, field, default, good, wrong, wrong_in_file):
    """The feet and mount tests' heights (m): set, saved, loaded, switched off; out of range
    or of the wrong type refused when set and when read from a file; absent from an older
    file, the test is off."""

    from support import descriptor_with_header

    tensor = affordances.build_descriptor(example)
    assert tensor.acceptance()[field] == default
    tensor.set_acceptance(tensor.threshold(), **{field: good})
    saved = tensor.save(tmp_path / "d.npz")
    assert getattr(it.InteractionTensor.load(saved), field) == good
    tensor.set_acceptance(tensor.threshold(), **{field: "off"})
    assert getattr(tensor, field) is None
    for value in wrong:
        with pytest.raises(ValueError, match=field):
            tensor.set_acceptance(tensor.threshold(), **{field: value})
    for i, value in enumerate(wrong_in_file):
        descriptor_with_header(saved, tmp_path / f"bad{i}.npz", **{field: value})
        with pytest.raises(InputError, match=field):
            it.InteractionTensor.load(tmp_path / f"bad{i}.npz")
    old = descriptor_with_header(saved, tmp_path / "old.npz", drop=field)
    assert getattr(it.InteractionTensor.load(old), field) is None
    other = "placing-bowl" if field == "feet_reach" else "sitting-human"   # no such test
    assert getattr(affordances.build_descriptor(other), field) is None
