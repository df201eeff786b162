"""Another library's arrays straight into a signature: meshio (Debian
python3-meshio) reads a file this test writes; never skipped."""
import meshio
import numpy as np

import phks
from conftest import assert_same_signature
from shapes import creature, write_obj


def test_meshio_arrays_give_the_files_signature(tmp_path):
    v, f = creature(3, seed=4)
    path = tmp_path / "creature.obj"
    write_obj(path, v, f)
    m = meshio.read(path)
    points, triangles = m.points, m.cells_dict["triangle"]
    np.testing.assert_array_equal(points, v)  # %.17g round-trips
    from_meshio = phks.signature(phks.Mesh(points, triangles))
    from_file = phks.signature(phks.load(path))
    assert_same_signature(from_meshio, from_file)
    np.testing.assert_array_equal(from_meshio.vertices, from_file.vertices)
    np.testing.assert_array_equal(points[from_meshio.vertices],
                                  from_meshio.positions)


def test_meshio_written_ply_loads_alike(tmp_path):
    v, f = creature(2, seed=6)
    path = tmp_path / "creature.ply"
    meshio.write_points_cells(path, v, [("triangle", f.astype(np.int32))],
                              binary=True)
    mesh = phks.load(path)
    np.testing.assert_array_equal(mesh.vertices, v)
    np.testing.assert_array_equal(mesh.triangles, f)

