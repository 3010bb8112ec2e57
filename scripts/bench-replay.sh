#!/usr/bin/env bash
# `cairn replay` timed on the same graphs by one or more builds, one after
# the other on each graph (so a machine that slows down slows them alike),
# with a table of the per-step figures: median, p90, p99, mean, the whole
# replay, fresh factorisations, and the final chi2 against the batch solve.
# Usage:
#   scripts/bench-replay.sh WORKDIR GRAPH.g2o... [-- BINARY...]
# BINARY defaults to build/cairn; each is copied first, so that rebuilding
# while this runs changes nothing. Graphs the simulator makes, e.g.
#   build/cairn simulate --dim 2 --poses 100000 --seed 1 -o sim100k.g2o
set -euo pipefail
cd "$(dirname "$0")/.."
WORK="${1:?usage: bench-replay.sh WORKDIR GRAPH.g2o... [-- BINARY...]}"
shift
graphs=()
while [ $# -gt 0 ] && [ "$1" != "--" ]; do graphs+=("$1"); shift; done
[ $# -gt 0 ] && shift
binaries=("$@")
[ ${#binaries[@]} -eq 0 ] && binaries=(build/cairn)
mkdir -p "$WORK"
copies=()
for k in "${!binaries[@]}"; do
  cp "${binaries[$k]}" "$WORK/cairn$k"
  copies+=("$WORK/cairn$k")
done
for g in "${graphs[@]}"; do
  for k in "${!copies[@]}"; do
    name="$(basename "$g" .g2o)_$k"
    echo "== ${binaries[$k]} on $g" >&2
    steps=()  # builds from before --steps run without it
    "${copies[$k]}" replay --help | grep -q -- --steps && steps=(--steps "$WORK/$name.csv")
    "${copies[$k]}" replay "$g" --quiet --json "$WORK/$name.json" "${steps[@]}" > /dev/null
  done
done
python3 - "$WORK" "${#copies[@]}" "${graphs[@]}" <<'EOF'
import json, os, sys
work, builds, graphs = sys.argv[1], int(sys.argv[2]), sys.argv[3:]
print("| graph | build | median | p90 | p99 | mean | whole replay | fresh factorisations "
      "(room, fill, refused) | final chi2 / batch chi2 |")
print("| --- | --- | --- | --- | --- | --- | --- | --- | --- |")
for g in graphs:
    for k in range(builds):
        j = json.load(open(os.path.join(work, "%s_%d.json" % (os.path.basename(g)[:-4], k))))
        by = j.get("refactorizations_by_reason", {})
        why = ", ".join(str(by.get(r, "?")) for r in ("room", "fill", "refused"))
        print("| %s | %d | %.2f ms | %.2f ms | %.2f ms | %.2f ms | %.1f s | %d (%s) | %.10g / %.10g |" % (
            os.path.basename(g), k, 1e3 * j["median_step_s"], 1e3 * j["p90_step_s"],
            1e3 * j["p99_step_s"], 1e3 * j["total_s"] / j["steps"], j["total_s"],
            j["refactorizations"], why, j["final_chi2"], j["batch_chi2"]))
EOF
