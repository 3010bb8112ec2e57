#!/usr/bin/env python3
"""Makes a g2o file with indefinite information matrices, to exercise
--repair-information: a fraction of the between-edges (EDGE_SE2,
EDGE_SE3:QUAT) get a negative eigenvalue, -r times their largest, in a
random direction, r drawn uniformly from (0, WORST] (the first such edge
gets WORST itself). Everything else is copied as it is.

  python3 scripts/make-indefinite.py IN.g2o OUT.g2o [--fraction 0.3] [--worst 0.47] [--seed 1]

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


def main():
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("input")
    ap.add_argument("output")
    ap.add_argument("--fraction", type=float, default=0.3)
    ap.add_argument("--worst", type=float, default=0.47)
    ap.add_argument("--seed", type=int, default=1)
    args = ap.parse_args()
    rng = random.Random(args.seed)
    # tag -> (fields before the information, its dimension)
    layout = {"EDGE_SE2": (6, 3), "EDGE_SE3:QUAT": (10, 6)}
    changed = edges = 0
    out = []
    with open(args.input) as f:
        for line in f:
            tokens = line.split()
            if not tokens or tokens[0] not in layout:
                out.append(line)
                continue
            edges += 1
            first, n = layout[tokens[0]]
            if rng.random() >= args.fraction:
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
          "largest)" % (args.output, changed, edges, args.worst))


if __name__ == "__main__":
    sys.exit(main())
