"""Shape databases: add, batch, query, get, list, remove, close."""
import numpy as np
import pytest

import phks
from conftest import assert_same_signature
from shapes import creature


@pytest.fixture(scope="module")
def shapes():
    return {"s%d" % seed: phks.signature(phks.Mesh(*creature(3, seed=seed)))
            for seed in range(4)}


def test_roundtrip(tmp_path, shapes):
    path = tmp_path / "shapes.db"
    with phks.Database(path) as db:
        assert len(db) == 0 and db.list() == [] and not db.closed
        assert db.query(shapes["s0"], k=3) == []
        first = db.add("s0", shapes["s0"], label="blob")
        rest = db.add_batch([("s1", shapes["s1"], "blob"),
                             ("s2", shapes["s2"]),
                             ["s3", shapes["s3"], None]])
        ids = [first] + rest
        assert len(set(ids)) == 4 and len(db) == 4
        assert db.list() == sorted(ids)

        hits = db.query(shapes["s2"], k=3)
        assert len(hits) == 3
        assert hits[0].name == "s2" and hits[0].score == 0
        assert hits[0].id == ids[2] and hits[0].label == ""
        # The scores are phks.score's, best first.
        for h in hits:
            sig = shapes[h.name]
            assert h.score == phks.score(shapes["s2"], sig)
            assert (h.similarity, h.verified) == phks.similarity(
                shapes["s2"], sig)
            assert len(h) == 4  # the attributes are not items
        assert hits[0].similarity == 1
        assert hits[0].verified == len(shapes["s2"])
        assert [h.score for h in hits] == sorted(h.score for h in hits)
        labels = {h.name: h.label for h in db.query(shapes["s0"], k=100)}
        assert labels == {"s0": "blob", "s1": "blob", "s2": "", "s3": ""}

        entry = db.get(ids[1])
        assert (entry.id, entry.name, entry.label) == (ids[1], "s1", "blob")
        assert_same_signature(entry.signature, shapes["s1"])
        assert entry.signature.vertices is None

        db.remove(ids[2])
        assert len(db) == 3 and ids[2] not in db.list()
        assert db.query(shapes["s2"], k=1)[0].name != "s2"
        with pytest.raises(phks.Error) as e:
            db.remove(ids[2])
        assert e.value.status == phks.Status.INVALID_ARGUMENT
        with pytest.raises(phks.Error) as e:
            db.get(ids[2])
        assert e.value.status == phks.Status.INVALID_ARGUMENT
    assert db.closed
    with pytest.raises(ValueError):
        db.query(shapes["s0"])
    with pytest.raises(ValueError):
        len(db)
    db.close()  # twice is harmless

    # Committed: another handle, read-only, sees the same entries.
    with phks.Database(str(path), readonly=True) as again:
        assert again.list() == sorted(ids[:2] + ids[3:])
        with pytest.raises(phks.Error) as e:
            again.add("s2", shapes["s2"])
        assert e.value.status == phks.Status.INVALID_ARGUMENT


def test_batch_is_all_or_nothing(shapes):
    mesh = phks.Mesh(*creature(3, seed=0))
    other_options = phks.signature(mesh, operator_kind="literal")
    with phks.Database(":memory:") as db:
        db.add("s0", shapes["s0"])
        with pytest.raises(phks.Error) as e:
            db.add_batch([("s1", shapes["s1"]), ("bad", other_options)])
        assert e.value.status == phks.Status.INCOMPATIBLE
        assert len(db) == 1
        with pytest.raises(phks.Error) as e:
            db.query(other_options)
        assert e.value.status == phks.Status.INCOMPATIBLE
        with pytest.raises(ValueError):
            db.add_batch([("only a name",)])
        with pytest.raises(TypeError):
            db.add_batch([("s1", "not a signature")])
        with pytest.raises(ValueError):
            db.add("nul\0name", shapes["s1"])
        with pytest.raises(ValueError):
            db.query(shapes["s0"], k=0)
        assert db.add_batch([]) == []
        assert len(db) == 1


def test_mismatch_names_both_values(shapes):
    # The option and both values as a Python user writes them, never the
    # enums' numbers ("hks_scaling 0 against 2").
    mesh = phks.Mesh(*creature(3, seed=0))
    unscaled = phks.signature(mesh, hks_scaling="none")
    with phks.Database(":memory:") as db:
        db.add("s0", shapes["s0"])
        for call in (lambda: db.add("unscaled", unscaled),
                     lambda: db.add_batch([("unscaled", unscaled)]),
                     lambda: db.query(unscaled)):
            with pytest.raises(phks.Error) as e:
                call()
            assert e.value.status == phks.Status.INCOMPATIBLE
            assert "hks_scaling none against local_area" in str(e.value)
        assert len(db) == 1


def test_long_names_come_back_whole(shapes):
    name = "n" * 1000
    with phks.Database(":memory:") as db:
        i = db.add(name, shapes["s0"], label="ä" * 300)
        assert db.get(i).name == name and db.get(i).label == "ä" * 300
        hit = db.query(shapes["s0"], k=1)[0]
        assert hit.name == name[:255]  # hits carry at most 255 bytes


def test_open_errors(tmp_path):
    with pytest.raises(phks.Error) as e:
        phks.Database(tmp_path / "missing.db", create=False)
    assert e.value.status == phks.Status.IO
    # In Python's terms, not the C flag's (PHKS_DB_CREATE).
    assert "(missing? create=True makes it)" in e.value.message
    assert "PHKS_" not in str(e.value)
    with pytest.raises(phks.Error) as e:
        phks.Database(tmp_path / "missing.db", readonly=True)
    assert "(missing? create=True without readonly=True makes it)" in \
        e.value.message
    not_db = tmp_path / "not.db"
    not_db.write_bytes(b"this is not an SQLite file" * 100)
    with pytest.raises(phks.Error) as e:
        phks.Database(not_db)
    assert e.value.status == phks.Status.CORRUPT
