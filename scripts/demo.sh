#!/usr/bin/env bash
# Installs what is missing, builds, and runs the main job on the bundled defaults.
set -euo pipefail
cd "$(dirname "$0")/.."
bash scripts/install_deps.sh
bash scripts/build.sh -DOMNIPOINT_BUILD_TESTS=OFF -DOMNIPOINT_BUILD_BENCH=OFF
build/src/cli/omnipoint --help

# Camera models: the rays of each bundled camera (.npy, and as an RGB picture) and its summary.
mkdir -p out/demo
for camera in examples/cameras/*; do
  name=$(basename "${camera%.*}")
  build/src/cli/omnipoint camera info --camera "$camera" | tee "out/demo/${name}_info.json"
  build/src/cli/omnipoint camera rays --camera "$camera" --out "out/demo/${name}_rays.npy" --png "out/demo/${name}_rays.png"
done
echo "ray maps and pictures written to out/demo/"
