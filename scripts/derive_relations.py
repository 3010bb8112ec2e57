#!/usr/bin/env python3
"""Relations (Kümmerle et al. 2009) derived from a CARMEN log's reference poses.

    scripts/derive_relations.py LOG.gz OUT.relations [--by-scan] [--seed S] [--loops N]

Writes lines `t1 t2 x y z roll pitch yaw`: the reference pose at t2 in the
frame of the one at t1 (z, roll and pitch 0). Two kinds, as the benchmark's
own files mix them: along the path, each scan to the first later scan at
least 1 m or 30 degrees on; and across loops, N pairs drawn at random (seed
S) among scans within 2 m of each other but at least 10 m apart along the
path. `t1`, `t2` are the laser lines' stamps as printed, or with --by-scan
the scans' 0-based indices among the laser lines (for logs whose printed
stamps repeat; `cairn eval --relations OUT --by-scan` reads them so).
A stamp shared by several scans is reported on stderr: such relations
cannot be paired by time.
"""
import argparse
import gzip
import math
import random
import sys


def wrap(a):
    return math.atan2(math.sin(a), math.cos(a))


def between(a, b):
    c, s = math.cos(a[2]), math.sin(a[2])
    dx, dy = b[0] - a[0], b[1] - a[1]
    return (c * dx + s * dy, -s * dx + c * dy, wrap(b[2] - a[2]))


def read_scans(path):
    """(stamp text, reference pose) of each FLASER / ROBOTLASER1 line."""
    opener = gzip.open if path.endswith(".gz") else open
    scans = []
    with opener(path, "rt", errors="replace") as f:
        for no, line in enumerate(f, 1):
            t = line.split()
            if not t or t[0] not in ("FLASER", "ROBOTLASER1"):
                continue
            try:
                if t[0] == "FLASER":
                    k = 2 + int(float(t[1]))
                else:  # type start fov res maxrange acc remission n ranges.. m remissions.. laser pose, robot pose
                    n = int(float(t[8]))
                    m = int(float(t[9 + n]))
                    k = 10 + n + m + 3
                pose = tuple(float(v) for v in t[k:k + 3])
                stamp = t[-3]
            except (ValueError, IndexError):
                sys.exit("%s:%d: malformed laser line" % (path, no))
            if len(pose) != 3:
                sys.exit("%s:%d: malformed laser line" % (path, no))
            scans.append((stamp, pose))
    return scans


def relations(scans, loops, rng):
    poses = [p for _, p in scans]
    path = [0.0]
    for a, b in zip(poses, poses[1:]):
        path.append(path[-1] + math.hypot(b[0] - a[0], b[1] - a[1]))
    pairs = []
    for i in range(len(poses)):
        for j in range(i + 1, len(poses)):
            d = between(poses[i], poses[j])
            if path[j] - path[i] >= 1.0 or abs(d[2]) >= math.radians(30):
                pairs.append((i, j))
                break
    far = [(i, j) for i in range(len(poses)) for j in range(i + 1, len(poses))
           if path[j] - path[i] >= 10.0 and
           math.hypot(poses[j][0] - poses[i][0], poses[j][1] - poses[i][1]) <= 2.0]
    pairs += sorted(rng.sample(far, min(loops, len(far))))
    return pairs


def main():
    p = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    p.add_argument("log")
    p.add_argument("out")
    p.add_argument("--by-scan", action="store_true")
    p.add_argument("--seed", type=int, default=1)
    p.add_argument("--loops", type=int, default=200)
    a = p.parse_args()
    scans = read_scans(a.log)
    pairs = relations(scans, a.loops, random.Random(a.seed))
    count = {}
    for s, _ in scans:
        count[s] = count.get(s, 0) + 1
    shared = sum(1 for s, _ in scans if count[s] > 1)
    if shared and not a.by_scan:
        print("%s: %d of %d scans share their printed stamp with another; relations touching "
              "them cannot be paired by time (--by-scan)" % (a.log, shared, len(scans)), file=sys.stderr)
    with open(a.out, "w") as f:
        for i, j in pairs:
            d = between(scans[i][1], scans[j][1])
            t1, t2 = (str(i), str(j)) if a.by_scan else (scans[i][0], scans[j][0])
            f.write("%s %s %.6f %.6f 0 0 0 %.6f\n" % (t1, t2, d[0], d[1], d[2]))
    print("%d relations (%d along the path, %d across loops)" %
          (len(pairs), len(pairs) - min(a.loops, len(pairs)), min(a.loops, len(pairs))), file=sys.stderr)


if __name__ == "__main__":
    main()
