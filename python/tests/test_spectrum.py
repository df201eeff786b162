"""The spectrum against a dense numpy solve of the generalized problem built
from phks.h's formulas, and persistent maxima against a function whose
maxima are known."""
import numpy as np
import pytest

import phks
from shapes import grid, icosphere

TAU, CUTOFF = 0.01, 3.5


def reference_operator(v, f):
    """phks.h, Spectrum: the axis-aligned unit box, A_p a third of the area
    around p, W = exp(-|w-p|^2 / 4h) within cutoff sqrt(4h),
    K_wp = A_w A_p W (w != p), S = (diag(K 1) - K) / (4 pi h^2), and the
    literal M = diag(A)."""
    p = v / (v.max(axis=0) - v.min(axis=0)).max()
    e1, e2 = p[f[:, 1]] - p[f[:, 0]], p[f[:, 2]] - p[f[:, 0]]
    tri_area = 0.5 * np.linalg.norm(np.cross(e1, e2), axis=1)
    area = np.zeros(len(p))
    for corner in range(3):
        np.add.at(area, f[:, corner], tri_area / 3)
    d2 = ((p[:, None, :] - p[None, :, :]) ** 2).sum(axis=2)
    w = np.exp(-d2 / (4 * TAU))
    w[d2 >= CUTOFF ** 2 * 4 * TAU] = 0
    np.fill_diagonal(w, 0)
    k = area[:, None] * area[None, :] * w
    s = (np.diag(k.sum(axis=1)) - k) / (4 * np.pi * TAU ** 2)
    return s, area


@pytest.fixture(scope="module")
def small():
    v, f = icosphere(1)
    v = v * np.array([1.3, 1.0, 0.8])  # no exact eigenvalue clusters
    mesh = phks.Mesh(v, f)
    # The reference is the vertices' operator (the paper's quadrature).
    spec = phks.spectrum(mesh, tau=TAU, cutoff=CUTOFF, box="axis_aligned",
                         operator_kind="literal", solver="dense",
                         quadrature="vertices", eigen_count=len(v))
    s, area = reference_operator(v, f)
    return mesh, spec, s, area


def test_eigenvalues_match_a_dense_generalized_solve(small):
    mesh, spec, s, area = small
    n = mesh.vertex_count
    assert len(spec) == n and spec.vertex_count == n and spec.sample_count == n
    assert spec.sample_vertices is None
    np.testing.assert_allclose(spec.mass, area, rtol=1e-12)
    # S phi = lambda M phi as the symmetric M^-1/2 S M^-1/2 (LAPACK's
    # dsyevd through numpy).
    r = 1 / np.sqrt(area)
    expect = np.linalg.eigvalsh(r[:, None] * s * r[None, :])
    got = spec.eigenvalues
    assert np.all(np.diff(got) >= 0)
    np.testing.assert_allclose(got, expect, rtol=1e-9,
                               atol=1e-9 * expect.max())


def test_eigenvectors_solve_the_problem_and_are_m_orthonormal(small):
    mesh, spec, s, area = small
    phi, lam = spec.eigenvectors, spec.eigenvalues
    assert phi.shape == (mesh.vertex_count, len(spec))
    scale = lam.max() * area.max()
    resid = s @ phi - area[:, None] * phi * lam[None, :]
    assert np.abs(resid).max() < 1e-9 * scale
    np.testing.assert_allclose(phi.T @ (area[:, None] * phi),
                               np.eye(len(spec)), atol=1e-9)
    # The sign convention: the entry of largest magnitude is positive.
    big = phi[np.abs(phi).argmax(axis=0), np.arange(phi.shape[1])]
    assert np.all(big > 0)


def test_hks_is_the_heat_kernel_diagonal(small):
    mesh, spec, s, area = small
    r = 1 / np.sqrt(area)
    lam, u = np.linalg.eigh(r[:, None] * s * r[None, :])
    for t in (0.0, 5 * TAU, 100 * TAU):
        # diag(M^-1/2 exp(-t B) M^-1/2): independent of how degenerate
        # eigenvectors are chosen.
        expect = (u ** 2 * np.exp(-t * lam)[None, :]).sum(axis=1) / area
        np.testing.assert_allclose(spec.hks(t), expect, rtol=1e-8)
    with pytest.raises(phks.Error) as e:
        spec.hks(-1)
    assert e.value.status == phks.Status.INVALID_ARGUMENT


def test_signature_from_a_spectrum_equals_the_direct_one():
    v, f = icosphere(3)
    mesh = phks.Mesh(v * np.array([1.5, 1.0, 0.6]), f)
    spec = phks.spectrum(mesh, eigen_count=100)
    assert spec.mesh is mesh and spec.options["eigen_count"] == 100
    assert len(spec) == 100
    a = spec.signature()
    b = phks.signature(mesh, eigen_count=100)
    assert a.encode() == b.encode()
    np.testing.assert_array_equal(a.vertices, b.vertices)


def test_persistent_maxima_and_segmentation():
    v, f = grid(31)
    c1, c2 = np.array([0.3, 0.3, 0]), np.array([0.72, 0.7, 0])
    fv = (np.exp(-((v - c1) ** 2).sum(1) / 0.02)
          + 0.6 * np.exp(-((v - c2) ** 2).sum(1) / 0.02))
    mesh = phks.Mesh(v, f)
    # The vertex maxima, found by brute force over the edges.
    neighbours = [set() for _ in v]
    for t in f:
        for a in t:
            neighbours[a].update(t)
    peaks = [i for i in range(len(v))
             if all(fv[i] > fv[j] for j in neighbours[i] if j != i)]
    peaks.sort(key=lambda i: -fv[i])
    assert len(peaks) == 2

    m = phks.persistent_maxima(mesh, fv, max_count=10, threshold=1e-9)
    np.testing.assert_array_equal(m.vertices, peaks)
    np.testing.assert_array_equal(m.values, fv[peaks])
    assert np.isinf(m.persistence[0])
    # The lower peak dies where it meets the higher one: its height above
    # the saddle, which lies between the two peaks' values and above 0.
    assert 0 < m.persistence[1] < fv[peaks[1]]
    assert m.labels.shape == (mesh.triangle_count,)
    assert set(np.unique(m.labels)) == {0, 1}
    # Each peak's triangles are in its own region.
    for region, peak in enumerate(peaks):
        touching = np.any(f == peak, axis=1)
        assert np.all(m.labels[touching] == region)
        assert peak in f[m.triangles[region]]

    one = phks.persistent_maxima(mesh, fv, max_count=1)
    np.testing.assert_array_equal(one.vertices, peaks[:1])
    assert np.all(one.labels == 0)

    with pytest.raises(ValueError):
        phks.persistent_maxima(mesh, fv[:-1])
    with pytest.raises(ValueError):
        phks.persistent_maxima(mesh, fv, max_count=0)
    bad = fv.copy()
    bad[7] = np.inf
    with pytest.raises(phks.Error) as e:
        phks.persistent_maxima(mesh, bad)
    assert e.value.status == phks.Status.NON_FINITE
    with pytest.raises(phks.Error) as e:
        phks.persistent_maxima(mesh, fv, threshold=-1)
    assert e.value.status == phks.Status.INVALID_ARGUMENT


def test_a_simplified_spectrum_has_one_entry_per_sample():
    from shapes import creature
    mesh = phks.Mesh(*creature(4, seed=7))
    spec = phks.spectrum(mesh, simplify_above=1000, simplify_target=400,
                         eigen_count=60)
    n, samples = mesh.vertex_count, spec.sample_count
    assert spec.vertex_count == n and samples < n
    assert abs(samples - 400) < 100
    s = spec.sample_vertices
    assert s.shape == (samples,) and np.all(np.diff(s.astype(np.int64)) > 0)
    phi = spec.eigenvectors
    assert phi.shape == (samples, 60) and spec.mass.shape == (samples,)
    np.testing.assert_allclose(phi.T @ (spec.mass[:, None] * phi),
                               np.eye(60), atol=1e-8)
    hks = spec.hks(0.01)
    assert hks.shape == (n,) and np.all(hks > 0)
    # At the samples the extension gives back the samples' own HKS, up to
    # the kernel average of the gains (1%, as tests/test_simplify.c allows;
    # measured 0.2% here).
    own = (phi ** 2 * np.exp(-0.01 * spec.eigenvalues)[None, :]).sum(axis=1)
    np.testing.assert_allclose(hks[s], own, rtol=1e-2)
