#!/usr/bin/env bash
# Builds the libFuzzer targets of fuzz/ (the readers, the solvers) with
# clang (address and undefined-behaviour sanitizers on) in ./build-fuzz and
# runs each for SECONDS (default 60) from the seed corpus in fuzz/corpus/. A
# crash leaves its input as build-fuzz/crash-* and makes this script fail:
# fix the reader or solver, then keep
# the input as a regression test (tests/test_fuzz_regressions.cpp).
set -euo pipefail
cd "$(dirname "$0")/.."
SECONDS_EACH="${1:-60}"
if ! command -v clang++ >/dev/null; then
  echo "fuzz.sh: clang++ not found (apt-get install clang); nothing done" >&2
  exit 1
fi
cmake -S . -B build-fuzz -DCMAKE_BUILD_TYPE=RelWithDebInfo -DCMAKE_CXX_COMPILER=clang++ \
  -DCAIRN_BUILD_FUZZERS=ON -DCAIRN_BUILD_TESTS=OFF -DCAIRN_BUILD_BENCHMARKS=OFF >/dev/null
cmake --build build-fuzz -j2 --target fuzz_g2o fuzz_toro fuzz_carmen fuzz_solvers
status=0
for target in g2o toro carmen solvers; do
  corpus="build-fuzz/corpus-$target"
  mkdir -p "$corpus"
  echo "== fuzz_$target for ${SECONDS_EACH}s"
  [ -x "build-fuzz/fuzz/fuzz_$target" ] || { echo "fuzz.sh: build-fuzz/fuzz/fuzz_$target missing" >&2; exit 1; }
  (cd build-fuzz && ./fuzz/fuzz_$target -max_total_time="$SECONDS_EACH" -max_len=4096 \
     -artifact_prefix="crash-$target-" "corpus-$target" "../fuzz/corpus/$target" \
     2>&1 | grep -E "DONE|ERROR|SUMMARY|Test unit written|stat::" ) || true
  if ls build-fuzz/crash-$target-* >/dev/null 2>&1; then status=1; fi
done
exit $status
