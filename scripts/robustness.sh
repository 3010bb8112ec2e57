#!/usr/bin/env bash
# The robustness table of docs/robustness.md: each dataset with 10%, 30% and
# 50% as many wrong loop closures (cairn corrupt) as it has loop closures,
# optimised by plain least squares and with --reject-outliers, each compared
# with the solution of the uncorrupted file. Every solve starts from the
# file's vertices. Usage: [PLAIN_ITERATIONS=30] scripts/robustness.sh [WORKDIR] [SOLVER]
set -euo pipefail
cd "$(dirname "$0")/.."
WORK="${1:-build/robustness}"
SOLVER="${2:-ceres}"
PLAIN_ITERATIONS="${PLAIN_ITERATIONS:-30}"
DATA=../shared/datasets/g2o
# A copy: rebuilding build/ while this runs must not change the binary midway.
mkdir -p "$WORK"
cp build/cairn "$WORK/cairn"
CAIRN="$WORK/cairn"
mkdir -p "$WORK"
: > "$WORK/runs.txt"
for file in 2d/intel 2d/city10000 2d/manhattan 3d/sphere2500; do
  if [ ! -r "$DATA/$file.g2o" ]; then
    echo "robustness.sh: $DATA/$file.g2o is missing" >&2
    exit 1
  fi
done
for file in 2d/intel 2d/city10000 2d/manhattan 3d/sphere2500; do
  name=$(basename "$file")
  in="$DATA/$file.g2o"
  $CAIRN optimize "$in" -o "$WORK/${name}_clean.g2o" --solver "$SOLVER" --quiet
  closures=$($CAIRN info "$in" --json | python3 -c 'import json,sys; print(json.load(sys.stdin)["loop_closures"])')
  for frac in 0.1 0.3 0.5; do
    base="$WORK/${name}_${frac}"
    seed=$(( ${#name} * 100 + ${frac#0.} ))
    $CAIRN corrupt "$in" -o "$base.g2o" --fraction "$frac" --seed "$seed" 2>/dev/null
    # Plain least squares, capped: with random wrong loop closures joining
    # far-apart poses the factorisation fills in (seconds an iteration on
    # city10000), and it ends metres off whether it converges or not.
    $CAIRN optimize "$base.g2o" -o "${base}_plain.g2o" --solver "$SOLVER" --quiet \
      --max-iterations "$PLAIN_ITERATIONS" --report "${base}_plain.json" || true
    # Wall and CPU (user + system) time of the whole run.
    start=$(date +%s.%N)
    cpu0=$(awk '{print $14 + $15 + $16 + $17}' /proc/$$/stat)
    $CAIRN optimize "$base.g2o" -o "${base}_gnc.g2o" --solver "$SOLVER" --quiet \
      --reject-outliers --report "${base}_gnc.json"
    echo "$(date +%s.%N) - $start" | bc > "${base}_gnc.wall"
    cpu1=$(awk '{print $14 + $15 + $16 + $17}' /proc/$$/stat)
    echo "scale=2; ($cpu1 - $cpu0) / $(getconf CLK_TCK)" | bc > "${base}_gnc.cpu"
    echo "$name $frac $closures" >> "$WORK/runs.txt"
    echo "== $name $frac done" >&2
  done
done
python3 scripts/robustness.py "$WORK"
