"""Signatures: caller numbering, arrays vs files, options, codec, scores."""
import gzip
import threading

import numpy as np
import pytest

import phks
from conftest import assert_same_signature
from shapes import creature, with_unused, write_off


def test_signature_arrays(creature_signature, creature_arrays):
    sig = creature_signature
    v, _ = creature_arrays
    k = len(sig)
    assert 2 <= k <= 15
    assert sig.vertices.shape == (k,) and sig.vertices.dtype == np.uint32
    assert sig.positions.shape == (k, 3)
    assert sig.vectors.shape == (k, 15) and sig.vector_length == 15
    # Features come most persistent first; the first is never merged.
    p = sig.persistence
    assert np.isinf(p[0]) and np.all(np.diff(p[1:]) <= 0)
    # Positions are the input coordinates of the feature vertices.
    np.testing.assert_array_equal(sig.positions, v[sig.vertices])


def test_vertices_are_in_the_callers_numbering(tmp_path, creature_arrays,
                                               creature_signature):
    v, f = creature_arrays
    v2, f2, where = with_unused(v, f)
    from_arrays = phks.signature(phks.Mesh(v2, f2))
    path = tmp_path / "creature.off"
    write_off(path, v2, f2)
    from_file = phks.signature(phks.load(path))
    # The same features as on the mesh without unused vertices, numbered
    # as the caller's arrays and the file number them.
    assert_same_signature(from_arrays, creature_signature)
    assert_same_signature(from_file, creature_signature)
    np.testing.assert_array_equal(from_arrays.vertices,
                                  where[creature_signature.vertices])
    np.testing.assert_array_equal(from_file.vertices, from_arrays.vertices)
    np.testing.assert_array_equal(v2[from_file.vertices],
                                  from_file.positions)
    # mesh_vertices is the cleaned mesh's numbering.
    np.testing.assert_array_equal(from_file.mesh_vertices,
                                  creature_signature.vertices)


def test_options_are_keywords_with_the_c_defaults(creature_mesh,
                                                  creature_signature):
    d = phks.default_options()
    assert d["eigen_count"] == 300 and d["tau"] == 0.0002
    assert d["cutoff"] == 3.5 and d["feature_count"] == 15
    assert d["scales"] == (5, 20, 40, 60, 100, 150, 200, 300, 400, 500, 600,
                           700, 800, 900, 1000)
    assert d["operator_kind"] == "random_walk" and d["box"] == "principal"
    assert d["hks_scaling"] == "local_area" and d["solver"] == "auto"
    assert d["boundary_margin"] == 2 and d["tolerance"] == 1e-10
    assert d["quadrature"] == "triangles"
    assert d["simplify_above"] == 25000 and d["simplify_target"] == 10000
    # Every default spelled out gives the default signature.
    assert_same_signature(phks.signature(creature_mesh, **d),
                          creature_signature)
    assert creature_signature.options == d
    # Enums as strings or ints.
    a = phks.signature(creature_mesh, operator_kind="literal",
                       hks_scaling="none", feature_count=5,
                       scales=[5, 50, 500])
    b = phks.signature(creature_mesh, operator_kind=0, hks_scaling=0,
                       feature_count=5, scales=(5.0, 50.0, 500.0),
                       scale_count=3)
    assert_same_signature(a, b)
    assert len(a) <= 5 and a.vector_length == 3
    assert a.options["operator_kind"] == "literal"
    assert a.options["scales"] == (5, 50, 500)
    q = phks.signature(creature_mesh, quadrature="vertices", feature_count=5)
    assert q.options["quadrature"] == "vertices"
    assert phks.signature(creature_mesh, quadrature=0,
                          feature_count=5).options == q.options


def test_bad_options(creature_mesh):
    with pytest.raises(TypeError):
        phks.signature(creature_mesh, colour="red")
    with pytest.raises(ValueError):
        phks.signature(creature_mesh, box="round")
    with pytest.raises(ValueError):
        phks.signature(creature_mesh, eigen_count=-1)
    with pytest.raises(TypeError):
        phks.signature(creature_mesh, eigen_count=2.5)
    with pytest.raises(ValueError):
        phks.signature(creature_mesh, scales=[1] * 33)
    with pytest.raises(ValueError):
        phks.signature(creature_mesh, scales=[1, 2], scale_count=3)
    # Values only the library checks: phks.Error naming the field.
    for bad in ({"tau": -1.0}, {"tau": float("nan")}, {"cutoff": 0.5},
                {"solver": 9}, {"scales": [5, float("inf")]}):
        with pytest.raises(phks.Error) as e:
            phks.signature(creature_mesh, **bad)
        assert e.value.status == phks.Status.INVALID_ARGUMENT
        assert list(bad)[0] in e.value.message


def test_encode_decode(creature_mesh, creature_signature):
    sig = creature_signature
    blob = sig.encode()
    assert isinstance(blob, bytes)
    back = phks.Signature.decode(blob)
    assert_same_signature(back, sig)
    np.testing.assert_array_equal(back.positions, sig.positions)
    assert back.vertices is None  # no mesh: only the cleaned numbering
    np.testing.assert_array_equal(back.mesh_vertices, sig.mesh_vertices)
    with_mesh = phks.decode(memoryview(blob), mesh=creature_mesh)
    np.testing.assert_array_equal(with_mesh.vertices, sig.vertices)
    assert back.options == sig.options
    assert phks.score(back, sig) == 0

    damaged = bytearray(blob)
    damaged[len(blob) // 2] ^= 0x10
    with pytest.raises(phks.Error) as e:
        phks.decode(bytes(damaged))
    assert e.value.status == phks.Status.CORRUPT
    with pytest.raises(phks.Error) as e:
        phks.decode(blob[:-7])
    assert e.value.status in (phks.Status.TRUNCATED, phks.Status.CORRUPT)
    with pytest.raises(TypeError):
        phks.decode("not bytes")
    # Too short for any format's header: cut short, not "newer".
    with pytest.raises(phks.Error) as e:
        phks.decode(b"PHKSxxxxxxxx")
    assert e.value.status == phks.Status.TRUNCATED
    assert "12 bytes" in e.value.message and "newer" not in e.value.message


def test_pickle_keeps_the_callers_numbering(creature_mesh,
                                            creature_signature):
    import pickle
    sig = creature_signature
    back = pickle.loads(pickle.dumps(sig))
    assert_same_signature(back, sig)
    np.testing.assert_array_equal(back.vertices, sig.vertices)
    decoded = pickle.loads(pickle.dumps(phks.decode(sig.encode())))
    assert decoded.vertices is None
    assert_same_signature(decoded, sig)


def l1_nearest(a, b):
    """Independent brute force: nearest b (L1) for each row of a."""
    d = np.abs(a[:, None, :] - b[None, :, :]).sum(axis=2)
    return d.argmin(axis=1), d.min(axis=1)


def test_nearest_score_and_match(creature_nearest, other_nearest):
    a, b = creature_nearest, other_nearest
    assert phks.score(a, a) == 0
    s = phks.score(a, b)
    # Symmetric up to the order of the sum (the last bit).
    assert s > 0 and s == pytest.approx(phks.score(b, a), rel=1e-14)
    ia, da = l1_nearest(a.vectors, b.vectors)
    ib, db = l1_nearest(b.vectors, a.vectors)
    assert s == pytest.approx(da.sum() + db.sum(), rel=1e-12)

    m = phks.match(a, b)
    assert m.score == s
    na, nb = len(a), len(b)
    assert len(m.feature_a) == na + nb
    np.testing.assert_array_equal(m.from_a, [True] * na + [False] * nb)
    np.testing.assert_array_equal(m.feature_a[:na], np.arange(na))
    np.testing.assert_array_equal(m.feature_b[:na], ia)
    np.testing.assert_array_equal(m.feature_b[na:], np.arange(nb))
    np.testing.assert_array_equal(m.feature_a[na:], ib)
    np.testing.assert_allclose(m.distance, np.concatenate([da, db]),
                               rtol=1e-12)
    assert not m.verified.any()
    score, fa, fb, dist, from_a, verified = m  # a named tuple
    assert score == s
    # Nothing is verified; the similarity is the NEAREST formula.
    terms = (na + nb) * a.vectors.shape[1]
    assert m.verified_count == 0
    assert m.similarity == pytest.approx(np.exp(-s / (terms * 0.15)),
                                         rel=1e-14)
    assert phks.similarity(a, a) == (1.0, 0)


def test_score_nearest_is_the_papers_formula(creature_signature,
                                             other_signature):
    a, b = creature_signature, other_signature
    s = phks.score_nearest(a, b)
    expect = (l1_nearest(a.vectors, b.vectors)[1].sum()
              + l1_nearest(b.vectors, a.vectors)[1].sum())
    assert s == pytest.approx(expect, rel=1e-12)
    assert phks.score_nearest(b, a) == pytest.approx(s, rel=1e-14)
    assert phks.score_nearest(a, a) == 0


def test_nearest_matching_scores_as_score_nearest(creature_nearest,
                                                  other_nearest,
                                                  creature_signature):
    a, b = creature_nearest, other_nearest
    assert phks.score(a, b) == phks.score_nearest(a, b)
    assert phks.score(b, a) == phks.score_nearest(b, a)
    # The matching changes the scoring, not the feature vectors.
    np.testing.assert_array_equal(a.vectors, creature_signature.vectors)


def test_matching_option_round_trips(creature_mesh, creature_nearest,
                                     creature_signature):
    assert phks.default_options()["matching"] == "verified"
    assert creature_signature.options["matching"] == "verified"
    assert creature_nearest.options["matching"] == "nearest"
    assert_same_signature(
        phks.signature(creature_mesh, **creature_nearest.options),
        creature_nearest)
    assert_same_signature(phks.signature(creature_mesh, matching=0),
                          creature_nearest)
    # NEAREST ignores the local descriptor: its blob leaves it out, and
    # the signature decodes with "heat" (docs/formats.md, format 5).
    back = phks.decode(creature_nearest.encode())
    assert back.options == dict(creature_nearest.options,
                                local_descriptor="heat")
    assert phks.score(back, creature_nearest) == 0
    with pytest.raises(ValueError):
        phks.signature(creature_mesh, matching="closest")
    with pytest.raises(phks.Error) as e:
        phks.score(creature_nearest, creature_signature)
    assert e.value.status == phks.Status.INCOMPATIBLE


def test_local_descriptor_option(creature_mesh, creature_signature):
    assert phks.default_options()["local_descriptor"] == "spin"
    assert creature_signature.options["local_descriptor"] == "spin"
    spin = creature_signature
    heat = phks.signature(creature_mesh, local_descriptor="heat")
    assert heat.options["local_descriptor"] == "heat"
    assert phks.signature(creature_mesh, local_descriptor=0,
                          feature_count=3).options["local_descriptor"] == \
        "heat"
    # Spin images: the field, the unit box's scale and 100 bytes per point
    # (features and samples); the heat blob is format 4's.
    spin_blob, heat_blob = spin.encode(), heat.encode()
    assert heat_blob[4] == 4 and spin_blob[4] == 5
    assert (len(spin_blob) - len(heat_blob) - 12) % 100 == 0
    assert len(spin_blob) - len(heat_blob) - 12 >= 100 * len(heat)
    assert phks.decode(heat_blob).options == heat.options
    assert phks.decode(spin_blob).options == spin.options
    # Verified signatures of other local descriptors do not compare.
    with pytest.raises(phks.Error) as e:
        phks.score(heat, spin)
    assert e.value.status == phks.Status.INCOMPATIBLE
    assert "local_descriptor heat against spin" in e.value.message
    with pytest.raises(ValueError):
        phks.signature(creature_mesh, local_descriptor="hks")


def test_global_descriptor_option(creature_mesh, creature_signature,
                                  creature_nearest):
    assert phks.default_options()["global_descriptor"] == "none"
    assert creature_signature.options["global_descriptor"] == "none"
    d2 = phks.signature(creature_mesh, global_descriptor="d2")
    assert d2.options["global_descriptor"] == "d2"
    assert phks.signature(creature_mesh, global_descriptor=1,
                          feature_count=3).options["global_descriptor"] == \
        "d2"
    # Verified signatures of other global descriptors do not compare.
    with pytest.raises(phks.Error) as e:
        phks.score(creature_signature, d2)
    assert e.value.status == phks.Status.INCOMPATIBLE
    assert "global_descriptor none against d2" in e.value.message
    with pytest.raises(ValueError):
        phks.signature(creature_mesh, global_descriptor="D2")
    # A D2 blob keeps its distribution: it decodes to the same bytes and
    # scores as the signature it came from. Format 6 adds the field and
    # 32 bytes to format 5's spin images (docs/formats.md).
    blob = d2.encode()
    assert len(blob) == len(creature_signature.encode()) + 4 + 32
    back = phks.decode(blob)
    assert back.encode() == blob
    assert phks.score(back, d2) == phks.score(d2, d2)
    # NEAREST ignores it: the blob leaves it out (the bytes of NONE's) and
    # decodes with "none" (docs/formats.md, format 6).
    nearest = phks.signature(creature_mesh, matching="nearest",
                             global_descriptor="d2")
    assert nearest.encode() == creature_nearest.encode()
    assert phks.decode(nearest.encode()).options["global_descriptor"] == \
        "none"
    assert phks.score(nearest, creature_nearest) == 0


def test_verified_score_is_asymmetric(creature_signature, other_signature):
    a, b = creature_signature, other_signature
    assert phks.score(a, a) == pytest.approx(0, abs=1e-12)
    ab, ba = phks.score(a, b), phks.score(b, a)
    # The paper's score times 1 - the share of the query verified.
    assert 0 < ab <= phks.score_nearest(a, b)
    assert 0 < ba <= phks.score_nearest(b, a)
    # Query first: the share is the query's.
    assert ab != pytest.approx(ba, rel=1e-6)


def test_verified_match(creature_signature, other_signature):
    a, b = creature_signature, other_signature
    m = phks.match(a, b)
    na, nb = len(a), len(b)
    assert m.score == phks.score(a, b)
    np.testing.assert_array_equal(m.from_a, [True] * na + [False] * nb)
    np.testing.assert_array_equal(m.feature_a[:na], np.arange(na))
    np.testing.assert_array_equal(m.feature_b[na:], np.arange(nb))
    # Every row's distance is that of the pair it names; a verified
    # partner may be one of b's samples, numbered after its features.
    points_b = np.vstack([b.vectors, b.sample_vectors])
    assert len(b.sample_vectors) == 20
    np.testing.assert_allclose(
        m.distance, np.abs(a.vectors[m.feature_a] -
                           points_b[m.feature_b]).sum(axis=1), rtol=1e-12)
    ok = m.verified[:na]
    assert ok.any()
    # The verified pairs are one to one; a's other rows and all of b's
    # name the nearest feature.
    pairs = set(zip(m.feature_a[:na][ok], m.feature_b[:na][ok]))
    assert len({fb for _, fb in pairs}) == len(pairs)
    ia, _ = l1_nearest(a.vectors, b.vectors)
    ib, _ = l1_nearest(b.vectors, a.vectors)
    np.testing.assert_array_equal(m.feature_b[:na][~ok], ia[~ok])
    np.testing.assert_array_equal(m.feature_a[na:], ib)
    # b's row is verified exactly when its pair is one of a's.
    back = [(fa, fb) in pairs for fa, fb in
            zip(m.feature_a[na:], m.feature_b[na:])]
    np.testing.assert_array_equal(m.verified[na:], back)


def test_incompatible_signatures(creature_mesh, creature_signature):
    other = phks.signature(creature_mesh, operator_kind="literal")
    with pytest.raises(phks.Error) as e:
        phks.score(creature_signature, other)
    assert e.value.status == phks.Status.INCOMPATIBLE
    with pytest.raises(phks.Error) as e:
        phks.match(other, creature_signature)
    assert e.value.status == phks.Status.INCOMPATIBLE
    with pytest.raises(TypeError):
        phks.score(creature_signature, "x")


def test_mismatch_names_both_values(creature_mesh, creature_signature):
    # The option and both values as a Python user writes them, never the
    # enums' numbers ("hks_scaling 2 against 0").
    unscaled = phks.signature(creature_mesh, hks_scaling="none")
    for compare in (phks.score, phks.score_nearest, phks.match):
        with pytest.raises(phks.Error) as e:
            compare(creature_signature, unscaled)
        assert e.value.status == phks.Status.INCOMPATIBLE
        assert "hks_scaling local_area against none" in str(e.value)


def test_threads_compute_the_same_signature(creature_mesh,
                                            creature_signature):
    out = [None] * 3

    def run(i):
        out[i] = phks.signature(creature_mesh, threads=1)

    workers = [threading.Thread(target=run, args=(i,)) for i in range(3)]
    for w in workers:
        w.start()
    for w in workers:
        w.join()
    for sig in out:
        assert_same_signature(sig, creature_signature)


def test_the_gil_is_released_during_a_signature():
    mesh = phks.Mesh(*creature(4, seed=2))
    done = threading.Event()
    result = []

    def run():
        result.append(phks.signature(mesh, threads=1))
        done.set()

    worker = threading.Thread(target=run)
    gaps, last = [], None
    import time
    start = time.perf_counter()
    worker.start()
    while not done.is_set():
        now = time.perf_counter()
        if last is not None:
            gaps.append(now - last)
        last = now
        time.sleep(0.001)
    worker.join()
    elapsed = time.perf_counter() - start
    assert result and len(result[0]) > 0
    # This thread kept running while the other computed: no pause near the
    # length of the call.
    assert elapsed > 0.1
    assert max(gaps) < elapsed / 2


def test_a_shared_real_mesh(shared_meshes):
    """psb/1.off.gz (a human, 4.7k vertices): the file's own numbering,
    read here with gzip and numpy, agrees with the signature's."""
    path = shared_meshes + "/psb/1.off.gz"
    with gzip.open(path, "rt") as text:
        tokens = text.read().split()
    assert tokens[0] == "OFF"
    n, m = int(tokens[1]), int(tokens[2])
    v = np.array(tokens[4:4 + 3 * n], dtype=float).reshape(n, 3)
    f = np.array(tokens[4 + 3 * n:4 + 3 * n + 4 * m],
                 dtype=np.int64).reshape(m, 4)[:, 1:]
    from_file = phks.signature(phks.load(path))
    from_arrays = phks.signature(phks.Mesh(v, f))
    assert_same_signature(from_file, from_arrays)
    assert len(from_file) == 15
    np.testing.assert_array_equal(v[from_file.vertices], from_file.positions)
    assert phks.score(from_file, from_arrays) == 0


def test_similarity_reads_the_score(creature_signature, other_signature):
    a, b = creature_signature, other_signature
    assert phks.similarity(a, a) == (1.0, len(a))
    sim, verified = phks.similarity(a, b)
    # Q of the score: score = score_nearest (1 - Q).
    q = 1 - phks.score(a, b) / phks.score_nearest(a, b)
    assert 0 < sim < 1 and sim == pytest.approx(q, rel=1e-12)
    m = phks.match(a, b)
    assert (m.similarity, m.verified_count) == (sim, verified)
    assert verified == int(m.verified[:len(a)].sum())
    assert len(m) == 6  # the attributes are not items
    with pytest.raises(TypeError):
        phks.similarity(a, None)
