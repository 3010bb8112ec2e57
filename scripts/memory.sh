#!/usr/bin/env bash
# Peak memory of the Gauss-Newton solve on simulated graphs, as docs/robustness.md
# ("Memory") reports it: /usr/bin/time -v's maximum resident set size per edge,
# with the wall time and the linear solver the run chose.
# Usage: scripts/memory.sh [WORKDIR]   (BIN=other/cairn, EXTRA="--gn-factor-memory unlimited",
#        GRAPHS="3d:200000:1 3d:100000:3 ..." as dim:poses:seed)
set -euo pipefail
cd "$(dirname "$0")/.."
WORK="${1:-build/memory}"
BIN="${BIN:-build/cairn}"
EXTRA="${EXTRA:-}"
GRAPHS="${GRAPHS:-3d:200000:1 3d:100000:3 3d:50000:5 2d:1000000:1 2d:500000:7}"
mkdir -p "$WORK"
printf '| graph | edges | peak KiB | per edge | bound | wall s | solve s | linear solver |\n'
printf '| --- | --- | --- | --- | --- | --- | --- | --- |\n'
for g in $GRAPHS; do
  IFS=: read -r dim poses seed <<<"$g"
  file="$WORK/sim${dim}_${poses}_s${seed}.g2o"
  [ -f "$file" ] || "$BIN" simulate --dim "${dim%d}" --poses "$poses" --seed "$seed" -o "$file" >/dev/null
  # shellcheck disable=SC2086
  /usr/bin/time -v "$BIN" optimize --solver gn --quiet $EXTRA "$file" -o "$WORK/out.g2o" \
    --report "$WORK/report.json" 2>"$WORK/time.txt"
  python3 - "$dim" "$poses" "$seed" "$WORK/time.txt" "$WORK/report.json" <<'PY'
import json, re, sys
dim, poses, seed, timing, report = sys.argv[1:]
text = open(timing).read()
kib = int(re.search(r"Maximum resident set size \(kbytes\): (\d+)", text).group(1))
wall = re.search(r"Elapsed \(wall clock\) time \(h:mm:ss or m:ss\): (\S+)", text).group(1)
parts = [float(p) for p in wall.split(":")]
seconds = sum(p * 60 ** i for i, p in enumerate(reversed(parts)))
r = json.load(open(report))
per_edge = kib * 1024 / r["edges"]
bound = 1536 if dim == "2d" else 3072
print(f"| {dim.upper()}, {int(poses):,} poses, seed {seed} | {r['edges']:,} | {kib:,} | {per_edge:.0f} B | "
      f"{bound} B: {'met' if per_edge <= bound else 'over'} | {seconds:.1f} | {r['time_s']:.1f} | {r['linear_solver']} |")
PY
done
