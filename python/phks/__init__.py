"""phks - persistent heat signatures of triangle meshes (libphks).

numpy arrays in and out; docs/python.md in the source tree is the tour and
include/phks.h the manual of every call underneath.

    mesh = phks.load("bunny.ply")                  # or phks.Mesh(V, F)
    sig = phks.signature(mesh)                     # options as keywords
    sig.vertices, sig.positions, sig.vectors       # numpy arrays
    phks.score(sig, other)                         # 0 for itself
    with phks.Database("shapes.db") as db:
        db.add("bunny", sig, label="animal")
        db.query(sig, k=5)                         # [Hit(id, name, ...)]

Failures raise phks.Error (a RuntimeError) with .status, a phks.Status.
"""

# In an installed package, _phks sits beside this file. In a build tree it
# is built into BUILD/python/phks/ while this file stays in the source
# tree: with both folders on sys.path, extend_path joins them.
from pkgutil import extend_path as _extend_path

__path__ = _extend_path(__path__, __name__)

from ._phks import (  # noqa: E402
    MAX_SCALES,
    Database,
    Entry,
    Error,
    Hit,
    Match,
    Maxima,
    Mesh,
    Signature,
    Spectrum,
    Stage,
    Status,
    decode,
    default_options,
    geodesic_distances,
    library_version,
    load,
    load_memory,
    match,
    persistent_maxima,
    score,
    score_nearest,
    signature,
    similarity,
    spectrum,
    status_string,
)

__version__ = library_version

__all__ = [
    "MAX_SCALES", "Database", "Entry", "Error", "Hit", "Match", "Maxima",
    "Mesh", "Signature", "Spectrum", "Stage", "Status", "decode",
    "default_options", "geodesic_distances", "library_version", "load",
    "load_memory", "match", "persistent_maxima", "score", "score_nearest",
    "signature", "similarity", "spectrum", "status_string",
]
