#!/usr/bin/env bash
# Times `cairn optimize` on the shared g2o files: best of N runs per file and
# configuration, solver time as the report gives it (reading the file and
# writing the result excluded). Configurations run interleaved, so that a
# busy machine weighs on all of them alike.
#
#   scripts/bench-optimize.sh [-n RUNS] [-f "2d/intel 3d/sphere2500"] -- "OPTIONS A" "OPTIONS B" ...
#
# Prints one line per file and configuration: iterations, final chi2, best
# time_s, best linear solver time, linear solver used.
set -euo pipefail
cd "$(dirname "$0")/.."
runs=5
files="2d/intel 2d/city10000 3d/tinyGrid3D 3d/smallGrid3D 3d/sphere2500 3d/parking-garage"
while [ $# -gt 0 ]; do
  case "$1" in
    -n) runs=$2; shift 2 ;;
    -f) files=$2; shift 2 ;;
    --) shift; break ;;
    *) break ;;
  esac
done
[ $# -eq 0 ] && set -- ""
tool=${CAIRN:-build/cairn}
data=${CAIRN_DATASETS:-../shared/datasets}/g2o
tmp=$(mktemp -d)
trap 'rm -rf "$tmp"' EXIT

num() { grep -m1 -o "\"$1\": [^,]*" "$2" | sed 's/.*: //; s/"//g'; }

printf "%-18s %-48s %4s %14s %8s %8s  %s\n" file options iter final_chi2 time_s ls_s linear_solver
for f in $files; do
  declare -A best=() best_ls=() line=()
  for ((r = 0; r < runs; ++r)); do
    i=0
    for opts in "$@"; do
      # shellcheck disable=SC2086
      "$tool" optimize "$data/$f.g2o" -o "$tmp/out.g2o" --quiet --report "$tmp/r.json" $opts
      t=$(num time_s "$tmp/r.json")
      if [ -z "${best[$i]:-}" ] || awk "BEGIN{exit !($t < ${best[$i]})}"; then
        best[$i]=$t
        best_ls[$i]=$(num linear_solver_time_s "$tmp/r.json")
        line[$i]="$(num iterations "$tmp/r.json") $(num final_chi2 "$tmp/r.json") $(num linear_solver "$tmp/r.json")"
      fi
      i=$((i + 1))
    done
  done
  i=0
  for opts in "$@"; do
    read -r it chi ls_name <<<"${line[$i]}"
    printf "%-18s %-48s %4s %14.10g %8.3f %8.3f  %s\n" "$f" "${opts:-(defaults)}" "$it" "$chi" \
      "${best[$i]}" "${best_ls[$i]}" "$ls_name"
    i=$((i + 1))
  done
  unset best best_ls line
done
