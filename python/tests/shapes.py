"""Meshes the tests make themselves, and writers for the files they read."""
import numpy as np


def icosphere(subdivisions):
    """A geodesic sphere: (V float64 (n, 3), F int64 (m, 3)), outward."""
    t = (1 + 5 ** 0.5) / 2
    v = [(-1, t, 0), (1, t, 0), (-1, -t, 0), (1, -t, 0), (0, -1, t),
         (0, 1, t), (0, -1, -t), (0, 1, -t), (t, 0, -1), (t, 0, 1),
         (-t, 0, -1), (-t, 0, 1)]
    f = [(0, 11, 5), (0, 5, 1), (0, 1, 7), (0, 7, 10), (0, 10, 11),
         (1, 5, 9), (5, 11, 4), (11, 10, 2), (10, 7, 6), (7, 1, 8),
         (3, 9, 4), (3, 4, 2), (3, 2, 6), (3, 6, 8), (3, 8, 9),
         (4, 9, 5), (2, 4, 11), (6, 2, 10), (8, 6, 7), (9, 8, 1)]
    verts = [np.array(p, float) / np.linalg.norm(p) for p in v]
    faces = f
    for _ in range(subdivisions):
        cache = {}

        def mid(a, b):
            key = (min(a, b), max(a, b))
            if key not in cache:
                p = verts[a] + verts[b]
                verts.append(p / np.linalg.norm(p))
                cache[key] = len(verts) - 1
            return cache[key]

        new = []
        for a, b, c in faces:
            ab, bc, ca = mid(a, b), mid(b, c), mid(c, a)
            new += [(a, ab, ca), (b, bc, ab), (c, ca, bc), (ab, bc, ca)]
        faces = new
    return np.array(verts), np.array(faces, dtype=np.int64)


def creature(subdivisions=3, seed=0):
    """A stretched sphere with bumps of different heights: several clear
    heat maxima and well-separated principal axes."""
    v, f = icosphere(subdivisions)
    rng = np.random.default_rng(seed)
    bumps = rng.normal(size=(6, 3))
    bumps /= np.linalg.norm(bumps, axis=1)[:, None]
    heights = np.linspace(0.9, 0.3, len(bumps))
    r = np.ones(len(v))
    for c, h in zip(bumps, heights):
        r += h * np.exp(-np.sum((v - c) ** 2, axis=1) / 0.08)
    return v * r[:, None] * np.array([1.6, 1.0, 0.7]), f


def with_unused(v, f, every=5):
    """The same mesh with an unused vertex before vertex 0 and after every
    `every`-th vertex. Returns (V2, F2, where) with V2[where] == v."""
    rows, where = [], []
    junk = np.array([7.0, -3.0, 11.0])
    rows.append(junk)
    for i, p in enumerate(v):
        where.append(len(rows))
        rows.append(p)
        if i % every == every - 1:
            rows.append(junk + i)
    where = np.array(where)
    return np.array(rows), where[f], where


def write_off(path, v, f):
    with open(path, "w") as out:
        out.write("OFF\n%d %d 0\n" % (len(v), len(f)))
        for p in v:
            out.write("%.17g %.17g %.17g\n" % tuple(p))
        for t in f:
            out.write("3 %d %d %d\n" % tuple(t))


def write_obj(path, v, f):
    with open(path, "w") as out:
        out.write("# written by the phks tests\n")
        for p in v:
            out.write("v %.17g %.17g %.17g\n" % tuple(p))
        for t in f:
            out.write("f %d %d %d\n" % tuple(np.asarray(t) + 1))


def grid(n):
    """An n x n grid of vertices on the unit square, two triangles a cell."""
    x, y = np.meshgrid(np.linspace(0, 1, n), np.linspace(0, 1, n))
    v = np.column_stack([x.ravel(), y.ravel(), np.zeros(n * n)])
    f = []
    for j in range(n - 1):
        for i in range(n - 1):
            a = j * n + i
            f += [(a, a + 1, a + n + 1), (a, a + n + 1, a + n)]
    return v, np.array(f)
