#!/usr/bin/env python3
"""similarity_rule.py QUERIES.TSV [RATE...] - docs/retrieval.md's "What a
score means" from a `phks bench --queries-out` file: for complete and for
partial+incomplete queries, the lowest top-1 similarity (and, beside it,
the highest top-1 score) above which the best hit is of the query's class
at least RATE of the time (default 0.90 and 0.75), with the counts behind
each figure. Failed queries (rank -1, no similarity) are left out."""
import csv
import sys


def threshold(rows, key, rate, high_is_good):
    """The loosest value v of key such that the queries at least as good
    as v have a top-1 rate >= rate: (v, right, n), or None."""
    order = sorted(rows, key=lambda r: -r[key] if high_is_good else r[key])
    best, right = None, 0
    for n, r in enumerate(order, 1):
        right += r["right"]
        last = n == len(order) or order[n][key] != r[key]
        if last and right >= rate * n:
            best = (r[key], right, n)
    return best


def main():
    path, rates = sys.argv[1], [float(x) for x in sys.argv[2:]] or [0.9, 0.75]
    groups = {"complete": [], "partial+incomplete": []}
    with open(path) as f:
        for r in csv.DictReader(f, delimiter="\t"):
            if r["top1_similarity"] == "":
                continue
            g = "complete" if r["kind"] == "complete" else "partial+incomplete"
            groups[g].append({"sim": float(r["top1_similarity"]),
                              "score": float(r["top1_score"]),
                              "right": r["top1_label"] == r["class"]})
    print("| queries | n | top-1 right | rate | similarity at least | "
          "right / queries there | score at most | right / queries there |")
    print("|---|---:|---:|---:|---:|---:|---:|---:|")
    for g, rows in groups.items():
        right = sum(r["right"] for r in rows)
        for rate in rates:
            s = threshold(rows, "sim", rate, True)
            c = threshold(rows, "score", rate, False)
            cell = lambda t, f: ("%s | %d / %d" % (f % t[0], t[1], t[2])
                                 if t else "- | -")
            print("| %s | %d | %d | %.0f%% | %s | %s |" %
                  (g, len(rows), right, 100 * rate, cell(s, "%.3f"),
                   cell(c, "%.2f")))


if __name__ == "__main__":
    main()
