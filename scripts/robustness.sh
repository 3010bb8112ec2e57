#!/usr/bin/env bash
# The robustness table of docs/robustness.md: each dataset with random wrong
# loop closures (cairn corrupt --fraction: 10%, 30%, 50%, 90% as many as it
# has loop closures) and with aliased groups (--grouped 5 and 10: 5%, 10%,
# 20%, measured on the clean solution's poses), optimised with
# --reject-outliers from the file's vertices and compared with the solution
# of the uncorrupted file. Usage:
#   [SEED=0] [DATASETS="2d/intel ..."] [CASES="random:0.3 grouped5:0.1"] \
#     [EXTRA="--gnc-iterations 1"] [BIN=path/to/cairn] scripts/robustness.sh [WORKDIR] [SOLVER]
# SEED shifts every case's seed (other seeds, same cases); a DATASETS entry
# that is a readable .g2o path (e.g. from cairn simulate) is taken as it is;
# EXTRA is passed to every --reject-outliers run (to try other options);
# BIN names another binary than build/cairn (an older build, to compare).
set -euo pipefail
cd "$(dirname "$0")/.."
WORK="${1:-build/robustness}"
SOLVER="${2:-ceres}"
SEED="${SEED:-0}"
EXTRA="${EXTRA:-}"
DATASETS="${DATASETS:-2d/intel 2d/city10000 2d/manhattan 3d/sphere2500}"
DATA=../shared/datasets/g2o
mkdir -p "$WORK"
# A copy: rebuilding build/ while this runs must not change the binary midway.
cp "${BIN:-build/cairn}" "$WORK/cairn"
CAIRN="$WORK/cairn"
: > "$WORK/runs.txt"
path_of() { if [ -r "$1" ]; then echo "$1"; else echo "$DATA/$1.g2o"; fi; }
for file in $DATASETS; do
  if [ ! -r "$(path_of "$file")" ]; then
    echo "robustness.sh: $DATA/$file.g2o is missing" >&2
    exit 1
  fi
done
# Wall time of a command, in seconds, into the file named first.
timed() {
  local out="$1"; shift
  local start end
  start=$(date +%s.%N)
  "$@"
  end=$(date +%s.%N)
  echo "$end - $start" | bc > "$out"
}
for file in $DATASETS; do
  name=$(basename "$file" .g2o)
  in=$(path_of "$file")
  # The clean solve is the ratios' yardstick, and a single run of it varies
  # by half on a busy machine: the median of three.
  for k in 1 2 3; do
    timed "$WORK/${name}_clean.wall$k" \
      $CAIRN optimize "$in" -o "$WORK/${name}_clean.g2o" --solver "$SOLVER" --quiet
  done
  sort -g "$WORK/${name}"_clean.wall[123] | sed -n 2p > "$WORK/${name}_clean.wall"
  closures=$($CAIRN info "$in" --json | python3 -c 'import json,sys; print(json.load(sys.stdin)["loop_closures"])')
  cases="${CASES:-random:0.1 random:0.3 random:0.5 random:0.9 grouped5:0.05 grouped5:0.1 grouped5:0.2 grouped10:0.05 grouped10:0.1 grouped10:0.2}"
  for c in $cases; do
    kind=${c%%:*}
    frac=${c#*:}
    base="$WORK/${name}_${kind}_${frac}"
    seed=$(( ${#name} * 100 + ${#kind} * 10 + 10#${frac#0.} + SEED ))
    if [ "$kind" = random ]; then
      $CAIRN corrupt "$in" -o "$base.g2o" --fraction "$frac" --seed "$seed" 2>/dev/null
    else
      # Aliasing as a real front-end would meet it: on the geometry itself.
      $CAIRN corrupt "$in" -o "$base.g2o" --fraction "$frac" --grouped "${kind#grouped}" \
        --truth "$WORK/${name}_clean.g2o" --seed "$seed" 2>/dev/null
    fi
    timed "${base}.wall" \
      $CAIRN optimize "$base.g2o" -o "${base}_out.g2o" --solver "$SOLVER" --quiet \
        --reject-outliers --rejected "${base}_rejected.g2o" --report "${base}.json" $EXTRA
    echo "$name $kind $frac $closures" >> "$WORK/runs.txt"
    echo "== $name $kind $frac: $(cat "${base}.wall") s" >&2
  done
done
python3 scripts/robustness.py "$WORK"
