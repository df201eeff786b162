"""phks.load on formats read through assimp (glTF here, written by the
test): the vertices are the meshes' in scene order, as in an OFF of the
same arrays. Without assimp in the build, the refusal is checked."""
import base64
import gzip
import json
import struct

import numpy as np
import pytest

import phks
from phks import _phks
from shapes import icosphere, write_off

has_assimp = _phks._has_assimp()


def write_gltf(path, parts):
    """parts: (name, vertices, faces, translation) per mesh and node; one
    buffer, embedded as base64: float32 positions, uint32 indices."""
    data = b""
    views, accessors, meshes, nodes = [], [], [], []
    for i, (name, v, f, move) in enumerate(parts):
        pos = np.asarray(v, dtype="<f4").tobytes()
        idx = np.asarray(f, dtype="<u4").tobytes()
        for chunk, count, kind, ctype in ((pos, len(v), "VEC3", 5126),
                                          (idx, 3 * len(f), "SCALAR", 5125)):
            views.append({"buffer": 0, "byteOffset": len(data),
                          "byteLength": len(chunk)})
            acc = {"bufferView": len(views) - 1, "componentType": ctype,
                   "count": count, "type": kind}
            if kind == "VEC3":
                acc["min"] = np.min(v, axis=0).astype("f4").tolist()
                acc["max"] = np.max(v, axis=0).astype("f4").tolist()
            accessors.append(acc)
            data += chunk
        meshes.append({"name": name + "_mesh", "primitives": [{
            "attributes": {"POSITION": 2 * i}, "indices": 2 * i + 1}]})
        node = {"name": name, "mesh": i}
        if move is not None:
            node["translation"] = list(move)
        nodes.append(node)
    doc = {"asset": {"version": "2.0"}, "scene": 0,
           "buffers": [{"byteLength": len(data),
                        "uri": "data:application/octet-stream;base64," +
                        base64.b64encode(data).decode()}],
           "bufferViews": views, "accessors": accessors, "meshes": meshes,
           "nodes": nodes, "scenes": [{"nodes": list(range(len(nodes)))}]}
    path.write_text(json.dumps(doc))


@pytest.fixture
def sphere():
    v, f = icosphere(2)
    # float32 coordinates, as glTF stores them, for an exact comparison.
    return v.astype(np.float32).astype(np.float64), f


@pytest.mark.skipif(not has_assimp, reason="built without assimp")
def test_gltf_gives_the_off_vertices(tmp_path, sphere):
    v, f = sphere
    write_off(tmp_path / "s.off", v, f)
    write_gltf(tmp_path / "s.gltf", [("sphere", v, f, None)])
    a, b = phks.load(tmp_path / "s.off"), phks.load(tmp_path / "s.gltf")
    np.testing.assert_array_equal(b.vertices, a.vertices)
    np.testing.assert_array_equal(b.triangles, a.triangles)
    np.testing.assert_array_equal(b.vertex_origin, a.vertex_origin)
    assert phks.score(phks.signature(a), phks.signature(b)) == 0


@pytest.mark.skipif(not has_assimp, reason="built without assimp")
def test_a_gzipped_gltf_reads_as_the_gltf(tmp_path, sphere):
    write_gltf(tmp_path / "s.gltf", [("sphere", *sphere, None)])
    packed = tmp_path / "s.gltf.gz"
    packed.write_bytes(gzip.compress((tmp_path / "s.gltf").read_bytes()))
    a, b = phks.load(tmp_path / "s.gltf"), phks.load(packed)
    np.testing.assert_array_equal(b.vertices, a.vertices)
    np.testing.assert_array_equal(b.triangles, a.triangles)
    cut = tmp_path / "cut.gltf.gz"
    cut.write_bytes(packed.read_bytes()[:100])
    with pytest.raises(phks.Error) as e:
        phks.load(cut)
    assert e.value.status == phks.Status.TRUNCATED
    assert "cut.gltf.gz: gzip data: truncated" in e.value.message


@pytest.mark.skipif(not has_assimp, reason="built without assimp")
def test_gltf_meshes_are_merged_with_their_transforms(tmp_path, sphere):
    v, f = sphere
    write_gltf(tmp_path / "two.gltf", [("a", v, f, None),
                                       ("b", v, f, (5.0, 0.0, 0.0))])
    mesh = phks.load(str(tmp_path / "two.gltf"))
    n = len(v)
    assert mesh.vertex_count == 2 * n
    np.testing.assert_array_equal(mesh.vertices[:n], v)
    np.testing.assert_allclose(mesh.vertices[n:], v + [5.0, 0.0, 0.0],
                               atol=1e-6)


@pytest.mark.skipif(not has_assimp, reason="built without assimp")
def test_a_broken_gltf_raises(tmp_path):
    path = tmp_path / "broken.gltf"
    path.write_text('{"asset":')
    with pytest.raises(phks.Error) as e:
        phks.load(path)
    assert "broken.gltf" in e.value.message and "assimp" in e.value.message
    with pytest.raises(phks.Error) as e:
        phks.load(tmp_path / "nowhere.glb")
    assert e.value.status == phks.Status.IO


@pytest.mark.skipif(has_assimp, reason="built with assimp")
def test_without_assimp_gltf_is_refused(tmp_path, sphere):
    write_gltf(tmp_path / "s.gltf", [("sphere", *sphere, None)])
    with pytest.raises(phks.Error) as e:
        phks.load(tmp_path / "s.gltf")
    assert "built without assimp: cannot read .gltf" in e.value.message
