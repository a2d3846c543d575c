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

# Predict: a point cloud from each bundled example image (pinhole without and with its camera
# and sparse depth, fisheye, panorama) with the bundled model (models/omnipoint_default.safetensors,
# a small model trained on synthetic scenes: docs/TRAINING.md, "The bundled model"). Set
# OMNIPOINT_MODEL to use another checkpoint.
omnipoint="build/src/cli/omnipoint predict --out out/demo/predict"
$omnipoint examples/images/pinhole.png
build/src/cli/omnipoint predict --out out/demo/predict_with_camera examples/images/pinhole.png \
  --camera examples/images/pinhole.txt --sparse-depth examples/images/pinhole_sparse_depth.npy
$omnipoint examples/images/fisheye.png --camera examples/images/fisheye.txt
$omnipoint examples/images/panorama.png --camera examples/images/panorama.json
echo "predictions written to out/demo/predict/<image>/ and out/demo/predict_with_camera/pinhole/"
echo "(points.ply, points.glb, points/distance/depth/rays/normals .npy, mask/depth/distance/depth_vis/preview/image .png, camera.json, cameras.txt)"
echo "to look at them in a browser: build/src/cli/omnipoint view out/demo"
