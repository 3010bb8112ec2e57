#!/usr/bin/env bash
# The robustness table over several seeds: scripts/robustness.sh once per
# seed (each in WORKDIR/seed_N), then, per dataset and case, in how many
# seeds it passed, and every failing cell. One seed is one draw of the wrong
# loop closures; a rule tuned to one draw shows here. Usage:
#   [SEEDS="1 2 3"] [DATASETS=...] [CASES=...] [EXTRA=...] [BIN=...] \
#     scripts/robustness-seeds.sh [WORKDIR] [SOLVER]
# DATASETS, CASES, EXTRA and BIN are passed on to robustness.sh.
set -euo pipefail
cd "$(dirname "$0")/.."
WORK="${1:-build/robustness-seeds}"
SOLVER="${2:-ceres}"
SEEDS="${SEEDS:-1 2 3 4 5 6}"
mkdir -p "$WORK"
for seed in $SEEDS; do
  echo "== seed $seed" >&2
  SEED="$seed" bash scripts/robustness.sh "$WORK/seed_$seed" "$SOLVER" > "$WORK/seed_$seed.md" 2>/dev/null
done
python3 - "$WORK" $SEEDS <<'EOF'
import sys
work, seeds = sys.argv[1], sys.argv[2:]
passed, cells, failing = {}, [], []
for seed in seeds:
    for line in open(f"{work}/seed_{seed}.md"):
        c = [x.strip() for x in line.strip().strip("|").split("|")]
        if len(c) != 10 or c[-1] not in ("yes", "NO"):
            continue
        key = (c[0], c[1])
        if key not in passed:
            passed[key] = 0
            cells.append(key)
        passed[key] += c[-1] == "yes"
        if c[-1] == "NO":
            failing.append(f"| {seed} | {c[0]} | {c[1]} | {c[3]} | {c[4]} | {c[5]} |")
print(f"| dataset | case | passed (of {len(seeds)} seeds) |")
print("| --- | --- | --- |")
for key in cells:
    print(f"| {key[0]} | {key[1]} | {passed[key]} |")
total = sum(passed.values())
print(f"\n{total} of {len(cells) * len(seeds)} cells pass over seeds {' '.join(seeds)}.")
if failing:
    print("\n| seed | dataset | case | RMS vs clean (m) | wrong rejected | good kept |")
    print("| --- | --- | --- | --- | --- | --- |")
    print("\n".join(failing))
EOF
