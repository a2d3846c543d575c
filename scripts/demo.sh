#!/usr/bin/env bash
# Installs what is missing, builds, and runs the main job on the bundled defaults.
set -euo pipefail
cd "$(dirname "$0")/.."
bash scripts/install_deps.sh
bash scripts/build.sh -DOMNIPOINT_BUILD_TESTS=OFF -DOMNIPOINT_BUILD_BENCH=OFF
build/src/cli/omnipoint --help
