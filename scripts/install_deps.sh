#!/usr/bin/env bash
# Installs the Debian packages OmniPoint needs that are missing. Usage: install_deps.sh [--tests]
set -euo pipefail

# libgloo-dev: the gloo headers that c10d's ProcessGroupGloo.hpp includes (Gloo itself is in libtorch_cpu).
# liblzf-dev: LZF for binary_compressed .pcd point clouds.
# libcpp-httplib-dev: the web server of `omnipoint view` (and the hub tests' stand-in server).
# libcurl4-openssl-dev, libssl-dev: downloads of published models and their checksums
# (--model hf:...).
# libexif-dev: a photo's camera and orientation from its EXIF data.
# libhdf5-dev: Hypersim's HDF5 images (the C API).
packages=(g++ cmake ninja-build ccache pkg-config
          libtorch-dev libopenblas0-pthread nlohmann-json3-dev libcli11-dev
          libopencv-dev libgloo-dev liblzf-dev libcpp-httplib-dev libcurl4-openssl-dev libssl-dev libexif-dev
          libhdf5-dev)
# npm: the build installs the viewer's pinned three.js with `npm ci`. A Node.js from elsewhere
# (NodeSource) brings its own npm; Debian's nodejs needs Debian's npm beside it.
command -v npm >/dev/null || packages+=(nodejs npm)
if [[ "${1:-}" == "--tests" ]]; then
  # GoogleTest, Google Benchmark, OpenCV contrib (cv::omnidir cross-checks), PyTorch for tools/,
  # Chromium for the viewer's browser test; clang with LLVM's OpenMP for the ThreadSanitizer
  # lane, clang-tidy for the check of changed files.
  packages+=(libgtest-dev libgmock-dev libbenchmark-dev libopencv-contrib-dev python3-torch python3-numpy
             chromium clang libomp-dev clang-tidy)
fi

missing=()
for p in "${packages[@]}"; do
  dpkg-query -W -f='${Status}' "$p" 2>/dev/null | grep -q "install ok installed" || missing+=("$p")
done
if (( ${#missing[@]} )); then
  echo "installing: ${missing[*]}"
  SUDO=""
  [[ $(id -u) -ne 0 ]] && SUDO=sudo
  $SUDO apt-get update -qq
  DEBIAN_FRONTEND=noninteractive $SUDO apt-get install -y -qq --no-install-recommends "${missing[@]}"
fi
