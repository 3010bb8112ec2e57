#!/usr/bin/env bash
# Runs `cairn compare` on the shared g2o files (both solvers side by side in
# one process, from the same start) and prints a Markdown table for
# docs/benchmarks.md. Each solver runs REPEAT times (default 3, alternating
# which goes first) and its fastest run is reported, so that neither pays
# alone for the process's fresh memory.
# Usage: [REPEAT=N] scripts/benchmarks.sh [BUILD_DIR] [DATASETS]
set -euo pipefail
build=${1:-build}
data=${2:-../shared/datasets/g2o}
tmp=$(mktemp -d)
trap 'rm -rf "$tmp"' EXIT
echo "| file | init | ceres: iterations, s | gn: iterations, s | gn s to reach ceres's chi2 | ratio (gn to reach / ceres total) | final chi2 ceres | final chi2 gn | max diff m, deg |"
echo "| --- | --- | --- | --- | --- | --- | --- | --- | --- |"
for spec in 2d/intel:file 2d/MIT:file 2d/MIT:spanning-tree 2d/manhattan:file 2d/city10000:file \
            3d/smallGrid3D:file 3d/sphere2500:file 3d/parking-garage:file; do
  f=${spec%%:*}; init=${spec##*:}
  [ -f "$data/$f.g2o" ] || { echo "| $f | missing | | | | | | | |"; continue; }
  "$build/cairn" compare --quiet --repeat "${REPEAT:-3}" --init "$init" --json "$tmp/r.json" "$data/$f.g2o" > "$tmp/out.txt" 2> "$tmp/err.txt" || true
  python3 - "$f" "$init" "$tmp/r.json" <<'PY'
import json, sys
f, init, path = sys.argv[1:4]
r = json.load(open(path))
c, g = r["ceres"], r["gn"]
reach = r.get("gn_time_to_reach_ceres_s", g["time_s"])
print(f"| {f} | {init} | {c['iterations']}, {c['time_s']:.3f} | {g['iterations']}, {g['time_s']:.3f} | "
      f"{reach:.3f} | {reach / c['time_s']:.2f} | {c['final_chi2']:.10g} | {g['final_chi2']:.10g} | "
      f"{r['max_translation_diff']:.1e}, {r['max_rotation_diff_deg']:.1e} |")
PY
done
