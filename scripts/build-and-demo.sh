#!/usr/bin/env bash
# Installs what cairn needs from Debian's packages, builds it (Release) in
# ./build, and runs the demo on a pose graph the repository makes itself.
set -euo pipefail
cd "$(dirname "$0")/.."

SUDO=""
[ "$(id -u)" -ne 0 ] && SUDO="sudo"
PACKAGES=(build-essential cmake pkg-config libceres-dev libeigen3-dev libsuitesparse-dev
          libgoogle-glog-dev libgflags-dev libgtest-dev libgmock-dev libbenchmark-dev
          zlib1g-dev libopenblas0-pthread universal-ctags python3 nlohmann-json3-dev ninja-build)
missing=()
for p in "${PACKAGES[@]}"; do
  dpkg-query -W -f='${Status}' "$p" 2>/dev/null | grep -q "install ok installed" || missing+=("$p")
done
if [ ${#missing[@]} -gt 0 ]; then
  echo "== installing: ${missing[*]}"
  $SUDO apt-get update -qq
  DEBIAN_FRONTEND=noninteractive $SUDO apt-get install -y -qq --no-install-recommends "${missing[@]}"
fi

echo "== configuring and building (Release) in ./build"
# Ninja starts a test's objects before the libraries it links are done,
# which keeps both cores busy (Make waits target by target). A build tree
# configured earlier keeps its own generator.
generator=()
[ -f build/CMakeCache.txt ] || generator=(-G Ninja)
cmake -S . -B build "${generator[@]}" -DCMAKE_BUILD_TYPE=Release
cmake --build build -j"$(nproc)"

echo "== demo: a simulated 2D Manhattan-world graph, optimised, against its ground truth"
mkdir -p build/demo
build/cairn simulate --dim 2 --poses 3000 --seed 7 -o build/demo/manhattan.g2o
build/cairn info build/demo/manhattan.g2o
build/cairn optimize build/demo/manhattan.g2o -o build/demo/manhattan_opt.g2o --init chordal \
  --plot build/demo/manhattan.svg --report build/demo/manhattan_report.json
echo "-- trajectory error of the odometry estimate, then of the optimised one:"
build/cairn eval build/demo/manhattan.g2o build/demo/manhattan_truth.g2o | grep ATE
build/cairn eval build/demo/manhattan_opt.g2o build/demo/manhattan_truth.g2o | grep ATE
echo "== demo: both solvers side by side on a simulated 3D sphere"
build/cairn simulate --dim 3 --poses 2500 --seed 7 -o build/demo/sphere.g2o
build/cairn compare --quiet build/demo/sphere.g2o
echo "-- its trajectory error in 3D against the ground truth, odometry then optimised:"
build/cairn optimize build/demo/sphere.g2o -o build/demo/sphere_opt.g2o --quiet
build/cairn eval build/demo/sphere.g2o build/demo/sphere_truth.g2o | grep ATE
build/cairn eval build/demo/sphere_opt.g2o build/demo/sphere_truth.g2o | grep ATE
echo "== demo outputs are in build/demo/ (manhattan.svg: before and after)"
