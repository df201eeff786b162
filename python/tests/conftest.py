"""Shared fixtures. The tests import phks from PYTHONPATH: the build's
python/ folder (the extension) and the source's python/ folder (the
package), as meson test sets it (python/meson.build)."""
import os

import numpy as np
import pytest

import phks
from shapes import creature


@pytest.fixture(scope="session")
def creature_arrays():
    return creature(3, seed=0)


@pytest.fixture(scope="session")
def creature_mesh(creature_arrays):
    return phks.Mesh(*creature_arrays)


@pytest.fixture(scope="session")
def creature_signature(creature_mesh):
    return phks.signature(creature_mesh)


@pytest.fixture(scope="session")
def other_signature():
    return phks.signature(phks.Mesh(*creature(3, seed=1)))


@pytest.fixture(scope="session")
def creature_nearest(creature_mesh):
    """The paper's matching: the symmetric nearest-L1 score."""
    return phks.signature(creature_mesh, matching="nearest")


@pytest.fixture(scope="session")
def other_nearest():
    return phks.signature(phks.Mesh(*creature(3, seed=1)), matching="nearest")


@pytest.fixture
def shared_meshes():
    """The shared real meshes (PHKS_SHARED_MESHES), or skip."""
    folder = os.environ.get("PHKS_SHARED_MESHES", "")
    if not folder or not os.path.isdir(folder):
        pytest.skip("shared meshes not found (PHKS_SHARED_MESHES)")
    return folder


def assert_same_signature(a, b):
    assert a.encode() == b.encode()
    np.testing.assert_array_equal(a.vectors, b.vectors)
    np.testing.assert_array_equal(a.persistence, b.persistence)
