"""docs/python.md's examples run as they stand, in order, in one
namespace, in a scratch folder."""
import os
import re

import pytest

DOC = os.path.join(os.path.dirname(__file__), "..", "..", "docs",
                   "python.md")


def test_the_tour_runs(tmp_path, monkeypatch, capsys):
    with open(DOC) as f:
        blocks = re.findall(r"^```python\n(.*?)^```", f.read(),
                            re.S | re.M)
    assert len(blocks) >= 8
    monkeypatch.chdir(tmp_path)
    namespace = {}
    for i, block in enumerate(blocks):
        try:
            exec(compile(block, "docs/python.md block %d" % i, "exec"),
                 namespace)
        except Exception:  # name the block in the failure
            pytest.fail("docs/python.md block %d failed:\n%s" % (i, block))
    out = capsys.readouterr().out
    assert "<phks.Mesh: 1152 vertices, 2304 triangles>" in out
    assert "IO 3 no/such/file.off" in out
