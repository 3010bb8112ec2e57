#!/usr/bin/env bash
# Generates a 2D g2o file of 1,000,000 edges (500,001 poses along a random
# walk, 500,000 odometry edges and 500,000 loop closures between random
# poses) and measures how long `cairn info` takes to parse it and its peak
# memory (GNU time). Usage: scripts/large-input.sh [WORKDIR]
set -euo pipefail
cd "$(dirname "$0")/.."
WORK="${1:-build/large}"
mkdir -p "$WORK"
FILE="$WORK/million.g2o"
if [ ! -f "$FILE" ]; then
  python3 - "$FILE" <<'PY'
import math, random, sys
random.seed(1)
n = 500001
info = "100 0 0 100 0 1000"
with open(sys.argv[1], "w") as f:
    x = y = th = 0.0
    for i in range(n):
        f.write(f"VERTEX_SE2 {i} {x:.6f} {y:.6f} {th:.6f}\n")
        x += math.cos(th); y += math.sin(th)
        th = math.remainder(th + random.uniform(-0.3, 0.3), 2 * math.pi)
    for i in range(n - 1):
        f.write(f"EDGE_SE2 {i} {i+1} 1 0 {random.uniform(-0.3, 0.3):.6f} {info}\n")
    for k in range(n - 1):
        a = random.randrange(n - 2); b = random.randrange(a + 2, n)
        f.write(f"EDGE_SE2 {a} {b} {random.uniform(-9, 9):.6f} {random.uniform(-9, 9):.6f} "
                f"{random.uniform(-3, 3):.6f} {info}\n")
PY
fi
ls -l "$FILE"
/usr/bin/time -v build/cairn info "$FILE" 2>&1 | grep -E "edges|vertices|Elapsed|Maximum resident"
