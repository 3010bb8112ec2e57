#!/usr/bin/env python3
"""Tables the runs of scripts/robustness.sh: for each dataset and case, the
RMS position difference of --reject-outliers's result from the solution
without outliers, the share of wrong loop closures rejected and of good ones
kept, the run's wall time and its ratio to the clean file's solve, and
whether the written graph holds exactly the kept loop closures.
Usage: robustness.py WORKDIR"""
import json
import math
import os
import sys


def read_graph(path):
    """Positions by id and loop closures (non-consecutive pairs) of a g2o file."""
    pos, closures = {}, set()
    with open(path) as f:
        for line in f:
            t = line.split()
            if not t:
                continue
            if t[0] == "VERTEX_SE2":
                pos[int(t[1])] = (float(t[2]), float(t[3]), 0.0)
            elif t[0] == "VERTEX_SE3:QUAT":
                pos[int(t[1])] = (float(t[2]), float(t[3]), float(t[4]))
            elif t[0].startswith("EDGE_SE"):
                a, b = int(t[1]), int(t[2])
                if abs(a - b) != 1:
                    closures.add((a, b))
    return pos, closures


def rms(a, b):
    s = sum(sum((x - y) ** 2 for x, y in zip(a[k], b[k])) for k in b)
    return math.sqrt(s / len(b))


def row(work, name, kind, frac, closures):
    base = os.path.join(work, f"{name}_{kind}_{frac}")
    clean, _ = read_graph(os.path.join(work, f"{name}_clean.g2o"))
    wrong = set()
    for l in open(base + ".g2o.outliers.txt"):
        if l.strip() and not l.startswith("#"):
            a, b = l.split()
            wrong.add((int(a), int(b)))
    report = json.load(open(base + ".json"))
    rejected = {tuple(p) for p in report["rejected_loop_closures"]}
    out, kept = read_graph(base + "_out.g2o")
    _, all_closures = read_graph(base + ".g2o")
    exact = kept == all_closures - rejected
    good = int(closures)
    caught = len(rejected & wrong)
    wall = float(open(base + ".wall").read())
    clean_wall = float(open(os.path.join(work, f"{name}_clean.wall")).read())
    return dict(name=name, kind=kind, frac=float(frac), wrong=len(wrong), good=good,
                rms=rms(out, clean), caught=100.0 * caught / max(1, len(wrong)),
                kept=100.0 * (good - len(rejected - wrong)) / max(1, good),
                wall=wall, ratio=wall / clean_wall, exact=exact)


def main(work):
    rows = [row(work, *line.split()) for line in open(os.path.join(work, "runs.txt"))]
    print("| dataset | case | wrong / good loop closures | RMS vs clean (m) | wrong rejected "
          "| good kept | wall time (s) | x clean solve | -o = kept | pass |")
    print("| --- | --- | --- | --- | --- | --- | --- | --- | --- | --- |")
    passed = 0
    for r in rows:
        ok = r["rms"] <= 0.05 and r["caught"] >= 95 and r["kept"] >= 95 and r["exact"]
        passed += ok
        case = ("random " if r["kind"] == "random" else
                f"aliased, groups of {r['kind'][len('grouped'):]}, ") + f"{round(r['frac'] * 100)}%"
        print(f"| {r['name']} | {case} | {r['wrong']} / {r['good']} | {r['rms']:.3g} "
              f"| {r['caught']:.1f}% | {r['kept']:.1f}% | {r['wall']:.1f} | {r['ratio']:.0f} "
              f"| {'yes' if r['exact'] else 'NO'} | {'yes' if ok else 'NO'} |")
    print(f"\n{passed} of {len(rows)} pass (RMS <= 0.05 m, >= 95% rejected, >= 95% kept, "
          "-o holding exactly the kept loop closures).")


if __name__ == "__main__":
    main(sys.argv[1])
