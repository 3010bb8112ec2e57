#!/usr/bin/env bash
# The Gauss-Newton path's ways to solve H dx = -b side by side on every
# shared file: iterations, final chi2, time_s and what the report names.
# Usage: scripts/linear-solvers.sh [path/to/cairn] [solvers...]
#   (default: build/cairn, auto qr cg)
set -euo pipefail
cd "$(dirname "$0")/.."
CAIRN="${1:-build/cairn}"
shift || true
SOLVERS="${*:-auto qr cg}"
DATA=../shared/datasets/g2o
if [ ! -d "$DATA" ]; then
  echo "linear-solvers.sh: $DATA is missing" >&2
  exit 1
fi
work=$(mktemp -d)
trap 'rm -rf "$work"' EXIT
for f in 2d/intel 2d/MIT 2d/CSAIL 2d/manhattan 2d/city10000 3d/tinyGrid3D 3d/smallGrid3D \
         3d/sphere2500 3d/parking-garage 3d/sphere_bignoise_vertex3; do
  for solver in $SOLVERS; do
    rc=0
    "$CAIRN" optimize "$DATA/$f.g2o" -o "$work/out.g2o" --init file --solver gn \
      --linear-solver "$solver" --quiet --report "$work/r.json" > /dev/null || rc=$?
    python3 - "$f" "$solver" "$rc" "$work/r.json" <<'PY'
import json, sys
f, solver, rc, path = sys.argv[1:]
if rc != "0":
    print(f"{f} {solver}: exit {rc}")
    sys.exit(0)
r = json.load(open(path))
print(f"{f} {solver}: {r['iterations']} iterations, chi2 {r['final_chi2']:.12g}, "
      f"{r['time_s']:.3f} s, {r['termination']} ({r['linear_solver']})")
PY
    rm -f "$work/r.json"
  done
done
