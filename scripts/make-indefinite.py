#!/usr/bin/env python3
"""Makes a g2o file with indefinite information matrices, to exercise
--repair-information: a fraction of the between-edges (EDGE_SE2,
EDGE_SE3:QUAT) get a negative eigenvalue, -r times their largest, in a
random direction, r drawn uniformly from (0, WORST] (the first such edge
gets WORST itself). Everything else is copied as it is. Bridges of the
graph (edges whose removal would split it, as odometry beyond the last loop
closure) are left alone unless --bridges: once repaired, such an edge says
nothing in one direction, and everything beyond it would be free in that
direction (cairn refuses such a graph, naming a vertex). So would it a
stretch of odometry with many such edges (k of them in one stretch leave
3(k-1) degrees of freedom in 2D against 2k constraints, 6(k-1) against 5k
in 3D): --loops-only leaves odometry alone.

  python3 scripts/make-indefinite.py IN.g2o OUT.g2o [--fraction 0.3] [--worst 0.47] [--seed 1]
                                    [--bridges]

Prints how many matrices it changed. Plain Python (no numpy): a cyclic
Jacobi eigen-decomposition of each 3x3 or 6x6 matrix."""
import argparse
import math
import random
import sys


def jacobi_eigen(a):
    """Eigenvalues and eigenvectors (columns of v) of a symmetric matrix."""
    n = len(a)
    a = [row[:] for row in a]
    v = [[float(i == j) for j in range(n)] for i in range(n)]
    for _ in range(100):
        off = sum(a[i][j] ** 2 for i in range(n) for j in range(n) if i != j)
        if off < 1e-30 * sum(a[i][i] ** 2 for i in range(n)):
            break
        for p in range(n - 1):
            for q in range(p + 1, n):
                if a[p][q] == 0.0:
                    continue
                theta = (a[q][q] - a[p][p]) / (2 * a[p][q])
                t = math.copysign(1.0, theta) / (abs(theta) + math.sqrt(theta * theta + 1))
                c = 1 / math.sqrt(t * t + 1)
                s = t * c
                for k in range(n):  # columns p, q of a, then rows
                    akp, akq = a[k][p], a[k][q]
                    a[k][p], a[k][q] = c * akp - s * akq, s * akp + c * akq
                for k in range(n):
                    apk, aqk = a[p][k], a[q][k]
                    a[p][k], a[q][k] = c * apk - s * aqk, s * apk + c * aqk
                for k in range(n):
                    vkp, vkq = v[k][p], v[k][q]
                    v[k][p], v[k][q] = c * vkp - s * vkq, s * vkp + c * vkq
    return [a[i][i] for i in range(n)], v


def make_indefinite(info, r, rng):
    """The information in a random direction u replaced by -r times the
    largest eigenvalue of what is left: P Omega P - r lambda_max u u^T,
    P = I - u u^T. Random directions, since the shared files' matrices have
    tied eigenvalues: the smallest eigenvector would be the same axis on
    every edge, and clipping it would leave whole chains free."""
    n = len(info)
    u = [rng.gauss(0, 1) for _ in range(n)]
    norm = math.sqrt(sum(x * x for x in u))
    u = [x / norm for x in u]
    p = [[float(i == j) - u[i] * u[j] for j in range(n)] for i in range(n)]
    pi = [[sum(p[i][k] * info[k][j] for k in range(n)) for j in range(n)] for i in range(n)]
    rest = [[sum(pi[i][k] * p[k][j] for k in range(n)) for j in range(n)] for i in range(n)]
    lam, _ = jacobi_eigen(rest)
    neg = -r * max(lam)
    return [[rest[i][j] + neg * u[i] * u[j] for j in range(n)] for i in range(n)]


def bridges(pairs):
    """Indices of the edges whose removal disconnects the graph (Tarjan's
    low-link, iteratively; parallel edges are never bridges)."""
    adj = {}
    for k, (a, b) in enumerate(pairs):
        adj.setdefault(a, []).append((b, k))
        adj.setdefault(b, []).append((a, k))
    order, low, out, clock = {}, {}, set(), 0
    for root in adj:
        if root in order:
            continue
        order[root] = low[root] = clock
        clock += 1
        stack = [(root, -1, iter(adj[root]))]
        while stack:
            v, via, it = stack[-1]
            for w, k in it:
                if k == via:
                    continue
                if w in order:
                    low[v] = min(low[v], order[w])
                else:
                    order[w] = low[w] = clock
                    clock += 1
                    stack.append((w, k, iter(adj[w])))
                    break
            else:
                stack.pop()
                if stack:
                    u = stack[-1][0]
                    low[u] = min(low[u], low[v])
                    if low[v] > order[u]:
                        out.add(via)
    return out


def main():
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("input")
    ap.add_argument("output")
    ap.add_argument("--fraction", type=float, default=0.3)
    ap.add_argument("--worst", type=float, default=0.47)
    ap.add_argument("--seed", type=int, default=1)
    ap.add_argument("--bridges", action="store_true", help="bridges of the graph too")
    ap.add_argument("--loops-only", action="store_true",
                    help="only loop closures (ids not consecutive), still about FRACTION of all edges")
    args = ap.parse_args()
    with open(args.input) as f:
        lines = f.readlines()
    rng = random.Random(args.seed)
    # tag -> (fields before the information, its dimension)
    layout = {"EDGE_SE2": (6, 3), "EDGE_SE3:QUAT": (10, 6)}
    pairs = [tuple(l.split()[1:3]) for l in lines if l.split()[:1] and l.split()[0] in layout]
    keep = set() if args.bridges else bridges(pairs)
    if args.loops_only:
        keep |= {k for k, (a, b) in enumerate(pairs) if abs(int(a) - int(b)) == 1}
    changed = edges = 0
    out = []
    share = args.fraction * len(pairs) / max(1, len(pairs) - len(keep))
    for line in lines:
        tokens = line.split()
        if not tokens or tokens[0] not in layout:
            out.append(line)
            continue
        edges += 1
        first, n = layout[tokens[0]]
        # Bridges count towards the fraction: about that share of all edges.
        if (edges - 1) in keep or rng.random() >= share:
            out.append(line)
            continue
        values = [float(x) for x in tokens[first:]]
        info = [[0.0] * n for _ in range(n)]
        k = 0
        for r in range(n):
            for c in range(r, n):
                info[r][c] = info[c][r] = values[k]
                k += 1
        worst = args.worst if changed == 0 else rng.uniform(0, args.worst)
        info = make_indefinite(info, max(worst, 1e-3), rng)
        upper = [info[r][c] for r in range(n) for c in range(r, n)]
        out.append(" ".join(tokens[:first] + ["%.17g" % x for x in upper]) + "\n")
        changed += 1
    with open(args.output, "w") as f:
        f.writelines(out)
    print("%s: %d of %d between-edges made indefinite (smallest eigenvalue down to -%g of the "
          "largest; %d edges left alone)" % (args.output, changed, edges, args.worst, len(keep)))


if __name__ == "__main__":
    sys.exit(main())
