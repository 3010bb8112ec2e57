#!/usr/bin/env bash
# For every shared g2o file and every initialisation, the final chi-squared
# both solvers reach (cairn compare), as a Markdown table for
# docs/initialization.md. Usage: scripts/initialization.sh [BUILD_DIR] [DATASETS]
set -euo pipefail
build=${1:-build}
data=${2:-../shared/datasets/g2o}
tmp=$(mktemp -d)
trap 'rm -rf "$tmp"' EXIT
echo "| file | init | init s | chi2 after init | ceres final chi2 (s) | gn final chi2 (s) | agree |"
echo "| --- | --- | --- | --- | --- | --- | --- |"
for f in 2d/intel 2d/MIT 2d/city10000 2d/manhattan 2d/CSAIL 3d/tinyGrid3D 3d/smallGrid3D \
         3d/sphere2500 3d/parking-garage 3d/sphere_bignoise_vertex3; do
  [ -f "$data/$f.g2o" ] || continue
  for init in file odometry spanning-tree chordal auto; do
    ok=yes
    "$build/cairn" compare --quiet --init "$init" --json "$tmp/r.json" "$data/$f.g2o" \
      > /dev/null 2>&1 || ok=no
    python3 - "$f" "$init" "$ok" "$tmp/r.json" <<'PY'
import json, sys
f, init, ok, path = sys.argv[1:5]
r = json.load(open(path))
i, c, g = r["init"], r["ceres"], r["gn"]
print(f"| {f} | {init} | {i['time_s']:.4f} | {i['chi2']:.6g} | {c['final_chi2']:.10g} ({c['time_s']:.2f}) | "
      f"{g['final_chi2']:.10g} ({g['time_s']:.2f}) | {ok} |")
PY
  done
done
