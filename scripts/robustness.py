#!/usr/bin/env python3
"""Tables the robustness runs of scripts/robustness.sh: for each dataset and
outlier fraction, the RMS position difference from the solution without
outliers (plain least squares and --reject-outliers), and how many wrong and
good loop closures --reject-outliers rejected. Usage: robustness.py WORKDIR"""
import json
import math
import os
import sys


def positions(path):
    pos = {}
    with open(path) as f:
        for line in f:
            t = line.split()
            if t and t[0] == "VERTEX_SE2":
                pos[int(t[1])] = (float(t[2]), float(t[3]), 0.0)
            elif t and t[0] == "VERTEX_SE3:QUAT":
                pos[int(t[1])] = (float(t[2]), float(t[3]), float(t[4]))
    return pos


def rms(a_path, b_path):
    if not os.path.exists(a_path):
        return float("nan")
    a, b = positions(a_path), positions(b_path)
    s = sum(sum((x - y) ** 2 for x, y in zip(a[k], b[k])) for k in b)
    return math.sqrt(s / len(b))


def main(work):
    rows = []
    for line in open(os.path.join(work, "runs.txt")):
        name, frac, closures = line.split()
        base = os.path.join(work, f"{name}_{frac}")
        clean = os.path.join(work, f"{name}_clean.g2o")
        wrong = set()
        for l in open(base + ".g2o.outliers.txt"):
            if l.strip() and not l.startswith("#"):
                a, b = l.split()
                wrong.add((int(a), int(b)))
        report = json.load(open(base + "_gnc.json"))
        rejected = {tuple(p) for p in report["rejected_loop_closures"]}
        caught = len(rejected & wrong)
        good_rejected = len(rejected - wrong)
        good = int(closures)
        times = {}
        for kind in ("plain", "gnc"):
            j = base + f"_{kind}.json"
            times[kind] = json.load(open(j))["time_s"] if os.path.exists(j) else float("nan")
        j = base + "_plain.json"
        plain_end = json.load(open(j))["termination"] if os.path.exists(j) else "failed"
        rows.append((name, float(frac), len(wrong), good,
                     rms(base + "_plain.g2o", clean), rms(base + "_gnc.g2o", clean),
                     100.0 * caught / max(1, len(wrong)),
                     100.0 * (good - good_rejected) / max(1, good),
                     times["gnc"], float(open(base + "_gnc.wall").read()), plain_end,
                     float(open(base + "_gnc.cpu").read())))
    print("| dataset | wrong / good loop closures | RMS plain LS (m) | RMS --reject-outliers (m) "
          "| wrong rejected | good kept | --reject-outliers wall / CPU time (s) | pass |")
    print("| --- | --- | --- | --- | --- | --- | --- | --- |")
    for name, frac, nw, ng, rp, rg, caught, kept, _, wall, plain_end, cpu in rows:
        ok = rg <= 0.05 and caught >= 95 and kept >= 95
        note = "" if plain_end == "convergence" else f" ({plain_end})"
        print(f"| {name} | {int(round(frac * 100))}%: {nw} / {ng} | {rp:.3g}{note} | {rg:.3g} "
              f"| {caught:.1f}% | {kept:.1f}% | {wall:.1f} / {cpu:.1f} | {'yes' if ok else 'NO'} |")


if __name__ == "__main__":
    main(sys.argv[1])
