"""Meshes from arrays and files: numbering, dtypes, and the errors."""
import gzip

import numpy as np
import pytest

import phks
from shapes import grid, icosphere, with_unused, write_obj, write_off


def test_unused_vertices_are_dropped_and_mapped_back():
    v, f = icosphere(1)
    v2, f2, where = with_unused(v, f)
    mesh = phks.Mesh(v2, f2)
    assert mesh.vertex_count == len(v)
    assert mesh.triangle_count == len(f)
    # Kept in their original order, and mapped back to the caller's rows.
    np.testing.assert_array_equal(mesh.vertex_origin, where)
    np.testing.assert_array_equal(mesh.vertices, v2[where])
    np.testing.assert_array_equal(mesh.vertex_origin[mesh.triangles], f2)
    assert mesh.vertex_origin.dtype == np.uint32
    assert mesh.component_count == 1
    assert len(mesh.boundary_edges) == 0
    assert mesh.area == pytest.approx(4 * np.pi, rel=0.1)


def test_views_are_read_only_and_keep_the_mesh_alive():
    v, f = icosphere(1)
    verts = phks.Mesh(v, f).vertices  # the mesh itself is dropped
    with pytest.raises(ValueError):
        verts[0, 0] = 1
    np.testing.assert_array_equal(verts, v)


def test_file_numbering_is_the_files(tmp_path):
    v, f = icosphere(1)
    v2, f2, where = with_unused(v, f, every=3)
    path = tmp_path / "holes.obj"
    write_obj(path, v2, f2)
    mesh = phks.load(str(path))
    np.testing.assert_array_equal(mesh.vertex_origin, where)
    np.testing.assert_array_equal(mesh.vertices, v2[where])


def test_load_accepts_path_objects_gzip_and_memory(tmp_path):
    v, f = icosphere(1)
    path = tmp_path / "s.off"
    write_off(path, v, f)
    gz = tmp_path / "s.off.gz"
    gz.write_bytes(gzip.compress(path.read_bytes()))
    for mesh in (phks.load(path), phks.load(gz),
                 phks.load_memory(path.read_bytes()),
                 phks.load_memory(bytearray(path.read_bytes()), format="off"),
                 phks.load_memory(path.read_bytes(), format=1)):
        np.testing.assert_array_equal(mesh.vertices, v)
        np.testing.assert_array_equal(mesh.triangles, f)


@pytest.mark.parametrize("dtype", [np.int8, np.uint8, np.int16, np.uint16,
                                   np.int32, np.uint32, np.int64, np.uint64,
                                   np.intc, np.uintp])
def test_any_integer_dtype_for_faces(dtype):
    v, f = icosphere(0)
    mesh = phks.Mesh(v, f.astype(dtype))
    np.testing.assert_array_equal(mesh.triangles, f)


def test_vertices_convert_from_float32_ints_and_lists():
    v, f = icosphere(0)
    a = phks.Mesh(v.astype(np.float32), f)
    np.testing.assert_array_equal(a.vertices, v.astype(np.float32))
    b = phks.Mesh((v * 10).round().astype(np.int64).tolist(), f.tolist())
    np.testing.assert_array_equal(b.vertices, (v * 10).round())
    # Strided (non-contiguous) inputs are copied, not misread.
    wide = np.zeros((len(v), 6))
    wide[:, ::2] = v
    np.testing.assert_array_equal(phks.Mesh(wide[:, ::2], f).vertices, v)


def status_of(excinfo):
    return excinfo.value.status


def test_errors_carry_the_status_and_the_librarys_message(tmp_path):
    v, f = icosphere(0)
    bad = v.copy()
    bad[3, 1] = np.nan
    with pytest.raises(phks.Error) as e:
        phks.Mesh(bad, f)
    assert e.value.status == phks.Status.NON_FINITE
    assert e.value.status.name == "NON_FINITE"
    assert "not finite" in e.value.message
    assert isinstance(e.value, RuntimeError)

    out = f.copy()
    out[5, 2] = len(v)  # the library's own check
    with pytest.raises(phks.Error) as e:
        phks.Mesh(v, out)
    assert e.value.status == phks.Status.INDEX_OUT_OF_RANGE
    assert str(len(v)) in e.value.message

    for wrong in (-1, 2 ** 32, 2 ** 40):  # what uint32 cannot hold
        out = f.copy()
        out[2, 0] = wrong
        with pytest.raises(phks.Error) as e:
            phks.Mesh(v, out)
        assert e.value.status == phks.Status.INDEX_OUT_OF_RANGE
        assert "faces[2, 0]" in e.value.message
    with pytest.raises(phks.Error) as e:
        phks.Mesh(v, np.array([[0, 1, 2**64 - 1]], dtype=np.uint64))
    assert e.value.status == phks.Status.INDEX_OUT_OF_RANGE

    with pytest.raises(phks.Error) as e:
        phks.Mesh(v, np.zeros((0, 3), dtype=np.int32))
    assert e.value.status == phks.Status.NO_TRIANGLES

    with pytest.raises(phks.Error) as e:
        phks.Mesh(np.zeros((3, 3)), [[0, 1, 2]])
    assert e.value.status == phks.Status.ZERO_AREA

    missing = tmp_path / "nowhere.off"
    with pytest.raises(phks.Error) as e:
        phks.load(missing)
    assert e.value.status == phks.Status.IO
    assert int(e.value.status) == 3
    assert str(missing) in e.value.message
    assert str(e.value).startswith(phks.status_string(3))

    garbage = tmp_path / "garbage.off"
    garbage.write_text("OFF\n3 1 0\n0 0 0\n1 0 zero\n0 1 0\n3 0 1 2\n")
    with pytest.raises(phks.Error) as e:
        phks.load(garbage)
    assert e.value.status == phks.Status.PARSE
    assert "garbage.off" in e.value.message and "line 4" in e.value.message


def test_argument_errors_are_python_errors():
    v, f = icosphere(0)
    with pytest.raises(TypeError):
        phks.Mesh(v, f.astype(float))
    with pytest.raises(ValueError):
        phks.Mesh(v[:, :2], f)
    with pytest.raises(ValueError):
        phks.Mesh(v, f[:, :2])
    with pytest.raises(TypeError):
        phks.Mesh(v.astype(complex), f)
    with pytest.raises(ValueError):
        phks.load_memory(b"OFF", format="vrml")


def test_argument_errors_name_the_argument_and_its_shape():
    v, f = icosphere(0)
    with pytest.raises(TypeError, match=r"^Mesh: vertices must be an "
                       r"\(n, 3\) array of numbers, got None$"):
        phks.Mesh(None, None)
    with pytest.raises(ValueError, match=r"^Mesh: vertices must be an "
                       r"\(n, 3\) array of numbers, got shape \(36,\)$"):
        phks.Mesh(v.ravel(), f)
    with pytest.raises(TypeError, match=r"^Mesh: faces must be an \(m, 3\) "
                       r"array of integers, got None$"):
        phks.Mesh(v, None)
    with pytest.raises(ValueError, match=r"^Mesh: faces must be an \(m, 3\) "
                       r"array of integers, got shape \(60,\)$"):
        phks.Mesh(v, f.ravel())
    with pytest.raises(TypeError, match=r"^Mesh: faces must be an \(m, 3\) "
                       r"array of integers, got an array of float64$"):
        phks.Mesh(v, f.astype(float))
    with pytest.raises(TypeError, match=r"^Mesh: vertices must be an "
                       r"\(n, 3\) array of numbers, got an array of "
                       r"complex128$"):
        phks.Mesh(v.astype(complex), f)
    with pytest.raises(ValueError, match=r"^Mesh: vertices must be an "
                       r"\(n, 3\) array of numbers, got a list numpy "
                       r"cannot make an array of"):
        phks.Mesh([[0, 0, 0], [1, 0]], f)


def test_geodesic_distances_on_a_grid_follow_its_edges():
    # Cells of side h with one diagonal each, along +x+y: the shortest edge
    # path from the corner to column i, row j takes min(i, j) diagonals
    # and |i - j| straight steps.
    n = 9
    h = 1 / (n - 1)
    mesh = phks.Mesh(*grid(n))
    d = phks.geodesic_distances(mesh, 0)
    assert d.shape == (n * n,) and d.dtype == np.float64
    i, j = np.meshgrid(np.arange(n), np.arange(n))
    path = h * (np.sqrt(2) * np.minimum(i, j) + np.abs(i - j))
    np.testing.assert_allclose(d, path.ravel(), rtol=1e-12, atol=1e-15)
    euclid = np.linalg.norm(mesh.vertices - mesh.vertices[0], axis=1)
    assert (d >= euclid - 1e-12).all()
    # Along the edge row and the diagonal, the path is the straight line.
    np.testing.assert_allclose(d[:n], euclid[:n], rtol=1e-12)
    diagonal = np.arange(n) * (n + 1)
    np.testing.assert_allclose(d[diagonal], euclid[diagonal], rtol=1e-12)
    # A distance is one whichever end is the source.
    far = n * n - 1
    assert phks.geodesic_distances(mesh, far)[0] == pytest.approx(d[far])


def test_geodesic_distances_of_pieces_out_of_reach_are_infinite():
    v, f = grid(5)
    far = v + [0, 0, 10]
    mesh = phks.Mesh(np.vstack([v, far]), np.vstack([f, f + len(v)]))
    d = phks.geodesic_distances(mesh, 0, box="axis_aligned")
    assert np.isfinite(d[:len(v)]).all()
    assert np.isinf(d[len(v):]).all()


def test_geodesic_distances_errors():
    mesh = phks.Mesh(*grid(3))
    with pytest.raises(phks.Error) as e:
        phks.geodesic_distances(mesh, 9)
    assert e.value.status == phks.Status.INVALID_ARGUMENT
    with pytest.raises(ValueError):
        phks.geodesic_distances(mesh, -1)
    with pytest.raises(TypeError):
        phks.geodesic_distances(mesh, 0, colour="red")
    with pytest.raises(TypeError):
        phks.geodesic_distances(mesh, 0, progress=print)


def test_load_memory_limits():
    """max_bytes and max_vertices refuse a mesh above them with TOO_LARGE
    and the limit in the message; at the limits it loads."""
    text = ("OFF\n4 2 0\n0 0 0\n1 0 0\n0 1 0\n1 1 0\n"
            "3 0 1 2\n3 1 3 2\n").encode()
    mesh = phks.load_memory(text, max_bytes=len(text), max_vertices=4)
    assert mesh.vertex_count == 4
    with pytest.raises(phks.Error) as e:
        phks.load_memory(text, max_vertices=3)
    assert e.value.status == phks.Status.TOO_LARGE
    assert "the mesh has 4 vertices, more than the limit of 3" in str(e.value)
    with pytest.raises(phks.Error) as e:
        phks.load_memory(gzip.compress(text), max_bytes=len(text) - 1)
    assert e.value.status == phks.Status.TOO_LARGE
    assert "inflates to more than %d bytes" % (len(text) - 1) in str(e.value)
    with pytest.raises(ValueError):
        phks.load_memory(text, max_vertices=-1)
