#!/usr/bin/env bash
# Installs what is missing, builds, and runs the whole test suite.
set -euo pipefail
cd "$(dirname "$0")/.."
bash scripts/install_deps.sh --tests
bash scripts/check_format.sh
bash scripts/build.sh -DOMNIPOINT_BUILD_TESTS=ON -DOMNIPOINT_BUILD_BENCH=ON -DOMNIPOINT_WERROR=ON
ctest --test-dir build --output-on-failure -j "$(nproc)"
# The sanitizer lane's CI subset (README "Checks"): the io, camera and geometry layers' tests
# under ASan + UBSan.
bash scripts/sanitize.sh --ci
